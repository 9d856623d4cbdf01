//! Light tracing and bidirectional path tracing through participating media, against
//! the volumetric path tracer: a fog-filled Cornell box, a heterogeneous (procedural)
//! medium, and point and spot lights inside a chromatic, forward-scattering fog that
//! also holds the camera. Every bound comes from the renders' own noise (block-wise
//! means and standard errors over independent iterations, `bidirectional/stats.rs`).

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::scene::Scene;
use common::{compile, settings};
use serde_json::{json, Value};
use stats::{assert_agree, blocks, run, Rect, Run};

const SIZE: u32 = 16;
const BLOCK: u32 = 4;

/// The Cornell box at SIZE x SIZE pixels, as JSON to modify.
fn cornell() -> Value {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.json"
    ))
    .expect("cornell box");
    let mut v: Value = serde_json::from_str(&text).expect("cornell box parses");
    v["film"] = json!({"width": SIZE, "height": SIZE});
    v
}

fn fog_box(medium: Value) -> Scene {
    common::fog_box(SIZE, medium)
}

/// Renders `scene` with volpath, lt and bpt (`iterations` each, in that order; light
/// tracing takes more, its pixels see fewer paths) and checks that each bidirectional
/// render agrees with volpath block by block, with no dropped samples.
fn agree(scene: &Scene, max_depth: u32, iterations: [u64; 3]) {
    let regions: Vec<Rect> = blocks(SIZE, SIZE, BLOCK);
    let p = json!({"max_depth": max_depth});
    let runs: Vec<Run> = ["volpath", "lt", "bpt"]
        .iter()
        .zip(iterations)
        .enumerate()
        .map(|(k, (alg, n))| run(scene, &settings(alg, p.clone()), 7 + k as u64, n, &regions))
        .collect();
    for r in &runs {
        assert_eq!(r.dropped, 0, "{}: dropped samples", r.name);
        let m = r.whole().mean;
        assert!(
            m.iter().all(|c| c.is_finite() && *c > 0.0),
            "{}: {m:?}",
            r.name
        );
    }
    assert_agree(&runs[0], &runs[1], &regions);
    assert_agree(&runs[0], &runs[2], &regions);
}

#[test]
fn fog_filled_cornell_box() {
    // Optical depth 1.2 across the box: in-scattering, attenuation and the walls
    // seen through fog all matter.
    let scene = fog_box(json!({
        "type": "homogeneous", "sigma_t": [0.6, 0.6, 0.6], "albedo": [0.8, 0.8, 0.8]
    }));
    assert!(scene.has_media);
    agree(&scene, 8, [1200, 2400, 800]);
}

#[test]
fn heterogeneous_medium_in_the_cornell_box() {
    // Procedural noise with empty regions (threshold), a chromatic albedo, and
    // heterogeneous tracking on every segment and shadow ray.
    let scene = fog_box(json!({
        "type": "procedural", "sigma_t": [2.5, 2.5, 2.5], "albedo": [0.9, 0.75, 0.6],
        "threshold": 0.3, "frequency": 2,
        "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}
    }));
    // volpath's corner blocks (rays grazing the box's front edges, through the thin fog
    // between the walls and the boundary) are heavy-tailed: with 800 iterations a
    // render that missed its rare bright paths read 4.5 standard errors low, while
    // 12000 iterations over four seeds agreed with lt to within 1.5. Twice the
    // iterations put more of that tail into its standard error.
    agree(&scene, 8, [1600, 1600, 500]);
}

#[test]
fn point_and_spot_lights_in_chromatic_fog() {
    // The fog fills everything (no boundary: the camera's medium is unbounded), with
    // sigma_t differing per channel and forward scattering; the area light is gone.
    let mut v = cornell();
    v["camera"]["medium"] = json!("fog");
    v["media"] = json!({"fog": {
        "type": "homogeneous", "sigma_a": [0.05, 0.1, 0.3], "sigma_s": [0.35, 0.5, 0.3],
        "phase": {"type": "hg", "g": 0.4}
    }});
    let shapes = v["shapes"].as_array_mut().unwrap();
    shapes.retain(|s| s["name"] != "light");
    v["lights"] = json!([
        {"type": "point", "position": [0.3, 0.6, 0.2], "intensity": [2, 2, 2]},
        {"type": "spot", "position": [-0.6, 0.8, -0.5], "target": [0.2, -1, 0.3],
         "intensity": [6, 6, 6], "cutoff_angle": 25, "beam_width": 15}
    ]);
    let scene = compile(v);
    assert_eq!(scene.light_media, vec![Some(0), Some(0)]);
    agree(&scene, 8, [1200, 2400, 800]);
}

#[test]
fn extreme_media_render_without_dropped_samples() {
    // Nearly empty, opaque, strongly chromatic (the MIS transmittance floor), black,
    // sharply peaked phase functions, and dense procedural media (short paths: every
    // connection through the densest one is a long ratio-tracking walk).
    let mut cases = common::extreme_media();
    cases.push(
        json!({"type": "procedural", "sigma_t": [8, 8, 8], "albedo": [0.9, 0.9, 0.9],
               "threshold": 0.5, "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}}),
    );
    for medium in cases {
        let scene = fog_box(medium.clone());
        for alg in ["lt", "bpt"] {
            let r = run(&scene, &settings(alg, json!({"max_depth": 12})), 3, 2, &[]);
            assert_eq!(r.dropped, 0, "{alg} in {medium}");
            let m = r.whole().mean;
            assert!(
                m.iter().all(|c| c.is_finite() && *c >= 0.0),
                "{alg} in {medium}"
            );
        }
    }
}

#[test]
fn glass_sphere_in_fog() {
    // A dielectric whose outside is fog and inside vacuum: paths switch media at a
    // specular interface. Light tracing cannot see through the glass (no connection
    // passes a specular surface), so only bpt is compared.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/media/glass-sphere-fog.json"
    );
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": SIZE, "height": SIZE});
    let scene = compile(v);
    let regions: Vec<Rect> = blocks(SIZE, SIZE, BLOCK);
    let p = json!({"max_depth": 8});
    let a = run(&scene, &settings("volpath", p.clone()), 21, 1200, &regions);
    let b = run(&scene, &settings("bpt", p), 22, 800, &regions);
    assert_eq!(a.dropped + b.dropped, 0);
    assert_agree(&a, &b, &regions);
}
