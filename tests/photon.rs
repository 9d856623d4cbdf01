//! Progressive photon mapping (`ppm`, `sppm`): convergence towards path tracing on the
//! Cornell box, state save/load continuing bit-identically, independence from the
//! thread count, and no dropped samples on scenes with every light type and
//! delta materials.

mod common;
use caustic::camera::Camera;
use caustic::film::Film;
use caustic::integrator::{Integrator, RenderStats, Settings};
use caustic::scene::Scene;
use serde_json::json;
use std::path::Path;

/// A built-in scene re-framed to `size` x `size` pixels.
fn scene(name: &str, size: u32) -> Scene {
    zoomed(name, size, None)
}

/// The same, with the field of view narrowed to `fov` degrees (same centre).
fn zoomed(name: &str, size: u32, fov: Option<f32>) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let mut scene = Scene::load(&path).expect("scene loads");
    let c = &scene.camera;
    let fov = fov.unwrap_or(2.0 * c.tan_half.x.atan().to_degrees());
    scene.camera = Camera::new(
        c.origin,
        c.origin + c.forward,
        c.up,
        fov,
        true,
        size,
        size,
        c.aperture_radius,
        Some(c.focus_distance),
    );
    scene
}

/// Runs iterations `range` of `integ` into `film`.
fn run(
    integ: &dyn Integrator,
    scene: &Scene,
    seed: u64,
    range: std::ops::Range<u64>,
    film: &mut Film,
) -> RenderStats {
    let mut stats = RenderStats::default();
    for i in range {
        stats += integ.iterate(scene, seed, i, film);
    }
    stats
}

/// The mean image after `n` iterations, as a flat list of channel values.
fn mean_image(scene: &Scene, s: &Settings, seed: u64, n: u64) -> Vec<f64> {
    let (film, it) = common::render(scene, s, seed, n);
    assert_eq!(film.dropped(), 0, "{} dropped samples", film.dropped());
    film.sums()
        .iter()
        .flat_map(|p| p.iter().map(move |v| v / it as f64))
        .collect()
}

/// Samples per pixel of each of the 4 PT references.
const REF_SPP: u64 = 96;

fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let se: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    (se / a.len() as f64).sqrt()
}

fn mean(a: &[f64]) -> f64 {
    a.iter().sum::<f64>() / a.len() as f64
}

/// Photon settings for 32 x 32 test images: enough photons per pass, and an initial
/// radius of about one pixel (the Cornell box's bounding sphere has radius ~1.7, one
/// pixel is ~0.09 units on the back wall).
fn photon_settings(alg: &str) -> Settings {
    common::settings(alg, json!({"light_paths": 8.0, "radius_factor": 0.05}))
}

/// RMSE to a path-traced reference at 4, 16 and 64 iterations falls by a clear factor
/// each time, and the final image's mean matches the reference's within a tolerance
/// computed from the reference's own noise plus a stated allowance for the bias of
/// density estimation.
fn converges_towards_pt(scene: &Scene, s: &Settings, max_ratio: f64) {
    let alg = s.name();
    // Reference: 4 independent PT renders, whose spread gives the standard error of
    // the reference mean.
    let pt = common::settings("pt", json!({}));
    let refs: Vec<Vec<f64>> = (0..4)
        .map(|k| mean_image(scene, &pt, 1000 + k, REF_SPP))
        .collect();
    let reference: Vec<f64> = (0..refs[0].len())
        .map(|i| refs.iter().map(|r| r[i]).sum::<f64>() / refs.len() as f64)
        .collect();
    let ref_means: Vec<f64> = refs.iter().map(|r| mean(r)).collect();
    let (ref_mean, ref_se) = common::mean_se(&ref_means);
    eprintln!(
        "{alg}: reference RMSE ~ {}",
        rmse(&refs[0], &refs[1]) / 8f64.sqrt()
    );

    let mut errors = Vec::new();
    let mut last = Vec::new();
    for n in [4u64, 16, 64] {
        let img = mean_image(scene, s, 7, n);
        errors.push(rmse(&img, &reference));
        last = img;
    }
    eprintln!("{alg}: RMSE to PT at 4/16/64 iterations: {errors:?}");
    for w in errors.windows(2) {
        assert!(
            w[1] < max_ratio * w[0],
            "{alg}: RMSE {errors:?} does not fall by {max_ratio} per 4x iterations"
        );
    }
    // Mean brightness: 4 reference standard errors, plus 1% for what density
    // estimation blurs away at the image border and in corners.
    let m = mean(&last);
    let tol = 4.0 * ref_se + 0.01 * ref_mean;
    eprintln!("{alg}: mean {m} vs PT {ref_mean} +- {ref_se} (tolerance {tol})");
    assert!(
        (m - ref_mean).abs() <= tol,
        "{alg}: mean {m} vs PT {ref_mean} (tolerance {tol})"
    );
}

