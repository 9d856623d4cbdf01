//! One ray light against quadrature: a fixed light segment and camera segment in an
//! infinite homogeneous medium. Every sampler's Monte Carlo estimate of the
//! volume-to-volume double integral, and of the volume-to-surface integral at fixed
//! surface points, agrees with adaptive quadrature within 4 of its standard errors.

use super::quadrature::{integrate, integrate2};
use super::{light, medium, pair, rng, t_splits, u_splits, SAMPLERS};
use crate::integrator::many::vrl::{
    estimate_volume_to_surface, estimate_volume_to_volume, volume_to_surface, volume_to_volume,
    Grey, Pair, Sampler, SurfacePoint, SurfaceSampler,
};
use crate::math::Vec3;

/// Mean and standard error of the mean of n draws.
pub fn mean_se(n: usize, mut draw: impl FnMut() -> f64) -> (f64, f64) {
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let x = draw();
        assert!(x.is_finite() && x >= 0.0, "estimate {x}");
        s += x;
        s2 += x * x;
    }
    let mean = s / n as f64;
    let var = (s2 / n as f64 - mean * mean).max(0.0) * n as f64 / (n - 1) as f64;
    (mean, (var / n as f64).sqrt())
}

/// The volume-to-volume integral by quadrature, split at closest approach.
pub fn reference(p: &Pair, m: &Grey) -> f64 {
    reference_within(p, m, 1e-6)
}

/// [`reference`] to relative tolerance `rel`.
pub fn reference_within(p: &Pair, m: &Grey, rel: f64) -> f64 {
    integrate2(
        |u, t| volume_to_volume(p, m, u as f32, t as f32) as f64,
        (0.0, p.light.tmax as f64),
        (0.0, p.cam.tmax as f64),
        &u_splits(p),
        t_splits(p),
        rel,
    )
}

/// One sampler's estimate (mean, standard error) from n samples.
pub fn estimate(s: &Sampler, p: &Pair, m: &Grey, n: usize, seed: u64) -> (f64, f64) {
    let mut r = rng(4, seed);
    mean_se(n, || {
        let xi = [r.next_f32(), r.next_f32()];
        estimate_volume_to_volume(s, p, m, xi, |_, _| true) as f64
    })
}

#[test]
fn volume_to_volume_estimates_agree_with_quadrature() {
    for (k, (name, g)) in [
        ("general", 0.5),
        ("close", 0.0),
        ("close", 0.9),
        ("general", -0.9),
    ]
    .into_iter()
    .enumerate()
    {
        let (p, m) = (pair(name), medium(g));
        let q = reference(&p, &m);
        for (j, s) in SAMPLERS.iter().enumerate() {
            let (mean, se) = estimate(s, &p, &m, 100_000, (8 * k + j) as u64);
            let z = (mean - q) / se;
            eprintln!(
                "{s:?} {name} g={g}: {mean:.6} vs {q:.6}, {z:+.2} SE (SE/mean {:.1e})",
                se / mean
            );
            assert!(
                z.abs() < 4.0,
                "{s:?} {name} g={g}: {mean} vs {q}, {z:.2} SE"
            );
        }
    }
}

#[test]
fn volume_to_surface_estimates_agree_with_quadrature() {
    let points = [
        // 0.058 from the light ray, facing it.
        SurfacePoint {
            p: Vec3::new(0.9, 0.05, -0.03),
            n: -Vec3::Y,
            albedo: 0.7,
        },
        SurfacePoint {
            p: Vec3::new(0.5, -0.8, 0.4),
            n: Vec3::new(0.0, 1.0, -0.5).normalize(),
            albedo: 0.7,
        },
    ];
    let samplers = [
        SurfaceSampler::Uniform,
        SurfaceSampler::Exponential,
        SurfaceSampler::EquiAngular,
    ];
    let l = light();
    for (k, sp) in points.iter().enumerate() {
        for g in [0.0, 0.9] {
            let m = medium(g);
            let q = integrate(
                |u| volume_to_surface(&l, &m, sp, u as f32) as f64,
                0.0,
                2.0,
                &[sp.p.x as f64],
                1e-7,
            );
            for (j, s) in samplers.iter().enumerate() {
                let mut r = rng(5, (6 * k + j) as u64 + if g > 0.0 { 3 } else { 0 });
                let (mean, se) = mean_se(100_000, || {
                    estimate_volume_to_surface(*s, &l, &m, sp, r.next_f32(), |_, _| true) as f64
                });
                let z = (mean - q) / se;
                eprintln!("surface {k} {s:?} g={g}: {mean:.6} vs {q:.6}, {z:+.2} SE");
                assert!(
                    z.abs() < 4.0,
                    "surface {k} {s:?} g={g}: {mean} vs {q}, {z:.2} SE"
                );
            }
        }
    }
}

#[test]
fn every_sampler_maps_to_a_surface_sampler() {
    let map: Vec<SurfaceSampler> = SAMPLERS.iter().map(Sampler::surface).collect();
    assert_eq!(
        map,
        [
            SurfaceSampler::Uniform,
            SurfaceSampler::Exponential,
            SurfaceSampler::Uniform,
            SurfaceSampler::EquiAngular,
            SurfaceSampler::EquiAngular
        ]
    );
}
