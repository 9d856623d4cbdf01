//! The bidirectional family (lt, bpt, bpm, vcm) against the path tracer and against
//! each other, at small resolutions. Every agreement bound comes from the renders'
//! own noise: per-block means and standard errors estimated from the spread of
//! independent iterations (see `bidirectional/stats.rs`).

#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::integrator::bidir::BidirSettings;
use caustic::integrator::Settings;
use caustic::scene::{load::read_scene_file, Scene};
use serde_json::{json, Value};
use stats::{assert_agree, blocks, run, Rect, Run};
use std::path::Path;
use std::sync::OnceLock;

/// A built-in scene at `size` x `size` pixels.
fn scene(name: &str, size: u32) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let mut f = read_scene_file(&path).expect("scene reads");
    f.film.width = size;
    f.film.height = size;
    Scene::compile(&f, path.parent()).expect("scene compiles")
}

/// `algorithm` with the scene's defaults (its `max_depth` carries over) and `params`.
fn settings(scene: &Scene, algorithm: &str, params: Value) -> Settings {
    let map = params.as_object().cloned().unwrap_or_default();
    Settings::resolve(Some(algorithm), scene.integrator.as_ref(), &map).expect("settings")
}

const CORNELL: u32 = 48;
const BLOCK: u32 = 8;

fn cornell() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| scene("cornell-box.json", CORNELL))
}

fn cornell_blocks() -> Vec<Rect> {
    blocks(CORNELL, CORNELL, BLOCK)
}

/// The path tracer's Cornell box, shared by the tests that compare against it.
fn cornell_pt() -> &'static Run {
    static R: OnceLock<Run> = OnceLock::new();
    R.get_or_init(|| {
        let s = cornell();
        run(s, &settings(s, "pt", json!({})), 1, 512, &cornell_blocks())
    })
}

const ALGORITHMS: [&str; 5] = ["pt", "lt", "bpt", "bpm", "vcm"];
const SCENES: [&str; 5] = [
    "cornell-box.json",
    "smallvcm/gbs_s.json",
    "smallvcm/glm_c.json",
    "smallvcm/gbs_p.json",
    "smallvcm/gbs_b.json",
];

/// Item 6: No algorithm drops a sample (non-finite or negative) on any built-in scene, and
/// each one sees some light.
#[test]
fn no_dropped_samples_on_builtin_scenes() {
    for name in SCENES {
        let s = scene(name, 32);
        for alg in ALGORITHMS {
            let integrator = settings(&s, alg, json!({})).build();
            let mut film = caustic::film::Film::new(32, 32);
            for i in 0..4 {
                integrator.iterate(&s, 11, i, &mut film);
            }
            assert_eq!(film.dropped(), 0, "{alg} on {name}: dropped samples");
            let mean = film.to_image(0.25).mean();
            assert!(
                mean.is_finite() && mean.max_element() > 0.0,
                "{alg} on {name}: mean {mean}"
            );
        }
    }
}

/// Item 7: vcm's image does not depend on the number of threads: rendered inside rayon
/// pools of 1 and 2 threads, the pixel sums are bit-identical. The light pass spans
/// several chunks and merges are frequent (large radius), so both the chunked light
/// pass and the parallel hash-grid build are exercised.
#[test]
fn vcm_is_independent_of_thread_count() {
    let s = scene("smallvcm/gbs_s.json", 64);
    let st = settings(&s, "vcm", json!({"radius_factor": 0.02}));
    let render = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let integrator = st.build();
            let mut film = caustic::film::Film::new(64, 64);
            let mut merges = 0;
            for i in 0..3 {
                merges += integrator.iterate(&s, 5, i, &mut film).merges;
            }
            (film, merges)
        })
    };
    let (one, merges) = render(1);
    let (two, merges2) = render(2);
    assert!(
        merges > 1000,
        "too few merges to exercise the grid: {merges}"
    );
    assert_eq!(merges, merges2);
    assert_eq!(one.dropped(), two.dropped());
    let differing = one
        .sums()
        .iter()
        .zip(two.sums())
        .filter(|(a, b)| {
            a.iter()
                .zip(b.iter())
                .any(|(x, y)| x.to_bits() != y.to_bits())
        })
        .count();
    assert_eq!(
        differing, 0,
        "{differing} pixels differ between 1 and 2 threads"
    );
}

