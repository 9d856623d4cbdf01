//! The moves of a unidirectional camera path that `pt`, `volpath`, `vpm` and `sppm`
//! share: continuing with a BSDF sample at a surface, and Russian roulette on the
//! throughput.

use crate::geometry::Interaction;
use crate::material::{BsdfSample, Material, Mode};
use crate::math::{max_component, Frame, Rgb, Rng, Vec3};

/// A BSDF sample at a surface (`wo` towards the previous vertex, in `frame`): the world
/// direction and the sample. None when the material gives none, or when the direction
/// lies on the other side of the geometric surface than the shading frame says (it
/// would leak light through the surface). Random numbers: one for the lobe, two for
/// the direction.
#[inline(always)]
pub fn sample_bsdf(
    it: &Interaction,
    frame: &Frame,
    wo: Vec3,
    m: &Material,
    rng: &mut Rng,
) -> Option<(Vec3, BsdfSample)> {
    let u_lobe = rng.next_f32();
    let s = m.sample(wo, u_lobe, rng.next_2d(), Mode::Radiance)?;
    let wi = frame.to_world(s.wi.into());
    ((wi.dot(it.ng) > 0.0) == (s.wi.z > 0.0)).then_some((wi, s))
}

/// Russian roulette after `rr_depth` scattering events, with survival the largest
/// throughput channel (at most 0.95); false ends the path, as does zero throughput.
#[inline]
pub fn roulette(depth: u32, rr_depth: u32, beta: &mut Rgb, rng: &mut Rng) -> bool {
    if depth >= rr_depth {
        let q = max_component(*beta).min(0.95);
        if rng.next_f32() >= q {
            return false;
        }
        *beta /= q;
    }
    *beta != Rgb::ZERO
}
