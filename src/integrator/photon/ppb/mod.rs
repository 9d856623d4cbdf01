//! Progressive photon beams (`ppb`; Jarosz, Nowrouzezahrai, Thomas, Sloan and Zwicker
//! 2011, "Progressive photon beams"): light in media estimated from photon beams
//! against camera beams, surfaces path traced and direct light at surfaces by
//! next-event estimation, as `vpm` does with photon points
//! ([`crate::integrator::transport::density_camera`]).
//!
//! ## An iteration
//! 1. Light pass of the one light tracer, run alone
//!    ([`crate::integrator::paths::light_pass::LightPass`]), keeping the subpaths'
//!    segments through media; each becomes a beam
//!    ([`crate::integrator::estimators::beams`]: `short` to the flight's end, or `long`
//!    to the surface with transmittance).
//! 2. A BVH over the beams (`estimators::Lbvh`: Morton order of the boxes' centres with
//!    unique keys, so its tree and the order of every query's results do not depend on
//!    the thread count).
//! 3. Camera pass: every segment of a camera path in a medium is one query against the
//!    beams ([`crate::integrator::estimators::beam_estimate`]); the path passes it with
//!    its transmittance.
//!
//! ## The estimate
//! The radiance scattered towards the camera along a segment o + t d is
//! int T_c(t) sigma_s(x_t) int f(w', -d) L(x_t, w') dw' dt. A beam of power Phi along
//! direction d_b puts Phi w_b(s) delta_2D(x perp beam) into int L dw' at a point x at
//! distance s along it; integrated over t, the 2D delta perpendicular to the beam gives
//! 1 / sin(theta) at the lines' closest points. Blurring the remaining 1D delta in the
//! distance u between the lines with a kernel k gives the beam x beam 1D estimate
//! ```text
//! L ~ sum_b k(u_b) Phi_b w_b(t_b) T_c(t_c) sigma_s(x(t_c)) f(d_b, -d) / sin(theta_b)
//! ```
//! with sigma_s once, at the camera point (the beam carries light, not scattered
//! light). Kernel: the constant 1 / (2r) on |u| < r rather than Epanechnikov's
//! 3 / (4r) (1 - u^2 / r^2): at the same radius it has the lower peak, hence the lower
//! variance, and its normalisation is the one SmallUPBP's MIS weights use for this
//! estimator, which the combined `upbp` will share.
//!
//! Near-parallel pairs (sin theta < 0.1, `estimate::SIN_PARALLEL`) use instead the 2D
//! kernel 1 / (pi r^2) across the camera line, integrated along the beam over the part
//! within r of the camera segment (one uniform point of that interval, times its
//! length). That is finite for exactly parallel lines, where 1 / sin(theta) is not, and
//! it tends to the same limit as r -> 0; the split is by a fixed angle, so neither
//! class's bias depends on the other and both vanish with r. Nothing is dropped.
//!
//! ## Progressive radius
//! A 1D kernel: r_{i+1} = r_i (i + alpha) / (i + 1) (Knaus and Zwicker 2011 with k = 1,
//! `transport::radius`), alpha = 4 / 5 by default, the balance of variance ~ r^-1
//! and squared bias ~ r^4 (see `vpm`'s notes). The 2D fallback shares the radius.
//!
//! `max_depth` counts segments over both halves: a beam that is segment k of its light
//! path lights a camera segment reached after j surface events when k + j + 1 <=
//! max_depth (the camera point lies on the beam).

pub use crate::integrator::estimators::beams::BeamForm;

use crate::film::Film;
use crate::integrator::drive::pixels::{render_density_camera, tile_memory};
use crate::integrator::estimators::beam_estimate::Gather;
use crate::integrator::estimators::beams::{self, Beam, PIECE};
use crate::integrator::estimators::Lbvh;
use crate::integrator::memory::{array, paths_driver, refilled, Estimate, Facts};
use crate::integrator::paths::light_pass::LightPass;
use crate::integrator::paths::store::{store_memory, StorePlan};
use crate::integrator::paths::Tracing;
use crate::integrator::pilot;
use crate::integrator::transport::density_camera::Depths;
use crate::integrator::transport::light_paths::{check_light_pass, LightPaths};
use crate::integrator::transport::params::ParamError;
use crate::integrator::transport::params::{check_alpha, check_radius};
use crate::integrator::transport::radius::radius_schedule;
use crate::integrator::{Integrator, RenderStats};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::sync::Mutex;

