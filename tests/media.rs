//! Participating media: transmittance estimators against the closed form, single
//! scattering against quadrature, a furnace filled with a scattering medium, equi-angular
//! sampling against distance sampling, extreme media, and scene checks.

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::math::{Rgb, Rng, Vec3};
use caustic::medium::grid_io::DenseGrid;
use caustic::medium::voxels::{DensityField, VoxelGrid};
use caustic::medium::{Flight, Heterogeneous, Homogeneous, Medium, Phase};
use common::*;
use glam::Affine3A;
use serde_json::{json, Value};
use stats::{assert_agree, blocks, run};

// ---------------------------------------------------------------------------------
// Transmittance and free flights, at the library level
// ---------------------------------------------------------------------------------

/// A heterogeneous medium over the box [-2, 2]^3 from a density function of the
/// local coordinates.
fn grid_medium(dims: [usize; 3], sigma_t: Rgb, f: impl Fn(Vec3) -> f32) -> Heterogeneous {
    let mut data = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let c = Vec3::new(
                    (x as f32 + 0.5) / dims[0] as f32,
                    (y as f32 + 0.5) / dims[1] as f32,
                    (z as f32 + 0.5) / dims[2] as f32,
                );
                data.push(f(c));
            }
        }
    }
    let g = DenseGrid {
        dims,
        data,
        bounds: None,
    };
    // World [-2, 2]^3 -> local [0, 1]^3.
    let to_local =
        Affine3A::from_scale(Vec3::splat(0.25)) * Affine3A::from_translation(Vec3::splat(2.0));
    Heterogeneous::new(
        DensityField::Grid(VoxelGrid::new(&g)),
        Rgb::splat(0.6),
        None,
        sigma_t,
        Phase::Isotropic,
        to_local,
    )
}

