//! One pass of `ppm` / `sppm`, phase by phase (module notes of `sppm`): the camera
//! pass, the photon waves gathered into the visible points, the per-pixel statistics,
//! and the film they give.

use super::media::gather_segments;
use super::state::State;
use super::{CameraResult, Gathered, PhotonMap, PhotonMapper, PIXEL_CHUNK, WAVE};
use crate::film::{is_valid_sample, Film};
use crate::integrator::estimators::beam_query::BeamQuery;
use crate::integrator::paths::photons::{Photon, SurfacePhoton};
use crate::integrator::transport::Stream;
use crate::integrator::RenderStats;
use crate::math::{Rgb, Vec3};
use crate::scene::Scene;
use rayon::prelude::*;

/// What every phase of a pass reads.
pub(super) struct Pass<'a> {
    pub scene: &'a Scene,
    pub seed: u64,
    pub iteration: u64,
    /// Photon paths of the pass.
    pub paths: u64,
}

impl PhotonMapper {
    /// The statistics for `iteration`: those kept, when the caller continues where
    /// they left off, else fresh ones (at iteration 0, and whenever the seed, the
    /// iteration or the image size does not follow on).
    pub(super) fn state_for<'s>(
        &self,
        state: &'s mut Option<State>,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        npix: usize,
    ) -> &'s mut State {
        let fresh = match state {
            Some(st) => {
                iteration == 0 || st.seed != seed || st.next != iteration || st.pixels.len() != npix
            }
            None => true,
        };
        if fresh {
            *state = Some(State::new(
                seed,
                iteration,
                npix,
                self.s.initial_radius(scene),
            ));
        }
        state.as_mut().expect("state was just set")
    }

    /// Phase 1: every pixel's camera path, in fixed chunks of pixels.
    pub(super) fn camera_pass(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        npix: usize,
        stats: &mut RenderStats,
    ) -> Vec<CameraResult> {
        let parts: Vec<(Vec<CameraResult>, RenderStats)> = (0..npix)
            .step_by(PIXEL_CHUNK)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|a| {
                let mut st = RenderStats::default();
                let v = (a..(a + PIXEL_CHUNK).min(npix))
                    .map(|i| self.camera_path(scene, seed, iteration, i as u64, &mut st))
                    .collect();
                (v, st)
            })
            .collect();
        let mut camera = Vec::with_capacity(npix);
        for (v, st) in parts {
            camera.extend(v);
            *stats += st;
        }
        camera
    }

    /// Phase 2: the pass's photon paths in waves of [`WAVE`], each wave's photons
    /// gathered into every visible point (within the pixel's radius) and along every
    /// camera segment in a medium. What each pixel gathered over the waves.
    pub(super) fn photon_waves(
        &self,
        pass: &Pass,
        camera: &[CameraResult],
        state: &State,
        map: &mut PhotonMap,
        stats: &mut RenderStats,
    ) -> Vec<Gathered> {
        let mut gathered = vec![Gathered::default(); camera.len()];
        let r_max = camera
            .iter()
            .zip(&state.pixels)
            .filter(|(c, _)| c.vp.is_some())
            .map(|(_, p)| p.r as f32)
            .fold(0.0f32, f32::max);
        let crosses_media = camera.iter().any(|c| !c.segments.is_empty());
        let mut start = 0u64;
        while start < pass.paths && (r_max > 0.0 || crosses_media) {
            let end = (start + WAVE as u64).min(pass.paths);
            let (scene, seed, iteration) = (pass.scene, pass.seed, pass.iteration);
            *stats += self.trace_wave(scene, seed, iteration, start..end, map);
            map.grid.build(&map.pos, r_max.max(f32::MIN_POSITIVE));
            if crosses_media {
                map.bvh.build(&mut map.media);
            }
            stats.vertex_bytes = stats.vertex_bytes.max(map.bytes());
            let wave = start / WAVE as u64;
            self.gather_wave(pass, wave, camera, state, map, &mut gathered);
            start = end;
        }
        gathered
    }

    /// One wave's photons into every pixel's sums.
    fn gather_wave(
        &self,
        pass: &Pass,
        wave: u64,
        camera: &[CameraResult],
        state: &State,
        map: &PhotonMap,
        gathered: &mut [Gathered],
    ) {
        let (scene, seed, iteration) = (pass.scene, pass.seed, pass.iteration);
        let beams = BeamQuery {
            scene,
            photons: &map.media,
            bvh: &map.bvh,
            radius: self.s.medium_radius_at(scene, iteration),
            inv_paths: 1.0,
            max_depth: self.s.max_depth,
        };
        gathered
            .par_iter_mut()
            .with_min_len(256)
            .zip(camera.par_iter())
            .zip(state.pixels.par_iter())
            .enumerate()
            .for_each(|(i, ((acc, c), px))| {
                if let Some(vp) = &c.vp {
                    self.gather(scene, map, vp, px.r as f32, acc);
                }
                if !c.segments.is_empty() {
                    // One sequence per pixel and wave (ratio tracking to photons).
                    let mut rng = Stream::SppmMedium.rng(seed ^ (wave + 1), iteration, i as u64);
                    let mut st = RenderStats::default();
                    let l = gather_segments(&beams, &c.segments, &mut rng, &mut st);
                    acc.medium = std::array::from_fn(|k| acc.medium[k] + l[k] as f64);
                    acc.medium_merges += st.merges;
                }
            });
    }

    /// Phase 3: each pixel's direct sum, and its N, R and tau [2008, eqs. (7), (8),
    /// (11)]; the samples dropped as not finite.
    pub(super) fn update_pixels(
        &self,
        state: &mut State,
        camera: &[CameraResult],
        gathered: &[Gathered],
        paths: u64,
    ) -> u64 {
        let alpha = self.s.alpha as f64;
        let per_path = 1.0 / paths.max(1) as f64;
        state
            .pixels
            .par_iter_mut()
            .with_min_len(256)
            .zip(camera.par_iter())
            .zip(gathered.par_iter())
            .map(|((px, c), g)| {
                let mut dropped = 0;
                // The camera pass's radiance, media included (averaged over passes).
                let medium = g.medium.map(|v| (v * per_path) as f32);
                let l = c.l + Rgb::new(medium[0], medium[1], medium[2]);
                if is_valid_sample(l) {
                    for c in 0..3 {
                        px.direct[c] += l[c] as f64;
                    }
                } else {
                    dropped += 1;
                }
                let phi_ok = g.phi.iter().all(|v| v.is_finite() && *v >= 0.0);
                if !phi_ok {
                    dropped += 1;
                } else if g.m > 0 {
                    let m = g.m as f64;
                    let n_new = px.n + alpha * m;
                    let r_new = px.r * (n_new / (px.n + m)).sqrt();
                    let shrink = (r_new / px.r) * (r_new / px.r);
                    for c in 0..3 {
                        px.tau[c] = (px.tau[c] + g.phi[c]) * shrink;
                    }
                    px.n = n_new;
                    px.r = r_new;
                }
                dropped
            })
            .sum()
    }
}

