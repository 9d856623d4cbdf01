//! The photon walk of the density estimators that carry no MIS (`ppm`, `sppm`, `vpm`):
//! photon paths from the lights, free flights through media, BSDF sampling at surfaces
//! (importance transport, with the adjoint correction for shading normals), and
//! photons stored where the estimator asks: at every real scattering event in a medium,
//! and (for the surface estimators) at non-delta surfaces after at least one event.
//!
//! Photons are rouletted with survival (new power) / (old power), so survivors keep
//! about the power they had: the best case for a density estimate (pbrt-v4's SPPM
//! does the same). The bidirectional family's light tracer ([`super::light_path`])
//! rouletts differently, with a continuation probability fixed by the vertex alone,
//! because its reverse densities must hold that probability too.
//!
//! Random numbers per path: the emission sample, then per event the walk's flight
//! draws, the scattering direction and the roulette draw.

use super::vertex::{Media, NoMedia, WithMedia};
use crate::film::is_valid_sample;
use crate::geometry::{spawn_ray, Interaction, Ray};
use crate::integrator::drive::light::ChunkTracer;
use crate::integrator::transport::adjoint::adjoint_correction;
use crate::integrator::transport::emit::sample_emission;
use crate::integrator::transport::medium_walk::{MediumWalk, Segment, Step};
use crate::integrator::transport::Stream;
use crate::integrator::RenderStats;
use crate::material::{Material, Mode};
use crate::math::{max_component, Rgb, Rng, Vec3};
use crate::scene::{Scene, Surfacing};

/// A photon stored at a scattering event in a medium.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Photon {
    pub(crate) p: Vec3,
    /// Direction the light travelled before scattering here (the phase function's `d`).
    pub(crate) d: Vec3,
    /// Power: flux per emitted path, times the weight sigma_s T / pdf of the free flight
    /// that ended here.
    pub(crate) beta: Rgb,
    pub(crate) medium: u32,
    /// Scattering events on the photon path before this one.
    pub(crate) depth: u32,
}

/// A photon stored at a surface (its position is kept apart, for the hash grid).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfacePhoton {
    /// Towards where the photon came from, world space.
    pub(crate) wi: Vec3,
    /// Power carried (flux per emitted path).
    pub(crate) beta: Rgb,
    /// Scattering events before it arrived.
    pub(crate) depth: u32,
}

/// The photons of one chunk of paths.
#[derive(Default)]
pub(crate) struct PhotonChunk {
    /// Surface photons' positions and the rest of them, in the same order.
    pub(crate) surface_pos: Vec<Vec3>,
    pub(crate) surface: Vec<SurfacePhoton>,
    /// Photons in media.
    pub(crate) media: Vec<Photon>,
    pub(crate) stats: RenderStats,
    /// Medium photons were dropped for the budget.
    pub(crate) over_budget: bool,
}

/// What a photon pass keeps, and how long its paths may be.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PhotonRules {
    /// Longest path in Mitsuba's sense, over the photon and camera halves: a photon
    /// stored after k events counts only where k + 2 <= max_depth, and a path ends
    /// once no later photon can.
    pub max_depth: u32,
    /// Events before Russian roulette starts.
    pub rr_depth: u32,
    /// Surface photons are stored.
    pub surfaces: bool,
    /// Medium photons one chunk may store.
    pub budget: usize,
}

/// One iteration's (or wave's) photon paths, for the light-path loop.
pub(crate) struct PhotonPass<'a> {
    pub scene: &'a Scene,
    pub rules: PhotonRules,
    /// The random stream of the algorithm, seeded per (seed, iteration, path).
    pub stream: Stream,
    pub seed: u64,
    pub iteration: u64,
}

impl ChunkTracer for PhotonPass<'_> {
    type Chunk = PhotonChunk;

    fn clear(&self, chunk: &mut PhotonChunk) {
        chunk.surface_pos.clear();
        chunk.surface.clear();
        chunk.media.clear();
        chunk.stats = RenderStats::default();
        chunk.over_budget = false;
    }

    #[inline(always)]
    fn trace(&self, index: u64, chunk: &mut PhotonChunk) {
        let mut rng = self.stream.rng(self.seed, self.iteration, index);
        if self.scene.has_media {
            trace_photon::<WithMedia>(self.scene, &self.rules, &mut rng, chunk);
        } else {
            trace_photon::<NoMedia>(self.scene, &self.rules, &mut rng, chunk);
        }
    }
}

/// Medium photons one of `chunks` chunks may store: its share of `max_photon_mib`.
pub(crate) fn photon_budget(max_photon_mib: f32, chunks: usize) -> usize {
    crate::integrator::drive::light::chunk_share::<Photon>(max_photon_mib, chunks)
}

/// Photon paths per iteration: `light_paths` x `pixels`, rounded up, at least one.
pub(crate) fn photon_paths(light_paths: f32, pixels: f64) -> usize {
    (light_paths as f64 * pixels).ceil().max(1.0) as usize
}

/// One photon path; `M` (whether the scene has media) is decided once per path.
#[inline(always)]
fn trace_photon<M: Media>(
    scene: &Scene,
    rules: &PhotonRules,
    rng: &mut Rng,
    out: &mut PhotonChunk,
) {
    let Some((mut ray, beta, medium)) = emit(scene, rng) else {
        return;
    };
    let mut walk = PhotonWalk {
        path: MediumWalk { beta, medium },
        depth: 0,
    };
    loop {
        out.stats.rays += 1;
        let step = if M::ON {
            walk.path
                .next(scene, &mut ray, &mut (), rng, &mut out.stats)
        } else {
            surface_step(scene.next_scattering(&mut ray, &mut out.stats.rays))
        };
        let next = match step {
            Step::Scatter { seg, t, .. } => in_medium(scene, rules, &seg, t, &mut walk, rng, out),
            Step::Surface(it, m) => at_surface(scene, rules, &it, &m, ray.d, &mut walk, rng, out),
            Step::Escaped | Step::End => None,
        };
        let Some(next) = next else {
            return;
        };
        ray = next;
    }
}