/// `ppb`: progressive photon beams.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path in segments (Mitsuba's meaning), over the light path, the beam and the camera path together |
/// | `rr_depth` | 5 | camera-path scattering events before Russian roulette |
/// | `light_paths` | 0.01 | light subpaths per iteration: a number is a multiple of the pixel count, `{"count": N}` an absolute count (few beams and many iterations win: at 30 s on fog-cornell and spot-shaft, 0.01 beat 0.05 and 0.25 and was within 15% of 0.0025 in RMSE, lowest in relative MSE) |
/// | `beams` | `short` | `short`: beams end where the light's free flight did (weight T / P(pass), 1 in grey media); `long`: to the next surface, weighted by transmittance (heterogeneous media always use long beams) |
/// | `radius` | none | beam radius of the first iteration in scene units; overrides `radius_factor` |
/// | `radius_factor` | 0.005 | beam radius of the first iteration as a fraction of the scene's bounding-sphere radius |
/// | `alpha` | 0.8 | radius reduction r_{i+1} = r_i (i + alpha) / (i + 1) (1D kernel); 1 keeps the radius fixed |
/// | `max_beam_mib` | 512 | budget for the light segments stored per iteration (beams beyond it are not stored; a warning is logged) |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct PpbSettings {
    pub max_depth: u32,
    pub rr_depth: u32,
    pub light_paths: LightPaths,
    pub beams: BeamForm,
    pub radius: Option<f32>,
    pub radius_factor: f32,
    pub alpha: f32,
    pub max_beam_mib: f32,
}

impl Default for PpbSettings {
    fn default() -> Self {
        PpbSettings {
            max_depth: 64,
            rr_depth: 5,
            light_paths: LightPaths::Multiple(0.01),
            beams: BeamForm::Short,
            radius: None,
            radius_factor: 0.005,
            alpha: 0.8,
            max_beam_mib: 512.0,
        }
    }
}

impl PpbSettings {
    /// A job's memory (module `memory`): in scenes with media and lights, the light
    /// pass's store (segments kept) and the beams cut from it with their BVH; the
    /// camera pass's tile buffers.
    pub fn memory(&self, facts: &Facts) -> Estimate {
        let mut e = Estimate::default();
        let scene = facts.scene;
        if scene.has_media && !scene.lights.is_empty() {
            let paths = self.light_paths.count(facts.pixels() as usize);
            let multiple = match self.light_paths {
                LightPaths::Multiple(m) => Some(m),
                LightPaths::Count { .. } => None,
            };
            let driver = paths_driver(multiple, paths, facts);
            let walk = pilot::walk(facts, self.max_depth, true);
            let plan = StorePlan {
                tracing: Tracing::STORE,
                paths,
                walk,
                keep_segments: true,
                max_vertex_mib: self.max_beam_mib,
                driver: &driver,
                budget_field: "max_beam_mib",
            };
            let stored = store_memory(&mut e, &plan, true);
            let pieces = match walk.segments > 0.0 {
                true => stored.segments * pilot::pieces(&walk, self.beams) / walk.segments,
                false => 0.0,
            };
            let bytes = array::<Beam>(refilled(pieces, 0.0)) + Lbvh::<Beam>::bytes_for(pieces);
            e.add("photon beams", &driver, bytes);
        }
        tile_memory(&mut e, facts);
        e
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        check_light_pass(self.max_depth, self.light_paths, self.max_beam_mib)
            .map_err(|e| e.renamed("max_vertex_mib", "max_beam_mib"))?;
        check_radius(self.radius, self.radius_factor)?;
        check_alpha(self.alpha)
    }

    /// The beam radius of `iteration` (from 0) on `scene`.
    pub fn radius_at(&self, scene: &Scene, iteration: u64) -> f32 {
        let r1 = self
            .radius
            .unwrap_or(self.radius_factor * scene.sphere.radius);
        radius_schedule(r1, self.alpha, 1, iteration)
    }
}

#[derive(Default)]
struct Workspace {
    beams: Vec<Beam>,
    bvh: Lbvh<Beam>,
}

pub struct Ppb {
    s: PpbSettings,
    light: LightPass,
    ws: Mutex<Workspace>,
}

impl Ppb {
    pub fn new(s: PpbSettings) -> Self {
        let light = LightPass::new(s.max_depth, s.light_paths, s.max_beam_mib).keeping_segments();
        Ppb {
            s,
            light,
            ws: Mutex::new(Workspace::default()),
        }
    }
}

impl Integrator for Ppb {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let ws = &mut *guard;
        let form = self.s.beams;
        // Without media there is nothing for beams to light: no light pass.
        let mut stats = RenderStats::default();
        ws.beams.clear();
        let mut count = 0;
        if scene.has_media && !scene.lights.is_empty() {
            let (n, st) = self.light.run(scene, seed, iteration, |store| {
                let segs = store.segments().copied();
                let piece = scene.sphere.radius * PIECE;
                let out = &mut ws.beams;
                beams::collect(
                    scene,
                    segs,
                    store.paths(),
                    form,
                    piece,
                    seed,
                    iteration,
                    out,
                )
            });
            (stats, count) = (st, n);
        }
        ws.bvh.build(&mut ws.beams);
        let radius = self.s.radius_at(scene, iteration);
        // Beams, not their pieces.
        stats.light_vertices = count as u64;
        stats.merge_radius = radius;
        stats.vertex_bytes +=
            (ws.beams.capacity() * std::mem::size_of::<Beam>() + ws.bvh.bytes()) as u64;
        let g = Gather {
            scene,
            beams: &ws.beams,
            bvh: &ws.bvh,
            radius,
            max_depth: self.s.max_depth,
        };
        let depths = Depths {
            max_depth: self.s.max_depth,
            rr_depth: self.s.rr_depth,
        };
        stats += render_density_camera(scene, (seed, iteration), film, &g, depths);
        stats
    }
}