fn resolve(alg: &str, scene_default: Option<Value>, params: Value) -> Result<Settings, String> {
    let map = params.as_object().cloned().unwrap_or_default();
    Settings::resolve(Some(alg), scene_default.as_ref(), &map).map_err(|e| e.to_string())
}

/// Item 8: Settings of the bidirectional family: bpm cannot drop merging at the first
/// camera vertex, unknown fields are refused, and a scene's `max_depth` written for
/// pt carries over.
#[test]
fn bidirectional_settings() {
    let err = resolve("bpm", None, json!({"merge_first": false})).unwrap_err();
    assert!(
        err.contains("merge_first") && err.contains("vcm"),
        "unclear error: {err}"
    );
    // vcm has other techniques for those paths.
    assert!(resolve("vcm", None, json!({"merge_first": false})).is_ok());

    for alg in ["lt", "bpt", "bpm", "vcm"] {
        let err = resolve(alg, None, json!({"radius_facter": 0.01})).unwrap_err();
        assert!(err.contains("radius_facter"), "{alg}: {err}");
        // A pt-only parameter is unknown to the bidirectional family.
        let err = resolve(alg, None, json!({"rr_depth": 3})).unwrap_err();
        assert!(err.contains("rr_depth"), "{alg}: {err}");
        for bad in [
            json!({"max_depth": 0}),
            json!({"alpha": 0.0}),
            json!({"alpha": 1.5}),
            json!({"light_paths": 0.0}),
            json!({"radius": -1.0}),
            json!({"radius_factor": 0.0}),
        ] {
            assert!(resolve(alg, None, bad.clone()).is_err(), "{alg} took {bad}");
        }
    }

    let pt_default = json!({"algorithm": "pt", "max_depth": 10});
    let expect = |max_depth| BidirSettings {
        max_depth,
        ..Default::default()
    };
    assert_eq!(
        resolve("vcm", Some(pt_default.clone()), json!({})).unwrap(),
        Settings::Vcm(expect(10))
    );
    for (alg, wrap) in [
        ("lt", Settings::Lt as fn(BidirSettings) -> Settings),
        ("bpt", Settings::Bpt),
        ("bpm", Settings::Bpm),
    ] {
        assert_eq!(
            resolve(alg, Some(pt_default.clone()), json!({})).unwrap(),
            wrap(expect(10)),
            "{alg}"
        );
    }
    // Parameters beat the scene's default; pt-only defaults do not leak (nor fail).
    assert_eq!(
        resolve("vcm", Some(pt_default.clone()), json!({"max_depth": 4})).unwrap(),
        Settings::Vcm(expect(4))
    );
    let with_rr = json!({"algorithm": "pt", "max_depth": 10, "rr_depth": 2});
    assert_eq!(
        resolve("vcm", Some(with_rr), json!({})).unwrap(),
        Settings::Vcm(expect(10))
    );
    // A scene default for vcm itself applies whole.
    let vcm_default = json!({"algorithm": "vcm", "max_depth": 6, "alpha": 0.5});
    assert_eq!(
        resolve("vcm", Some(vcm_default), json!({})).unwrap(),
        Settings::Vcm(BidirSettings {
            max_depth: 6,
            alpha: 0.5,
            ..Default::default()
        })
    );
    // The built-in SmallVCM scenes say max_depth 10 for pt, and so vcm uses 10.
    let s = scene("smallvcm/gbs_s.json", 8);
    assert_eq!(settings(&s, "vcm", json!({})), Settings::Vcm(expect(10)));

    // Settings round-trip through JSON.
    let s = resolve(
        "vcm",
        None,
        json!({"merge_first": false, "heuristic": "power", "radius": 0.01}),
    )
    .unwrap();
    let back: Settings = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(s, back);
}

