//! Degenerate geometry and extreme media: every sampler returns a point of both
//! segments with a finite positive density (never an invented one: it is `pdf` at
//! the point), and refuses only segments without length.

use super::{cameras, light, pair, pair_with, rng, SAMPLERS};
use crate::integrator::many::vrl::{
    estimate_volume_to_volume, Grey, Pair, PairMedia, Phases, Sampler, Segment,
};
use crate::math::Vec3;
use crate::medium::Phase;

#[test]
fn segments_without_length_are_refused() {
    let l = light();
    let bad = [
        Segment::new(Vec3::ZERO, Vec3::Y, 0.0),
        Segment::new(Vec3::ZERO, Vec3::Y, f32::INFINITY),
        Segment::new(Vec3::splat(f32::NAN), Vec3::Y, 1.0),
    ];
    for b in bad {
        assert!(Pair::new(l, b).is_none(), "{b:?}");
        assert!(Pair::new(b, l).is_none(), "{b:?}");
    }
}

#[test]
fn the_guards_are_where_the_geometry_says() {
    assert!(pair("parallel").parallel());
    assert!(!pair("nearly_parallel").parallel());
    let ni = pair("nearly_intersecting");
    assert!((ni.h0 - 1e-4).abs() < 1e-9 && ni.h0 > ni.h_min, "{ni:?}");
    let i = pair("intersecting");
    assert_eq!(i.h0, 0.0);
    assert!(i.h0_guarded() == i.h_min && i.h_min > 0.0);
    let c = pair("close");
    assert!((c.h0 - 0.02).abs() < 1e-6 && (c.sin - 0.2f64.atan().cos()).abs() < 1e-6);
}

fn extreme_media() -> Vec<PairMedia> {
    let mut v = vec![];
    for sigma in [1e-4f32, 1.0, 1e4] {
        for g in [-0.99f32, 0.0, 0.99] {
            let phase = Phase::HenyeyGreenstein { g };
            let phases = Phases {
                light: phase,
                cam: phase,
            };
            v.push(PairMedia {
                sigma_light: sigma,
                sigma_cam: sigma,
                phases,
            });
        }
    }
    v
}

/// Extra pairs: a camera ray through the light's origin and one starting on the ray
/// light, besides the fixtures.
fn all_pairs() -> Vec<Pair> {
    let mut v: Vec<Pair> = cameras().into_iter().map(|(_, c)| pair_with(c)).collect();
    v.push(pair_with(Segment::new(
        Vec3::new(0.0, -1.0, 0.0),
        Vec3::Y,
        2.0,
    )));
    v.push(pair_with(Segment::new(
        Vec3::new(1.5, 0.0, 0.0),
        Vec3::new(0.0, 0.6, 0.8),
        1.0,
    )));
    v.push(pair_with(Segment::new(
        Vec3::new(3.0, 0.0, 0.0),
        -Vec3::X,
        0.5,
    )));
    v
}

#[test]
fn degenerate_pairs_and_extreme_media_give_finite_positive_densities() {
    let edge = [0.0f32, 1.0 - f32::EPSILON / 2.0];
    for (i, p) in all_pairs().iter().enumerate() {
        for (j, m) in extreme_media().iter().enumerate() {
            for (k, s) in SAMPLERS.iter().enumerate() {
                let mut r = rng(6, (i * 100 + j * 10 + k) as u64);
                let mut xis: Vec<[f32; 2]> =
                    (0..300).map(|_| [r.next_f32(), r.next_f32()]).collect();
                xis.extend(edge.iter().flat_map(|&a| edge.iter().map(move |&b| [a, b])));
                for xi in xis {
                    let x = s.sample(p, m, xi);
                    let ctx = format!("{s:?} pair {i} media {j} xi {xi:?}: {x:?}");
                    assert!((0.0..=p.light.tmax).contains(&x.u), "{ctx}");
                    assert!((0.0..=p.cam.tmax).contains(&x.t), "{ctx}");
                    assert!(x.pdf > 0.0 && x.pdf.is_finite(), "{ctx}");
                    assert_eq!(x.pdf, s.pdf(p, m, x.u, x.t), "{ctx}");
                }
            }
        }
    }
}

#[test]
fn estimates_stay_finite_on_degenerate_pairs() {
    for (i, p) in all_pairs().iter().enumerate() {
        for g in [-0.99, 0.99] {
            for sigma_t in [1e-4, 1e4] {
                let m = Grey {
                    sigma_s: sigma_t,
                    sigma_t,
                    phase: Phase::HenyeyGreenstein { g },
                };
                for (k, s) in SAMPLERS.iter().enumerate() {
                    let mut r = rng(7, (i * 10 + k) as u64);
                    for _ in 0..200 {
                        let e = estimate_volume_to_volume(
                            s,
                            p,
                            &m,
                            [r.next_f32(), r.next_f32()],
                            |_, _| true,
                        );
                        assert!(
                            e.is_finite() && e >= 0.0,
                            "{s:?} pair {i} g={g} sigma={sigma_t}: {e}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn samples_scale_with_the_scene() {
    // Scenes scaled by 1e-3 and 1e4 draw the same points in scene units.
    let base = pair("close");
    let scaled = |k: f32| {
        let seg = |s: Segment| Segment::new(s.o * k, s.d, s.tmax * k);
        Pair::new(seg(base.light), seg(base.cam)).unwrap()
    };
    let media = |k: f32| PairMedia {
        sigma_light: 1.0 / k,
        sigma_cam: 1.0 / k,
        phases: Phases {
            light: Phase::HenyeyGreenstein { g: 0.5 },
            cam: Phase::HenyeyGreenstein { g: 0.5 },
        },
    };
    let samplers: [Sampler; 5] = SAMPLERS;
    for k in [1e-3f32, 1e4] {
        let p = scaled(k);
        let mut r = rng(8, k as u64);
        for s in &samplers {
            for _ in 0..200 {
                let xi = [r.next_f32(), r.next_f32()];
                let (a, b) = (
                    s.sample(&base, &media(1.0), xi),
                    s.sample(&p, &media(k), xi),
                );
                assert!(
                    (b.u / k - a.u).abs() < 1e-4 && (b.t / k - a.t).abs() < 1e-4,
                    "{s:?} {k}: {a:?} {b:?}"
                );
                let rel = (b.pdf * k * k / a.pdf - 1.0).abs();
                assert!(rel < 1e-2, "{s:?} {k}: {a:?} {b:?}");
            }
        }
    }
}
