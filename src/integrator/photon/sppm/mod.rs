//! Progressive photon mapping (PPM; Hachisuka, Ogaki and Jensen 2008) and stochastic
//! progressive photon mapping (SPPM; Hachisuka and Jensen 2009).
//!
//! Every pass (= iteration) has two halves:
//! 1. A camera pass: one camera path per pixel, followed through delta (specular)
//!    events to the first non-delta surface, its *visible point*. Emission met on the
//!    way (and at the visible point) is added with weight 1, and direct lighting at the
//!    visible point is estimated by next-event estimation (one light sample, one shadow
//!    ray), as pbrt-v4's SPPM does. PPM replays the same camera sample every pass (the
//!    camera random stream of iteration 0), so its visible points are those of the
//!    first ray-tracing pass, recomputed rather than stored; SPPM draws a new jittered
//!    sample (film position, lens, lobe choices) every pass.
//! 2. A photon pass (the photon walk of `paths::photons`): `light_paths x pixels` photon
//!    paths. Photons that have scattered at least once are stored at non-delta
//!    surfaces; photons arriving straight from the light are not (that light is the NEE
//!    term above), so photons carry only indirect light.
//!
//! Each pixel keeps the statistics of the papers: N (accumulated photon count), R
//! (radius) and tau (accumulated flux). With M photons found within R of this pass's
//! visible point and Phi = beta_vp sum f(wo, wi_p) Phi_p their flux [2008, eq. (9)]:
//!   N' = N + alpha M                       [2008, eq. (7)]
//!   R' = R sqrt((N + alpha M) / (N + M))   [2008, eq. (8)]
//!   tau' = (tau + Phi) R'^2 / R^2          [2008, eq. (11)]
//! and the pixel's indirect radiance is tau / (N_emitted pi R^2) [2008, eq. (12)],
//! N_emitted being every photon path emitted so far. SPPM uses the same update with
//! the visible point of the current pass [2009, sec. 4]. The image written to the film
//! is direct (the mean over passes of the camera-pass radiance) plus that indirect
//! estimate.
//!
//! Photons are gathered per visible point from a hash grid built over the photons of
//! a wave (rather than splatting photons into a grid of visible points): every pixel
//! sums its photons in the grid's fixed order with no atomics, so the image does not
//! depend on the thread count, and photon memory is bounded by the wave size.
//!
//! In scenes with participating media the camera path crosses media with their
//! transmittance, photons take free flights, and the media are gathered along the camera
//! segments with the beam radiance estimate of `estimators::beam_query` ([`media`]).
//!
//! Iterations are not independent: the per-pixel statistics are the integrator's state
//! (`save_state` / `load_state`). After iteration i the film holds (i + 1) times the
//! current estimate, so that every consumer's sums / iterations is the estimate.

mod media;
mod pass;
mod settings;
mod state;

use crate::film::Film;
use crate::geometry::{spawn_ray, Interaction};
use crate::integrator::drive::light::{chunk_count, trace_chunks};
use crate::integrator::estimators::{HashGrid, PointBvh};
use crate::integrator::memory::{
    array, capped, paths_driver, pushed, refilled, Estimate as Memory, Facts,
};
use crate::integrator::paths::photons::{
    photon_budget, photon_paths, surface_step, Photon, PhotonChunk, PhotonPass, PhotonRules,
    SurfacePhoton,
};
use crate::integrator::transport::camera::{sample_bsdf, stop_or_follow_delta, Stop};
use crate::integrator::transport::medium_walk::{MediumWalk, Step};
use crate::integrator::transport::nee::{direct_unweighted, Origin};
use crate::integrator::transport::params::check_radius;
use crate::integrator::transport::params::{check_alpha, check_photon_params, ParamError};
use crate::integrator::transport::radius::radius_schedule;
use crate::integrator::transport::{Stream, PATHS_PER_TASK};
use crate::integrator::{Integrator, RenderStats};
use crate::material::{Material, Mode};
use crate::math::{Frame, Rgb, Rng, Vec2, Vec3};
use crate::scene::Scene;
use media::{CameraSegment, Record};
use pass::{estimate_film, Pass};
use serde::{Deserialize, Serialize};
pub use settings::SppmSettings;
pub use state::StateError;
use state::{PixelStat, State};
use std::ops::Range;
use std::sync::Mutex;

