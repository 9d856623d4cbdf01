//! The beam radiance estimate (Jarosz, Zwicker and Jensen 2008) over the photons a
//! photon pass stored in media: one query per camera segment, against the photons'
//! BVH, with a constant 2D kernel across the ray. `vpm` uses it, and `ppm` and `sppm`
//! for their media.

use super::{Point, PointBvh};
use crate::integrator::paths::photons::Photon;
use crate::integrator::transport::medium_walk::Segment;
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng, Vec3, PI};
use crate::scene::Scene;

impl Point for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// The beam radiance estimate over one iteration's (or wave's) photons in media, for
/// `vpm` and for the medium part of `ppm` and `sppm`.
pub(crate) struct BeamQuery<'a> {
    pub scene: &'a Scene,
    pub photons: &'a [Photon],
    pub bvh: &'a PointBvh<Photon>,
    pub radius: f32,
    /// 1 / photon paths emitted.
    pub inv_paths: f32,
    pub max_depth: u32,
}

impl BeamQuery<'_> {
    /// Beam radiance estimate over the camera segment `seg` (ray o + t d, t in [0, tmax)):
    /// (1 / (N pi r^2)) sum_p T(o, o + t_p d) f_p(d_p, -d) beta_p over the photons
    /// within r of the segment [Jarosz et al. 2008, constant 2D kernel], per unit of the
    /// throughput at the segment's start; photons stored after k events count on a
    /// segment reached after `cam_depth` surface events when k + cam_depth + 2 <=
    /// max_depth.
    pub fn segment(
        &self,
        seg: &Segment,
        cam_depth: u32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        let (mi, ray, tmax) = (seg.medium, &seg.ray, seg.tmax);
        let med = &self.scene.media[mi as usize];
        let phase = med.phase();
        let homogeneous = med.as_homogeneous();
        let wo = -ray.d;
        let mut sum = Rgb::ZERO;
        self.bvh
            .query(self.photons, ray.o, ray.d, tmax, self.radius, |ph, t| {
                if ph.medium != mi || ph.depth + cam_depth + 2 > self.max_depth {
                    return;
                }
                stats.merges += 1;
                let tr = match homogeneous {
                    Some(h) => h.transmittance(t),
                    None => med.transmittance(ray.o, ray.d, t, rng),
                };
                sum += tr * ph.beta * phase.eval(ph.d, wo);
            });
        let r = self.radius;
        sum * (self.inv_paths / (PI * r * r))
    }
}
