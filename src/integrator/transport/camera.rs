//! The moves of a unidirectional camera path that `pt`, `volpath`, `vpm` and `sppm`
//! share: continuing with a BSDF sample at a surface, and Russian roulette on the
//! throughput; and the state of such a path in media between two flights
//! ([`CameraWalk`], for `volpath` and the density estimators' camera path).

use super::medium_walk::MediumWalk;
use crate::geometry::{spawn_ray, Interaction, Ray};
use crate::integrator::RenderStats;
use crate::material::{BsdfSample, Material, Mode};
use crate::math::{max_component, Frame, Rgb, Rng, Vec3};
use crate::scene::Scene;

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
    on_its_side(it, frame, s)
}

/// The sample with its world direction, unless that direction lies on the other side
/// of the geometric surface than the shading frame says.
#[inline(always)]
fn on_its_side(it: &Interaction, frame: &Frame, s: BsdfSample) -> Option<(Vec3, BsdfSample)> {
    let wi = frame.to_world(s.wi.into());
    ((wi.dot(it.ng) > 0.0) == (s.wi.z > 0.0)).then_some((wi, s))
}

/// What a camera path does at a non-delta surface where it would stop to estimate
/// the BSDF's continuous lobes (a visible point, a gather of virtual lights).
pub enum Stop {
    /// Stop here, with the stop's estimate scaled by this factor.
    Here(f32),
    /// Follow the BSDF's delta lobe (plastic's coating) with this sample instead.
    Follow(Option<(Vec3, BsdfSample)>),
}

/// Stops at a surface whose BSDF has only continuous lobes. Where a delta lobe is
/// mixed in (probability p of being sampled), the path follows it with probability p
/// (the sample's weight carries 1 / p) and otherwise stops with its estimate scaled by
/// 1 / (1 - p): the delta lobe, which no density estimate or connection can reach,
/// is kept without bias. Random numbers only where p > 0, so other scenes render as
/// before.
pub fn stop_or_follow_delta(
    it: &Interaction,
    frame: &Frame,
    wo: Vec3,
    m: &Material,
    rng: &mut Rng,
) -> Stop {
    let p = m.delta_probability(wo);
    if p <= 0.0 {
        return Stop::Here(1.0);
    }
    let u = rng.next_f32();
    if u >= p {
        return Stop::Here(1.0 / (1.0 - p));
    }
    // u / p is uniform on [0, 1) here: it picks among several delta lobes (a
    // mixture's), and plastic, with one, ignores it.
    let s = m.sample_delta(wo, u / p, rng.next_2d(), Mode::Radiance);
    Stop::Follow(s.and_then(|s| on_its_side(it, frame, s)))
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

/// A unidirectional camera path in media between two flights: the ray it follows
/// next, its throughput and the medium it travels in, the scattering events so far,
/// whether they were all delta events (emission found then has MIS weight 1), and the
/// radiance gathered.
pub struct CameraWalk {
    pub ray: Ray,
    pub walk: MediumWalk,
    pub depth: u32,
    pub specular: bool,
    pub l: Rgb,
}

impl CameraWalk {
    /// A path that starts with camera ray `ray`, in the camera's medium.
    #[inline(always)]
    pub fn new(scene: &Scene, ray: Ray) -> Self {
        CameraWalk {
            ray,
            walk: MediumWalk {
                beta: Rgb::ONE,
                medium: scene.camera_medium,
            },
            depth: 0,
            specular: true,
            l: Rgb::ZERO,
        }
    }

    /// Continues from surface `it` with BSDF sample `(wi, s)` (from [`sample_bsdf`]):
    /// its weight, one more scattering event, [`roulette`] after `rr_depth` of them,
    /// the medium on `wi`'s side and the ray along `wi`. False when the path ends.
    #[inline(always)]
    pub fn bounce(
        &mut self,
        scene: &Scene,
        it: &Interaction,
        (wi, s): (Vec3, BsdfSample),
        rr_depth: u32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> bool {
        self.walk.beta *= Rgb::from(s.weight);
        self.specular = s.delta;
        self.depth += 1;
        if !roulette(self.depth, rr_depth, &mut self.walk.beta, rng) {
            return false;
        }
        self.walk.medium = scene.medium_after(it, wi, self.walk.medium);
        self.ray = spawn_ray(it.p, it.p_err, it.ng, wi);
        stats.rays += 1;
        true
    }
}
