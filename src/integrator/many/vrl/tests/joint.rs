//! Every joint density integrates to one over the two segments, and the density a
//! sample carries is `pdf` at that sample, bit for bit.

use super::quadrature::integrate;
use super::{cameras, medium, pair_with, rng, t_splits, u_splits, GS, SAMPLERS};
use crate::integrator::many::vrl::{Pair, PairMedia, Sampler};

/// Both ends in `medium(g)`.
pub fn media(g: f32) -> PairMedia {
    medium(g).pair_media()
}

/// The probability of the cell [u_a, u_b] x [t_a, t_b] under the joint density, by
/// quadrature of p(u) p(t | u), the product `Sampler::pdf` forms. The conditional
/// density is built once per u, as sampling does, and from u in f64 (sampling rounds
/// u to f32 first): a density that steps at every f32 would stall the quadrature.
pub fn mass(s: &Sampler, p: &Pair, m: &PairMedia, us: (f64, f64), ts: (f64, f64), rel: f64) -> f64 {
    let light = s.light_density(p, m);
    let splits = t_splits(p);
    let inner = |u: f64| {
        let cam = s.camera_density(p, m, u);
        light.pdf(u) * integrate(|t| cam.pdf(t), ts.0, ts.1, &splits(u), 1e-2 * rel)
    };
    integrate(inner, us.0, us.1, &u_splits(p), rel)
}

/// The integral of the joint density over both segments.
pub fn total(s: &Sampler, p: &Pair, m: &PairMedia) -> f64 {
    mass(
        s,
        p,
        m,
        (0.0, p.light.tmax as f64),
        (0.0, p.cam.tmax as f64),
        1e-7,
    )
}

#[test]
fn every_joint_density_integrates_to_one() {
    for (name, cam) in cameras() {
        let p = pair_with(cam);
        for s in SAMPLERS {
            let i = total(&s, &p, &media(0.5));
            eprintln!("{s:?} {name}: integral {i:.7}");
            assert!((i - 1.0).abs() < 1e-6, "{s:?} {name}: integral {i}");
        }
    }
    let p = pair_with(cameras()[0].1);
    for g in GS {
        for nodes in [2, 10, 64] {
            let s = Sampler::JointAdvanced { nodes };
            let i = total(&s, &p, &media(g));
            assert!((i - 1.0).abs() < 1e-6, "{s:?} g={g}: integral {i}");
        }
    }
}

#[test]
fn a_sample_carries_the_density_pdf_gives_it() {
    for (case, (name, cam)) in cameras().into_iter().enumerate() {
        let p = pair_with(cam);
        for (k, s) in SAMPLERS.iter().enumerate() {
            let mut r = rng(1, (case * 8 + k) as u64);
            for _ in 0..2000 {
                let x = s.sample(&p, &media(0.9), [r.next_f32(), r.next_f32()]);
                let again = s.pdf(&p, &media(0.9), x.u, x.t);
                assert_eq!(x.pdf, again, "{s:?} {name}: {x:?}");
            }
        }
    }
}
