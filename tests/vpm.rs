//! Volumetric photon mapping (`vpm`): convergence towards `volpath` on a fog-filled
//! Cornell box and around a point light in an infinite medium, for both estimates; the
//! point and beam estimates agreeing at a small fixed radius; no dropped samples;
//! images independent of the thread count.

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::film::Film;
use caustic::integrator::photon::vpm::Estimate;
use caustic::integrator::transport::radius::radius_schedule;
use caustic::integrator::{RenderStats, Settings};
use caustic::scene::Scene;
use common::*;
use serde_json::{json, Value};
use stats::{blocks, Run};

/// The Cornell box at `size` x `size`, framed on its middle (fov 22: walls, boxes and
/// fog, but not the light, whose edge pixels would make the error mostly antialiasing
/// noise of path-traced emission), filled with a homogeneous isotropic fog bounded by
/// a null cube just outside the walls, as in tests/media.rs.
fn fog_box(size: u32) -> Scene {
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string("scenes/cornell-box.json").unwrap()).unwrap();
    v["film"] = json!({"width": size, "height": size});
    v["camera"]["fov"] = json!(22);
    v["materials"]["boundary"] = json!({"type": "null"});
    v["media"] = json!({"fog": {"type": "homogeneous", "sigma_t": [1, 1, 1],
                                "albedo": [0.8, 0.8, 0.8]}});
    v["shapes"].as_array_mut().unwrap().push(
        json!({"type": "cube", "material": "boundary", "interior": "fog",
                     "transform": {"scale": 1.001}}),
    );
    compile(v)
}

/// The Cornell box framed as `fog_box`, filled with chromatic procedural smoke
/// (heterogeneous: spectral tracking, ratio tracking, sigma_s varying in space) with a
/// backward-scattering phase function.
fn smoke_box(size: u32) -> Scene {
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string("scenes/cornell-box.json").unwrap()).unwrap();
    v["film"] = json!({"width": size, "height": size});
    v["camera"]["fov"] = json!(22);
    v["materials"]["boundary"] = json!({"type": "null"});
    v["media"] = json!({"smoke": {"type": "procedural", "sigma_t": [3, 2, 1],
                                  "albedo": [0.9, 0.7, 0.8], "octaves": 3,
                                  "phase": {"type": "hg", "g": -0.3},
                                  "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}}});
    v["shapes"].as_array_mut().unwrap().push(
        json!({"type": "cube", "material": "boundary", "interior": "smoke",
                     "transform": {"scale": 1.001}}),
    );
    compile(v)
}

/// A point light in an infinite, chromatic, forward-scattering medium that holds the
/// camera: the image is in-scattered light only. The light sits outside the view, so
/// the radiance along camera rays is smooth (a light in view makes it ~1 / distance
/// from the light, where kernel bias falls more slowly than the r^2 the rates assume).
fn point_in_fog(size: u32) -> Scene {
    compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 0], "target": [0, 0, 1], "up": [0, 1, 0]},
                   "fov": 50, "medium": "fog"},
        "film": {"width": size, "height": size},
        "media": {"fog": {"type": "homogeneous", "sigma_a": [0.1, 0.1, 0.1],
                          "sigma_s": [0.4, 0.3, 0.2], "phase": {"type": "hg", "g": 0.5}}},
        "lights": [{"type": "point", "position": [1.2, 0.3, 1.0], "intensity": [5, 5, 5]}]
    }))
}

/// A volpath reference: its mean image, the mean variance of its pixel values (which
/// the squared error of any image against it contains on average), and its image mean
/// with that mean's standard error.
struct Reference {
    image: Vec<[f64; 3]>,
    variance: f64,
    mean: f64,
    mean_se: f64,
}

fn reference(scene: &Scene, spp: u64) -> Reference {
    let start = std::time::Instant::now();
    let r: Run = stats::run(scene, &settings("volpath", json!({})), 99, spp, &[]);
    assert_eq!(r.dropped, 0, "volpath dropped samples");
    let values = (3 * r.sums.len()) as f64;
    let variance = r
        .pixel_variance()
        .iter()
        .map(|v| v[0] + v[1] + v[2])
        .sum::<f64>()
        / values;
    let w = r.whole();
    let reference = Reference {
        image: r.image(),
        variance,
        mean: w.mean.iter().sum::<f64>() / 3.0,
        mean_se: (w.se.iter().map(|s| s * s).sum::<f64>()).sqrt() / 3.0,
    };
    eprintln!(
        "volpath reference: {spp} spp in {:.1} s, mean {:.4} +- {:.4}, noise RMSE {:.4}",
        start.elapsed().as_secs_f64(),
        reference.mean,
        reference.mean_se,
        variance.sqrt()
    );
    reference
}