#[test]
fn sppm_converges_towards_pt_on_the_cornell_box() {
    let s = photon_settings("sppm");
    converges_towards_pt(&scene("cornell-box.json", 32), &s, 0.75);
}

/// Plastic's coating is a delta lobe beside a diffuse one: sppm's visible points
/// estimate the diffuse part and its camera paths follow the coating with its
/// sampling probability, so a Cornell box with a glossy plastic back wall and floor, a
/// rough plastic box and a rough glass box still converges to pt.
#[test]
fn sppm_converges_towards_pt_with_plastics() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.json");
    let mut f = caustic::scene::load::read_scene_file(&path).expect("scene reads");
    f.film.width = 32;
    f.film.height = 32;
    let mut v = serde_json::to_value(&f).unwrap();
    // A dense coating (F = 0.36 at normal incidence) over a dark base: most of what
    // these walls send to the camera is the coating's delta reflection.
    v["materials"]["plastic"] =
        json!({"type": "plastic", "int_ior": 4.0, "diffuse_reflectance": [0.2, 0.2, 0.2]});
    v["materials"]["coat"] = json!({"type": "roughplastic", "alpha": 0.2});
    v["materials"]["glass"] = json!({"type": "roughdielectric", "alpha": 0.3});
    for shape in v["shapes"].as_array_mut().unwrap() {
        let m = match shape["name"].as_str().unwrap() {
            "back" | "floor" => "plastic",
            "small box" => "coat",
            "large box" => "glass",
            _ => continue,
        };
        shape["material"] = json!(m);
    }
    let f = serde_json::from_value(v).expect("scene parses");
    let scene = Scene::compile(&f, path.parent()).expect("scene compiles");
    converges_towards_pt(&scene, &photon_settings("sppm"), 0.75);
}

/// PPM keeps one camera sample per pixel for the whole job, so it converges to the
/// radiance at that point, not to the pixel's mean: an aliasing error that PT does not
/// have. It is large where a pixel straddles the light (radiance ~17 against ~0.5), so
/// the test frames the middle of the box (walls, boxes, no light in view), where it is
/// small next to the photon noise and bias being measured.
#[test]
fn ppm_converges_towards_pt_on_the_cornell_box() {
    let s = common::settings("ppm", json!({"light_paths": 1.0, "radius_factor": 0.03}));
    converges_towards_pt(&zoomed("cornell-box.json", 32, Some(20.0)), &s, 0.85);
}

/// 6 iterations straight, or 3, save, a new integrator, load, 3 more: same film bits.
#[test]
fn state_round_trip_continues_bit_identically() {
    let scene = scene("cornell-box.json", 24);
    for alg in ["ppm", "sppm"] {
        let s = photon_settings(alg);
        let straight = s.build();
        let mut a = Film::new(scene.width(), scene.height());
        run(straight.as_ref(), &scene, 3, 0..6, &mut a);

        let first = s.build();
        assert!(first.save_state().is_none(), "{alg}: state before any pass");
        let mut b = Film::new(scene.width(), scene.height());
        run(first.as_ref(), &scene, 3, 0..3, &mut b);
        let state = first.save_state().expect("state after a pass");
        drop(first);
        let second = s.build();
        second.load_state(&state).expect("state loads");
        run(second.as_ref(), &scene, 3, 3..6, &mut b);
        assert_eq!(a, b, "{alg}: resumed film differs");
        assert_eq!(second.save_state(), straight.save_state());

        // The other variant's state, or a damaged one, is refused.
        let other = if alg == "ppm" { "sppm" } else { "ppm" };
        assert!(photon_settings(other).build().load_state(&state).is_err());
        assert!(s.build().load_state(&state[..state.len() - 8]).is_err());

        // Without its state, a continuation starts its statistics afresh but still
        // leaves a film whose sums / iterations is a valid image.
        let fresh = s.build();
        let mut c = b.clone();
        run(fresh.as_ref(), &scene, 3, 6..7, &mut c);
        let m: f64 = c.sums().iter().map(|p| p[1]).sum::<f64>() / 7.0;
        let m0: f64 = b.sums().iter().map(|p| p[1]).sum::<f64>() / 6.0;
        assert!(
            m.is_finite() && (m - m0).abs() < 0.5 * m0,
            "{alg}: {m} vs {m0}"
        );
    }
}

