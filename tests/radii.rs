//! `radii` (and `medium_radii`): one `bpm` or `vcm` job renders, beside its main image,
//! one EXR layer `radius<i>` per listed initial merge radius. Each layer must equal the
//! image of a separate job with `radius` (and `medium_radius`) set to that entry, same
//! seed and iteration count, within float rounding, and must differ from the main
//! image. Bad lists are refused by settings parsing, naming the field.

mod common;
use caustic::film::Image;
use caustic::integrator::Settings;
use caustic::scene::{load::read_scene_file, Scene};
use common::*;
use serde_json::{json, Value};
use std::path::Path;

const SEED: u64 = 11;
const ITERATIONS: u64 = 4;

fn small_cornell() -> Scene {
    let mut f = read_scene_file(Path::new("scenes/cornell-box.json")).unwrap();
    f.film.width = 24;
    f.film.height = 24;
    Scene::compile(&f, Some(Path::new("scenes"))).unwrap()
}

/// `base` with `extra`'s fields added (replacing any of the same name).
fn with(base: &Value, extra: &Value) -> Value {
    let mut v = base.clone();
    for (k, x) in extra.as_object().unwrap() {
        v[k] = x.clone();
    }
    v
}

/// Largest per-pixel absolute difference between `a` and `b`, relative to `b`'s
/// brightest value.
fn mismatch(a: &Image, b: &Image) -> f32 {
    let peak = b
        .pixels()
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max);
    assert!(peak > 0.0, "black reference image");
    a.pixels()
        .iter()
        .zip(b.pixels())
        .map(|(x, y)| (*x - *y).abs().max_element() / peak)
        .fold(0.0, f32::max)
}

/// Renders `alg` with `base` plus `list` (the `radii` / `medium_radii` fields) and
/// asserts that layer `radius<i>` equals the image of a job with `base` plus
/// `single[i]` (its `radius`, maybe `medium_radius`), and differs from the main image.
fn assert_layers_are_separate_jobs(
    scene: &Scene,
    alg: &str,
    base: Value,
    list: Value,
    single: &[Value],
) {
    let (film, n) = render(scene, &settings(alg, with(&base, &list)), SEED, ITERATIONS);
    assert_eq!(n, ITERATIONS);
    let main = film.to_image(1.0 / n as f64);
    // The layers change nothing in the main image: it is the job without them.
    let (alone, m) = render(scene, &settings(alg, base.clone()), SEED, ITERATIONS);
    let worst = mismatch(&main, &alone.to_image(1.0 / m as f64));
    eprintln!("{alg} main image: {worst:.2e} of the peak from the job without layers");
    assert!(worst < 1e-6, "{alg} {list}: main image moved by {worst}");
    let layers = film.layer_images();
    let names: Vec<&str> = layers.iter().map(|(n, _)| n.as_str()).collect();
    let expected: Vec<String> = (0..single.len()).map(|i| format!("radius{i}")).collect();
    assert_eq!(names, expected, "{alg} {list}");
    for ((name, layer), one) in layers.iter().zip(single) {
        let (job, m) = render(scene, &settings(alg, with(&base, one)), SEED, ITERATIONS);
        assert_eq!(m, ITERATIONS);
        let job = job.to_image(1.0 / m as f64);
        // The same light and camera paths, and the same photons found within the
        // radius: the merge sums only run over them in another order (the hash grid
        // is built for the largest radius), so only rounding may differ (measured:
        // at most 1e-7 of the peak).
        let worst = mismatch(layer, &job);
        eprintln!("{alg} {name}: {worst:.2e} of the peak from a separate job");
        assert!(
            worst < 1e-6,
            "{alg} {name} differs from a job with {one} by {worst}"
        );
        // The radius matters, so a copy of the main image cannot pass.
        let apart = mismatch(layer, &main);
        assert!(
            apart > 1e-3,
            "{alg} {name} is the main image (difference {apart})"
        );
    }
}

/// Layers at half and twice the main radius (radius_factor 0.02 of the scene's
/// bounding sphere) on the Cornell box.
fn surface_case(alg: &str) {
    let scene = small_cornell();
    let r = 0.02 * scene.sphere.radius;
    let radii = [0.5 * r, 2.0 * r];
    let base = json!({"max_depth": 6, "radius_factor": 0.02});
    let single: Vec<Value> = radii.iter().map(|r| json!({"radius": r})).collect();
    assert_layers_are_separate_jobs(&scene, alg, base, json!({"radii": radii}), &single);
}

#[test]
fn vcm_radius_layers_equal_separate_jobs() {
    surface_case("vcm");
}

#[test]
fn bpm_radius_layers_equal_separate_jobs() {
    surface_case("bpm");
}

/// In fog, each layer merges in the medium with its `medium_radii` entry, or with the
/// job's own `medium_radius` when the list is absent.
#[test]
fn vcm_radius_layers_in_fog_equal_separate_jobs() {
    let scene = shipped_media("fog-cornell", 16, 8);
    let base = json!({"radius": 0.03, "medium_radius": 0.05});
    assert_layers_are_separate_jobs(
        &scene,
        "vcm",
        base.clone(),
        json!({"radii": [0.015, 0.06], "medium_radii": [0.1, 0.025]}),
        &[
            json!({"radius": 0.015, "medium_radius": 0.1}),
            json!({"radius": 0.06, "medium_radius": 0.025}),
        ],
    );
    assert_layers_are_separate_jobs(
        &scene,
        "vcm",
        base,
        json!({"radii": [0.06]}),
        &[json!({"radius": 0.06})],
    );
}