fn mean_image(film: &Film, n: u64) -> Vec<[f64; 3]> {
    let k = 1.0 / n as f64;
    film.sums()
        .iter()
        .map(|p| [p[0] * k, p[1] * k, p[2] * k])
        .collect()
}

fn squared_error(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let se: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>())
        .sum();
    se / (3 * a.len()) as f64
}

fn image_mean(a: &[[f64; 3]]) -> f64 {
    a.iter().map(|p| p[0] + p[1] + p[2]).sum::<f64>() / (3 * a.len()) as f64
}

/// Iteration counts at which the error is measured.
const NS: [u64; 7] = [1, 2, 4, 8, 16, 32, 64];
/// Independent jobs the squared errors are averaged over.
const SEEDS: u64 = 6;

/// RMSE against the reference after each of NS iterations, from the squared error
/// averaged over SEEDS jobs minus the reference's own variance (an estimate of the
/// expected squared error against the truth); the image mean of each job at the end.
struct Curve {
    rmse: Vec<f64>,
    final_means: Vec<f64>,
    stats: RenderStats,
}

fn error_curve(scene: &Scene, s: &Settings, r: &Reference) -> Curve {
    let mut mse = [0.0f64; NS.len()];
    let mut final_means = Vec::new();
    let mut stats = RenderStats::default();
    for seed in 1..=SEEDS {
        let integ = s.build();
        let mut film = Film::new(scene.width(), scene.height());
        for i in 0..NS[NS.len() - 1] {
            stats += integ.iterate(scene, seed, i, &mut film);
            if let Some(k) = NS.iter().position(|&n| n == i + 1) {
                let img = mean_image(&film, i + 1);
                mse[k] += (squared_error(&img, &r.image) - r.variance) / SEEDS as f64;
                if k == NS.len() - 1 {
                    final_means.push(image_mean(&img));
                }
            }
        }
        assert_eq!(film.dropped(), 0, "{}: dropped samples", s.name());
    }
    Curve {
        rmse: mse.iter().map(|v| v.max(0.0).sqrt()).collect(),
        final_means,
        stats,
    }
}

/// Least-squares slope of log y against log x.
fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.max(1e-30).ln()).collect();
    let n = x.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// The log-log slope over NS of the RMSE that the kernel's variance alone gives: the
/// mean of n independent estimates whose variances grow as r_i^-k, i.e. sqrt(sum_{i<=n}
/// (r_1 / r_i)^k) / n with the integrator's radius schedule. (With alpha = 4 / (k + 4),
/// the squared bias falls at the same asymptotic rate; variance that does not depend on
/// the radius, from camera paths and photon paths, falls as n^-1/2.)
fn kernel_variance_slope(alpha: f32, k: u32) -> f64 {
    let y: Vec<f64> = NS
        .iter()
        .map(|&n| {
            let s: f64 = (0..n)
                .map(|i| (1.0 / radius_schedule(1.0, alpha, k, i) as f64).powi(k as i32))
                .sum();
            s.sqrt() / n as f64
        })
        .collect();
    let x: Vec<f64> = NS.iter().map(|&n| n as f64).collect();
    log_slope(&x, &y)
}

/// Slack on either side of the expected slope range: the measured slope of an average
/// over SEEDS jobs wanders by about +-0.05 between seed sets.
const SLOPE_SLACK: f64 = 0.12;
/// Bias of the final images allowed on top of the noise, as a fraction of the mean.
const MEAN_BIAS: f64 = 0.03;

/// vpm with `params` converges towards the reference: its RMSE falls with the
/// iterations at a rate between the kernel-variance rate and n^-1/2 (module notes of
/// vpm.rs: at the default alpha, squared bias falls with the variance), ends well below
/// where it started, and the final image mean matches the reference within noise plus
/// MEAN_BIAS.
fn assert_converges(name: &str, scene: &Scene, r: &Reference, params: Value) {
    let s = settings("vpm", params.clone());
    let Settings::Vpm(vs) = &s else {
        unreachable!()
    };
    let start = std::time::Instant::now();
    let c = error_curve(scene, &s, r);
    let x: Vec<f64> = NS.iter().map(|&n| n as f64).collect();
    let slope = log_slope(&x, &c.rmse);
    let k = vs.estimate.kernel_dims();
    let slowest = kernel_variance_slope(vs.alpha(), k);
    let iterations = SEEDS * NS[NS.len() - 1];
    eprintln!(
        "{name} {params}: {:.1} s for {SEEDS} x {} iterations; photons/it {}, merges/it {}",
        start.elapsed().as_secs_f64(),
        NS[NS.len() - 1],
        c.stats.light_vertices / iterations,
        c.stats.merges / iterations
    );
    eprintln!(
        "  RMSE at n = {NS:?}: {:?}\n  log-log slope {slope:.3} (expected in [-0.5, {slowest:.3}] +- {SLOPE_SLACK})",
        c.rmse.iter().map(|v| format!("{v:.5}")).collect::<Vec<_>>()
    );
    assert!(
        slope <= slowest + SLOPE_SLACK && slope >= -0.5 - SLOPE_SLACK,
        "{name} {params}: RMSE {:?} falls with slope {slope:.3}, expected in [-0.5, {slowest:.3}] +- {SLOPE_SLACK}",
        c.rmse
    );
    let (first, last) = (c.rmse[0], c.rmse[NS.len() - 1]);
    assert!(
        last < 0.4 * first,
        "{name} {params}: RMSE {first} -> {last} over 64 iterations"
    );
    let (m, se) = mean_se(&c.final_means);
    let tol = 4.0 * (se * se + r.mean_se * r.mean_se).sqrt() + MEAN_BIAS * r.mean;
    eprintln!(
        "  image mean {m:.4} +- {se:.4} vs volpath {:.4} (tolerance {tol:.4})",
        r.mean
    );
    assert!(
        (m - r.mean).abs() <= tol,
        "{name} {params}: image mean {m} vs volpath {} (tolerance {tol})",
        r.mean
    );
}

