//! The walk through media and `null` boundaries that every tracer in media shares: from
//! a ray's origin to its next event (a surface that scatters, a real scattering point in
//! a medium, escape, or the end of the path), crossing index-matched boundaries and
//! sampling free flights in the medium the path is in.
//!
//! The tracers differ only in what they do with each medium segment they cross, so the
//! walk hands every segment (origin, unit direction, length, medium, throughput at its
//! start) to a [`Segments`] visitor twice: before the flight, where the visitor may
//! gather along the whole segment and take it over (the beam radiance estimate passes
//! with the segment's transmittance instead of sampling a distance), and after the walk
//! passed it (bidirectional MIS adds its optical depth; light subpaths keep it as a ray
//! light or photon beam). A scattering event returns with the segment it ended, so the
//! caller also knows the part [0, t) it travelled.
//!
//! Random numbers: those of `Medium::sample_flight` per medium segment, in order; the
//! visitor's own draws come before the flight's.

use crate::geometry::{spawn_ray, Interaction, Ray};
use crate::integrator::RenderStats;
use crate::material::textured::MaterialRef;

use crate::math::{Rgb, Rng};
use crate::medium::Flight;
use crate::scene::{Scene, MAX_NULL_CROSSINGS};

/// The part of a ray inside one medium: from `ray.o` along the unit `ray.d` for
/// `tmax` (infinite when the ray leaves the scene), entered with throughput `beta`.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub ray: Ray,
    pub tmax: f32,
    pub medium: u32,
    pub beta: Rgb,
}

/// What the walk meets next.
pub enum Step<'a> {
    /// A surface that scatters (null boundaries are crossed, never returned).
    Surface(Interaction, MaterialRef<'a>),
    /// A real scattering event at distance `t` on `seg`; the throughput already holds
    /// the flight's `weight` (sigma_s T / pdf).
    Scatter { seg: Segment, t: f32, weight: Rgb },
    /// The ray left the scene.
    Escaped,
    /// Absorbed, out of throughput, taken over by the visitor, or lost between null
    /// boundaries.
    End,
}

/// What a visitor decides for a medium segment before the walk crosses it.
pub enum Cross {
    /// Sample a free flight on it (the walk's default).
    Flight,
    /// Pass to its end, multiplying the throughput by this weight (the visitor
    /// estimated the segment itself, e.g. with its transmittance).
    Pass(Rgb),
    /// End the path here.
    End,
}

/// A tracer's view of the medium segments its walk crosses.
pub trait Segments {
    /// Before the flight over `seg`; the default samples one.
    #[inline(always)]
    fn enter(&mut self, _seg: &Segment, _rng: &mut Rng, _stats: &mut RenderStats) -> Cross {
        Cross::Flight
    }

    /// The walk reached the end of `seg` (a surface, a null boundary or escape).
    #[inline(always)]
    fn passed(&mut self, _seg: &Segment) {}
}

/// Plain free flights: nothing gathered, nothing kept.
impl Segments for () {}

/// The throughput and medium of a path between events.
#[derive(Clone, Copy, Debug)]
pub struct MediumWalk {
    pub beta: Rgb,
    /// The medium the path travels in.
    pub medium: Option<u32>,
}

