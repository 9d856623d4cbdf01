//! Volumetric path tracing: the path tracer with participating media. Free flights
//! come from the medium (closed form when homogeneous, spectral tracking otherwise);
//! next-event estimation goes through media with their transmittance (ratio tracking
//! when heterogeneous) and is combined with phase or BSDF sampling by MIS on the
//! directional densities, the transmittance being estimated independently by each
//! strategy (as Mitsuba's `volpath` does).
//!
//! In homogeneous media, light from point and spot lights is also gathered by
//! equi-angular sampling along each camera or bounce segment (Kulla and Fajardo 2012,
//! "Importance sampling techniques for path tracing in participating media", sec. 3),
//! combined by MIS with the distance-sampled scattering point that connects to the
//! same light. `pt` runs this integrator when the scene has media.

use super::memory::{Estimate, Facts};
use super::{Integrator, RenderStats};
use crate::film::Film;
use crate::geometry::offset::SHADOW_EPSILON;
use crate::geometry::{Interaction, Ray};
use crate::integrator::drive::pixels::{render_pixels, tile_memory};
use crate::integrator::transport::camera::{roulette, sample_bsdf, CameraWalk};
use crate::integrator::transport::equiangular::EquiAngular;
use crate::integrator::transport::medium_walk::{
    seen_emission, sees_emission, Cross, Segment, Segments, Step,
};
use crate::integrator::transport::nee::{sample_light_through, Origin};
use crate::integrator::transport::params::{check_max_depth, ParamError};
use crate::integrator::transport::{emitted, escaped, Heuristic};
use crate::light::Light;
use crate::material::Material;
use crate::math::{Rgb, Rng, Vec3};
use crate::medium::Homogeneous;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// Volumetric path tracer parameters.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path in scattering events, Mitsuba's meaning (medium events count) |
/// | `rr_depth` | 5 | scattering events before Russian roulette starts |
/// | `heuristic` | `power` | MIS weights: `power` (beta = 2) or `balance` |
/// | `equiangular` | true | equi-angular sampling for point and spot lights in homogeneous media |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct VolpathSettings {
    pub max_depth: u32,
    pub rr_depth: u32,
    pub heuristic: Heuristic,
    pub equiangular: bool,
}

impl Default for VolpathSettings {
    fn default() -> Self {
        VolpathSettings {
            max_depth: 64,
            rr_depth: 5,
            heuristic: Heuristic::Power,
            equiangular: true,
        }
    }
}

impl VolpathSettings {
    /// A job's memory (module `memory`): the camera pass's tile buffers; paths keep
    /// nothing between pixels.
    pub fn memory(&self, facts: &Facts) -> Estimate {
        let mut e = Estimate::default();
        tile_memory(&mut e, facts);
        e
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        check_max_depth(self.max_depth)
    }
}

/// A distance sampled by free flight on a homogeneous segment, for equi-angular MIS.
#[derive(Clone, Copy)]
struct FlightPoint<'a> {
    medium: &'a Homogeneous,
    seg: Segment,
    t: f32,
}

/// The walk's visitor on camera and bounce segments: equi-angular gathering from point
/// and spot lights before each free flight, in homogeneous media.
struct Gather<'a> {
    vp: &'a VolPath,
    scene: &'a Scene,
    on: bool,
    l: Rgb,
}

impl Segments for Gather<'_> {
    #[inline(always)]
    fn enter(&mut self, seg: &Segment, rng: &mut Rng, stats: &mut RenderStats) -> Cross {
        let med = &self.scene.media[seg.medium as usize];
        if let (true, Some(h)) = (self.on, med.as_homogeneous()) {
            self.l += self.vp.equiangular(self.scene, h, seg, rng, stats);
        }
        Cross::Flight
    }
}

pub struct VolPath {
    s: VolpathSettings,
}

impl VolPath {
    pub fn new(s: VolpathSettings) -> Self {
        VolPath { s }
    }

    #[inline]
    fn mis(&self, a: f32, b: f32) -> f32 {
        self.s.heuristic.weight(a, b)
    }

    /// Position of a light that equi-angular sampling serves (points and spots).
    fn point_position(light: &Light) -> Option<Vec3> {
        match light {
            Light::Point(l) => Some(l.position),
            Light::Spot(l) => Some(l.position),
            _ => None,
        }
    }