/// Per-channel mean and standard error of n draws of a vector estimator.
fn estimate(n: usize, mut f: impl FnMut() -> Rgb) -> (Rgb, Rgb) {
    let (mut s, mut s2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    for _ in 0..n {
        let v = f().as_dvec3();
        s += v;
        s2 += v * v;
    }
    let m = s / n as f64;
    let var = (s2 / n as f64 - m * m) * (n as f64 / (n as f64 - 1.0));
    (
        m.as_vec3(),
        (var / n as f64)
            .max(glam::DVec3::ZERO)
            .as_vec3()
            .map(f32::sqrt),
    )
}

fn assert_close(name: &str, (m, se): (Rgb, Rgb), expected: Rgb) {
    for c in 0..3 {
        let tol = 4.0 * se[c] + 1e-6;
        assert!(
            (m[c] - expected[c]).abs() <= tol,
            "{name}: channel {c}: {} vs expected {} (se {})",
            m[c],
            expected[c],
            se[c]
        );
    }
}

#[test]
fn transmittance_estimators_match_the_closed_form() {
    let o = Vec3::new(-1.5, -0.3, 0.2);
    let d = Vec3::new(1.0, 0.4, -0.2).normalize();
    let len = 2.2;
    let sigma = Rgb::new(0.3, 0.9, 1.7);
    let exact = (-sigma * len).exp();
    let n = 40_000;
    let mut rng = Rng::new(1, 2, 3);

    // Homogeneous: closed form, and the pass weight of chromatic free flights.
    let h = Homogeneous::new(sigma * 0.4, sigma * 0.6, Phase::Isotropic);
    assert!((h.transmittance(len) - exact).abs().max_element() < 1e-6);
    let beta = Rgb::new(1.0, 0.5, 0.2);
    let pass = |f: Flight| match f {
        Flight::Pass { weight } => weight,
        _ => Rgb::ZERO,
    };
    assert_close(
        "homogeneous free flight",
        estimate(n, || pass(h.sample_flight(len, beta, &mut rng))),
        exact,
    );

    // A long segment, which free flights pass with probability below 0.3.
    let long = 6.0;
    assert_close(
        "homogeneous free flight, long segment",
        estimate(n, || pass(h.sample_flight(long, beta, &mut rng))),
        (-sigma * long).exp(),
    );

    // A constant grid: ratio tracking, spectral tracking and grey delta tracking.
    let g = grid_medium([5, 4, 3], sigma, |_| 1.0);
    assert_close(
        "ratio tracking, constant grid",
        estimate(n, || g.transmittance(o, d, len, &mut rng)),
        exact,
    );
    assert_close(
        "spectral tracking pass weight, constant grid",
        estimate(n, || pass(g.sample_flight(o, d, len, beta, &mut rng))),
        exact,
    );
    let grey = grid_medium([5, 4, 3], Rgb::splat(0.9), |_| 1.0);
    let exact_grey = (-0.9f32 * len).exp();
    assert_close(
        "delta tracking, constant grid",
        estimate(n, || {
            Rgb::splat(grey.delta_tracking_passes(o, d, len, &mut rng) as u8 as f32)
        }),
        Rgb::splat(exact_grey),
    );
}

#[test]
fn tracking_matches_quadrature_in_a_varying_grid() {
    // Density varies smoothly; the optical depth is integrated by small steps over the
    // same trilinear field the tracker sees.
    let field = |p: Vec3| 0.2 + 2.0 * p.x * p.x + (6.0 * p.y).sin().abs() * p.z;
    let sigma = Rgb::new(0.5, 1.0, 2.0);
    let g = grid_medium([12, 10, 8], sigma, field);
    let o = Vec3::new(-2.5, -1.0, -1.7);
    let d = Vec3::new(1.0, 0.35, 0.6).normalize();
    let len = 5.5;
    let steps = 200_000;
    let mut tau = 0.0f64;
    let (to_local, density) = (g.to_local, &g.density);
    for i in 0..steps {
        let t = (i as f32 + 0.5) / steps as f32 * len;
        let p = to_local.transform_point3(o + d * t);
        if p.min_element() >= 0.0 && p.max_element() <= 1.0 {
            tau += density.eval(p) as f64 * (len / steps as f32) as f64;
        }
    }
    let exact = (-sigma * tau as f32).exp();
    let mut rng = Rng::new(4, 5, 6);
    let n = 40_000;
    assert_close(
        "ratio tracking",
        estimate(n, || g.transmittance(o, d, len, &mut rng)),
        exact,
    );
    let beta = Rgb::ONE;
    assert_close(
        "spectral tracking",
        estimate(n, || match g.sample_flight(o, d, len, beta, &mut rng) {
            Flight::Pass { weight } => weight,
            _ => Rgb::ZERO,
        }),
        exact,
    );
}

/// The MIS's optical depth of a heterogeneous piece (a deterministic proxy, not an
/// estimate of the image): the same from either end and for any split of the piece
/// at its midpoint samples, exact for a constant density, within 20% of the fine
/// quadrature for a smooth one, and 0 outside the field's box.
#[test]
fn mis_depth_of_heterogeneous_media_is_symmetric_and_close() {
    let sigma = Rgb::new(0.5, 1.0, 2.0);
    let grey = sigma.element_sum() / 3.0;
    let flat = grid_medium([4, 4, 4], sigma, |_| 0.7);
    let (o, d) = (
        Vec3::new(-1.5, -1.0, -0.5),
        Vec3::new(1.0, 0.35, 0.6).normalize(),
    );
    let depth = flat.mis_depth(o, d, 0.0, 2.0);
    assert!(
        (depth - 0.7 * grey * 2.0).abs() < 1e-5,
        "constant density: {depth}"
    );
    let field = |p: Vec3| 0.2 + 2.0 * p.x * p.x + (6.0 * p.y).sin().abs() * p.z;
    let g = grid_medium([12, 10, 8], sigma, field);
    let len = 3.0;
    let forward = g.mis_depth(o, d, 0.0, len);
    let back = g.mis_depth(o + d * len, -d, 0.0, len);
    assert!(
        (forward - back).abs() <= 1e-5 * forward,
        "{forward} vs {back}"
    );
    let steps = 100_000;
    let fine: f64 = (0..steps)
        .map(|i| {
            let t = (i as f32 + 0.5) / steps as f32 * len;
            (g.mis_sigma_at(o + d * t) * len / steps as f32) as f64
        })
        .sum();
    let rel = (forward as f64 - fine).abs() / fine;
    assert!(rel < 0.2, "quadrature {forward} vs fine {fine}");
    let outside = Vec3::new(5.0, 5.0, 5.0);
    assert_eq!(g.mis_depth(outside, Vec3::X, 0.0, 10.0), 0.0);
    assert_eq!(g.mis_sigma_at(outside), 0.0);
    assert_eq!(g.mis_depth(o, d, 1.0, 1.0), 0.0);
}

#[test]
fn free_flight_collision_density_matches_sigma_t_times_transmittance() {
    // For a homogeneous chromatic medium the weighted scatter events estimate
    // integral_0^L sigma_s T(t) dt = sigma_s / sigma_t (1 - T(L)) per channel.
    let sigma_a = Rgb::new(0.1, 0.2, 0.05);
    let sigma_s = Rgb::new(0.4, 0.2, 1.1);
    let h = Homogeneous::new(sigma_a, sigma_s, Phase::Isotropic);
    let st = sigma_a + sigma_s;
    let len = 1.7;
    let expected = sigma_s / st * (Rgb::ONE - (-st * len).exp());
    let mut rng = Rng::new(7, 8, 9);
    let beta = Rgb::new(0.3, 1.0, 0.6);
    let m = Medium::Homogeneous(h);
    assert_close(
        "homogeneous scatter weights",
        estimate(60_000, || {
            match m.sample_flight(Vec3::ZERO, Vec3::X, len, beta, &mut rng) {
                Flight::Scatter { weight, .. } => weight,
                _ => Rgb::ZERO,
            }
        }),
        expected,
    );
    // The same integral through spectral tracking of a constant grid, albedo 0.6.
    let g = grid_medium([3, 3, 3], st, |_| 1.0);
    let expected = st * 0.6 / st * (Rgb::ONE - (-st * len).exp());
    let o = Vec3::new(-1.0, 0.0, 0.0);
    assert_close(
        "spectral tracking scatter weights",
        estimate(60_000, || {
            match g.sample_flight(o, Vec3::X, len, beta, &mut rng) {
                Flight::Scatter { weight, .. } => weight,
                _ => Rgb::ZERO,
            }
        }),
        expected,
    );
}

// ---------------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------------

/// Single scattering of a point light seen along one ray in an infinite homogeneous
/// medium, by quadrature: integral of T(t) sigma_s p(mu) I T(r) / r^2 dt.
fn single_scattering(c: Vec3, intensity: f64, sigma_s: f64, sigma_t: f64, g: f64) -> f64 {
    let phase = Phase::HenyeyGreenstein { g: g as f32 };
    let n = 400_000;
    let tmax = 60.0 / sigma_t;
    let mut sum = 0.0;
    // Substitution t = tmax x^2 puts nodes near the camera and the light's closest point.
    for i in 0..n {
        let x = (i as f64 + 0.5) / n as f64;
        let t = tmax * x * x;
        let dt = 2.0 * tmax * x / n as f64;
        let p = glam::DVec3::new(0.0, 0.0, t);
        let to_light = c.as_dvec3() - p;
        let r = to_light.length();
        let mu = to_light.z / r;
        let f = (-sigma_t * (t + r)).exp() * sigma_s * phase.eval_mu(mu as f32) as f64 * intensity
            / (r * r);
        sum += f * dt;
    }
    sum
}

fn single_scattering_scene(
    equiangular: bool,
) -> (caustic::scene::Scene, caustic::integrator::Settings) {
    let scene = compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 0], "target": [0, 0, 1], "up": [0, 1, 0]},
                   "fov": 0.02, "medium": "fog"},
        "film": {"width": 4, "height": 4},
        "media": {"fog": {"type": "homogeneous", "sigma_a": [0.1, 0.1, 0.1],
                          "sigma_s": [0.3, 0.3, 0.3],
                          "phase": {"type": "henyey_greenstein", "g": 0.5}}},
        "lights": [{"type": "point", "position": [0.5, 0.0, 2.0], "intensity": [10, 10, 10]}]
    }));
    let s = settings(
        "volpath",
        json!({"max_depth": 2, "equiangular": equiangular}),
    );
    (scene, s)
}