#[test]
fn image_does_not_depend_on_the_thread_count() {
    let scene = scene("cornell-box.json", 24);
    for alg in ["ppm", "sppm"] {
        let s = photon_settings(alg);
        let films: Vec<Film> = [1, 2, 3]
            .into_iter()
            .map(|threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| common::render(&scene, &s, 11, 4).0)
            })
            .collect();
        assert_eq!(films[0], films[1], "{alg}: 1 vs 2 threads");
        assert_eq!(films[0], films[2], "{alg}: 1 vs 3 threads");
    }
}

/// Every built-in scene (area, point, directional and environment lights; glass,
/// mirror, Phong, meshes with shading normals): no sample is dropped, every camera
/// sample is counted, photons are stored and found, and the image is not black.
#[test]
fn no_dropped_samples() {
    let scenes = [
        "cornell-box.json",
        "smallvcm/gbs_s.json",
        "smallvcm/glm_c.json",
        "smallvcm/gbs_p.json",
        "smallvcm/gbs_b.json",
    ];
    for name in scenes {
        let scene = scene(name, 24);
        for alg in ["ppm", "sppm"] {
            let s = common::settings(alg, json!({"light_paths": 4.0, "radius_factor": 0.03}));
            let integ = s.build();
            let mut film = Film::new(scene.width(), scene.height());
            let stats = run(integ.as_ref(), &scene, 5, 0..3, &mut film);
            let px = (scene.width() * scene.height()) as u64;
            assert_eq!(film.dropped(), 0, "{name} {alg}: dropped samples");
            assert_eq!(stats.samples, 3 * px, "{name} {alg}: camera samples");
            assert!(stats.light_vertices > 0, "{name} {alg}: no photons stored");
            assert!(stats.merges > 0, "{name} {alg}: no photons gathered");
            assert!(stats.merge_radius > 0.0);
            let m: f64 = film.sums().iter().map(|p| p[0] + p[1] + p[2]).sum();
            assert!(m.is_finite() && m > 0.0, "{name} {alg}: image sum {m}");
        }
    }
}

/// Image mean of each iteration of a fresh job (differences of the film's sums; for
/// SPPM with max_depth 2 the passes are independent, as PT's iterations are).
fn iteration_means(scene: &Scene, s: &Settings, seed: u64, n: u64) -> Vec<f64> {
    let integ = s.build();
    let mut film = Film::new(scene.width(), scene.height());
    let mut prev = 0.0;
    let count = film.sums().len() as f64 * 3.0;
    (0..n)
        .map(|i| {
            integ.iterate(scene, seed, i, &mut film);
            let total: f64 = film.sums().iter().map(|p| p[0] + p[1] + p[2]).sum();
            let m = (total - prev) / count;
            prev = total;
            m
        })
        .collect()
}

/// With max_depth 2 (direct light only) photons never contribute: the image is the
/// emission plus NEE estimate alone, whose mean must match PT's (which adds BSDF
/// sampling by MIS) within 4 standard errors of the difference.
#[test]
fn direct_only_matches_pt() {
    let scene = scene("cornell-box.json", 16);
    let pt = common::settings("pt", json!({"max_depth": 2}));
    let sp = common::settings("sppm", json!({"max_depth": 2}));
    let (ma, sa) = common::mean_se(&iteration_means(&scene, &pt, 1, 128));
    let (mb, sb) = common::mean_se(&iteration_means(&scene, &sp, 1, 128));
    let tol = 4.0 * (sa * sa + sb * sb).sqrt();
    eprintln!("direct only: PT {ma} +- {sa}, SPPM {mb} +- {sb}");
    assert!(
        (ma - mb).abs() <= tol,
        "PT {ma} vs SPPM {mb} (tolerance {tol})"
    );
    let integ = sp.build();
    let mut film = Film::new(scene.width(), scene.height());
    let stats = run(integ.as_ref(), &scene, 1, 0..2, &mut film);
    assert_eq!(stats.merges, 0);
}

#[test]
fn settings_resolve_and_validate() {
    let s = common::settings("sppm", json!({"alpha": 0.5, "radius": 0.02}));
    let back: Settings = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(s, back);
    assert_eq!(s.name(), "sppm");
    let map = |v: serde_json::Value| v.as_object().cloned().unwrap();
    for bad in [
        json!({"alpha": 1.5}),
        json!({"light_paths": -1.0}),
        json!({"radius": 0.0}),
        json!({"radius_factor": 0.0}),
        json!({"alpha_": 0.5}),
    ] {
        assert!(
            Settings::resolve(Some("ppm"), None, &map(bad.clone())).is_err(),
            "{bad}"
        );
    }
}