/// A scene without media: the next surface as the walk's step.
#[inline(always)]
pub(crate) fn surface_step(s: Surfacing<'_>) -> Step<'_> {
    match s {
        Surfacing::Hit(it, m) => Step::Surface(it, m),
        Surfacing::Escaped => Step::Escaped,
        Surfacing::Lost => Step::End,
    }
}

/// A scattering event at distance `t` on `seg`: stores the photon (its power already
/// holds the flight's weight), then samples the phase function; the ray the path goes
/// on along, or None.
#[inline(always)]
fn in_medium(
    scene: &Scene,
    rules: &PhotonRules,
    seg: &Segment,
    t: f32,
    walk: &mut PhotonWalk,
    rng: &mut Rng,
    out: &mut PhotonChunk,
) -> Option<Ray> {
    let p = seg.ray.at(t);
    // A camera segment reached directly (j = 0) needs k + 2 <= max_depth.
    if walk.depth + 2 <= rules.max_depth {
        if out.media.len() < rules.budget {
            out.media.push(Photon {
                p,
                d: seg.ray.d,
                beta: walk.path.beta,
                medium: seg.medium,
                depth: walk.depth,
            });
            out.stats.light_vertices += 1;
        } else {
            out.over_budget = true;
        }
    }
    if walk.depth + 3 > rules.max_depth {
        return None;
    }
    let phase = scene.media[seg.medium as usize].phase();
    let (wi, _) = phase.sample(seg.ray.d, rng.next_2d());
    // The phase function is sampled exactly: its weight is 1, and the flight's weight
    // is in the power since the walk returned.
    walk.roulette(seg.beta, rules, rng).then(|| Ray::new(p, wi))
}

/// A photon arriving along `d` at surface `it`: stored there when the pass keeps
/// surface photons, after at least one event (photons straight from a light are the
/// camera side's next-event estimate) and where the surface is not a delta one; then a
/// BSDF sample. The ray the path goes on along, or None.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn at_surface(
    scene: &Scene,
    rules: &PhotonRules,
    it: &Interaction,
    m: &Material,
    d: Vec3,
    walk: &mut PhotonWalk,
    rng: &mut Rng,
    out: &mut PhotonChunk,
) -> Option<Ray> {
    if rules.surfaces && walk.depth >= 1 && !m.is_delta() {
        out.surface_pos.push(it.p);
        out.surface.push(SurfacePhoton {
            wi: -d,
            beta: walk.path.beta,
            depth: walk.depth,
        });
        out.stats.light_vertices += 1;
    }
    // Photons stored after this bounce have k >= depth + 1.
    if walk.depth + 3 > rules.max_depth {
        return None;
    }
    let (wi, weight) = photon_bounce(scene, it, m, -d, rng)?;
    let old = walk.path.beta;
    walk.path.beta *= weight;
    if !walk.roulette(old, rules, rng) {
        return None;
    }
    walk.path.medium = scene.medium_after(it, wi, walk.path.medium);
    Some(spawn_ray(it.p, it.p_err, it.ng, wi))
}

/// Where a photon path starts: its ray, power (Le cos / (p_pos p_dir p_select)) and the
/// medium the light emits into.
fn emit(scene: &Scene, rng: &mut Rng) -> Option<(Ray, Rgb, Option<u32>)> {
    let start = sample_emission(scene, rng)?;
    let beta = start.power();
    if !is_valid_sample(beta) || beta == Rgb::ZERO {
        return None;
    }
    Some((start.ray, beta, start.medium))
}

/// A photon's BSDF sample at a surface: the new direction and the power factor, with
/// the adjoint correction for shading normals that light subpaths also apply.
#[inline(always)]
fn photon_bounce(
    scene: &Scene,
    it: &Interaction,
    m: &Material,
    wo_world: Vec3,
    rng: &mut Rng,
) -> Option<(Vec3, Rgb)> {
    let frame = scene.shading_frame(it);
    let wo = frame.to_local(wo_world);
    let s = m.sample(wo, rng.next_f32(), rng.next_2d(), Mode::Importance)?;
    let wi = frame.to_world(s.wi.into());
    let (wo_ng, wi_ng) = (wo_world.dot(it.ng), wi.dot(it.ng));
    if (wi_ng > 0.0) != (s.wi.z > 0.0) || (wo_ng > 0.0) != (wo.z > 0.0) {
        return None;
    }
    let corr = adjoint_correction(frame.n, it.ng, wo_world, wi);
    Some((wi, Rgb::from(s.weight) * corr))
}

/// A photon path between events: its power and medium, and the scattering events so
/// far.
struct PhotonWalk {
    path: MediumWalk,
    depth: u32,
}

impl PhotonWalk {
    /// One more scattering event, the power having gone from `old` to its value now:
    /// from `rr_depth` events on, Russian roulette with survival (new power) / (old
    /// power). False ends the path.
    #[inline(always)]
    fn roulette(&mut self, old: Rgb, rules: &PhotonRules, rng: &mut Rng) -> bool {
        let new = self.path.beta;
        self.depth += 1;
        if self.depth >= rules.rr_depth {
            let q = (max_component(new) / max_component(old)).min(1.0);
            if q.is_nan() || rng.next_f32() >= q {
                return false;
            }
            self.path.beta = new / q;
        }
        self.path.beta != Rgb::ZERO && self.path.beta.is_finite()
    }
}
