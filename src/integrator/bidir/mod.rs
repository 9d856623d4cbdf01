//! The bidirectional family on one core (Georgiev et al. 2012, "Light Transport
//! Simulation with Vertex Connection and Merging"): light tracing (`lt`),
//! bidirectional path tracing (`bpt`), bidirectional photon mapping (`bpm`), vertex
//! connection and merging (`vcm`) and unifying points, beams and paths (`upbp`,
//! Křivánek et al. 2014) differ only in which techniques they use
//! ([`Technique`], in `settings.rs`); the MIS weights of [`mis`] weigh whatever set is
//! on. All five live here: the light subpaths come from
//! [`crate::integrator::paths::light_path`], the camera walk is [`camera_path`] (its
//! light samples and connections in [`connect`]), merging
//! at points [`merge`] (the camera side in [`camera_merge`]), the radius layers
//! [`radius_layers`], and `upbp`'s photon beams and camera beams [`beams`].
//!
//! One iteration: trace N light subpaths (N = `light_paths` x pixels), storing their
//! non-specular vertices and splatting connections to the camera; build the hash grid
//! over the stored vertices; then trace one camera subpath per pixel, connecting to
//! light sampling, to the vertices of the light subpath with the pixel's index, and
//! merging with every stored vertex within the radius.
//!
//! In scenes with participating media both subpaths also scatter in media (the
//! vertices and walks of [`crate::integrator::paths`]) and every connection carries the
//! transmittance of its segment; the MIS quantities account for distance sampling (see
//! [`mis`]). `bpm` and `vcm` also merge at medium vertices of the camera subpath: light
//! vertices in the same medium within the medium radius, with the 3D kernel
//! 1 / (4/3 pi r^3) (point x point 3D of Křivánek et al. 2014), a second merge
//! estimator with its own eta in the MIS.

mod adaptive;
mod beams;
mod camera_merge;
mod camera_path;
mod connect;
mod merge;
pub mod mis;
mod radius_layers;
mod selection;

use super::{Integrator, RenderStats};
use crate::film::Film;
use crate::integrator::drive::pixels::{film_sample, render_paths};
use crate::integrator::estimators::beams::BeamForm;
use crate::integrator::paths::layers::Layers;
use crate::integrator::paths::light_path::trace_light_paths;
use crate::integrator::paths::partial::{Merge, Merges, Mis};
use crate::integrator::paths::parts::{RadiusLayer, Scale, Selection, ALL};
use crate::integrator::paths::store::Store;
use crate::integrator::paths::vertex::{Media, NoMedia, WithMedia};
use crate::integrator::transport::light_paths::light_path_count;
use crate::integrator::transport::radius::radius_schedule;
use crate::math::Rgb;
use crate::scene::Scene;
use beams::BeamStore;
use camera_path::CameraPass;
use merge::MergeSet;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

#[cfg(test)]
mod correlation_tests;
mod settings;
pub use settings::{
    radius_layer_name, BidirSettings, Estimators, MergeDepth, PixelSelection, Technique,
    UpbpTechnique, MAX_STRATEGY_LENGTH,
};

/// An iteration's constants: the subpaths' ([`crate::integrator::paths::Pass`], which
/// this derefs to) and the family's own settings and technique.
pub(crate) struct Pass<'a> {
    pub core: crate::integrator::paths::Pass<'a>,
    pub s: &'a BidirSettings,
    pub technique: Technique,
}

impl<'a> std::ops::Deref for Pass<'a> {
    type Target = crate::integrator::paths::Pass<'a>;

    #[inline(always)]
    fn deref(&self) -> &Self::Target {
        &self.core
    }
}

/// Buffers kept between iterations so that the light-vertex store and the grid do not
/// reallocate once they have grown to the scene's needs.
#[derive(Default)]
struct Workspace {
    /// The light paths of the iteration, their vertices stored per chunk.
    store: Store,
    /// Merging at surfaces and in media, each over its own vertices.
    surface: MergeSet,
    medium: MergeSet,
    /// Photon points and beams for the camera beams of `upbp`.
    beams: BeamStore,
}