    /// Next-event estimation: one light, transmittance to it, MIS. `seg` is the
    /// free-flight segment a medium point was sampled on, for equi-angular MIS.
    #[inline(always)]
    fn direct(
        &self,
        scene: &Scene,
        at: &Origin,
        seg: Option<&FlightPoint>,
        medium: Option<u32>,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        let seen = sample_light_through(scene, at, medium, rng, stats);
        let Some((link, tr)) = seen.filter(|(_, tr)| *tr != Rgb::ZERO) else {
            return Rgb::ZERO;
        };
        let w = if !link.delta {
            self.mis(link.pdf_light, link.pdf_scatter)
        } else {
            self.equiangular_partner(seg, &scene.lights[link.light])
        };
        link.f * tr * link.li * (w / link.pdf_light)
    }

    /// MIS weight of a distance-sampled connection to a point or spot light against
    /// equi-angular sampling of the same segment (1 where that is not used).
    fn equiangular_partner(&self, fp: Option<&FlightPoint>, light: &Light) -> f32 {
        let Some(fp) = fp else {
            return 1.0;
        };
        let Some(c) = Self::point_position(light) else {
            return 1.0;
        };
        let Some(ea) = EquiAngular::new(&fp.seg.ray, fp.seg.tmax, c) else {
            return 1.0;
        };
        self.mis(fp.medium.flight_pdf(fp.t, fp.seg.beta), ea.pdf(fp.t))
    }

    /// Single scattering towards a point or spot light at an equi-angular distance on
    /// `seg` in homogeneous `med` (its `beta`: the throughput the segment's free flight
    /// is sampled with). Returns the weighted contribution.
    fn equiangular(
        &self,
        scene: &Scene,
        med: &Homogeneous,
        seg: &Segment,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        let (ray, tmax, beta) = (&seg.ray, seg.tmax, seg.beta);
        let (li, sel_pdf, _) = scene.light_sampler.sample(rng.next_f32());
        let u = rng.next_f32();
        let light = &scene.lights[li];
        let Some(c) = Self::point_position(light) else {
            return Rgb::ZERO;
        };
        let Some(ea) = EquiAngular::new(ray, tmax, c) else {
            return Rgb::ZERO;
        };
        let (t, pdf_t) = ea.sample(u);
        if pdf_t.is_nan() || pdf_t <= 0.0 {
            return Rgb::ZERO;
        }
        let p = ray.at(t);
        let Some(ls) = light.sample_li(p, rng.next_2d()) else {
            return Rgb::ZERO;
        };
        let ph = med.phase.eval(ray.d, ls.wi());
        let scatter = med.transmittance(t) * med.sigma_s * ph;
        if scatter == Rgb::ZERO || ls.li() == Rgb::ZERO {
            return Rgb::ZERO;
        }
        stats.shadow_rays += 1;
        let shadow = Ray {
            o: p,
            d: ls.p() - p,
            tmax: 1.0 - SHADOW_EPSILON,
        };
        let tr = scene.transmittance(&shadow, Some(seg.medium), rng, &mut stats.shadow_rays);
        let w = self.mis(pdf_t, med.flight_pdf(t, beta));
        beta * scatter * tr * ls.li() * (w / (sel_pdf * pdf_t))
    }

    /// Radiance along one camera ray: steps until the path ends.
    // Forced inline, like pt's kernel, so the AVX2 copy of the tile loop holds it.
    #[inline(always)]
    fn li(&self, scene: &Scene, ray: Ray, rng: &mut Rng, stats: &mut RenderStats) -> Rgb {
        let mut path = Path {
            cam: CameraWalk::new(scene, ray),
            pdf_dir: 0.0,
            prev_p: ray.o,
            equi: self.s.equiangular
                && scene
                    .lights
                    .iter()
                    .any(|l| Self::point_position(l).is_some()),
        };
        while self.step(scene, &mut path, rng, stats) {}
        path.cam.l
    }

    /// One flight and what its event contributes: false when the path ends there.
    #[inline(always)]
    fn step(&self, scene: &Scene, path: &mut Path, rng: &mut Rng, stats: &mut RenderStats) -> bool {
        match self.fly(scene, path, rng, stats) {
            Step::Surface(it, m) => self.at_surface(scene, path, &it, &m, rng, stats),
            Step::Scatter { seg, t, .. } => self.in_medium(scene, path, seg, t, rng, stats),
            Step::Escaped => {
                if !path.seen(scene) {
                    let (c, h) = (&mut path.cam, self.s.heuristic);
                    c.l += c.walk.beta * escaped(scene, c.ray.d, c.specular, path.pdf_dir, h);
                }
                false
            }
            Step::End => false,
        }
    }