/// Item 1: pt, lt, bpt and vcm converge to the same Cornell box: every 8 x 8 block and the
/// whole-image mean agree within noise.
#[test]
fn cornell_box_agrees_across_algorithms() {
    let s = cornell();
    let regions = cornell_blocks();
    let reference = cornell_pt();
    assert_eq!(reference.dropped, 0);
    for (alg, seed, iterations) in [("lt", 2, 256), ("bpt", 3, 128), ("vcm", 4, 128)] {
        let r = run(s, &settings(s, alg, json!({})), seed, iterations, &regions);
        assert_eq!(r.dropped, 0, "{alg}");
        assert_agree(&r, reference, &regions);
    }
}

/// Item 4: vcm without merging at the first camera vertex loses no energy: it agrees with
/// vcm with it, and with pt.
#[test]
fn vcm_without_first_merge_agrees() {
    let s = cornell();
    let regions = cornell_blocks();
    let without = run(
        s,
        &settings(s, "vcm", json!({"merge_first": false})),
        5,
        128,
        &regions,
    );
    let with = run(
        s,
        &settings(s, "vcm", json!({"merge_first": true})),
        6,
        128,
        &regions,
    );
    assert_eq!(without.dropped + with.dropped, 0);
    assert_agree(&without, &with, &regions);
    assert_agree(&without, cornell_pt(), &regions);
}

/// Item 2: bpt and vcm agree on SmallVCM's glm_c (area light in a light box, large mirror
/// sphere).
#[test]
fn glm_c_bpt_and_vcm_agree() {
    let s = scene("smallvcm/glm_c.json", 48);
    let regions = blocks(48, 48, BLOCK);
    let bpt = run(&s, &settings(&s, "bpt", json!({})), 7, 128, &regions);
    let vcm = run(&s, &settings(&s, "vcm", json!({})), 8, 128, &regions);
    assert_eq!(bpt.dropped + vcm.dropped, 0);
    assert_agree(&vcm, &bpt, &regions);
}