/// The visible point at `it` (shading `frame`, `wo` local), reached with throughput
/// `beta` after `depth` events in `medium`, and the direct light it sees by light
/// sampling alone: the camera path stops here, so no BSDF sample can find the light.
fn visible_point(
    scene: &Scene,
    (it, frame, wo, m): (&Interaction, &Frame, Vec3, &Material),
    (beta, depth, medium): (Rgb, u32, Option<u32>),
    rng: &mut Rng,
    stats: &mut RenderStats,
) -> (VisiblePoint, Rgb) {
    let at = Origin::Surface { it, frame, wo, m };
    let direct = beta * direct_unweighted(scene, &at, medium, rng, stats);
    let vp = VisiblePoint {
        p: it.p,
        ng: it.ng,
        frame: *frame,
        wo,
        beta,
        material: scene.shapes[it.shape as usize].material,
        uv: scene.uv(it),
        depth,
    };
    (vp, direct)
}

/// Which visible points a pass uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// PPM: the same camera sample per pixel every pass.
    Ppm,
    /// SPPM: a new camera sample per pixel every pass.
    Sppm,
}

/// Photon paths traced (and their photons held in memory) at once.
const WAVE: usize = 1 << 19;
/// Pixels per parallel task of the camera pass.
const PIXEL_CHUNK: usize = 256;

/// A camera path's first non-delta vertex.
#[derive(Clone, Copy)]
struct VisiblePoint {
    p: Vec3,
    ng: Vec3,
    frame: Frame,
    /// Towards the camera, local frame.
    wo: Vec3,
    /// Camera-path throughput up to here.
    beta: Rgb,
    material: u32,
    uv: Vec2,
    /// Scattering events before this vertex.
    depth: u32,
}

/// The photons of one wave and the grid over their positions; in media, the medium
/// photons and their BVH.
#[derive(Default)]
struct PhotonMap {
    grid: HashGrid,
    pos: Vec<Vec3>,
    data: Vec<SurfacePhoton>,
    media: Vec<Photon>,
    bvh: PointBvh<Photon>,
}

/// What a pixel's camera path found: radiance on the way, its visible point, and the
/// medium segments it crossed.
#[derive(Default)]
struct CameraResult {
    l: Rgb,
    vp: Option<VisiblePoint>,
    segments: Vec<CameraSegment>,
}

/// Per-pixel gather result of one pass.
#[derive(Clone, Copy, Default)]
struct Gathered {
    phi: [f64; 3],
    m: u64,
    /// Media: the beam radiance estimates' sum over the pass's waves, and how many
    /// photons they found.
    medium: [f64; 3],
    medium_merges: u64,
}

pub struct PhotonMapper {
    s: SppmSettings,
    variant: Variant,
    inner: Mutex<Inner>,
}

/// What `iterate` changes: the statistics, and photon buffers kept for their capacity.
#[derive(Default)]
struct Inner {
    state: Option<State>,
    map: PhotonMap,
}

impl PhotonMapper {
    pub fn new(s: SppmSettings, variant: Variant) -> Self {
        PhotonMapper {
            s,
            variant,
            inner: Mutex::new(Inner::default()),
        }
    }

    /// Photon paths per pass for a scene.
    fn paths_per_pass(&self, scene: &Scene) -> u64 {
        let px = scene.width() as f64 * scene.height() as f64;
        photon_paths(self.s.light_paths, px) as u64
    }

