//! `ppm` and `sppm` in participating media. Surfaces keep their visible points and
//! per-pixel statistics; the media are gathered as `vpm`'s beam radiance estimate does
//! (Jarosz, Zwicker and Jensen 2008), with a radius of its own following the 2D
//! schedule r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1) of the iteration index:
//! - the camera path crosses media to its visible point with their transmittance
//!   (closed form, or ratio tracking), recording every medium segment it crosses with
//!   the throughput at its start;
//! - photon paths take free flights: a real scattering event in a medium stores a
//!   medium photon (power sigma_s T / pdf included, direct ones too, since the camera
//!   path does no next-event estimation in media), then samples the phase function;
//!   surface photons are stored as without media, after at least one event of either
//!   kind (the visible point's next-event estimate, with transmittance, has the rest);
//! - each wave's medium photons are gathered along every recorded segment, and the
//!   pass's sum, divided by the photon paths of the pass, joins the camera-pass
//!   radiance (an average over passes, like the direct light).

use crate::integrator::estimators::beam_query::BeamQuery;
use crate::integrator::transport::medium_walk::{Cross, Segment, Segments};
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng};
use crate::scene::Scene;

/// A medium segment of a camera path, reached after `depth` scattering events.
#[derive(Clone, Copy, Debug)]
pub(super) struct CameraSegment {
    pub seg: Segment,
    pub depth: u32,
}

/// The camera walk's visitor: records each medium segment and crosses it with its
/// transmittance.
pub(super) struct Record<'a> {
    pub scene: &'a Scene,
    pub depth: u32,
    pub out: &'a mut Vec<CameraSegment>,
}

impl Segments for Record<'_> {
    fn enter(&mut self, seg: &Segment, rng: &mut Rng, _: &mut RenderStats) -> Cross {
        self.out.push(CameraSegment {
            seg: *seg,
            depth: self.depth,
        });
        let med = &self.scene.media[seg.medium as usize];
        Cross::Pass(med.transmittance(seg.ray.o, seg.ray.d, seg.tmax, rng))
    }
}

/// The radiance the medium photons of `q` scatter towards the camera along `segments`,
/// per photon path of `q` (its inv_paths is 1: the pass divides by its own count).
pub(super) fn gather_segments(
    q: &BeamQuery,
    segments: &[CameraSegment],
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Rgb {
    segments
        .iter()
        .map(|c| c.seg.beta * q.segment(&c.seg, c.depth, rng, stats))
        .fold(Rgb::ZERO, |a, b| a + b)
}
