//! Volumetric photon mapping (Jensen and Christensen 1998, "Efficient simulation of
//! light transport in scenes with participating media using photon maps"), made
//! progressive in the probabilistic form of Knaus and Zwicker 2011 ("Progressive photon
//! mapping: a probabilistic approach"), with two radiance estimates: the point query of
//! the original paper and the beam radiance estimate (Jarosz, Zwicker and Jensen 2008,
//! "The beam radiance estimate for volumetric photon mapping").
//!
//! ## An iteration
//! 1. Photon pass (the photon walk of `paths::photons`): `light_paths x pixels`
//!    photon paths leave the lights (emission sampling, in the medium each light emits
//!    into), take free flights through media and scatter at surfaces and in media. Every real scattering event in a medium
//!    stores a photon: position x_p, propagation direction d_p, power beta_p, medium,
//!    and the number of events before it. beta_p is the throughput *after* the free
//!    flight's weight, which already holds sigma_s T / pdf, so the stored powers are a
//!    sample of the scattered flux: E[sum_p beta_p g(x_p, d_p)] = N int sigma_s(x)
//!    L(x, w) g(x, w) dw dx for N emitted paths. Photons are rouletted at every event
//!    with survival (new power) / (old power), which keeps their powers nearly equal,
//!    the best case for a density estimate.
//! 2. Camera pass: one path per pixel. Media are left entirely to the photons (the camera
//!    path never scatters in a medium); surfaces are path traced (see below).
//!
//! ## The two estimates (N photon paths, radius r, phase function f_p, wo = -ray.d)
//! `point`: a free flight is sampled on the camera segment. If it scatters at x with
//! weight W = sigma_s(x) T / pdf, the path ends there with
//! ```text
//! W / sigma_s(x) * 1 / (N (4/3) pi r^3) * sum_{|x_p - x| < r} f_p(d_p, wo) beta_p
//! ```
//! (the 3D kernel density estimate of the in-scattered radiance sigma_s int f_p L dw,
//! divided by sigma_s because W holds it already). If it passes, the path continues to
//! the surface with the flight's pass weight.
//!
//! `beam` (default): the whole camera segment [0, s) in the medium is one query. Every
//! photon whose sphere of radius r the segment passes through, i.e. whose projection
//! t_p = (x_p - o).d lies in [0, s) and whose distance from the ray is below r,
//! contributes with the 2D kernel 1 / (pi r^2):
//! ```text
//! 1 / (N pi r^2) * sum_p T(o, o + t_p d) f_p(d_p, wo) beta_p
//! ```
//! estimating int_0^s T(t) sigma_s int f_p L dw dt with the kernel blurring only across
//! the ray (no sigma_s: beta_p holds it). The path then continues to the surface with
//! the segment's transmittance (closed form in homogeneous media, ratio tracking
//! otherwise, as for the T to each photon). One query replaces ray marching, and no
//! noise comes from sampling a distance.
//!
//! Only photons of the camera segment's own medium count (a kernel reaching across an
//! index-matched boundary would mix media of different sigma_s).
//!
//! ## Surfaces
//! Path traced (the camera path shared with `ppb`, `transport::density_camera`): direct
//! light by next-event estimation (one light, its transmittance through media with
//! `Scene::transmittance`), indirect light by continuing the camera path with a BSDF
//! sample, on which the next medium segment queries the photons again.
//! Emitters count only when seen through specular events (NEE found the rest). So no
//! surface photon map is needed: surface transport is unbiased and all bias is the
//! volume kernel's, which is what this integrator is about; photons still bounce off
//! surfaces, so light that reached the medium via walls is in the photons. A scene
//! without media renders as a path tracer with NEE (no photons are traced).
//!
//! ## Progressive radius
//! Iterations are independent estimates averaged by the film, the radius of iteration
//! i (from 1) following Knaus and Zwicker: r_{i+1}^k = r_i^k (i + alpha) / (i + 1) with
//! k the kernel's dimension [2011, eq. (15) for k = 2, eq. (20) for k = 3]. The
//! variance of an estimate grows as r^-k (photons in the kernel ~ r^k, kernel ~ r^-k),
//! so this is the schedule under which the variance of iteration i grows as
//! i^(1 - alpha) whatever k: the point query shrinks with k = 3, the beam estimate,
//! whose kernel is a disk across the ray, with k = 2. With bias ~ r^2 the mean image's
//! MSE falls as n^-alpha (variance) against n^(-4 (1 - alpha) / k) (squared bias); they
//! balance at alpha = 4 / (k + 4): the defaults 2/3 (beam) and 4/7 (point), RMSE
//! ~ n^-1/3 and n^-2/7. The radius is a function of the iteration index alone.
//!
//! ## Acceleration
//! Point queries use the shared hash grid (cells of 2r, 8 cells per query), beam
//! queries the point BVH of `estimators::lbvh`, rebuilt every iteration. Walking
//! hash-grid cells along the ray would need a 3D DDA dilated by r through a hashed
//! table whose slots alias far-away cells.
//!
//! ## Determinism
//! Photon paths run in fixed chunks, each with its own RNG stream per path; chunks are
//! concatenated in order, the BVH order comes from a sort on unique keys, and the camera
//! pass is the shared tile loop. An iteration is a pure function of (scene, settings,
//! seed, iteration).