    /// Camera half of a pass for pixel `index`: the radiance found on the way to the
    /// visible point (emission seen through delta events, plus NEE there), and the
    /// visible point itself.
    fn camera_path(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        index: u64,
        stats: &mut RenderStats,
    ) -> CameraResult {
        let w = scene.width() as u64;
        let cam_iteration = match self.variant {
            Variant::Ppm => 0,
            Variant::Sppm => iteration,
        };
        let mut rng = Stream::SppmCamera.rng(seed, cam_iteration, index);
        let film_pos = Vec2::new((index % w) as f32, (index / w) as f32) + rng.next_2d();
        let mut ray = scene.camera.generate_ray(film_pos, rng.next_2d());
        stats.samples += 1;
        stats.rays += 1;
        let mut out = CameraResult::default();
        // Media: transmittance estimates drawn anew every pass (ppm replays the camera
        // sample, not the ratio tracking along it).
        let mut tr_rng = Stream::SppmMedium.rng(seed, iteration, index);
        let mut walk = MediumWalk {
            beta: Rgb::ONE,
            medium: scene.camera_medium,
        };
        let mut depth = 0u32;
        loop {
            let step = if scene.has_media {
                let mut rec = Record {
                    scene,
                    depth,
                    out: &mut out.segments,
                };
                walk.next(scene, &mut ray, &mut rec, &mut tr_rng, stats)
            } else {
                surface_step(scene.next_scattering(&mut ray, &mut stats.rays))
            };
            let beta = walk.beta;
            let (it, m) = match step {
                Step::Surface(it, m) => (it, m),
                Step::Escaped => {
                    // Every event so far was a delta lobe: no NEE could have found this.
                    if !scene.env_lights.is_empty() {
                        out.l += beta * scene.env_radiance(ray.d);
                    }
                    return out;
                }
                Step::Scatter { .. } | Step::End => return out,
            };
            if let Some((_, area)) = scene.area_light(&it) {
                out.l += beta * area.le(&it, -ray.d);
            }
            if depth + 1 >= self.s.max_depth {
                return out;
            }
            let frame = scene.shading_frame(&it);
            let wo = frame.to_local(-ray.d);
            // A visible point estimates the continuous lobes; a delta lobe mixed in
            // (plastic's coating) is followed instead with its sampling probability.
            let stop = if m.is_delta() {
                None
            } else {
                Some(stop_or_follow_delta(&it, &frame, wo, &m, &mut rng))
            };
            let followed = match stop {
                Some(Stop::Here(scale)) => {
                    let beta = if scale == 1.0 { beta } else { beta * scale };
                    let mut nee_rng = Stream::SppmDirect.rng(seed, iteration, index);
                    let at = (&it, &frame, wo, &*m);
                    let vp =
                        visible_point(scene, at, (beta, depth, walk.medium), &mut nee_rng, stats);
                    out.l += vp.1;
                    out.vp = Some(vp.0);
                    return out;
                }
                Some(Stop::Follow(s)) => Some(s),
                None => None,
            };
            let next = match followed {
                Some(s) => s,
                None => sample_bsdf(&it, &frame, wo, &m, &mut rng),
            };
            let Some((wi, s)) = next else {
                return out;
            };
            walk.beta *= Rgb::from(s.weight);
            depth += 1;
            if walk.beta == Rgb::ZERO {
                return out;
            }
            walk.medium = scene.medium_after(&it, wi, walk.medium);
            ray = spawn_ray(it.p, it.p_err, it.ng, wi);
            stats.rays += 1;
        }
    }