pub struct Bidir {
    s: BidirSettings,
    technique: Technique,
    layers: Layers,
    keep_segments: bool,
    ws: Mutex<Workspace>,
    /// Per pixel, its candidate ([`selection`]); empty: the job's weights everywhere.
    choice: Mutex<Vec<u8>>,
    /// With `selection: adaptive`, the pilots' measurements and choices.
    adaptive: Option<Mutex<adaptive::State>>,
}

impl Bidir {
    pub fn new(technique: Technique, s: BidirSettings) -> Self {
        let adaptive = (s.selection_for(technique) == PixelSelection::Adaptive)
            .then(|| Mutex::new(adaptive::State::default()));
        Bidir {
            layers: Layers::new(&s, technique),
            s,
            technique,
            keep_segments: technique.uses(Merge::BeamBeam1d),
            ws: Mutex::new(Workspace::default()),
            choice: Mutex::new(Vec::new()),
            adaptive,
        }
    }

    /// The same with each pixel's candidate fixed (row-major, indices into
    /// [`selection::candidates`]).
    #[cfg(test)]
    pub(crate) fn with_choice(self, choice: Vec<u8>) -> Self {
        *self.choice.lock().unwrap() = choice;
        self
    }

    fn pass<'a>(&'a self, scene: &'a Scene, iteration: u64, choice: &'a [u8]) -> Pass<'a> {
        let pixels = scene.width() as usize * scene.height() as usize;
        let light_paths = light_path_count(pixels, self.s.light_paths);
        let s = &self.s;
        let beam_paths = beam_path_count(light_paths, s.beam_paths);
        let sized = |initial: [Option<f32>; Merge::COUNT]| {
            let radii = self.radii(scene, iteration, initial);
            let merges = self.merges(scene, radii, light_paths, beam_paths);
            (radii, merges, self.mis(light_paths, merges))
        };
        let job = [s.radius, s.medium_radius, s.pb2d_radius, s.bb1d_radius];
        let (radii, merges, mis) = sized(job);
        let norms = |m: &Merges| ALL.map(|k| m.norm(k));
        let radius_layers = (0..s.radii.len())
            .map(|i| {
                let (radii, merges, own) = sized(s.layer_radii(i));
                RadiusLayer {
                    scale: Scale::between(&mis, &own),
                    mis: own,
                    radii,
                    norms: norms(&merges),
                    layer: self.layers.radii + i,
                }
            })
            .collect();
        let mut core = crate::integrator::paths::Pass {
            scene,
            tracing: self.technique.tracing(),
            max_depth: s.max_depth,
            russian_roulette: s.russian_roulette,
            max_vertex_mib: s.max_vertex_mib,
            mis,
            radii,
            norms: norms(&merges),
            beam_paths,
            light_paths,
            layers: &self.layers,
            keep_segments: self.keep_segments,
            radius_layers,
            selection: None,
        };
        if !choice.is_empty() {
            core.selection = Some(Selection {
                candidates: selection::candidates(&core),
                choice,
                width: scene.width(),
            });
        }
        Pass {
            core,
            s: &self.s,
            technique: self.technique,
        }
    }

    /// Each merge estimator's radius in iteration `iteration`, the surface's from the
    /// initial `radius` and the medium's from `medium` (the settings' factors where
    /// None).
    fn radii(
        &self,
        scene: &Scene,
        iteration: u64,
        [radius, medium, pb2d, bb1d]: [Option<f32>; Merge::COUNT],
    ) -> [f32; Merge::COUNT] {
        let s = &self.s;
        let r0 = radius.unwrap_or(s.radius_factor * scene.sphere.radius);
        // [TR] eq. 21 with the first iteration numbered 1; the floor only guards the
        // arithmetic after astronomically many iterations.
        let surface = (r0 / ((iteration + 1) as f32).powf(0.5 * (1.0 - s.alpha))).max(1e-7 * r0);
        // Point x point 3D, point x beam 2D and beam x beam 1D: the schedule of their
        // kernel's dimension, from the iteration index (transport::radius).
        let volume = |r: Option<f32>, factor: f32, alpha: f32, k: u32| {
            let r0 = r.unwrap_or(factor * scene.sphere.radius);
            radius_schedule(r0, alpha, k, iteration)
        };
        [
            surface,
            volume(medium, s.medium_radius_factor, s.medium_alpha, 3),
            volume(pb2d, s.pb2d_radius_factor, s.pb2d_alpha, 2),
            volume(bb1d, s.bb1d_radius_factor, s.bb1d_alpha, 1),
        ]
    }

    /// The estimators this technique uses in `scene`, with `radii`.
    fn merges(
        &self,
        scene: &Scene,
        radii: [f32; Merge::COUNT],
        light_paths: usize,
        beam_paths: usize,
    ) -> Merges {
        let mut merges = Merges::default();
        for k in ALL {
            let in_scene = k == Merge::Surface || scene.has_media;
            if self.technique.uses(k) && in_scene {
                // Beams come from the first `beam_paths` light paths only.
                let count = if k == Merge::BeamBeam1d {
                    beam_paths
                } else {
                    light_paths
                };
                merges = merges.with(k, radii[k as usize], count as f32);
            }
        }
        merges
    }

    /// The MIS of an iteration with `merges`.
    fn mis(&self, light_paths: usize, merges: Merges) -> Mis {
        let s = &self.s;
        let mut mis = Mis::new(
            s.heuristic,
            light_paths as f32,
            self.technique.connects(),
            merges,
        );
        mis.merge_first = s.merge_first;
        mis.long_query = s.query_beams == BeamForm::Long && s.long_beam_weights;
        mis.first_medium = s.merge_depth == MergeDepth::First;
        mis.local_media = s.local_media_mis;
        mis.correlated = s.correlation_aware;
        mis
    }
}