use crate::film::Film;
use crate::integrator::drive::light::{chunk_count, trace_chunks};
use crate::integrator::drive::pixels::{render_density_camera, tile_memory};
use crate::integrator::estimators::beam_query::BeamQuery;
use crate::integrator::estimators::{HashGrid, PointBvh};
use crate::integrator::memory::{
    array, budgeted, capped, paths_driver, refilled, Estimate as Memory, Facts,
};
use crate::integrator::paths::photons::{
    photon_budget, photon_paths, Photon, PhotonChunk, PhotonPass, PhotonRules,
};
use crate::integrator::transport::density_camera::{Depths, MediumGather};
use crate::integrator::transport::medium_walk::Segment;
use crate::integrator::transport::params::ParamError;
use crate::integrator::transport::params::{check_alpha, check_photon_params};
use crate::integrator::transport::radius::radius_schedule;
use crate::integrator::transport::{Stream, PATHS_PER_TASK};
use crate::integrator::{Integrator, RenderStats};
use crate::math::{Rgb, Rng, Vec3, PI};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::sync::Mutex;

/// How radiance from media is estimated from the photons.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Estimate {
    /// The beam radiance estimate (Jarosz et al. 2008): camera beams against photon
    /// points, one query per camera segment, 2D kernel. Not photon beams (photons
    /// stored as segments), which are another estimator. Written `beam` in settings.
    #[default]
    #[serde(rename = "beam", alias = "beam_radiance")]
    BeamRadiance,
    /// A 3D kernel at a distance-sampled point of each camera segment.
    Point,
}

impl Estimate {
    /// Dimension of the kernel (the exponent of r in its normalisation).
    pub fn kernel_dims(self) -> u32 {
        match self {
            Estimate::BeamRadiance => 2,
            Estimate::Point => 3,
        }
    }

    /// Knaus and Zwicker's alpha that balances variance and squared bias asymptotically
    /// for this kernel: 4 / (k + 4) (module notes).
    pub fn default_alpha(self) -> f32 {
        4.0 / (self.kernel_dims() as f32 + 4.0)
    }
}

/// Volumetric photon mapping parameters.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path in Mitsuba's sense (1 = emitters seen directly; medium events count), over the photon and camera halves together: a photon stored after k events counts on a camera segment reached after j surface events when k + j + 2 <= max_depth |
/// | `rr_depth` | 5 | camera-path scattering events before Russian roulette (survival min(largest throughput channel, 0.95)); photons are rouletted at every event with survival new / old power |
/// | `light_paths` | 1.0 | photon paths per iteration, as a multiple of the pixel count; in (0, 1024] |
/// | `estimate` | `beam` | `beam`: the beam radiance estimate along each camera segment (2D kernel 1 / (pi r^2)); `point`: a 3D kernel 1 / ((4/3) pi r^3) at one distance-sampled point per segment |
/// | `radius` | none | radius of the first iteration in scene units; overrides `radius_factor` |
/// | `radius_factor` | 0.03 | radius of the first iteration as a fraction of the scene's bounding-sphere radius |
/// | `alpha` | none | Knaus and Zwicker's alpha in (0, 1]: r_{i+1}^k = r_i^k (i + alpha) / (i + 1), k = 2 (beam) or 3 (point); none picks 2/3 for `beam`, 4/7 for `point`; 1 keeps the radius fixed |
/// | `max_photon_mib` | 1024 | budget for the photons stored per iteration; photons beyond it are not stored (a warning is logged) |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct VpmSettings {
    pub max_depth: u32,
    pub rr_depth: u32,
    pub light_paths: f32,
    pub estimate: Estimate,
    pub radius: Option<f32>,
    pub radius_factor: f32,
    pub alpha: Option<f32>,
    pub max_photon_mib: u32,
}

impl Default for VpmSettings {
    fn default() -> Self {
        VpmSettings {
            max_depth: 64,
            rr_depth: 5,
            light_paths: 1.0,
            estimate: Estimate::BeamRadiance,
            radius: None,
            radius_factor: 0.03,
            alpha: None,
            max_photon_mib: 1024,
        }
    }
}

