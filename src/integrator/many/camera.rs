//! The camera path of the many-light methods: it follows specular chains and never
//! scatters in a medium. Every segment it crosses in a medium gathers the in-scattered
//! light there (direct, VPLs, ray lights) and is passed with its transmittance; the
//! first non-specular surface gathers and ends the path. Emitters count only when seen
//! along a purely specular chain: next-event estimation found the rest.

use super::gather::{At, CamSeg, Gather};
use crate::geometry::{spawn_ray, Ray};
use crate::integrator::paths::segments::extent;
use crate::integrator::transport::camera::{roulette, sample_bsdf, stop_or_follow_delta, Stop};
use crate::integrator::transport::medium_walk::{Cross, MediumWalk, Segment, Segments, Step};
use crate::integrator::RenderStats;
use crate::math::{Rgb, Rng};

/// Specular bounces before Russian roulette on the throughput.
const RR_DEPTH: u32 = 5;

/// The walk's visitor: each medium segment of camera segment `j` gathers, and is
/// passed with its transmittance.
struct InScatter<'a, 'b> {
    g: &'a Gather<'b>,
    j: u32,
    l: Rgb,
}

impl Segments for InScatter<'_, '_> {
    #[inline]
    fn enter(&mut self, seg: &Segment, rng: &mut Rng, stats: &mut RenderStats) -> Cross {
        let scene = self.g.scene;
        let med = &scene.media[seg.medium as usize];
        let (o, d) = (seg.ray.o, seg.ray.d);
        if let Some((len, cut)) = extent(med, o, d, seg.tmax, rng.next_f32()) {
            let c = CamSeg {
                o,
                d,
                len,
                cut,
                full: med.support_end(o, d, seg.tmax),
                medium: seg.medium,
            };
            self.l += seg.beta * self.g.segment(&c, self.j, rng, stats);
        }
        if self.g.compensates() {
            // The residual of the capped VPLs along the segment, from one free flight.
            let x = med.sample_flight(o, d, seg.tmax, seg.beta, rng);
            if let crate::medium::Flight::Scatter { t, weight } = x {
                let at = At::Medium {
                    p: seg.ray.at(t),
                    d,
                    medium: seg.medium,
                };
                self.l += seg.beta * weight * self.g.residual(&at, self.j, rng, stats);
            }
        }
        Cross::Pass(med.transmittance(o, d, seg.tmax, rng))
    }
}

/// Radiance along one camera ray.
pub(super) fn li(g: &Gather, mut ray: Ray, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
    let scene = g.scene;
    let mut walk = MediumWalk {
        beta: Rgb::ONE,
        medium: scene.camera_medium,
    };
    let mut l = Rgb::ZERO;
    // Segments of the path so far, the one being traced included.
    let mut j = 1u32;
    loop {
        let mut visit = InScatter { g, j, l: Rgb::ZERO };
        let step = walk.next(scene, &mut ray, &mut visit, rng, stats);
        l += visit.l;
        let (it, m) = match step {
            Step::Surface(it, m) => (it, m),
            Step::Escaped => {
                if !scene.env_lights.is_empty() {
                    l += walk.beta * scene.env_radiance(ray.d);
                }
                break;
            }
            Step::Scatter { .. } | Step::End => break,
        };
        if let Some((_, area)) = scene.area_light(&it) {
            l += walk.beta * area.le(&it, -ray.d);
        }
        let frame = scene.shading_frame(&it);
        let wo = frame.to_local(-ray.d);
        // The gather estimates the continuous lobes; a delta lobe mixed in (plastic's
        // coating) is followed instead with its sampling probability.
        let mut followed = None;
        if !m.is_delta() {
            match stop_or_follow_delta(&it, &frame, wo, &m, rng) {
                Stop::Here(scale) => {
                    let beta = if scale == 1.0 {
                        walk.beta
                    } else {
                        walk.beta * scale
                    };
                    l += beta * g.surface(&it, frame, wo, &m, walk.medium, j, rng, stats);
                    break;
                }
                Stop::Follow(s) => followed = Some(s),
            }
        }
        if j >= g.max_depth {
            break;
        }
        let next = match followed {
            Some(s) => s,
            None => sample_bsdf(&it, &frame, wo, &m, rng),
        };
        let Some((wi, s)) = next else {
            break;
        };
        walk.beta *= Rgb::from(s.weight);
        if !roulette(j, RR_DEPTH, &mut walk.beta, rng) {
            break;
        }
        j += 1;
        walk.medium = scene.medium_after(&it, wi, walk.medium);
        ray = spawn_ray(it.p, it.p_err, it.ng, wi);
        stats.rays += 1;
    }
    l
}