/// Item 3: Progressive photon mapping's convergence: bpm's merge radius follows
/// r_i = r_1 i^((alpha - 1) / 2), and its error against the converged path-traced
/// Cornell box falls at a rate between what the radius schedule predicts for pure
/// noise and for pure bias.
///
/// With r_i^2 = r_1^2 i^(alpha - 1), iteration i's variance grows as 1 / r_i^2 and its
/// bias as r_i^2, so after n iterations the noise part of the MSE goes as
/// S(n) / n^2 with S(n) = sum i^(1 - alpha), and the bias as T(n) / n with
/// T(n) = sum i^(alpha - 1). Between n and 4n the RMSE ratio is therefore between
/// sqrt(S(4n) n^2 / (S(n) 16 n^2)) (about 0.60 for alpha = 0.75) and
/// T(4n) n / (T(n) 4n) (about 0.77); parts of the image that do not depend on the
/// radius (directly seen emitters, pixel antialiasing) fall as 1 / sqrt(n), i.e. 0.5.
/// An estimator whose error stalls (energy lost or gained) gives a ratio near 1.
#[test]
fn bpm_error_falls_at_the_progressive_rate() {
    let s = cornell();
    let alpha = 0.75f64;
    let st = settings(s, "bpm", json!({"alpha": alpha}));
    let r1 = 0.003 * s.sphere.radius as f64;

    let reference = cornell_pt();
    let ref_img = reference.image();
    let ref_var: f64 = reference
        .pixel_variance()
        .iter()
        .map(|v| v.iter().sum::<f64>())
        .sum::<f64>()
        / (ref_img.len() * 3) as f64;

    let checkpoints = [4u64, 16, 64];
    let seeds = [21u64, 22, 23];
    let mut mse = [0.0f64; 3];
    for seed in seeds {
        let integrator = st.build();
        let mut film = caustic::film::Film::new(CORNELL, CORNELL);
        for i in 0..*checkpoints.last().unwrap() {
            let stats = integrator.iterate(s, seed, i, &mut film);
            // [TR] eq. 21 with iterations numbered from 1.
            let expect = r1 * ((i + 1) as f64).powf(0.5 * (alpha - 1.0));
            assert!(
                (stats.merge_radius as f64 / expect - 1.0).abs() < 1e-4,
                "iteration {i}: radius {} expected {expect}",
                stats.merge_radius
            );
            if let Some(k) = checkpoints.iter().position(|&c| c == i + 1) {
                let img = film.to_image(1.0 / (i + 1) as f64);
                let sq: f64 = img
                    .pixels()
                    .iter()
                    .zip(&ref_img)
                    .map(|(a, b)| (0..3).map(|c| (a[c] as f64 - b[c]).powi(2)).sum::<f64>())
                    .sum();
                // The reference's own noise adds its variance to the squared error.
                mse[k] += (sq / (ref_img.len() * 3) as f64 - ref_var) / seeds.len() as f64;
            }
        }
        assert_eq!(film.dropped(), 0);
    }

    let sum_pow = |n: u64, p: f64| (1..=n).map(|i| (i as f64).powf(p)).sum::<f64>();
    for k in 0..2 {
        let (n, m) = (checkpoints[k], checkpoints[k + 1]);
        let ratio = (mse[k + 1] / mse[k]).sqrt();
        let noise =
            (sum_pow(m, 1.0 - alpha) / (m * m) as f64 / (sum_pow(n, 1.0 - alpha) / (n * n) as f64))
                .sqrt();
        let bias = (sum_pow(m, alpha - 1.0) / m as f64) / (sum_pow(n, alpha - 1.0) / n as f64);
        let iid = (n as f64 / m as f64).sqrt();
        eprintln!(
            "bpm rmse {n} -> {m} iterations: {:.4e} -> {:.4e}, ratio {ratio:.3} \
             (pure noise {noise:.3}, pure bias {bias:.3}, radius-independent {iid:.3}); \
             reference variance {ref_var:.2e}",
            mse[k].sqrt(),
            mse[k + 1].sqrt()
        );
        assert!(mse[k + 1] > 0.0 && mse[k + 1] < mse[k]);
        // At the default radius (about 1/8 pixel here) noise dominates, so the
        // ratio follows the pure-noise prediction; a radius that did not shrink
        // (alpha ignored) would give 0.5, 13% below it.
        assert!(
            (ratio / noise - 1.0).abs() < 0.1,
            "bpm's RMSE ratio {n} -> {m} iterations is {ratio:.3}, predicted {noise:.3}"
        );
        // 10% slack on either side for the randomness of the error estimates.
        assert!(
            ratio > 0.9 * iid && ratio < 1.1 * noise.max(bias),
            "bpm's RMSE ratio {n} -> {m} iterations is {ratio:.3}, outside [{:.3}, {:.3}]",
            0.9 * iid,
            1.1 * noise.max(bias)
        );
    }
}

const GBS: u32 = 64;