impl VpmSettings {
    pub fn validate(&self) -> Result<(), ParamError> {
        check_photon_params(
            self.max_depth,
            self.light_paths,
            self.radius,
            self.radius_factor,
        )?;
        if let Some(a) = self.alpha {
            check_alpha(a)?;
        }
        if self.max_photon_mib == 0 {
            return Err(ParamError::new(
                "max_photon_mib",
                "max_photon_mib must be at least 1",
            ));
        }
        Ok(())
    }

    /// A job's memory (module `memory`): in scenes with media and lights, the photons
    /// of an iteration (per chunk, then in one array) and their index (the BVH of the
    /// beam estimate, or the positions and hash grid of the point estimate); the camera
    /// pass's tile buffers.
    pub fn memory(&self, facts: &Facts) -> Memory {
        let mut e = Memory::default();
        let scene = facts.scene;
        if scene.has_media && !scene.lights.is_empty() {
            let paths = photon_paths(self.light_paths, facts.pixels());
            let driver = paths_driver(Some(self.light_paths), paths, facts);
            let walk = crate::integrator::pilot::walk(facts, self.max_depth, true);
            let chunks = paths.div_ceil(PATHS_PER_TASK);
            let budget = photon_budget(self.max_photon_mib as f32, chunks) as f64;
            let wanted = paths as f64 / chunks as f64 * walk.medium;
            let per_chunk = wanted.min(budget);
            let n = per_chunk * chunks as f64;
            let driver = capped(
                &driver,
                wanted > budget,
                "max_photon_mib",
                self.max_photon_mib,
            );
            let stored = chunks as f64 * array::<Photon>(budgeted(per_chunk, 0.0, budget))
                + array::<Photon>(refilled(n, 0.0));
            e.add("photons", &driver, stored);
            let index = match self.estimate {
                Estimate::BeamRadiance => PointBvh::<Photon>::bytes_for(n),
                Estimate::Point => array::<Vec3>(refilled(n, 0.0)) + HashGrid::bytes_for(n),
            };
            e.add("photon index", &driver, index);
        }
        tile_memory(&mut e, facts);
        e
    }

    pub fn alpha(&self) -> f32 {
        self.alpha.unwrap_or(self.estimate.default_alpha())
    }

    /// The gather radius of `iteration` (from 0) on `scene`.
    pub fn radius_at(&self, scene: &Scene, iteration: u64) -> f32 {
        let r1 = self
            .radius
            .unwrap_or(self.radius_factor * scene.sphere.radius);
        radius_schedule(r1, self.alpha(), self.estimate.kernel_dims(), iteration)
    }
}

/// What `iterate` reuses between iterations.
#[derive(Default)]
struct Workspace {
    chunks: Vec<PhotonChunk>,
    photons: Vec<Photon>,
    positions: Vec<Vec3>,
    grid: HashGrid,
    bvh: PointBvh<Photon>,
}

/// What the camera pass reads: this iteration's photons, indexed for the estimate.
struct Gather<'a> {
    s: &'a VpmSettings,
    grid: &'a HashGrid,
    /// The photons, their BVH, the radius and 1 / photon paths emitted.
    q: BeamQuery<'a>,
}

pub struct Vpm {
    s: VpmSettings,
    ws: Mutex<Workspace>,
}

impl Vpm {
    pub fn new(s: VpmSettings) -> Self {
        Vpm {
            s,
            ws: Mutex::new(Workspace::default()),
        }
    }

    /// Photon paths per iteration for a scene with lights and media, else none.
    fn paths_per_iteration(&self, scene: &Scene) -> usize {
        if scene.lights.is_empty() || !scene.has_media {
            return 0;
        }
        photon_paths(
            self.s.light_paths,
            scene.width() as f64 * scene.height() as f64,
        )
    }
}

impl Vpm {
    /// The photon pass: fixed chunks in parallel, concatenated in chunk order.
    fn trace_photons(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        paths: usize,
        ws: &mut Workspace,
    ) -> RenderStats {
        let paths = 0..paths as u64;
        let pass = PhotonPass {
            scene,
            rules: PhotonRules {
                max_depth: self.s.max_depth,
                // Photons are rouletted at every event (`rr_depth` is the camera's).
                rr_depth: 0,
                surfaces: false,
                budget: photon_budget(self.s.max_photon_mib as f32, chunk_count(&paths)),
            },
            stream: Stream::VpmPhotons,
            seed,
            iteration,
        };
        trace_chunks(&pass, &mut ws.chunks, paths);
        ws.photons.clear();
        let mut stats = RenderStats::default();
        for chunk in &ws.chunks {
            ws.photons.extend_from_slice(&chunk.media);
            stats += chunk.stats;
        }
        if ws.chunks.iter().any(|c| c.over_budget) {
            tracing::warn!(
                "photons beyond max_photon_mib = {} were not stored this iteration; raise it or lower light_paths",
                self.s.max_photon_mib
            );
        }
        stats
    }
}