#[test]
fn single_scattering_matches_quadrature() {
    let expected = single_scattering(Vec3::new(0.5, 0.0, 2.0), 10.0, 0.3, 0.4, 0.5);
    for equiangular in [true, false] {
        let (scene, s) = single_scattering_scene(equiangular);
        let r = run(&scene, &s, 3, if equiangular { 400 } else { 2000 }, &[]);
        assert_eq!(r.dropped, 0);
        let e = r.whole();
        for c in 0..3 {
            assert!(
                (e.mean[c] - expected).abs() < 4.0 * e.se[c],
                "equiangular {equiangular}: {} +- {} vs quadrature {expected}",
                e.mean[c],
                e.se[c]
            );
            assert!(e.se[c] < 0.03 * expected, "se {} too large", e.se[c]);
        }
    }
}

/// A closed box (walls of albedo a emitting Le inwards) filled with a medium that
/// scatters without absorbing: the radiance field stays uniform, Le / (1 - a).
fn medium_furnace(phase: Value, sigma_s: f32) {
    let a = 0.5f32;
    let scene = compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0.1, -0.2, 0.3], "target": [1, 0.5, -0.2], "up": [0, 0, 1]},
                   "fov": 80, "medium": "fog"},
        "film": {"width": 16, "height": 16},
        "materials": {"wall": {"type": "diffuse", "reflectance": [a, a, a]}},
        "media": {"fog": {"type": "homogeneous", "sigma_a": [0, 0, 0],
                          "sigma_s": [sigma_s, sigma_s, sigma_s], "phase": phase}},
        // Normals point inwards, so the inside is the shape's exterior side.
        "shapes": [{"type": "cube", "material": "wall", "flip_normals": true,
                    "exterior": "fog", "transform": {"scale": [2, 3, 1.5]},
                    "emission": {"radiance": [1, 1, 1]}}]
    }));
    let s = settings("pt", json!({"max_depth": 100000}));
    let (film, n) = render(&scene, &s, 11, 24);
    assert_eq!(film.dropped(), 0);
    let expected = 1.0 / (1.0 - a as f64);
    for c in 0..3 {
        let (m, se) = mean_se(&channel(&film, n, c));
        assert!(
            (m - expected).abs() < 4.0 * se,
            "channel {c}: {m} +- {se} vs {expected}"
        );
        assert!(se < 0.02 * expected, "se {se} too large");
    }
}