impl MediumWalk {
    /// Follows `ray` (unit direction) to the next event; on return `ray` is the one
    /// the event lies on (the last null crossing's continuation). Rays beyond the
    /// first count in `stats.rays`.
    #[inline(always)]
    pub fn next<'a, V: Segments>(
        &mut self,
        scene: &'a Scene,
        ray: &mut Ray,
        visit: &mut V,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Step<'a> {
        for _ in 0..=MAX_NULL_CROSSINGS {
            let hit = scene.hit(ray);
            if let Some(medium) = self.medium {
                // A unit direction makes the hit's t the distance.
                let tmax = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                let seg = Segment {
                    ray: *ray,
                    tmax,
                    medium,
                    beta: self.beta,
                };
                match visit.enter(&seg, rng, stats) {
                    Cross::Flight => {
                        let med = &scene.media[medium as usize];
                        match med.sample_flight(ray.o, ray.d, tmax, self.beta, rng) {
                            Flight::Scatter { t, weight } => {
                                self.beta *= weight;
                                return Step::Scatter { seg, t, weight };
                            }
                            Flight::Pass { weight } => self.beta *= weight,
                            Flight::Absorbed => return Step::End,
                        }
                    }
                    Cross::Pass(weight) => self.beta *= weight,
                    Cross::End => return Step::End,
                }
                visit.passed(&seg);
                if self.beta == Rgb::ZERO {
                    return Step::End;
                }
            }
            let Some(hit) = hit else {
                return Step::Escaped;
            };
            let it = scene.interaction(ray, &hit);
            if !scene.passes(&it, ray) {
                let m = scene.material(&it);
                return Step::Surface(it, m);
            }
            self.medium = scene.medium_after(&it, ray.d, self.medium);
            *ray = spawn_ray(it.p, it.p_err, it.ng, ray.d);
            stats.rays += 1;
        }
        Step::End
    }
}

/// The emission a camera ray sees straight ahead: the radiance of the first surface
/// that scatters along `ray` (null boundaries crossed), or of the environment when it
/// leaves the scene, times the transmittance of the media on the way (closed form, or
/// ratio tracking in heterogeneous media).
///
/// Emission found by the camera's first segment has MIS weight 1 in every integrator,
/// so this expected value can stand in for the free flight's all-or-nothing estimate
/// of it (Le when the flight passes, 0 when it scatters first). Directly visible
/// lights in fog are otherwise the noisiest pixels of an image and converge only with
/// the iteration count, whatever the algorithm. Callers add it once per camera path,
/// whenever the first flight did not already reach a surface that does not emit
/// (there it is zero), and skip the first segment's own emission.
pub fn seen_emission(
    scene: &Scene,
    ray: &Ray,
    mut medium: Option<u32>,
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> Rgb {
    let mut ray = *ray;
    let mut tr = Rgb::ONE;
    stats.rays += 1;
    for _ in 0..=MAX_NULL_CROSSINGS {
        let hit = scene.hit(&ray);
        if let Some(m) = medium {
            // f32::MAX, not infinity: 0 x infinity would be NaN where sigma_t is 0.
            let tmax = hit.as_ref().map_or(f32::MAX, |h| h.t);
            tr *= scene.media[m as usize].transmittance(ray.o, ray.d, tmax, rng);
            if tr == Rgb::ZERO {
                return Rgb::ZERO;
            }
        }
        let Some(hit) = hit else {
            return tr * scene.env_radiance(ray.d);
        };
        let it = scene.interaction(&ray, &hit);
        if !scene.passes(&it, &ray) {
            return match scene.area_light(&it) {
                Some((_, area)) => tr * area.le(&it, -ray.d),
                None => Rgb::ZERO,
            };
        }
        medium = scene.medium_after(&it, ray.d, medium);
        ray = spawn_ray(it.p, it.p_err, it.ng, ray.d);
        stats.rays += 1;
    }
    Rgb::ZERO
}

/// Whether a camera path whose first walk ended at `surface` (None: it scattered in a
/// medium, was absorbed or got lost), or left the scene (`escaped`), must add
/// [`seen_emission`]: when the flight stopped short of the first surface, or reached
/// one that emits, or left the scene (see there).
#[inline]
pub fn sees_emission(scene: &Scene, surface: Option<&Interaction>, escaped: bool) -> bool {
    match surface {
        Some(it) => scene.area_light(it).is_some(),
        None if escaped => !scene.env_lights.is_empty(),
        None => true,
    }
}

impl Step<'_> {
    /// The surface the walk reached, if it did.
    #[inline]
    pub fn surface(&self) -> Option<&Interaction> {
        match self {
            Step::Surface(it, _) => Some(it),
            _ => None,
        }
    }
}
