//! The pilots' schedule and filter, and adaptive jobs: the same bits however their
//! iterations are split between integrators and threads, and the image of the job
//! with every estimator within noise.

use super::{box_filter, is_pilot, pilots_before, Bidir};
use crate::film::{ExactSums, Film};
use crate::integrator::drive::iterate_exact;
use crate::integrator::{Integrator, Settings};
use crate::scene::load::read_scene_file;
use crate::scene::Scene;
use std::path::Path;

#[test]
fn pilots_are_iterations_four_to_the_j_minus_one() {
    let pilots: Vec<u64> = (0..300).filter(|&i| is_pilot(i)).collect();
    assert_eq!(pilots, [0, 3, 15, 63, 255]);
    assert_eq!(pilots_before(16).collect::<Vec<_>>(), [0, 3, 15]);
    assert_eq!(pilots_before(0).count(), 0);
    assert_eq!(pilots_before(u64::MAX).count(), 32);
}

#[test]
fn box_filter_sums_clipped_neighbourhoods() {
    let (w, h) = (9, 5);
    let ones = vec![1.0; w * h * 2];
    let out = box_filter(&ones, 2, (w, h));
    // A corner sees 4 x 4 pixels, the centre 7 x 5 (the image is 5 high).
    assert_eq!(out[0], 16.0);
    assert_eq!(out[(2 * w + 4) * 2 + 1], 35.0);
    let mut spike = vec![0.0; w * h];
    spike[2 * w + 4] = 1.0;
    let out = box_filter(&spike, 1, (w, h));
    let total: f64 = out.iter().sum();
    assert_eq!(total, 35.0);
    assert_eq!(out[0], 0.0);
}

fn scene(file: &str, size: u32) -> Scene {
    let mut f = read_scene_file(Path::new(file)).unwrap();
    f.film.width = size;
    f.film.height = size;
    Scene::compile(&f, Path::new(file).parent()).unwrap()
}

fn bidir(alg: &str, params: &serde_json::Value) -> Bidir {
    let map = params.as_object().cloned().unwrap_or_default();
    match Settings::resolve(Some(alg), None, &map).unwrap() {
        Settings::Vcm(s) | Settings::Upbp(s) | Settings::Bpm(s) => {
            Bidir::new(s.technique_of(alg), s)
        }
        _ => unreachable!(),
    }
}

/// Iterations `range` of `integ` added to `sums`.
fn run(
    scene: &Scene,
    integ: &dyn Integrator,
    seed: u64,
    range: std::ops::Range<u64>,
    sums: &mut ExactSums,
) {
    let mut scratch = Film::new(scene.width(), scene.height());
    for i in range {
        iterate_exact(scene, integ, seed, i, &mut scratch, sums);
    }
}

fn upbp_adaptive() -> serde_json::Value {
    serde_json::json!({"max_depth": 6, "selection": "adaptive"})
}

/// An adaptive job split between two integrators (as a resumed job, or a pool's
/// ranges) and run on one thread renders the same bits as one integrator on the
/// default pool; and its pixels do not all keep every estimator.
#[test]
fn adaptive_jobs_are_the_same_bits_however_split() {
    let scene = scene("scenes/media/fog-cornell.json", 16);
    let size = || ExactSums::new(16, 16);
    let (n, seed) = (18, 4);
    let whole = bidir("upbp", &upbp_adaptive());
    let mut a = size();
    run(&scene, &whole, seed, 0..n, &mut a);
    let mut b = size();
    run(&scene, &bidir("upbp", &upbp_adaptive()), seed, 0..7, &mut b);
    run(&scene, &bidir("upbp", &upbp_adaptive()), seed, 7..n, &mut b);
    assert!(a == b, "split at 7: other bits");
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let c = one.install(|| {
        let mut c = size();
        run(&scene, &bidir("upbp", &upbp_adaptive()), seed, 0..n, &mut c);
        c
    });
    assert!(a == c, "one thread: other bits");
    let st = whole.adaptive.as_ref().unwrap().lock().unwrap();
    assert_eq!(st.pilots, 3, "pilots 0, 3 and 15");
    let last = st.choices.last().unwrap();
    let mut counts = [0usize; 8];
    for &c in last {
        counts[c as usize] += 1;
    }
    eprintln!("choices after 3 pilots: {counts:?}");
    assert!(counts[0] < 256, "every pixel kept every estimator");
}

/// The adaptive job's image equals the job with every estimator within noise, per
/// quarter of the image (paired over seeds: the same pilot iterations).
#[test]
fn adaptive_upbp_agrees_with_upbp() {
    for file in [
        "scenes/media/fog-cornell.json",
        "scenes/media/glass-sphere-fog.json",
    ] {
        let scene = scene(file, 16);
        let quarters = |integ: &dyn Integrator, seed| {
            let mut sums = ExactSums::new(16, 16);
            run(&scene, integ, seed, 0..6, &mut sums);
            let img = sums.to_film().to_image(1.0 / 6.0);
            let mut q = [0.0f64; 4];
            for (i, p) in img.pixels().iter().enumerate() {
                q[(i % 16 / 8) + 2 * (i / 128)] += (p.x + p.y + p.z) as f64;
            }
            q
        };
        let plain = serde_json::json!({"max_depth": 6, "selection": "all"});
        let runs: Vec<([f64; 4], [f64; 4])> = (0..10)
            .map(|seed| {
                (
                    quarters(&bidir("upbp", &upbp_adaptive()), seed),
                    quarters(&bidir("upbp", &plain), seed),
                )
            })
            .collect();
        for q in 0..4 {
            let d: Vec<f64> = runs.iter().map(|(a, b)| a[q] - b[q]).collect();
            let m = d.iter().sum::<f64>() / d.len() as f64;
            let var = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (d.len() - 1) as f64;
            let z = m.abs() / (var / d.len() as f64).sqrt().max(1e-300);
            eprintln!("{file} quarter {q}: mean difference {m:.3e}, {z:.2} se");
            assert!(z < 4.0, "{file} quarter {q}: {z} standard errors");
        }
    }
}
