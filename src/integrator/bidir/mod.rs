//! The bidirectional family on one core (Georgiev et al. 2012, "Light Transport
//! Simulation with Vertex Connection and Merging"): light tracing (`lt`),
//! bidirectional path tracing (`bpt`), bidirectional photon mapping (`bpm`) and vertex
//! connection and merging (`vcm`) differ only in which techniques they use; the MIS
//! quantities of [`mis`] weight whatever set is on.
//!
//! One iteration: trace N light subpaths (N = `light_paths` x pixels), storing their
//! non-specular vertices and splatting connections to the camera; build the hash grid
//! over the stored vertices; then trace one camera subpath per pixel, connecting to
//! light sampling, to the vertices of the light subpath with the pixel's index, and
//! merging with every stored vertex within the radius.
//!
//! In scenes with participating media both subpaths also scatter in media ([`media`],
//! [`vertex`]) and every connection carries the transmittance of its segment; the MIS
//! quantities account for distance sampling (see [`mis`]). `bpm` and `vcm` also merge
//! at medium vertices of the camera subpath: light vertices in the same medium within
//! the medium radius, with the 3D kernel 1 / (4/3 pi r^3) (point x point 3D of
//! Křivánek et al. 2014), a second merge estimator with its own eta in the MIS.

mod camera_path;
mod light_path;
mod media;
pub mod mis;
mod segments;
mod vertex;
mod walk;

use super::accel::HashGrid;
use super::common::params::check_radius;
use super::common::Heuristic;
use super::pixels::render_paths;
use super::vpm::radius_schedule;
use super::{Integrator, RenderStats};
use crate::film::Film;
use crate::material::Material;
use crate::math::{max_component, Rgb, Vec3};
use crate::scene::Scene;
use camera_path::CameraPass;
pub(crate) use light_path::LightVertex;
use light_path::{trace_light_paths, Chunk, MergeVertex};
use mis::{Merge, Merges, Mis};
pub(crate) use segments::{extent, LightSegment};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;
use vertex::{NoMedia, WithMedia};

/// Which techniques an iteration uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// Light tracing: light subpaths splatted to the camera, no MIS.
    Lt,
    /// Bidirectional path tracing: every (s, t) connection.
    Bpt,
    /// Bidirectional photon mapping: merging at every non-specular camera vertex.
    Bpm,
    /// Connections and merging, all weighted together.
    Vcm,
    /// The light pass alone, for estimators outside this family (virtual point and ray
    /// lights): vertices (and segments, when kept) stored, nothing connected.
    Store,
}

impl Technique {
    fn connects(self) -> bool {
        matches!(self, Technique::Bpt | Technique::Vcm)
    }

    fn merges(self) -> bool {
        matches!(self, Technique::Bpm | Technique::Vcm)
    }

    /// Light vertices are kept after the light pass.
    fn stores(self) -> bool {
        self != Technique::Lt
    }
}

/// Settings shared by `lt`, `bpt`, `bpm` and `vcm` (merging parameters only matter to
/// the last two).
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path in segments, as Mitsuba's `max_depth` (SmallVCM's max path length) |
/// | `light_paths` | 1 | light subpaths per iteration, as a multiple of the pixel count |
/// | `radius` | none | initial merge radius in scene units; overrides `radius_factor` |
/// | `radius_factor` | 0.003 | initial merge radius as a fraction of the scene's bounding-sphere radius |
/// | `alpha` | 0.75 | radius reduction: r_i = r_0 / i^((1 - alpha) / 2) |
/// | `medium_radius` | none | initial radius of merging in media (3D kernel) in scene units; overrides `medium_radius_factor` |
/// | `medium_radius_factor` | 0.02 | the same as a fraction of the scene's bounding-sphere radius |
/// | `medium_alpha` | 4/7 | its reduction, r_{i+1}^3 = r_i^3 (i + alpha) / (i + 1) (Knaus and Zwicker; 4/7 balances variance and squared bias in 3D) |
/// | `merge_first` | true | merge at the first camera vertex (when false, that technique leaves the MIS too) |
/// | `russian_roulette` | true | continue with probability max(albedo) at every vertex, as SmallVCM |
/// | `heuristic` | `balance` | MIS weights: `balance` or `power` |
/// | `max_vertex_mib` | 2048 | budget for stored light vertices per iteration |
/// | `technique_layers` | false | `vcm`: add EXR layers `vc` and `vm` with the connection-only and merging-only parts (thesis Table 5.5) |
/// | `strategy_images` | 0 | `bpt`/`vcm`/`lt`: one EXR layer `s<S>_t<T>` per connection strategy for path lengths up to this (0: off) |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct BidirSettings {
    pub max_depth: u32,
    pub light_paths: f32,
    pub radius: Option<f32>,
    pub radius_factor: f32,
    pub alpha: f32,
    pub medium_radius: Option<f32>,
    pub medium_radius_factor: f32,
    pub medium_alpha: f32,
    pub merge_first: bool,
    pub russian_roulette: bool,
    pub heuristic: Heuristic,
    pub max_vertex_mib: f32,
    pub technique_layers: bool,
    pub strategy_images: u32,
}