/// `upbp` with the estimators `radii` covers (connections, surface and point x point
/// merging) in fog.
#[test]
fn upbp_radius_layers_in_fog_equal_separate_jobs() {
    let scene = shipped_media("fog-cornell", 16, 8);
    // A job with radii selects `all` (`auto` is adaptive without them).
    let base = json!({"radius": 0.03, "medium_radius": 0.05, "techniques": "bpt+surf+pp3d",
                      "selection": "all"});
    assert_layers_are_separate_jobs(
        &scene,
        "upbp",
        base,
        json!({"radii": [0.06], "medium_radii": [0.1]}),
        &[json!({"radius": 0.06, "medium_radius": 0.1})],
    );
}

/// `upbp` with every estimator, the beams included: each layer's point x beam 2D
/// and beam x beam 1D radii from `pb2d_radii` and `bb1d_radii`, or the job's own
/// (then only their MIS weights differ from the main image's), with short and long
/// query beams.
#[test]
fn upbp_beam_radius_layers_in_fog_equal_separate_jobs() {
    let scene = shipped_media("fog-cornell", 16, 8);
    for query_beams in ["short", "long"] {
        let base = json!({"radius": 0.03, "medium_radius": 0.05, "pb2d_radius": 0.04,
                          "bb1d_radius": 0.015, "query_beams": query_beams,
                          "techniques": "bpt+surf+pp3d+pb2d+bb1d", "selection": "all"});
        assert_layers_are_separate_jobs(
            &scene,
            "upbp",
            base.clone(),
            json!({"radii": [0.06, 0.015], "medium_radii": [0.1, 0.03],
                   "pb2d_radii": [0.08, 0.02], "bb1d_radii": [0.03, 0.008]}),
            &[
                json!({"radius": 0.06, "medium_radius": 0.1, "pb2d_radius": 0.08,
                       "bb1d_radius": 0.03}),
                json!({"radius": 0.015, "medium_radius": 0.03, "pb2d_radius": 0.02,
                       "bb1d_radius": 0.008}),
            ],
        );
        assert_layers_are_separate_jobs(
            &scene,
            "upbp",
            base,
            json!({"radii": [0.06]}),
            &[json!({"radius": 0.06})],
        );
    }
}

/// The error of resolving `alg` with `params`, which must name `field` (and not be
/// serde's refusal of an unknown field).
fn refused(alg: &str, params: Value, field: &str) {
    let map = params.as_object().cloned().unwrap();
    let Err(err) = Settings::resolve(Some(alg), None, &map) else {
        panic!("{alg} accepted {params}");
    };
    let text = err.to_string();
    assert!(text.contains(field), "{alg} {params}: {text}");
    assert!(!text.contains("unknown field"), "{alg} {params}: {text}");
}

#[test]
fn radii_are_checked() {
    // Valid lists resolve (so the refusals below are not of an unknown field).
    let map = |v: Value| v.as_object().cloned().unwrap();
    for alg in ["bpm", "vcm"] {
        let ok = json!({"radii": [0.01, 0.04], "medium_radii": [0.02, 0.05]});
        Settings::resolve(Some(alg), None, &map(ok)).unwrap();
        Settings::resolve(Some(alg), None, &map(json!({"radii": vec![0.01; 16]}))).unwrap();
    }
    refused("bpt", json!({"radii": [0.01]}), "radii");
    // pt has no merge parameters at all: refusing `radii` as unknown is fine there.
    let err = Settings::resolve(Some("pt"), None, &map(json!({"radii": [0.01]}))).unwrap_err();
    assert!(err.to_string().contains("radii"), "{err}");
    // An empty list asks for no layers.
    let none = Settings::resolve(Some("vcm"), None, &map(json!({"radii": []})));
    assert!(none.is_ok(), "{none:?}");
    let all = json!({"radii": [0.01], "pb2d_radii": [0.02], "bb1d_radii": [0.01],
                     "techniques": "bpt+surf+pp3d+pb2d+bb1d"});
    Settings::resolve(Some("upbp"), None, &map(all)).unwrap();
    refused(
        "upbp",
        json!({"radii": [0.01, 0.02], "bb1d_radii": [0.05]}),
        "bb1d_radii",
    );
    refused(
        "upbp",
        json!({"radii": [0.01], "pb2d_radii": [-1.0]}),
        "pb2d_radii",
    );
    refused("vcm", json!({"radii": [0.01, -0.02]}), "radii");
    refused("bpm", json!({"radii": [0.0]}), "radii");
    refused("vcm", json!({"radii": vec![0.01; 17]}), "radii");
    refused(
        "vcm",
        json!({"radii": [0.01, 0.02], "medium_radii": [0.05]}),
        "medium_radii",
    );
}
