//! Issue 37's materials under every kind of light transport: the Cornell box with a
//! rough glass box, a rough plastic box, a smooth plastic back wall and an anisotropic
//! rough metal wall, rendered by pt, lt, bpt and vcm. Light tracing through rough
//! glass is where the importance-mode (adjoint) BSDF matters; a second scene puts the
//! light inside a slab of rough glass, where a wrong eta^2 would not cancel. Bounds
//! come from the renders' own noise (`bidirectional/stats.rs`).

#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::integrator::Settings;
use caustic::scene::{load::read_scene_file, Scene};
use serde_json::{json, Value};
use stats::{assert_agree, blocks, run};
use std::path::Path;

const SIZE: u32 = 32;

/// The Cornell box with the new materials; `covered` also puts the light inside a
/// slab of rough glass.
fn scene(covered: bool) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.json");
    let mut f = read_scene_file(&path).expect("scene reads");
    f.film.width = SIZE;
    f.film.height = SIZE;
    let mut v = serde_json::to_value(&f).unwrap();
    v["materials"]["glass"] = json!({"type": "roughdielectric", "alpha": 0.2});
    v["materials"]["coat"] = json!({"type": "roughplastic", "distribution": "ggx", "alpha": 0.3,
               "diffuse_reflectance": [0.2, 0.4, 0.7]});
    v["materials"]["plastic"] = json!({"type": "plastic", "nonlinear": true});
    v["materials"]["brushed"] = json!({"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.05,
               "alpha_v": 0.4, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 1.6]});
    for s in v["shapes"].as_array_mut().unwrap() {
        let m = match s["name"].as_str().unwrap() {
            "large box" => "glass",
            "small box" => "coat",
            "back" => "plastic",
            "green wall" => "brushed",
            _ => continue,
        };
        s["material"] = json!(m);
    }
    if covered {
        v["shapes"].as_array_mut().unwrap().push(json!({
            "name": "light cover", "type": "cube", "material": "glass",
            "transform": {"translate": [0, 0.99, 0.01], "scale": [0.3, 0.06, 0.3]}
        }));
    }
    v["integrator"]["max_depth"] = json!(8);
    let f = serde_json::from_value(v).expect("scene parses");
    Scene::compile(&f, path.parent()).expect("scene compiles")
}

fn settings(scene: &Scene, algorithm: &str, params: Value) -> Settings {
    let map = params.as_object().cloned().unwrap_or_default();
    Settings::resolve(Some(algorithm), scene.integrator.as_ref(), &map).expect("settings")
}

#[test]
fn rough_materials_agree_across_algorithms() {
    let s = scene(false);
    let regions = blocks(SIZE, SIZE, 8);
    let pt = run(&s, &settings(&s, "pt", json!({})), 1, 256, &regions);
    assert_eq!(pt.dropped, 0);
    for (alg, seed, iterations) in [
        ("lt", 2, 256),
        ("bpt", 3, 128),
        ("vcm", 4, 128),
        ("vpl-compensated", 5, 256),
    ] {
        // vpl clamps its geometry term unless told to compensate (an unbiased gather
        // of what the clamp removed).
        let (alg, params) = match alg {
            "vpl-compensated" => ("vpl", json!({"clamp": "compensate"})),
            _ => (alg, json!({})),
        };
        let r = run(&s, &settings(&s, alg, params), seed, iterations, &regions);
        assert_eq!(r.dropped, 0, "{alg}");
        assert_agree(&r, &pt, &regions);
    }
}

/// Light that starts inside rough glass and leaves it: the light-path methods see the
/// importance-mode refraction only once, so its eta^2 does not cancel as it does for
/// paths that enter and leave a closed glass object.
#[test]
fn light_inside_rough_glass_agrees_across_algorithms() {
    let s = scene(true);
    let regions = blocks(SIZE, SIZE, 8);
    let pt = run(&s, &settings(&s, "pt", json!({})), 11, 256, &regions);
    assert_eq!(pt.dropped, 0);
    assert!(
        pt.regions.last().unwrap().mean[0] > 0.05,
        "the covered light lights the box"
    );
    for (alg, seed, iterations) in [("lt", 12, 256), ("bpt", 13, 128)] {
        let r = run(
            &s,
            &settings(&s, alg, json!({})),
            seed,
            iterations,
            &regions,
        );
        assert_eq!(r.dropped, 0, "{alg}");
        assert_agree(&r, &pt, &regions);
    }
}
