//! Per-pixel candidates against whole jobs: a pixel weighted under a candidate must
//! render as a job with only that candidate's estimators where those cover every path
//! (the same subpaths, so equal up to rounding), and stay unbiased where they do not
//! (paths only a dropped merge finds keep their weight).

use super::super::Bidir;
use crate::film::Image;
use crate::integrator::drive::progressive::{render, Halt};
use crate::integrator::{Integrator, Settings};
use crate::scene::load::{parse_scene, read_scene_file};
use crate::scene::Scene;
use std::path::Path;

pub(in crate::integrator::bidir) fn scene(file: &str, size: u32) -> Scene {
    let mut f = read_scene_file(Path::new(file)).unwrap();
    f.film.width = size;
    f.film.height = size;
    // Box pixels: each pixel's value is its own path's and the splats that land in it.
    f.film.filter = serde_json::from_value(serde_json::json!("box")).unwrap();
    let dir = Path::new(file).parent().unwrap();
    Scene::compile(&f, Some(dir)).unwrap()
}

pub(in crate::integrator::bidir) fn bidir(alg: &str, params: serde_json::Value) -> Bidir {
    let map = params.as_object().cloned().unwrap_or_default();
    let settings = Settings::resolve(Some(alg), None, &map).unwrap();
    let s = match settings {
        Settings::Bpt(s) | Settings::Vcm(s) | Settings::Upbp(s) | Settings::Bpm(s) => s,
        _ => unreachable!(),
    };
    Bidir::new(s.technique_of(alg), s)
}

pub(in crate::integrator::bidir) fn image(
    scene: &Scene,
    integ: &dyn Integrator,
    seed: u64,
    n: u64,
) -> Image {
    let halt = Halt {
        iterations: Some(n),
        ..Halt::default()
    };
    let out = render(scene, integ, seed, halt, |_, _| {});
    out.film.to_image(1.0 / n as f64)
}

fn peak(img: &Image) -> f32 {
    img.pixels()
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max)
}