#[test]
fn converges_towards_volpath_in_a_fog_filled_cornell_box() {
    let scene = fog_box(16);
    let r = reference(&scene, 4096);
    assert_converges(
        "fog box",
        &scene,
        &r,
        json!({"estimate": "beam", "light_paths": 8, "radius": 0.1}),
    );
    assert_converges(
        "fog box",
        &scene,
        &r,
        json!({"estimate": "point", "light_paths": 8, "radius": 0.2}),
    );
}

#[test]
fn converges_towards_volpath_around_a_point_light_in_an_infinite_medium() {
    let scene = point_in_fog(16);
    let r = reference(&scene, 2048);
    assert_converges(
        "point light in fog",
        &scene,
        &r,
        json!({"estimate": "beam", "light_paths": 8, "radius": 0.15}),
    );
    assert_converges(
        "point light in fog",
        &scene,
        &r,
        json!({"estimate": "point", "light_paths": 8, "radius": 0.2}),
    );
}

/// At a small fixed radius (alpha 1: every iteration is an independent, identically
/// distributed estimate, so the spread of the iterations gives exact standard errors)
/// the two estimates agree block by block within 4 standard errors of the difference
/// plus a bias allowance. Their biases differ: both blur the in-scattered radiance over
/// r, but only the point query's ball loses volume beyond the walls (about 19% of the
/// kernel on average within r of a wall); at r = 0.05 in a box of size 2 that is ~1%.
#[test]
fn point_and_beam_estimates_agree_at_a_small_radius() {
    let scene = fog_box(16);
    let regions = blocks(16, 16, 4);
    let run = |estimate: &str, light_paths: f32, n: u64| {
        let s = settings(
            "vpm",
            json!({"estimate": estimate, "light_paths": light_paths,
                   "radius": 0.05, "alpha": 1.0}),
        );
        stats::run(&scene, &s, 3, n, &regions)
    };
    let beam = run("beam", 8.0, 48);
    let point = run("point", 32.0, 64);
    assert_eq!(beam.dropped + point.dropped, 0);
    let bias = 0.03;
    let mut worst: f64 = 0.0;
    for (k, (a, b)) in beam.regions.iter().zip(&point.regions).enumerate() {
        for c in 0..3 {
            let d = (a.mean[c] - b.mean[c]).abs();
            let tol = 4.0 * (a.se[c].powi(2) + b.se[c].powi(2)).sqrt()
                + bias * 0.5 * (a.mean[c] + b.mean[c]);
            worst = worst.max(d / tol);
            assert!(
                d <= tol,
                "region {k} channel {c}: beam {:.5} +- {:.5} vs point {:.5} +- {:.5} (tolerance {tol:.5})",
                a.mean[c],
                a.se[c],
                b.mean[c],
                b.se[c]
            );
        }
    }
    let (wa, wb) = (beam.whole(), point.whole());
    eprintln!(
        "beam {:.1} s, point {:.1} s; whole image beam {:.5} +- {:.5}, point {:.5} +- {:.5}; worst block at {worst:.2} of its tolerance",
        beam.seconds, point.seconds, wa.mean[1], wa.se[1], wb.mean[1], wb.se[1]
    );
}

