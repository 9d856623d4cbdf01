//! vpm's photon pass: photon paths from the lights through media and off surfaces,
//! storing a photon at every real scattering event in a medium (module notes of
//! `vpm`), in fixed chunks so the photons' order never depends on threads.

use super::{Vpm, Workspace};
use crate::film::is_valid_sample;
use crate::geometry::{spawn_ray, Interaction, Ray};
use crate::integrator::estimators::Point;
use crate::integrator::transport::emit::sample_emission;
use crate::integrator::transport::medium_walk::{MediumWalk, Segment, Step};
use crate::integrator::transport::{Stream, PATHS_PER_TASK};
use crate::integrator::RenderStats;
use crate::material::{Material, Mode};
use crate::math::{max_component, Rgb, Rng, Vec3};
use crate::scene::Scene;
use rayon::prelude::*;

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

impl Point for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// One chunk's photons, kept between iterations for its buffer.
#[derive(Default)]
pub(super) struct Chunk {
    pub(super) photons: Vec<Photon>,
    pub(super) stats: RenderStats,
    pub(super) over_budget: bool,
}

/// Photons one of `chunks` chunks may store: its share of `max_photon_mib`.
pub(crate) fn photon_budget(max_photon_mib: f32, chunks: usize) -> usize {
    (max_photon_mib as f64 * 1048576.0
        / std::mem::size_of::<Photon>() as f64
        / chunks.max(1) as f64) as usize
}

impl Vpm {
    /// The photon pass: fixed chunks in parallel, concatenated in chunk order.
    pub(super) fn trace_photons(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        paths: usize,
        ws: &mut Workspace,
    ) -> RenderStats {
        let chunks = paths.div_ceil(PATHS_PER_TASK);
        ws.chunks.resize_with(chunks, Chunk::default);
        ws.chunks.truncate(chunks);
        let budget = photon_budget(self.s.max_photon_mib as f32, chunks);
        ws.chunks.par_iter_mut().enumerate().for_each(|(c, chunk)| {
            chunk.photons.clear();
            chunk.stats = RenderStats::default();
            chunk.over_budget = false;
            for i in c * PATHS_PER_TASK..((c + 1) * PATHS_PER_TASK).min(paths) {
                let mut rng = Stream::VpmPhotons.rng(seed, iteration, i as u64);
                self.trace_photon(scene, &mut rng, chunk, budget);
            }
        });
        ws.photons.clear();
        let mut stats = RenderStats::default();
        for chunk in &ws.chunks {
            ws.photons.extend_from_slice(&chunk.photons);
            stats += chunk.stats;
        }
        if ws.chunks.iter().any(|c| c.over_budget) {
            tracing::warn!(
                "photons beyond max_photon_mib = {} were not stored this iteration; raise it or lower light_paths",
                self.s.max_photon_mib
            );
        }
        stats.light_vertices = ws.photons.len() as u64;
        stats
    }

    /// One photon path: free flights through media, photons stored where they scatter
    /// in one, BSDF sampling at surfaces.
    fn trace_photon(&self, scene: &Scene, rng: &mut Rng, out: &mut Chunk, budget: usize) {
        let Some((mut ray, beta, medium)) = emit(scene, rng) else {
            return;
        };
        let mut walk = PhotonWalk {
            path: MediumWalk { beta, medium },
            depth: 0,
        };
        loop {
            out.stats.rays += 1;
            match walk
                .path
                .next(scene, &mut ray, &mut (), rng, &mut out.stats)
            {
                Step::Scatter { seg, t, .. } => {
                    let Some(next) = self.store(scene, &seg, t, &mut walk, rng, out, budget) else {
                        return;
                    };
                    ray = next;
                }
                Step::Surface(it, m) => {
                    // Photons stored after this bounce have k >= depth + 1.
                    if walk.depth + 3 > self.s.max_depth {
                        return;
                    }
                    let Some((wi, weight)) = photon_bounce(scene, &it, &m, -ray.d, rng) else {
                        return;
                    };
                    if !walk.scatter(weight, rng) {
                        return;
                    }
                    walk.path.medium = scene.medium_after(&it, wi, walk.path.medium);
                    ray = spawn_ray(it.p, it.p_err, it.ng, wi);
                }
                Step::Escaped | Step::End => return,
            }
        }
    }

    /// A photon's scattering event at distance `t` on `seg`: stores the photon (its
    /// power already holds the flight's weight), then samples the phase function; the
    /// ray the path goes on along, or None.
    #[allow(clippy::too_many_arguments)]
    fn store(
        &self,
        scene: &Scene,
        seg: &Segment,
        t: f32,
        walk: &mut PhotonWalk,
        rng: &mut Rng,
        out: &mut Chunk,
        budget: usize,
    ) -> Option<Ray> {
        let p = seg.ray.at(t);
        // A camera segment reached directly (j = 0) needs k + 2 <= max_depth.
        if walk.depth + 2 <= self.s.max_depth {
            if out.photons.len() < budget {
                out.photons.push(Photon {
                    p,
                    d: seg.ray.d,
                    beta: walk.path.beta,
                    medium: seg.medium,
                    depth: walk.depth,
                });
            } else {
                out.over_budget = true;
            }
        }
        if walk.depth + 3 > self.s.max_depth {
            return None;
        }
        let phase = scene.media[seg.medium as usize].phase();
        let (wi, _) = phase.sample(seg.ray.d, rng.next_2d());
        // The phase function is sampled exactly: its weight is 1, and the flight's
        // weight is in the power since the walk returned.
        walk.roulette(seg.beta, rng).then(|| Ray::new(p, wi))
    }
}

/// Where a photon path starts: its ray, power (Le cos / (p_pos p_dir p_select)) and the
/// medium the light emits into.
pub(super) fn emit(scene: &Scene, rng: &mut Rng) -> Option<(Ray, Rgb, Option<u32>)> {
    let start = sample_emission(scene, rng)?;
    let beta = start.power();
    if !is_valid_sample(beta) || beta == Rgb::ZERO {
        return None;
    }
    Some((start.ray, beta, start.medium))
}

/// A photon's BSDF sample at a surface: the new direction and the power factor, with
/// the adjoint correction for shading normals |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|)
/// (Veach 1997, eq. (5.17)).
pub(crate) fn photon_bounce(
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
    let corr = (wo.z * wi_ng).abs() / (wo_ng * s.wi.z).abs();
    corr.is_finite().then_some((wi, Rgb::from(s.weight) * corr))
}

/// A photon path between events: its power and medium, and the scattering events so
/// far.
pub(super) struct PhotonWalk {
    pub(super) path: MediumWalk,
    pub(super) depth: u32,
}

impl PhotonWalk {
    /// A surface event multiplies the power by `weight`, then rouletted as below; false
    /// ends the path.
    #[inline]
    pub(super) fn scatter(&mut self, weight: Rgb, rng: &mut Rng) -> bool {
        let old = self.path.beta;
        self.path.beta *= weight;
        self.roulette(old, rng)
    }

    /// One more scattering event, the power having gone from `old` to its value now:
    /// Russian roulette with survival (new power) / (old power) lets survivors keep
    /// about the power they had (the best case for a density estimate).
    #[inline]
    pub(super) fn roulette(&mut self, old: Rgb, rng: &mut Rng) -> bool {
        let new = self.path.beta;
        self.depth += 1;
        let q = (max_component(new) / max_component(old)).min(1.0);
        if q.is_nan() || rng.next_f32() >= q {
            return false;
        }
        self.path.beta = new / q;
        self.path.beta != Rgb::ZERO && self.path.beta.is_finite()
    }
}