impl Default for BidirSettings {
    fn default() -> Self {
        BidirSettings {
            max_depth: 64,
            light_paths: 1.0,
            radius: None,
            radius_factor: 0.003,
            alpha: 0.75,
            medium_radius: None,
            medium_radius_factor: 0.02,
            medium_alpha: 4.0 / 7.0,
            merge_first: true,
            russian_roulette: true,
            heuristic: Heuristic::Balance,
            max_vertex_mib: 2048.0,
            technique_layers: false,
            strategy_images: 0,
        }
    }
}

impl BidirSettings {
    pub fn validate(&self, technique: Technique) -> Result<(), String> {
        if self.max_depth == 0 {
            return Err("max_depth must be at least 1".into());
        }
        if !(self.light_paths.is_finite() && self.light_paths > 0.0 && self.light_paths <= 64.0) {
            return Err(format!(
                "light_paths must be in (0, 64], got {}",
                self.light_paths
            ));
        }
        if let Some(r) = self.radius {
            if !(r.is_finite() && r > 0.0) {
                return Err(format!("radius must be positive and finite, got {r}"));
            }
        }
        if !(self.radius_factor.is_finite() && self.radius_factor > 0.0) {
            return Err(format!(
                "radius_factor must be positive, got {}",
                self.radius_factor
            ));
        }
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(format!("alpha must be in (0, 1], got {}", self.alpha));
        }
        check_radius(self.medium_radius, self.medium_radius_factor)
            .map_err(|e| format!("medium_{e}"))?;
        if !(self.medium_alpha > 0.0 && self.medium_alpha <= 1.0) {
            return Err(format!(
                "medium_alpha must be in (0, 1], got {}",
                self.medium_alpha
            ));
        }
        if !(self.max_vertex_mib.is_finite() && self.max_vertex_mib > 0.0) {
            return Err(format!(
                "max_vertex_mib must be positive, got {}",
                self.max_vertex_mib
            ));
        }
        if self.strategy_images > MAX_STRATEGY_LENGTH {
            return Err(format!(
                "strategy_images covers path lengths up to {MAX_STRATEGY_LENGTH}, got {}",
                self.strategy_images
            ));
        }
        if self.technique_layers && technique != Technique::Vcm {
            return Err("technique_layers (vc and vm parts) needs vcm".into());
        }
        if !self.merge_first && technique == Technique::Bpm {
            return Err(
                "merge_first: false leaves bpm no technique for light seen after one bounce; use vcm"
                    .into(),
            );
        }
        Ok(())
    }
}

/// Longest path with per-strategy images (lengths 1..=8 give 44 layers).
pub const MAX_STRATEGY_LENGTH: u32 = 8;

/// Extra images a pass splits its estimate into.
#[derive(Clone, Debug, Default)]
pub(crate) struct Layers {
    pub names: Vec<String>,
    /// Split by connection strategy up to this path length (0: no).
    strategies: u32,
    /// Split into connection and merging parts.
    techniques: bool,
}

impl Layers {
    fn new(s: &BidirSettings) -> Self {
        let mut names = Vec::new();
        if s.technique_layers {
            names = vec!["vc".to_string(), "vm".to_string()];
        } else {
            for k in 1..=s.strategy_images {
                names.extend((0..=k).map(|light| format!("s{light}_t{}", k + 1 - light)));
            }
        }
        Layers {
            names,
            strategies: if s.technique_layers {
                0
            } else {
                s.strategy_images
            },
            techniques: s.technique_layers,
        }
    }