/// Item 5: On gbs_s (a delta sun, a mirror and a glass sphere) pt cannot sample light
/// whose first bounce from the sun is specular. Caustics seen directly (the spot the
/// spheres throw on the right wall, and the light they scatter onto the back wall and
/// ceiling) are rendered by vcm, bpm and bpt (light tracing); caustics seen in the
/// mirror (sun - specular - diffuse - mirror - eye) only by merging, vcm and bpm.
/// Where no specular surface is seen, bpt, bpm and vcm agree within noise; pt is
/// never brighter than vcm beyond noise.
#[test]
fn gbs_s_caustics_need_bidirectional_methods() {
    let s = scene("smallvcm/gbs_s.json", GBS);
    let region = |r| Rect::relative(GBS, GBS, r);
    let caustics = [
        (
            "caustic spot on the right wall",
            region([0.82, 0.56, 0.9, 0.8]),
        ),
        ("back wall", region([0.3, 0.15, 0.7, 0.45])),
        ("ceiling", region([0.2, 0.0, 0.8, 0.1])),
    ];
    let mirrored = [(
        "caustic seen in the mirror sphere",
        region([0.44, 0.64, 0.49, 0.78]),
    )];
    // Both spheres lie inside this rectangle.
    let spheres = region([0.2, 0.55, 0.85, 0.9]);
    let grid = blocks(GBS, GBS, BLOCK);
    let mut regions: Vec<Rect> = caustics.iter().chain(&mirrored).map(|r| r.1).collect();
    let named = regions.len();
    regions.extend(&grid);

    // A merge radius of 0.015 (default 0.003) of the scene's radius, about a third of
    // a pixel here, keeps the merged mirror images from drowning in noise.
    let merging = json!({"radius_factor": 0.015});
    let pt = run(&s, &settings(&s, "pt", json!({})), 31, 256, &regions);
    let bpt = run(&s, &settings(&s, "bpt", json!({})), 32, 128, &regions);
    let vcm = run(&s, &settings(&s, "vcm", merging.clone()), 33, 128, &regions);
    let bpm = run(&s, &settings(&s, "bpm", merging), 34, 128, &regions);
    for r in [&pt, &bpt, &vcm, &bpm] {
        assert_eq!(r.dropped, 0, "{}", r.name);
    }

    // z of "a brighter than b" in region k, summed over red and green (the sun has no
    // blue).
    let brighter = |a: &Run, b: &Run, k: usize| {
        let (x, y) = (&a.regions[k], &b.regions[k]);
        let d = x.mean[0] + x.mean[1] - y.mean[0] - y.mean[1];
        let var = x.se[0].powi(2) + x.se[1].powi(2) + y.se[0].powi(2) + y.se[1].powi(2);
        d / var.sqrt()
    };
    for (k, (name, _)) in caustics.iter().enumerate() {
        for a in [&vcm, &bpm, &bpt] {
            let z = brighter(a, &pt, k);
            eprintln!("{name}: {} brighter than pt by {z:.1} se", a.name);
            assert!(
                z > 8.0,
                "{name}: {} not brighter than pt (z {z:.1})",
                a.name
            );
        }
    }
    for (j, (name, _)) in mirrored.iter().enumerate() {
        let k = caustics.len() + j;
        for a in [&vcm, &bpm] {
            for b in [&pt, &bpt] {
                let z = brighter(a, b, k);
                eprintln!("{name}: {} brighter than {} by {z:.1} se", a.name, b.name);
                assert!(z > 6.0, "{name}: {} vs {} (z {z:.1})", a.name, b.name);
            }
        }
    }

    // Blocks that show no specular surface.
    let clear: Vec<usize> = (named..regions.len())
        .filter(|&k| {
            let b = regions[k];
            b.x1 <= spheres.x0 || b.x0 >= spheres.x1 || b.y1 <= spheres.y0 || b.y0 >= spheres.y1
        })
        .collect();
    let only = |r: &Run, ks: &[usize]| stats::select(r, ks);
    let clear_rects: Vec<Rect> = clear.iter().map(|&k| regions[k]).collect();
    // (Not the whole image: it holds the mirror images bpt cannot render.)
    stats::assert_regions_agree(&only(&vcm, &clear), &only(&bpt, &clear), &clear_rects);
    let all: Vec<usize> = (named..regions.len()).collect();
    assert_agree(&only(&vcm, &all), &only(&bpm, &all), &grid);

    // pt only misses light: one-sided, it is never brighter than vcm beyond noise.
    let p_one = stats::normal_tail(4.0) / 2.0;
    let allowed = stats::allowed_failures(all.len() * 3, p_one, 1e-3);
    let mut above = Vec::new();
    for &k in &all {
        for c in 0..3 {
            let (x, y) = (&pt.regions[k], &vcm.regions[k]);
            let se = (x.se[c].powi(2) + y.se[c].powi(2)).sqrt();
            if x.mean[c] - y.mean[c] > 4.0 * se {
                above.push((regions[k], c, (x.mean[c] - y.mean[c]) / se));
            }
        }
    }
    assert!(
        above.len() <= allowed,
        "pt brighter than vcm beyond noise: {above:?}"
    );
}