/// Per pixel, a pseudo-random candidate below `n`.
fn scattered(pixels: usize, n: u8) -> Vec<u8> {
    (0..pixels)
        .map(|i| ((i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 61) as u8 % n)
        .collect()
}

/// Renders `alg` with `params` and each pixel's candidate scattered over `jobs.len()`
/// of them, and asserts that every pixel equals the job of its candidate (`params`
/// plus `jobs[c]`) up to rounding: where connections cover every path (no specular
/// surfaces), a candidate is that job on the same subpaths. Returns the largest
/// difference between two of the jobs (relative to the peak), which must be large
/// for the test to mean anything.
fn assert_pixels_match_jobs(
    scene: &Scene,
    alg: &str,
    params: &serde_json::Value,
    jobs: &[(&str, serde_json::Value)],
) -> f32 {
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let choice = scattered(w * h, jobs.len() as u8);
    let mixed = bidir(alg, params.clone()).with_choice(choice.clone());
    let mixed = image(scene, &mixed, 5, 2);
    let images: Vec<Image> = jobs
        .iter()
        .map(|(a, extra)| {
            let mut p = params.clone();
            for (k, v) in extra.as_object().unwrap() {
                p[k] = v.clone();
            }
            image(scene, &bidir(a, p), 5, 2)
        })
        .collect();
    let top = peak(&images[0]);
    let mut worst = vec![0.0f32; jobs.len()];
    for (i, &c) in choice.iter().enumerate() {
        let d = (mixed.pixels()[i] - images[c as usize].pixels()[i]).abs();
        worst[c as usize] = worst[c as usize].max(d.max_element() / top);
    }
    let mut apart = 0.0f32;
    for img in &images[1..] {
        let d = img.pixels().iter().zip(images[0].pixels());
        apart = apart.max(
            d.map(|(a, b)| (*a - *b).abs().max_element() / top)
                .fold(0.0, f32::max),
        );
    }
    eprintln!("{alg}: pixels against their candidate's job {worst:?}; jobs apart {apart:.1e}");
    for (c, (&d, job)) in worst.iter().zip(jobs).enumerate() {
        assert!(
            d < 1e-5,
            "candidate {c} ({job:?}): {d} of the peak from its job"
        );
    }
    apart
}

/// On the diffuse Cornell box every path has a connection, so a vcm pixel whose
/// candidate drops the merges is a bpt pixel, and one that keeps them a vcm pixel:
/// the same light and camera subpaths, the weights differing by rounding alone.
#[test]
fn pixels_render_as_the_job_of_their_candidate() {
    let scene = scene("scenes/cornell-box.json", 16);
    let params = serde_json::json!({"max_depth": 5, "radius_factor": 0.1});
    let jobs = [
        ("vcm", serde_json::json!({})),
        ("bpt", serde_json::json!({})),
    ];
    let apart = assert_pixels_match_jobs(&scene, "vcm", &params, &jobs);
    assert!(apart > 1e-3, "vcm and bpt agree too closely to tell apart");
}

/// The same for upbp's six candidates in fog (no specular surface): each pixel is the
/// upbp job with bpt and that candidate's estimators.
#[test]
fn upbp_pixels_render_as_the_job_of_their_candidate() {
    let scene = scene("scenes/media/fog-cornell.json", 16);
    let params = serde_json::json!({"max_depth": 5, "radius_factor": 0.1,
        "medium_radius_factor": 0.1, "pb2d_radius_factor": 0.05, "bb1d_radius_factor": 0.05,
        "selection": "all"});
    let sets = [
        "bpt+surf+pp3d+pb2d+bb1d",
        "bpt",
        "bpt+surf",
        "bpt+surf+pp3d",
        "bpt+surf+pb2d",
        "bpt+surf+bb1d",
    ];
    let jobs: Vec<(&str, serde_json::Value)> = sets
        .iter()
        .map(|s| ("upbp", serde_json::json!({"techniques": s})))
        .collect();
    let apart = assert_pixels_match_jobs(&scene, "upbp", &params, &jobs);
    assert!(
        apart > 1e-3,
        "the estimator sets agree too closely to tell apart"
    );
}

/// The sum of all channels over the pixels `region`, per seed: `runs` renders of `n`
/// iterations.
fn totals(
    scene: &Scene,
    integ: impl Fn() -> Bidir,
    region: &[bool],
    (runs, n): (u64, u64),
) -> Vec<f64> {
    (0..runs)
        .map(|seed| {
            let img = image(scene, &integ(), 100 + seed, n);
            let pixels = img.pixels().iter().zip(region).filter(|(_, &r)| r);
            pixels.map(|(p, _)| (p.x + p.y + p.z) as f64).sum()
        })
        .collect()
}

/// Mean and standard error of the mean.
fn mean_se(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// |mean(a - b)| in standard errors of that mean: `a` and `b` come from the same
/// seeds, so their difference is far less noisy than either (a paired test).
fn z(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let (m, se) = mean_se(&d);
    m.abs() / se.max(1e-300)
}

/// The Cornell box seen from inside a glass sphere and lit by a point light inside
/// another: every path to a wall is specular at both ends of its diffuse part, so only
/// merges find it (bpt renders the glass alone).
pub(in crate::integrator::bidir) fn glass_lamp_box(size: u32) -> Scene {
    let text = std::fs::read_to_string("scenes/cornell-box.json").unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["film"] = serde_json::json!({"width": size, "height": size, "filter": "box"});
    v["materials"]["glass"] = serde_json::json!({"type": "dielectric", "int_ior": 1.5});
    let shapes = v["shapes"].as_array_mut().unwrap();
    shapes.retain(|s| s["name"] != "light");
    for (center, r) in [([0.0, 0.0, 3.9], 0.3), ([0.0, 0.6, 0.0], 0.15)] {
        shapes.push(serde_json::json!({
            "type": "sphere", "center": center, "radius": r, "material": "glass"
        }));
    }
    v["lights"] =
        serde_json::json!([{"type": "point", "position": [0, 0.6, 0], "intensity": [2, 2, 2]}]);
    let f = parse_scene(&v.to_string()).unwrap();
    Scene::compile(&f, Some(Path::new("scenes"))).unwrap()
}

/// A pixel whose candidate drops the merges keeps them on the paths only they find:
/// in [`glass_lamp_box`] it renders vcm's image, not bpt's (nearly black).
#[test]
fn dropped_merges_keep_the_paths_only_they_find() {
    let scene = glass_lamp_box(16);
    let params = serde_json::json!({"max_depth": 8, "radius_factor": 0.05});
    let none = || bidir("vcm", params.clone()).with_choice(vec![1; 16 * 16]);
    let all = vec![true; 16 * 16];
    let runs = (12, 1);
    let cand = totals(&scene, none, &all, runs);
    let vcm = totals(&scene, || bidir("vcm", params.clone()), &all, runs);
    let bpt = totals(&scene, || bidir("bpt", params.clone()), &all, runs);
    let (zc, zb) = (z(&cand, &vcm), z(&bpt, &vcm));
    eprintln!(
        "image sums: candidate {:?}, vcm {:?}, bpt {:?}; candidate vs vcm {zc:.2} se, bpt vs vcm {zb:.2} se",
        mean_se(&cand),
        mean_se(&vcm),
        mean_se(&bpt)
    );
    assert!(zb > 10.0, "bpt misses too little to test ({zb} se)");
    assert!(
        zc < 4.0,
        "candidate differs from vcm by {zc} standard errors"
    );
}