impl PhotonMap {
    /// What the map holds in memory: photons, their grid, medium photons, their BVH.
    fn bytes(&self) -> u64 {
        (self.pos.capacity() * std::mem::size_of::<Vec3>()
            + self.data.capacity() * std::mem::size_of::<SurfacePhoton>()
            + self.grid.bytes()
            + self.media.capacity() * std::mem::size_of::<Photon>()
            + self.bvh.bytes()) as u64
    }
}

/// The estimate after the pass of `iteration`, times the iteration count the caller
/// divides by: direct (the mean over passes) plus tau / (N_emitted pi R^2) [2008, eq.
/// (12)].
pub(super) fn estimate_film(state: &State, w: u32, h: u32, iteration: u64, dropped: u64) -> Film {
    let k = (iteration + 1) as f64;
    let passes = state.passes as f64;
    let emitted = state.emitted.max(1) as f64;
    let sums: Vec<[f64; 3]> = state
        .pixels
        .par_iter()
        .with_min_len(1024)
        .map(|px| {
            let norm = 1.0 / (emitted * std::f64::consts::PI * px.r * px.r);
            std::array::from_fn(|c| k * (px.direct[c] / passes + px.tau[c] * norm))
        })
        .collect();
    Film::from_parts(w, h, sums, dropped)
}