impl Integrator for Bidir {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        if let Some(state) = &self.adaptive {
            return self.iterate_adaptive(state, scene, (seed, iteration), film);
        }
        let choice = self.choice.lock().unwrap_or_else(|e| e.into_inner());
        self.render(scene, (seed, iteration), film, &choice, false)
            .0
    }
}

impl Bidir {
    /// One iteration into `film`, each pixel under its candidate in `choice` (empty:
    /// the job's weights everywhere); a `pilot` iteration also measures every
    /// candidate in every pixel ([`adaptive`]).
    fn render(
        &self,
        scene: &Scene,
        (seed, iteration): (u64, u64),
        film: &mut Film,
        choice: &[u8],
        pilot: bool,
    ) -> (RenderStats, Option<adaptive::Pilot>) {
        let mut pass = self.pass(scene, iteration, choice);
        let k = self.layers.names.len();
        let candidates = match pilot {
            true => selection::candidates(&pass),
            false => Vec::new(),
        };
        // A pilot's candidates are layers after the film's, weighted as radius layers.
        let (radii, norms) = (pass.radii, pass.norms);
        pass.core
            .radius_layers
            .extend(candidates.iter().enumerate().map(|(i, c)| RadiusLayer {
                mis: c.mis,
                scale: c.scale,
                radii,
                norms,
                layer: k + i,
            }));
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let ws = &mut *guard;
        let mut stats = trace_light_paths(&pass, seed, iteration, &mut ws.store);
        ws.gather_positions(&pass);
        if pass.technique.merges() {
            // Wide enough for every radius layer; each merge keeps its own radius.
            let widest = |k: Merge| {
                let layers = pass.radius_layers.iter().map(|l| l.radii[k as usize]);
                layers.fold(pass.radii[k as usize], f32::max)
            };
            ws.surface
                .grid
                .build(&ws.surface.positions, widest(Merge::Surface));
            ws.medium
                .grid
                .build(&ws.medium.positions, widest(Merge::Point3d));
            ws.fill_merge();
            stats.merge_radius = pass.radii[0];
        }
        if scene.has_media {
            let Workspace { store, beams, .. } = ws;
            beams.build(&pass, &store.chunks, seed, iteration);
        }
        stats.vertex_bytes = (ws.store.vertex_store_bytes()
            + ws.surface.index_bytes()
            + ws.medium.index_bytes()
            + ws.beams.bytes()) as u64;
        let ids: Vec<usize> = self
            .layers
            .names
            .iter()
            .map(|n| film.begin_layer(n))
            .collect();
        let pixels = scene.width() as usize * scene.height() as usize;
        let slots = k + candidates.len();
        // Per-pixel layer values of the camera pass; each pixel's slots are written by
        // the one path of that pixel. A pilot's merges per pixel and estimator too.
        let atomics = |n: usize| (0..n).map(|_| AtomicU32::new(0)).collect::<Vec<_>>();
        let side = atomics(slots * 3 * pixels);
        let merges = atomics(if pilot { pixels * Merge::COUNT } else { 0 });
        if pass.technique != Technique::Lt {
            let (ws, side) = (&*ws, (&side[..], &merges[..]));
            let run = (&pass, ws, side, slots);
            stats += match (scene.has_media, pass.reweights()) {
                (true, false) => camera_pass::<WithMedia, false>(run, seed, iteration, film),
                (false, false) => camera_pass::<NoMedia, false>(run, seed, iteration, film),
                (true, true) => camera_pass::<WithMedia, true>(run, seed, iteration, film),
                (false, true) => camera_pass::<NoMedia, true>(run, seed, iteration, film),
            };
        }
        add_layer_values(scene, (seed, iteration), film, (&ids, slots), &side);
        // Splats go in after the camera pass, in chunk order: the sum never depends on
        // which thread traced which chunk.
        // A radius layer's splats are its own, not the main image's; a candidate's
        // are the pilot's.
        let radii = self.layers.radii;
        let mut measured = adaptive::Pilot::new(&side, (k, candidates), &merges);
        for &(p, v, layer) in ws.store.splats() {
            let layer = layer as usize;
            match ids.get(layer) {
                Some(&id) if layer >= radii => film.add_layer_splat(&scene.filter, p, v, id),
                _ if layer >= k && layer < slots => measured.add_splat(scene, p, v, layer - k),
                id => film.add_splat(&scene.filter, p, v, id.copied()),
            }
        }
        measured.rays_per_pixel = (stats.rays + stats.shadow_rays) as f64 / pixels as f64;
        (stats, pilot.then_some(measured))
    }
}

