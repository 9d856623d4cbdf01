//! Helpers shared by the integration tests.
#![allow(dead_code)]

use caustic::film::Film;
use caustic::integrator::drive::{self, Halt};
use caustic::integrator::Settings;
use caustic::scene::{load::parse_scene, Scene};

pub fn compile(json: serde_json::Value) -> Scene {
    let file = parse_scene(&json.to_string()).expect("scene parses");
    Scene::compile(&file, None).expect("scene compiles")
}

pub fn settings(alg: &str, params: serde_json::Value) -> Settings {
    let map = params.as_object().cloned().unwrap_or_default();
    Settings::resolve(Some(alg), None, &map).expect("settings")
}

/// Renders `spp` iterations and returns the film (sums) and the iteration count.
pub fn render(scene: &Scene, s: &Settings, seed: u64, spp: u64) -> (Film, u64) {
    let integ = s.build();
    let out = drive::render(
        scene,
        integ.as_ref(),
        seed,
        Halt {
            iterations: Some(spp),
            ..Halt::default()
        },
        |_, _| {},
    );
    (out.film, out.iterations)
}

/// `f` run on a rayon pool of `threads` threads (for images that must not depend on
/// the thread count).
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// A scene shipped under scenes/media at `size` x `size` with `max_depth` as its
/// integrator default (its assets found beside it).
pub fn shipped_media(name: &str, size: u32, max_depth: u32) -> Scene {
    let path = format!("{}/scenes/media/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    v["film"] = serde_json::json!({"width": size, "height": size});
    v["integrator"]["max_depth"] = serde_json::json!(max_depth);
    let base = std::path::Path::new(&path).parent().unwrap();
    let file = parse_scene(&v.to_string()).unwrap();
    Scene::compile(&file, Some(base)).unwrap()
}

/// Mean and standard error of a set of independent values.
pub fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// One channel of every pixel of a rendered film, as means over iterations.
pub fn channel(film: &Film, iterations: u64, c: usize) -> Vec<f64> {
    film.sums()
        .iter()
        .map(|p| p[c] / iterations as f64)
        .collect()
}

/// The Cornell box at `size` x `size` with `medium` inside an index-matched cube just
/// larger than the box: the camera looks in from outside, through the cube's front face.
pub fn fog_box(size: u32, medium: serde_json::Value) -> Scene {
    use serde_json::json;
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.json"
    ))
    .expect("cornell box");
    let mut v: serde_json::Value = serde_json::from_str(&text).expect("cornell box parses");
    v["film"] = json!({"width": size, "height": size});
    v["materials"]["boundary"] = json!({"type": "null"});
    v["media"] = json!({ "fog": medium });
    v["shapes"].as_array_mut().unwrap().push(json!({
        "type": "cube", "material": "boundary", "interior": "fog",
        "transform": {"scale": 1.001}
    }));
    compile(v)
}

/// The media issue's extreme cases: nearly empty, opaque, strongly chromatic, black,
/// sharply peaked phase functions both ways, and dense chromatic procedural noise.
pub fn extreme_media() -> Vec<serde_json::Value> {
    use serde_json::json;
    vec![
        json!({"type": "homogeneous", "sigma_t": [1e-4, 1e-4, 1e-4], "albedo": [0.8, 0.8, 0.8]}),
        json!({"type": "homogeneous", "sigma_t": [1e4, 1e4, 1e4], "albedo": [0.8, 0.8, 0.8]}),
        json!({"type": "homogeneous", "sigma_t": [1e4, 1e-4, 1.0], "albedo": [1, 0.5, 0]}),
        json!({"type": "homogeneous", "sigma_t": [2, 2, 2], "albedo": [0, 0, 0]}),
        json!({"type": "homogeneous", "sigma_t": [2, 2, 2], "albedo": [1, 1, 1],
               "phase": {"type": "hg", "g": 0.99}}),
        json!({"type": "homogeneous", "sigma_t": [2, 2, 2], "albedo": [1, 1, 1],
               "phase": {"type": "hg", "g": -0.99}}),
        json!({"type": "procedural", "sigma_t": [1e4, 1e3, 1e2], "albedo": [1, 1, 1],
               "octaves": 6, "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}}),
    ]
}

/// Asserts that `film` (`m` iterations) and `reference` (`n`) estimate the same image
/// in channel `c`: the mean of the per-pixel differences lies within four of its
/// standard errors, plus `bias` times the reference's mean for consistent methods.
/// Per-pixel differences cancel the image's own variation, leaving the noise.
pub fn assert_same_image(
    reference: &Film,
    n: u64,
    film: &Film,
    m: u64,
    c: usize,
    bias: f64,
    what: &str,
) {
    let a = channel(reference, n, c);
    let b = channel(film, m, c);
    let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| y - x).collect();
    let (mean, se) = mean_se(&d);
    let level = a.iter().sum::<f64>() / a.len() as f64;
    assert!(
        mean.abs() <= 4.0 * se + bias * level,
        "{what} channel {c}: mean difference {mean} (se {se}, image mean {level})"
    );
}

/// Renders `scene` with pt (`pt_spp` iterations) and with each `(algorithm, spp,
/// bias)`, all with `params`, and asserts each image equals pt's in channels 0 and 2
/// ([`assert_same_image`]) with no sample dropped.
pub fn assert_algorithms_agree_with_pt(
    scene: &Scene,
    params: serde_json::Value,
    pt_spp: u64,
    cases: &[(&str, u64, f64)],
) {
    let (reference, n) = render(scene, &settings("pt", params.clone()), 1, pt_spp);
    assert_eq!(reference.dropped(), 0, "pt");
    for &(alg, spp, bias) in cases {
        let (film, m) = render(scene, &settings(alg, params.clone()), 2, spp);
        assert_eq!(film.dropped(), 0, "{alg}");
        for c in [0, 2] {
            assert_same_image(&reference, n, &film, m, c, bias, alg);
        }
    }
}