    /// The flight to the next event. Point and spot lights are gathered by
    /// equi-angular sampling on the medium segments it crosses (while a scattering
    /// there could still count); emission with MIS weight 1 (seen directly or after a
    /// delta bounce) comes in media from the segment's transmittance instead of the
    /// flight (medium_walk::seen_emission), which rarely reaches it in dense media.
    #[inline(always)]
    fn fly<'s>(
        &self,
        scene: &'s Scene,
        path: &mut Path,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Step<'s> {
        let seen = path.seen(scene);
        let c = &mut path.cam;
        let mut gather = Gather {
            vp: self,
            scene,
            on: path.equi && c.depth + 1 < self.s.max_depth,
            l: Rgb::ZERO,
        };
        let (first, beta, medium) = (c.ray, c.walk.beta, c.walk.medium);
        let step = c.walk.next(scene, &mut c.ray, &mut gather, rng, stats);
        c.l += gather.l;
        if seen && sees_emission(scene, step.surface(), matches!(step, Step::Escaped)) {
            c.l += beta * seen_emission(scene, &first, medium, rng, stats);
        }
        step
    }

    /// A real scattering event at distance `t` on `seg`: next-event estimation
    /// (against equi-angular sampling of the same segment where that serves), then a
    /// phase function sample and roulette. False when the path ends.
    #[inline(always)]
    fn in_medium(
        &self,
        scene: &Scene,
        path: &mut Path,
        seg: Segment,
        t: f32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> bool {
        let c = &mut path.cam;
        if c.depth + 1 >= self.s.max_depth {
            return false;
        }
        let p = seg.ray.at(t);
        let med = &scene.media[seg.medium as usize];
        let fp = med
            .as_homogeneous()
            .filter(|_| path.equi)
            .map(|h| FlightPoint { medium: h, seg, t });
        let phase = med.phase();
        if !scene.lights.is_empty() {
            let at = Origin::Medium {
                p,
                d: c.ray.d,
                phase,
            };
            let e = self.direct(scene, &at, fp.as_ref(), c.walk.medium, rng, stats);
            c.l += c.walk.beta * e;
        }
        let (wi, pdf) = phase.sample(c.ray.d, rng.next_2d());
        c.specular = false;
        path.pdf_dir = pdf;
        path.prev_p = p;
        c.depth += 1;
        if !roulette(c.depth, self.s.rr_depth, &mut c.walk.beta, rng) {
            return false;
        }
        c.ray = Ray::new(p, wi);
        stats.rays += 1;
        true
    }

    /// A surface: its emission (MIS against the light sample that could have found
    /// it, unless `fly` counted it), then next-event estimation and a BSDF sample.
    /// False when the path ends.
    #[inline(always)]
    fn at_surface(
        &self,
        scene: &Scene,
        path: &mut Path,
        it: &Interaction,
        m: &Material,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> bool {
        let seen = path.seen(scene);
        let c = &mut path.cam;
        if !seen {
            let (h, pdf_dir) = (self.s.heuristic, path.pdf_dir);
            c.l += c.walk.beta * emitted(scene, it, c.ray.d, path.prev_p, c.specular, pdf_dir, h);
        }
        if c.depth + 1 >= self.s.max_depth {
            return false;
        }
        let frame = scene.shading_frame(it);
        let wo = frame.to_local(-c.ray.d);
        if !m.is_delta() && !scene.lights.is_empty() {
            let at = Origin::Surface {
                it,
                frame: &frame,
                wo,
                m,
            };
            c.l += c.walk.beta * self.direct(scene, &at, None, c.walk.medium, rng, stats);
        }
        let Some(sample) = sample_bsdf(it, &frame, wo, m, rng) else {
            return false;
        };
        path.pdf_dir = sample.1.pdf;
        path.prev_p = it.p;
        c.bounce(scene, it, sample, self.s.rr_depth, rng, stats)
    }
}

/// A camera path between flights: the state every tracer in media keeps
/// ([`CameraWalk`]), and what MIS against light sampling needs of its last scattering.
struct Path {
    cam: CameraWalk,
    /// Solid-angle density of the last scattering direction.
    pdf_dir: f32,
    /// The last scattering point, where light sampling's density is measured from.
    prev_p: Vec3,
    /// Equi-angular sampling serves this scene (it is on, and there is a point or spot
    /// light).
    equi: bool,
}

impl Path {
    /// Emission the next flight finds counts with MIS weight 1 and, in media, from the
    /// flight's transmittance (`VolPath::fly`): the path has only specular events.
    #[inline(always)]
    fn seen(&self, scene: &Scene) -> bool {
        self.cam.specular && scene.has_media
    }
}

impl Integrator for VolPath {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        render_pixels(
            scene,
            seed,
            iteration,
            film,
            #[inline(always)]
            |ray, rng, stats| self.li(scene, ray, rng, stats),
        )
    }
}