impl MediumGather for Gather<'_> {
    fn at_flights(&self) -> bool {
        self.s.estimate == Estimate::Point
    }

    fn segment(
        &self,
        seg: &Segment,
        cam_depth: u32,
        rng: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        self.q.segment(seg, cam_depth, rng, stats)
    }

    /// Point query: (1 / (N (4/3) pi r^3)) sum_{|x_p - x| < r} f_p(d_p, wo) beta_p, the
    /// in-scattered radiance sigma_s int f_p L dw at x [Jensen and Christensen 1998, the
    /// volume radiance estimate, with sigma_s inside beta_p], times W / sigma_s(x) =
    /// T / pdf (W holds sigma_s already; a channel that does not scatter adds nothing,
    /// and its W is 0 / 0).
    fn point(
        &self,
        seg: &Segment,
        t: f32,
        weight: Rgb,
        cam_depth: u32,
        _: &mut Rng,
        stats: &mut RenderStats,
    ) -> Rgb {
        let (mi, x, wo) = (seg.medium, seg.ray.at(t), -seg.ray.d);
        let q = &self.q;
        let med = &q.scene.media[mi as usize];
        let ss = med.sigma_s_at(x);
        let w = Rgb::select(ss.cmpgt(Rgb::ZERO), weight / ss, Rgb::ZERO);
        let phase = med.phase();
        let mut sum = Rgb::ZERO;
        self.grid.query_in(x, q.photons, |ph, _| {
            if ph.medium != mi || ph.depth + cam_depth + 2 > self.s.max_depth {
                return;
            }
            stats.merges += 1;
            sum += ph.beta * phase.eval(ph.d, wo);
        });
        let r = q.radius;
        w * sum * (q.inv_paths / (4.0 / 3.0 * PI * r * r * r))
    }
}

impl Integrator for Vpm {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        let radius = self.s.radius_at(scene, iteration);
        let paths = self.paths_per_iteration(scene);
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let ws = &mut *guard;
        let mut stats = self.trace_photons(scene, seed, iteration, paths, ws);
        let index_bytes = match self.s.estimate {
            Estimate::BeamRadiance => {
                ws.bvh.build(&mut ws.photons);
                ws.bvh.bytes()
            }
            Estimate::Point => {
                ws.positions.clear();
                ws.positions.extend(ws.photons.iter().map(|p| p.p));
                ws.grid.build(&ws.positions, radius);
                ws.grid.bytes() + ws.positions.capacity() * std::mem::size_of::<Vec3>()
            }
        };
        let g = Gather {
            s: &self.s,
            grid: &ws.grid,
            q: BeamQuery {
                scene,
                photons: &ws.photons,
                bvh: &ws.bvh,
                radius,
                inv_paths: 1.0 / paths.max(1) as f32,
                max_depth: self.s.max_depth,
            },
        };
        let depths = Depths {
            max_depth: self.s.max_depth,
            rr_depth: self.s.rr_depth,
        };
        stats += render_density_camera(scene, (seed, iteration), film, &g, depths);
        stats.merge_radius = radius;
        let chunk_bytes: usize = ws.chunks.iter().map(|c| c.media.capacity()).sum::<usize>()
            * std::mem::size_of::<Photon>();
        stats.vertex_bytes = (ws.photons.capacity() * std::mem::size_of::<Photon>()
            + chunk_bytes
            + index_bytes) as u64;
        stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_validate() {
        assert!(VpmSettings::default().validate().is_ok());
        assert_eq!(VpmSettings::default().alpha(), 2.0 / 3.0);
        let point = VpmSettings {
            estimate: Estimate::Point,
            ..Default::default()
        };
        assert_eq!(point.alpha(), 4.0 / 7.0);
        for bad in [
            VpmSettings {
                alpha: Some(0.0),
                ..Default::default()
            },
            VpmSettings {
                light_paths: 0.0,
                ..Default::default()
            },
            VpmSettings {
                radius: Some(f32::INFINITY),
                ..Default::default()
            },
            VpmSettings {
                max_depth: 0,
                ..Default::default()
            },
            VpmSettings {
                max_photon_mib: 0,
                ..Default::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
