//! Helpers shared by the integration tests.
#![allow(dead_code)]

use caustic::film::Film;
use caustic::integrator::driver::{self, Halt};
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
    let out = driver::render(
        scene,
        integ.as_ref(),
        seed,
        Halt {
            iterations: Some(spp),
            time: None,
        },
        |_, _| {},
    );
    (out.film, out.iterations)
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