    /// Photon paths `paths` of a pass into `map` (photons in path order).
    fn trace_wave(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        paths: Range<u64>,
        map: &mut PhotonMap,
    ) -> RenderStats {
        let pass = PhotonPass {
            scene,
            rules: PhotonRules {
                max_depth: self.s.max_depth,
                rr_depth: self.s.rr_depth,
                surfaces: true,
                budget: photon_budget(self.s.max_photon_mib, chunk_count(&paths)),
            },
            stream: Stream::SppmPhotons,
            seed,
            iteration,
        };
        // New chunks every wave, dropped once their photons are in the map.
        let mut chunks: Vec<PhotonChunk> = Vec::new();
        trace_chunks(&pass, &mut chunks, paths);
        map.pos.clear();
        map.data.clear();
        map.media.clear();
        let mut stats = RenderStats::default();
        for c in &chunks {
            map.pos.extend_from_slice(&c.surface_pos);
            map.data.extend_from_slice(&c.surface);
            map.media.extend_from_slice(&c.media);
            stats += c.stats;
        }
        if chunks.iter().any(|c| c.over_budget) {
            tracing::warn!(
                "medium photons beyond max_photon_mib = {} per wave were not stored; raise it or lower light_paths",
                self.s.max_photon_mib
            );
        }
        stats
    }

    /// Photons within the pixel's radius of its visible point: (flux Phi, count M).
    #[inline]
    fn gather(
        &self,
        scene: &Scene,
        map: &PhotonMap,
        vp: &VisiblePoint,
        r: f32,
        acc: &mut Gathered,
    ) {
        let m = scene.material_on(vp.material, vp.uv, vp.ng, &vp.frame);
        let r2 = r * r;
        let mut phi = Rgb::ZERO;
        map.grid.query_in(vp.p, &map.data, |ph, d2| {
            if d2 > r2 || ph.depth + vp.depth + 2 > self.s.max_depth {
                return;
            }
            acc.m += 1;
            let wi = vp.frame.to_local(ph.wi);
            if (ph.wi.dot(vp.ng) > 0.0) != (wi.z > 0.0) || wi.z == 0.0 {
                return;
            }
            // eval is f |cos theta_i|; the density estimate wants f alone.
            let f = m.eval(vp.wo, wi, Mode::Radiance) / wi.z.abs();
            phi += f * ph.beta;
        });
        let phi = vp.beta * phi;
        acc.phi = std::array::from_fn(|c| acc.phi[c] + phi[c] as f64);
    }
}

impl Integrator for PhotonMapper {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        let (w, h) = (scene.width(), scene.height());
        let npix = w as usize * h as usize;
        let mut guard = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let Inner { state, map } = &mut *guard;
        let state = self.state_for(state, scene, seed, iteration, npix);
        let mut stats = RenderStats::default();
        // 1. Camera pass: visible points, and the radiance found on the way.
        let camera = self.camera_pass(scene, seed, iteration, npix, &mut stats);
        // 2. Photon passes in waves, each gathered into every visible point.
        let paths = if scene.lights.is_empty() {
            0
        } else {
            self.paths_per_pass(scene)
        };
        let pass = Pass {
            scene,
            seed,
            iteration,
            paths,
        };
        let gathered = self.photon_waves(&pass, &camera, state, map, &mut stats);
        // 3. Per-pixel statistics [2008, eqs. (7), (8), (11)], then the film.
        let dropped = self.update_pixels(state, &camera, &gathered, paths);
        state.passes += 1;
        state.emitted += paths;
        state.next = iteration + 1;
        stats.merges = gathered.iter().map(|g| g.m + g.medium_merges).sum();
        stats.merge_radius =
            (state.pixels.iter().map(|p| p.r).sum::<f64>() / npix.max(1) as f64) as f32;
        *film = estimate_film(state, w, h, iteration, film.dropped() + dropped);
        stats
    }

    fn chained(&self) -> bool {
        true
    }

    fn save_state(&self) -> Option<Vec<u8>> {
        let guard = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        guard.state.as_ref().map(|s| s.encode(self.variant))
    }

    fn load_state(&self, bytes: &[u8]) -> Result<(), String> {
        let st = State::decode(bytes, self.variant).map_err(|e| e.to_string())?;
        self.inner.lock().unwrap_or_else(|e| e.into_inner()).state = Some(st);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