#[test]
fn furnace_filled_with_a_scattering_medium() {
    medium_furnace(json!({"type": "isotropic"}), 1.5);
    medium_furnace(json!({"type": "henyey_greenstein", "g": 0.8}), 0.7);
}

#[test]
fn equiangular_and_distance_sampling_agree() {
    // An infinite chromatic medium around the camera, lit by a point and a spot light:
    // the image is in-scattered light only, up to three scattering events.
    let scene = compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 0], "target": [0, 0, 1], "up": [0, 1, 0]},
                   "fov": 50, "medium": "fog"},
        "film": {"width": 16, "height": 16},
        "media": {"fog": {"type": "homogeneous", "sigma_a": [0.05, 0.1, 0.05],
                          "sigma_s": [0.3, 0.2, 0.1], "phase": {"type": "hg", "g": 0.5}}},
        "lights": [
            {"type": "point", "position": [0.4, 0.1, 2.0], "intensity": [5, 5, 5]},
            {"type": "spot", "position": [-0.5, 0.3, 3.0], "target": [0.5, -0.2, 1.0],
             "intensity": [20, 20, 20], "cutoff_angle": 30, "beam_width": 20}
        ]
    }));
    let regions = blocks(16, 16, 8);
    let p = |e: bool| settings("volpath", json!({"equiangular": e, "max_depth": 4}));
    let a = run(&scene, &p(true), 1, 64, &regions);
    let b = run(&scene, &p(false), 2, 256, &regions);
    assert_eq!(a.dropped + b.dropped, 0);
    assert_agree(&a, &b, &regions);
    // Equi-angular sampling is the better estimator for point lights in fog: compare
    // the per-iteration spread (se * sqrt(iterations)).
    let (ea, eb) = (a.whole(), b.whole());
    assert!(ea.se[0] * 8.0 < eb.se[0] * 16.0, "{ea:?} {eb:?}");
}

