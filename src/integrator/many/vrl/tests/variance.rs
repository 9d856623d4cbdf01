//! The samplers' variances on the close pair (0.02 apart), printed for the record,
//! and the ordering that is clearly expected asserted: the joint samplers, which
//! cancel the 1/w^2 singularity on both rays, beat the ones that cancel it on one ray
//! or none, and the advanced one wins in anisotropic media. Figures are per-sample variances of f / p, so they compare at equal
//! sample counts (time is for the benchmarks).

use super::estimates::{estimate, reference};
use super::{medium, pair, SAMPLERS};
use crate::integrator::many::vrl::Sampler;

#[test]
fn joint_samplers_have_the_lowest_variance_on_a_close_pair() {
    let p = pair("close");
    let n = 100_000;
    for g in [0.0, 0.9, -0.9] {
        let m = medium(g);
        let q = reference(&p, &m);
        let var: Vec<f64> = SAMPLERS
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let (_, se) = estimate(s, &p, &m, n, 100 + k as u64);
                let v = se * se * n as f64 / (q * q);
                eprintln!("variance / mean^2, close pair g={g}: {s:?} {v:.4}");
                v
            })
            .collect();
        let of = |s: Sampler| var[SAMPLERS.iter().position(|&x| x == s).unwrap()];
        let (uni, exp) = (of(Sampler::Uniform), of(Sampler::Exponential));
        let ue = of(Sampler::UniformEquiangular);
        let (simple, adv) = (
            of(Sampler::JointSimple),
            of(Sampler::JointAdvanced { nodes: 10 }),
        );
        // The joint samplers cancel 1/w^2 on both rays: the advanced one, which also
        // follows the phase product, is below every one-ray sampler at every g, and
        // as good as the simple one where the phase is flat.
        assert!(adv < uni.min(exp).min(ue), "g={g}: {var:?}");
        assert!(adv <= 1.05 * simple && simple < ue, "g={g}: {var:?}");
        if g == 0.0 {
            // With a flat phase equi-angular on the camera ray alone beats both
            // samplers that ignore the 1/w^2; with a peaked one it need not (at
            // g = +-0.9 it concentrates samples at closest approach, away from the
            // lobes, and the simple joint sampler is only ~25% below uniform), so
            // that ordering is asserted for g = 0 only.
            assert!(ue < uni.min(exp) && simple < ue, "g={g}: {var:?}");
        } else {
            assert!(adv < 0.5 * simple, "g={g}: {var:?}");
        }
    }
}