/// The camera pass, compiled for whether the scene has media (`M`) and the pass has
/// radius layers (`RADII`): `run` is the pass, its workspace, the per-pixel layer
/// slots and their number of layers.
#[allow(clippy::type_complexity)]
fn camera_pass<M: Media + Sync, const RADII: bool>(
    (pass, ws, side, k): (&Pass, &Workspace, (&[AtomicU32], &[AtomicU32]), usize),
    seed: u64,
    iteration: u64,
    film: &mut Film,
) -> RenderStats {
    let kernel = CameraPass::<M, RADII>::new(pass, ws, side, k);
    render_paths(pass.scene, seed, iteration, film, &kernel)
}

/// Adds the camera pass's per-pixel layer values (`side`: three f32 bits per layer
/// and pixel, `stride` layers a pixel) to the film's layers `ids` (the first ones),
/// at each pixel's camera sample (where a wider filter than the pixel box spreads them
/// from).
fn add_layer_values(
    scene: &Scene,
    (seed, iteration): (u64, u64),
    film: &mut Film,
    (ids, stride): (&[usize], usize),
    side: &[AtomicU32],
) {
    let (w, k) = (scene.width(), ids.len());
    if k == 0 {
        return;
    }
    for (pixel, slots) in side.chunks_exact(3 * stride).enumerate() {
        let (x, y) = (pixel as u32 % w, pixel as u32 / w);
        let p = match k == 0 || scene.filter.is_pixel_box() {
            true => crate::math::Vec2::ZERO,
            false => film_sample(seed, iteration, pixel as u64, x, y).0,
        };
        for (j, &id) in ids.iter().enumerate() {
            let v = Rgb::new(
                f32::from_bits(slots[3 * j].load(Ordering::Relaxed)),
                f32::from_bits(slots[3 * j + 1].load(Ordering::Relaxed)),
                f32::from_bits(slots[3 * j + 2].load(Ordering::Relaxed)),
            );
            film.add_layer_sample(&scene.filter, id, (x, y, p), v);
        }
    }
}

/// Light paths whose segments become photon beams (`upbp`'s `beam_paths`).
fn beam_path_count(light_paths: usize, share: f32) -> usize {
    ((light_paths as f64 * share as f64).round() as usize).max(1)
}