#[test]
fn extreme_media_render_without_dropped_samples() {
    let mut cases = extreme_media();
    cases.extend([
        json!({"type": "homogeneous", "sigma_a": [0.1, 0.1, 0.1], "sigma_s": [1, 1, 1],
               "phase": {"type": "schlick", "k": 0.9}}),
        json!({"type": "homogeneous", "sigma_a": [0.1, 0.1, 0.1], "sigma_s": [1, 1, 1],
               "phase": {"type": "rayleigh"}}),
        json!({"type": "procedural", "sigma_t": [8, 8, 8], "albedo": [0.9, 0.9, 0.9],
               "threshold": 0.5, "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}}),
    ]);
    for medium in cases {
        let scene = fog_box(12, medium.clone());
        let (film, n) = render(&scene, &settings("pt", json!({})), 3, 4);
        assert_eq!(film.dropped(), 0, "{medium}");
        let mean: f64 = channel(&film, n, 1).iter().sum::<f64>();
        assert!(mean.is_finite() && mean >= 0.0, "{medium}");
    }
}

#[test]
fn thin_medium_converges_to_the_empty_scene() {
    // sigma_t 1e-4 over a box of size 2: the fog changes the image by ~2e-4 relative.
    let thin = fog_box(
        12,
        json!({"type": "homogeneous", "sigma_t": [1e-4, 1e-4, 1e-4], "albedo": [1, 1, 1]}),
    );
    let regions = blocks(12, 12, 6);
    let a = run(&thin, &settings("pt", json!({})), 5, 48, &regions);
    let plain = {
        let mut v: Value =
            serde_json::from_str(&std::fs::read_to_string("scenes/cornell-box.json").unwrap())
                .unwrap();
        v["film"] = json!({"width": 12, "height": 12});
        compile(v)
    };
    let b = run(&plain, &settings("pt", json!({})), 6, 48, &regions);
    assert_agree(&a, &b, &regions);
}

#[test]
fn declared_but_unused_media_change_nothing() {
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string("scenes/cornell-box.json").unwrap()).unwrap();
    v["film"] = json!({"width": 16, "height": 16});
    let plain = compile(v.clone());
    v["media"] =
        json!({"fog": {"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}});
    let declared = compile(v);
    assert!(!declared.has_media);
    let s = settings("pt", json!({}));
    let (a, _) = render(&plain, &s, 1, 2);
    let (b, _) = render(&declared, &s, 1, 2);
    assert_eq!(a.sums(), b.sums(), "an unused medium changed the image");
}

#[test]
fn every_algorithm_takes_media_scenes() {
    let scene = fog_box(
        8,
        json!({"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}),
    );
    for &alg in caustic::integrator::ALGORITHMS {
        settings(alg, json!({}))
            .check_scene(&scene)
            .unwrap_or_else(|e| panic!("{alg} refused a media scene: {e}"));
    }
}

#[test]
fn bad_media_are_refused_with_their_path() {
    let base = |media: Value, shape_medium: &str| {
        json!({
            "format": 1,
            "camera": {"look_at": {"origin": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
            "film": {"width": 8, "height": 8},
            "materials": {"b": {"type": "null"}},
            "media": media,
            "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "b",
                        "interior": shape_medium}]
        })
    };
    let cases = [
        (
            json!({"f": {"type": "homogeneous", "sigma_a": [1, 1, 1], "sigma_s": [1, 1, 1],
                      "sigma_t": [1, 1, 1]}}),
            "f",
            "media.f",
        ),
        (
            json!({"f": {"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [1.2, 1, 1]}}),
            "f",
            "media.f.albedo",
        ),
        (
            json!({"f": {"type": "homogeneous", "sigma_t": [-1, 1, 1], "albedo": [1, 1, 1]}}),
            "f",
            "media.f.sigma_t",
        ),
        (
            json!({"f": {"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [1, 1, 1],
                      "phase": {"type": "hg", "g": 1.0}}}),
            "f",
            "media.f.phase.g",
        ),
        (
            json!({"f": {"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [1, 1, 1]}}),
            "fgo",
            "shapes[0].interior",
        ),
        (
            json!({"f": {"type": "procedural", "sigma_t": [1, 1, 1]}}),
            "f",
            "media.f",
        ),
        (
            json!({"f": {"type": "procedural", "sigma_t": [1, 1, 1], "octaves": 40,
                      "bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}}}),
            "f",
            "media.f.octaves",
        ),
        (
            json!({"f": {"type": "procedural", "sigma_t": [1, 1, 1],
                      "bounds": {"min": [0, 0, 0], "max": [1, -1, 1]}}}),
            "f",
            "media.f.bounds",
        ),
        (
            json!({"f": {"type": "grid", "file": "../smoke.vol", "sigma_t": [1, 1, 1]}}),
            "f",
            "media.f.file",
        ),
    ];
    for (media, name, path) in cases {
        let text = base(media.clone(), name).to_string();
        let err = caustic::scene::load::parse_scene(&text)
            .and_then(|f| caustic::scene::Scene::compile(&f, None).map(|_| ()))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(path), "{media}: {err}");
    }
}

#[test]
fn lights_know_the_medium_they_emit_into() {
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string("scenes/cornell-box.json").unwrap()).unwrap();
    v["materials"]["boundary"] = json!({"type": "null"});
    v["media"] =
        json!({"fog": {"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [0.5, 0.5, 0.5]}});
    v["shapes"].as_array_mut().unwrap().push(
        json!({"type": "cube", "material": "boundary", "interior": "fog",
                     "transform": {"scale": 1.001}}),
    );
    v["lights"] = json!([
        {"type": "point", "position": [0.2, 0.5, 0.1], "intensity": [1, 1, 1]},
        {"type": "point", "position": [0, 0, 3], "intensity": [1, 1, 1]}
    ]);
    let scene = compile(v);
    // The ceiling's area light (inside the fog cube, on a shape that is no boundary),
    // a point inside and a point outside.
    assert_eq!(scene.light_media, vec![Some(0), Some(0), None]);
    assert_eq!(scene.medium_at(Vec3::new(0.0, 0.0, 0.5)), Some(0));
    assert_eq!(scene.medium_at(Vec3::new(0.0, 0.0, 1.5)), None);
}

/// An area light of radiance Le seen through purely absorbing media (sigma_t 0.5, no
/// scattering): `infinite` fills the whole scene (the camera's medium), otherwise a
/// null-bounded cube between z = 1 and 3. With `mirror`, the light sits behind the
/// camera and a mirror at z = 2.5 turns the view back to it. Returns the scene and
/// the optical depths along the axis before the mirror (0 without one) and on the
/// segment that ends at the light.
fn light_through_ink(infinite: bool, mirror: bool) -> (caustic::scene::Scene, f64, f64) {
    let ink = json!({"type": "homogeneous", "sigma_a": [0.5, 0.5, 0.5], "sigma_s": [0, 0, 0]});
    let mut v = json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 0], "target": [0, 0, 1], "up": [0, 1, 0]}, "fov": 10},
        "film": {"width": 8, "height": 8},
        "materials": {"black": {"type": "diffuse", "reflectance": [0, 0, 0]},
                      "boundary": {"type": "null"}, "mirror": {"type": "mirror"}},
        "media": {"ink": ink},
        "shapes": [{"type": "rectangle", "material": "black", "emission": {"radiance": [4, 4, 4]},
                    "transform": {"rotate": [{"axis": [0, 1, 0], "angle": 180}], "scale": 3,
                                  "translate": [0, 0, 5]}}]
    });
    if mirror {
        v["shapes"][0]["transform"] = json!({"scale": 3, "translate": [0, 0, -2.5]});
        v["shapes"]
            .as_array_mut()
            .unwrap()
            .push(json!({"type": "rectangle", "material": "mirror",
            "transform": {"rotate": [{"axis": [0, 1, 0], "angle": 180}], "scale": 3,
                          "translate": [0, 0, 2.5]}}));
    }
    if infinite {
        v["camera"]["medium"] = json!("ink");
    } else {
        v["shapes"]
            .as_array_mut()
            .unwrap()
            .push(json!({"type": "cube", "material": "boundary",
            "interior": "ink", "transform": {"translate": [0, 0, 2]}}));
    }
    let (first, last) = match (infinite, mirror) {
        (true, false) => (0.0, 2.5),
        (false, false) => (0.0, 1.0),
        (true, true) => (1.25, 2.5),
        (false, true) => (0.75, 0.75),
    };
    (compile(v), first, last)
}

/// The algorithms that estimate radiance seen by the camera: `lt` never sees an
/// emitter directly (its paths start on the lights); `normals` and `albedo` are no
/// estimates of radiance.
fn seeing_algorithms() -> impl Iterator<Item = &'static str> {
    caustic::integrator::ALGORITHMS
        .iter()
        .copied()
        .filter(|a| !["lt", "normals", "albedo"].contains(a))
}

/// Emission seen straight through a medium is the same in one sample for every
/// algorithm: Le T, with T from the closed form rather than a free flight that either
/// reaches the light (Le) or stops short (0); the only spread left is the pixel
/// footprint's range of path lengths (rays up to 7.1 degrees off axis).
#[test]
fn lights_seen_through_media_take_their_transmittance_in_one_sample() {
    let le = 4.0f64;
    for infinite in [false, true] {
        let (scene, _, depth) = light_through_ink(infinite, false);
        let cos_max = (7.1f64.to_radians()).cos();
        let (hi, lo) = (le * (-depth).exp(), le * (-depth / cos_max).exp());
        for alg in seeing_algorithms() {
            let (film, n) = render(&scene, &settings(alg, json!({})), 3, 1);
            for (i, v) in channel(&film, n, 0).into_iter().enumerate() {
                assert!(
                    v >= lo * (1.0 - 1e-4) && v <= hi * (1.0 + 1e-4),
                    "{alg}, infinite medium {infinite}: pixel {i} reads {v}, expected Le T in [{lo}, {hi}]"
                );
            }
        }
    }
}

/// After delta bounces alone the camera path is the only technique that finds an
/// emitter, so the segment that reaches it takes its transmittance too: a light seen
/// in a mirror through ink reads, in one sample, either 0 (the free flight to the
/// mirror stopped: methods that sample it) or Le T_light times at most T_mirror, never
/// Le itself; and the mean over the pixels is Le T within four standard errors.
#[test]
fn lights_seen_in_a_mirror_through_media_take_their_transmittance() {
    let le = 4.0f64;
    let cos_max = (7.1f64.to_radians()).cos();
    for infinite in [false, true] {
        let (scene, first, last) = light_through_ink(infinite, true);
        let hi = le * (-last).exp();
        let lo = le * (-(first + last) / cos_max).exp();
        let (mean_hi, mean_lo) = (le * (-(first + last)).exp(), lo);
        for alg in seeing_algorithms() {
            let (film, n) = render(&scene, &settings(alg, json!({})), 3, 1);
            let v = channel(&film, n, 0);
            for (i, &x) in v.iter().enumerate() {
                assert!(
                    x == 0.0 || (x >= lo * (1.0 - 1e-4) && x <= hi * (1.0 + 1e-4)),
                    "{alg}, infinite medium {infinite}: pixel {i} reads {x}, expected 0 or within [{lo}, {hi}]"
                );
            }
            let (mean, se) = mean_se(&v);
            assert!(
                mean >= mean_lo - 4.0 * se && mean <= mean_hi + 4.0 * se,
                "{alg}, infinite medium {infinite}: mean {mean} +- {se}, expected Le T in [{mean_lo}, {mean_hi}]"
            );
        }
    }
}
