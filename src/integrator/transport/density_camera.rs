//! The camera path of the density estimators in media (`vpm`'s photon points, `ppb`'s
//! photon beams): media are left to the estimator, surfaces are path traced. Direct
//! light at surfaces by next-event estimation (one light, its transmittance through
//! media), indirect light by continuing with a BSDF sample; emitters count only when
//! seen through specular events. Every medium segment the path crosses is handed to
//! the estimator, which either gathers along the whole segment (the path then passes
//! it with its transmittance) or asks the walk for a free flight and gathers at its
//! scattering point, where the path ends. So surface transport is unbiased and all
//! bias is the volume kernel's.

use super::camera::{sample_bsdf, CameraWalk};
use super::medium_walk::{seen_emission, sees_emission, Cross, Segment, Segments, Step};
use super::nee::{direct_unweighted, Origin};
use crate::geometry::Ray;
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng};
use crate::scene::Scene;

/// A density estimate of the radiance scattered towards the camera in media.
pub trait MediumGather {
    /// Whether the estimate is made at a free flight's scattering point (`point`)
    /// rather than along whole segments (`segment`).
    fn at_flights(&self) -> bool;

    /// The radiance scattered towards the camera along the whole of `seg`, per unit of
    /// the throughput at its start, from light that arrived after `depth` surface
    /// events of the camera path.
    fn segment(&self, seg: &Segment, depth: u32, rng: &mut Rng, stats: &mut RenderStats) -> Rgb;

    /// The same at the scattering point `seg.ray.at(t)` of a free flight whose weight
    /// (sigma_s T / pdf) is `weight`, per unit of the throughput at the segment's start.
    fn point(
        &self,
        seg: &Segment,
        t: f32,
        weight: Rgb,
        depth: u32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb;
}

/// Path lengths: `max_depth` in Mitsuba's sense over both halves; a light
/// contribution stored after k events counts on a camera segment reached after j
/// surface events when k + j + 2 <= max_depth. `rr_depth`: camera scattering events
/// before Russian roulette.
#[derive(Clone, Copy, Debug)]
pub struct Depths {
    pub max_depth: u32,
    pub rr_depth: u32,
}

/// The walk's visitor: medium segments go to the estimator.
struct Gathers<'a, G> {
    g: &'a G,
    scene: &'a Scene,
    /// Surface events before the segment.
    depth: u32,
    counts: bool,
    l: Rgb,
}

impl<G: MediumGather> Segments for Gathers<'_, G> {
    #[inline]
    fn enter(&mut self, seg: &Segment, rng: &mut Rng, stats: &mut RenderStats) -> Cross {
        if self.g.at_flights() {
            return Cross::Flight;
        }
        if self.counts {
            self.l += seg.beta * self.g.segment(seg, self.depth, rng, stats);
        }
        let med = &self.scene.media[seg.medium as usize];
        Cross::Pass(med.transmittance(seg.ray.o, seg.ray.d, seg.tmax, rng))
    }
}

/// Radiance along one camera ray (module notes).
pub fn li<G: MediumGather>(
    scene: &Scene,
    g: &G,
    d: Depths,
    ray: Ray,
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Rgb {
    let mut c = CameraWalk::new(scene, ray);
    loop {
        let counts = c.depth + 2 <= d.max_depth;
        let mut visit = Gathers {
            g,
            scene,
            depth: c.depth,
            counts,
            l: Rgb::ZERO,
        };
        let (first, beta, medium) = (c.ray, c.walk.beta, c.walk.medium);
        let step = c.walk.next(scene, &mut c.ray, &mut visit, rng, stats);
        c.l += visit.l;
        // Estimates at flights leave the emission seen directly or after a delta
        // bounce to the flight: from its transmittance instead
        // (medium_walk::seen_emission). Otherwise the walk passes every segment with
        // its transmittance already.
        let seen = c.specular && scene.has_media && g.at_flights();
        if seen && sees_emission(scene, step.surface(), matches!(step, Step::Escaped)) {
            c.l += beta * seen_emission(scene, &first, medium, rng, stats);
        }
        let (it, m) = match step {
            Step::Surface(it, m) => (it, m),
            // Only estimates made at flights sample them: the query ends the path.
            Step::Scatter { seg, t, weight } => {
                if counts {
                    c.l += seg.beta * g.point(&seg, t, weight, c.depth, rng, stats);
                }
                break;
            }
            Step::Escaped => {
                if c.specular && !seen && !scene.env_lights.is_empty() {
                    c.l += c.walk.beta * scene.env_radiance(c.ray.d);
                }
                break;
            }
            Step::End => break,
        };
        if c.specular && !seen {
            if let Some((_, area)) = scene.area_light(&it) {
                c.l += c.walk.beta * area.le(&it, -c.ray.d);
            }
        }
        if c.depth + 1 >= d.max_depth {
            break;
        }
        let frame = scene.shading_frame(&it);
        let wo = frame.to_local(-c.ray.d);
        if !m.is_delta() {
            let at = Origin::Surface {
                it: &it,
                frame: &frame,
                wo,
                m: &m,
            };
            c.l += c.walk.beta * direct_unweighted(scene, &at, c.walk.medium, rng, stats);
        }
        let Some(sample) = sample_bsdf(&it, &frame, wo, &m, rng) else {
            break;
        };
        if !c.bounce(scene, &it, sample, d.rr_depth, rng, stats) {
            break;
        }
    }
    c.l
}