/// In heterogeneous smoke (where the point query divides the flight weight by the local
/// sigma_s and the beam estimate ratio-tracks the transmittance to every photon) both
/// estimates match volpath block by block within 4 standard errors of the difference
/// plus 3% for the kernel's blur of the smoke's density features (radii fixed and
/// small: alpha 1).
#[test]
fn agrees_with_volpath_in_heterogeneous_smoke() {
    let scene = smoke_box(16);
    let regions = blocks(16, 16, 8);
    let reference = stats::run(&scene, &settings("volpath", json!({})), 9, 4096, &regions);
    assert_eq!(reference.dropped, 0);
    for params in [
        json!({"estimate": "beam", "light_paths": 8, "radius": 0.03, "alpha": 1.0}),
        json!({"estimate": "point", "light_paths": 32, "radius": 0.06, "alpha": 1.0}),
    ] {
        let r = stats::run(&scene, &settings("vpm", params.clone()), 9, 64, &regions);
        assert_eq!(r.dropped, 0);
        eprintln!(
            "smoke {params}: {:.1} s; whole image {:.4?} +- {:.4?} vs volpath {:.4?} +- {:.4?}",
            r.seconds,
            r.whole().mean,
            r.whole().se,
            reference.whole().mean,
            reference.whole().se
        );
        for (k, (a, b)) in r.regions.iter().zip(&reference.regions).enumerate() {
            for c in 0..3 {
                let d = (a.mean[c] - b.mean[c]).abs();
                let tol = 4.0 * (a.se[c].powi(2) + b.se[c].powi(2)).sqrt() + 0.03 * b.mean[c];
                assert!(
                    d <= tol,
                    "smoke {params}: region {k} channel {c}: {:.5} +- {:.5} vs volpath {:.5} +- {:.5}",
                    a.mean[c],
                    a.se[c],
                    b.mean[c],
                    b.se[c]
                );
            }
        }
    }
}

/// Both estimates on a homogeneous and a heterogeneous (procedural) fog box and on a
/// media-free Cornell box: nothing dropped, every camera sample counted, photons stored
/// and found where there are media, per-iteration figures reported; and the same film
/// bits with 1 and 2 threads.
#[test]
fn no_dropped_samples_and_no_dependence_on_the_thread_count() {
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string("scenes/cornell-box.json").unwrap()).unwrap();
    v["film"] = json!({"width": 12, "height": 12});
    let scenes = [
        ("fog box", fog_box(12)),
        ("smoke box", smoke_box(12)),
        ("no media", compile(v)),
    ];
    for (name, scene) in &scenes {
        for estimate in ["beam", "point"] {
            let s = settings(
                "vpm",
                json!({"estimate": estimate, "light_paths": 2, "radius": 0.1}),
            );
            s.check_scene(scene).expect("vpm renders media scenes");
            let films: Vec<(Film, RenderStats)> = [1, 2]
                .into_iter()
                .map(|threads| {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    pool.install(|| {
                        let integ = s.build();
                        let mut film = Film::new(scene.width(), scene.height());
                        let mut st = RenderStats::default();
                        for i in 0..3 {
                            st += integ.iterate(scene, 5, i, &mut film);
                        }
                        (film, st)
                    })
                })
                .collect();
            let (film, st) = &films[0];
            assert_eq!(film, &films[1].0, "{name} {estimate}: 1 vs 2 threads");
            assert_eq!(film.dropped(), 0, "{name} {estimate}: dropped samples");
            assert_eq!(st.samples, 3 * 144, "{name} {estimate}: camera samples");
            let Settings::Vpm(vs) = &s else {
                unreachable!()
            };
            let k = if vs.estimate == Estimate::BeamRadiance {
                2
            } else {
                3
            };
            let r2 = radius_schedule(0.1, vs.alpha(), k, 2);
            assert_eq!(
                st.merge_radius, r2,
                "{name} {estimate}: radius of iteration 2"
            );
            assert!(r2 < 0.1 && r2 > 0.08, "{r2}");
            if scene.has_media {
                assert!(st.light_vertices > 0, "{name} {estimate}: no photons");
                assert!(st.merges > 0, "{name} {estimate}: no photons found");
            } else {
                assert_eq!(st.light_vertices, 0, "{name}: photons without media");
            }
            let m: f64 = film.sums().iter().map(|p| p[0] + p[1] + p[2]).sum();
            assert!(m.is_finite() && m > 0.0, "{name} {estimate}: image sum {m}");
        }
    }
}

#[test]
fn settings_resolve_validate_and_round_trip() {
    let s = settings(
        "vpm",
        json!({"estimate": "point", "alpha": 0.5, "radius": 0.02}),
    );
    let back: Settings = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(s, back);
    assert_eq!(s.name(), "vpm");
    assert!(caustic::integrator::ALGORITHMS.contains(&"vpm"));
    let map = |v: Value| v.as_object().cloned().unwrap();
    for bad in [
        json!({"estimate": "ray"}),
        json!({"alpha": 1.5}),
        json!({"light_paths": 0}),
        json!({"radius": -1.0}),
        json!({"radius_factor": 0.0}),
        json!({"max_photon_mib": 0}),
        json!({"radius_": 0.1}),
    ] {
        assert!(
            Settings::resolve(Some("vpm"), None, &map(bad.clone())).is_err(),
            "{bad}"
        );
    }
}