    /// The layer of a connection with `s` light and `t` camera vertices.
    #[inline]
    pub fn connection(&self, s: u32, t: u32) -> Option<usize> {
        if self.techniques {
            return Some(0);
        }
        let k = s + t - 1;
        (k >= 1 && k <= self.strategies).then(|| ((k - 1) * (k + 2) / 2 + s) as usize)
    }

    #[inline]
    pub fn merge(&self) -> Option<usize> {
        self.techniques.then_some(1)
    }
}

/// Per-iteration constants shared by both subpath tracers.
pub(crate) struct Pass<'a> {
    pub scene: &'a Scene,
    pub s: &'a BidirSettings,
    pub technique: Technique,
    pub mis: Mis,
    pub radius: f32,
    /// 1 / (pi r^2 N): the merge kernel's normalisation.
    pub vm_norm: f32,
    /// Merging in media: the radius and 1 / (4/3 pi r^3 N) (0 when not merging there).
    pub medium_radius: f32,
    pub medium_norm: f32,
    pub light_paths: usize,
    pub layers: &'a Layers,
    /// Light subpaths keep their segments through media (`segments`), for the
    /// estimators made of them.
    pub keep_segments: bool,
}

impl Pass<'_> {
    /// Russian-roulette continuation probability at a vertex with material `m`.
    #[inline]
    pub fn continuation(&self, m: &Material) -> f32 {
        if self.s.russian_roulette {
            max_component(m.albedo()).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }

    /// The same at a medium vertex whose single-scattering albedo is `albedo`.
    #[inline]
    pub fn medium_continuation(&self, albedo: Rgb) -> f32 {
        if self.s.russian_roulette {
            max_component(albedo).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// Buffers kept between iterations so that the light-vertex store and the grid do not
/// reallocate once they have grown to the scene's needs.
#[derive(Default)]
struct Workspace {
    /// The light paths of the iteration, their vertices stored per chunk.
    chunks: Vec<Chunk>,
    paths: usize,
    /// Merging at surfaces and in media, each over its own vertices.
    surface: MergeSet,
    medium: MergeSet,
}

/// The stored vertices of one merge site and the grid over them.
#[derive(Default)]
pub(super) struct MergeSet {
    /// Every such vertex's position, chunk after chunk (only when merging).
    pub positions: Vec<Vec3>,
    pub grid: HashGrid,
    /// What merging needs of each vertex, in the grid's storage order.
    pub merge: Vec<MergeVertex>,
}

pub struct Bidir {
    s: BidirSettings,
    technique: Technique,
    layers: Layers,
    keep_segments: bool,
    /// Light paths per iteration, when given as a count rather than by `light_paths`.
    path_count: Option<usize>,
    ws: Mutex<Workspace>,
}

impl Bidir {
    pub fn new(technique: Technique, s: BidirSettings) -> Self {
        Bidir {
            layers: Layers::new(&s),
            s,
            technique,
            keep_segments: false,
            path_count: None,
            ws: Mutex::new(Workspace::default()),
        }
    }

    /// The same, with light subpaths keeping their segments through media.
    pub(crate) fn keeping_segments(mut self) -> Self {
        self.keep_segments = true;
        self
    }

    /// The same, tracing `n` light paths per iteration whatever the image size.
    pub(crate) fn with_path_count(mut self, n: usize) -> Self {
        self.path_count = Some(n.max(1));
        self
    }

    /// The light pass of `iteration` alone ([`Technique::Store`]): hands the stored
    /// vertices and segments to `f` while the store is held.
    pub(crate) fn light_pass<R>(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        f: impl FnOnce(&LightStore) -> R,
    ) -> (R, RenderStats) {
        debug_assert_eq!(self.technique, Technique::Store);
        let pass = self.pass(scene, iteration);
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let mut stats = trace_light_paths(&pass, seed, iteration, &mut guard);
        stats.vertex_bytes = guard.vertex_store_bytes() as u64;
        (f(&LightStore { ws: &guard }), stats)
    }

    fn pass<'a>(&'a self, scene: &'a Scene, iteration: u64) -> Pass<'a> {
        let pixels = scene.width() as usize * scene.height() as usize;
        let light_paths = self.path_count.unwrap_or_else(|| {
            ((pixels as f64 * self.s.light_paths as f64).round() as usize).max(1)
        });
        let r0 = self
            .s
            .radius
            .unwrap_or(self.s.radius_factor * scene.sphere.radius);
        // [TR] eq. 21 with the first iteration numbered 1; the floor only guards the
        // arithmetic after astronomically many iterations.
        let radius =
            (r0 / ((iteration + 1) as f32).powf(0.5 * (1.0 - self.s.alpha))).max(1e-7 * r0);
        let t = self.technique;
        let medium_r0 = self
            .s
            .medium_radius
            .unwrap_or(self.s.medium_radius_factor * scene.sphere.radius);
        let medium_radius = radius_schedule(medium_r0, self.s.medium_alpha, 3, iteration);
        let mut merges = Merges::default();
        if t.merges() {
            merges = Merges::surface(radius, light_paths as f32);
            if scene.has_media {
                merges = merges.with(Merge::Point3d, medium_radius, light_paths as f32);
            }
        }
        let mut mis = Mis::new(self.s.heuristic, light_paths as f32, t.connects(), merges);
        mis.merge_first = self.s.merge_first;
        Pass {
            scene,
            s: &self.s,
            technique: t,
            mis,
            radius,
            vm_norm: merges.norm(Merge::Surface),
            medium_radius,
            medium_norm: merges.norm(Merge::Point3d),
            light_paths,
            layers: &self.layers,
            keep_segments: self.keep_segments,
        }
    }
}

impl Integrator for Bidir {
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats {
        let pass = self.pass(scene, iteration);
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let ws = &mut *guard;
        let mut stats = trace_light_paths(&pass, seed, iteration, ws);
        if pass.technique.merges() {
            ws.surface.grid.build(&ws.surface.positions, pass.radius);
            ws.medium
                .grid
                .build(&ws.medium.positions, pass.medium_radius);
            ws.fill_merge();
            stats.merge_radius = pass.radius;
        }
        stats.vertex_bytes =
            (ws.vertex_store_bytes() + ws.surface.index_bytes() + ws.medium.index_bytes()) as u64;
        let ids: Vec<usize> = self
            .layers
            .names
            .iter()
            .map(|n| film.begin_layer(n))
            .collect();
        let k = ids.len();
        // Per-pixel layer values of the camera pass; each pixel's slots are written by
        // the one path of that pixel.
        let side: Vec<AtomicU32> = (0..k * 3 * scene.width() as usize * scene.height() as usize)
            .map(|_| AtomicU32::new(0))
            .collect();
        if pass.technique != Technique::Lt {
            let (ws, side) = (&*ws, &side[..]);
            stats += if scene.has_media {
                let kernel = CameraPass::<WithMedia>::new(&pass, ws, side, k);
                render_paths(scene, seed, iteration, film, &kernel)
            } else {
                let kernel = CameraPass::<NoMedia>::new(&pass, ws, side, k);
                render_paths(scene, seed, iteration, film, &kernel)
            };
        }
        for (pixel, slots) in side.chunks_exact(3 * k.max(1)).enumerate() {
            for (j, &id) in ids.iter().enumerate() {
                let v = Rgb::new(
                    f32::from_bits(slots[3 * j].load(Ordering::Relaxed)),
                    f32::from_bits(slots[3 * j + 1].load(Ordering::Relaxed)),
                    f32::from_bits(slots[3 * j + 2].load(Ordering::Relaxed)),
                );
                film.add_layer_index(id, pixel, v);
            }
        }
        // Splats go in after the camera pass, in chunk order: the sum never depends on
        // which thread traced which chunk.
        for c in &ws.chunks {
            for &(pixel, v, layer) in &c.splats {
                film.add_index(pixel as usize, v);
                if let Some(&id) = ids.get(layer as usize) {
                    film.add_layer_index(id, pixel as usize, v);
                }
            }
        }
        stats
    }
}

/// An iteration's light subpaths as a light pass stored them ([`Bidir::light_pass`]).
pub(crate) struct LightStore<'a> {
    ws: &'a Workspace,
}

impl LightStore<'_> {
    /// Light paths traced (including those that stored nothing).
    pub fn paths(&self) -> usize {
        self.ws.paths
    }

    /// Every stored vertex, path after path, each path's in order of length.
    pub fn vertices(&self) -> impl Iterator<Item = &LightVertex> {
        self.ws.chunks.iter().flat_map(|c| c.vertices.iter())
    }

    /// Every kept segment through a medium, in the same order.
    pub fn segments(&self) -> impl Iterator<Item = &LightSegment> {
        self.ws.chunks.iter().flat_map(|c| c.segments.iter())
    }
}

/// A light-tracing contribution: (pixel, value, layer or u16::MAX).
pub(crate) type Splat = (u32, Rgb, u16);
