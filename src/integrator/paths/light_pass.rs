//! The light tracer run alone, for the estimators outside the bidirectional family
//! (virtual point and ray lights, photon beams, the memory pilot): every non-specular
//! vertex stored, segments through media kept on request, nothing connected to the
//! camera. The walk is the bidirectional core's, Russian roulette by albedo unless
//! turned off.

use super::layers::Layers;
use super::light_path::trace_light_paths;
use super::partial::{Merge, Merges, Mis};
use super::store::Store;
use super::{Pass, Tracing};
use crate::integrator::transport::light_paths::LightPaths;
use crate::integrator::transport::Heuristic;
use crate::integrator::RenderStats;
use crate::scene::Scene;
use std::sync::Mutex;

/// A light pass and the store it keeps between iterations.
pub(crate) struct LightPass {
    max_depth: u32,
    russian_roulette: bool,
    max_vertex_mib: f32,
    light_paths: LightPaths,
    keep_segments: bool,
    layers: Layers,
    store: Mutex<Store>,
}

impl LightPass {
    /// A pass of `light_paths` paths of at most `max_depth` segments, storing at most
    /// `max_vertex_mib` of vertices (and as much of segments), with Russian roulette
    /// by albedo.
    pub fn new(max_depth: u32, light_paths: LightPaths, max_vertex_mib: f32) -> Self {
        LightPass {
            max_depth,
            russian_roulette: true,
            max_vertex_mib,
            light_paths,
            keep_segments: false,
            layers: Layers::default(),
            store: Mutex::new(Store::default()),
        }
    }

    /// The same, keeping every light subpath's segments through media.
    pub fn keeping_segments(mut self) -> Self {
        self.keep_segments = true;
        self
    }

    /// The same, with Russian roulette turned on or off.
    pub fn with_roulette(mut self, on: bool) -> Self {
        self.russian_roulette = on;
        self
    }

    /// The light pass of `iteration`: hands the stored vertices and segments to `f`
    /// while the store is held.
    pub fn run<R>(
        &self,
        scene: &Scene,
        seed: u64,
        iteration: u64,
        f: impl FnOnce(&Store) -> R,
    ) -> (R, RenderStats) {
        let pixels = scene.width() as usize * scene.height() as usize;
        let light_paths = self.light_paths.count(pixels);
        // No connection and no merge: the partial MIS quantities the walk keeps are
        // read by no one, and are those of the balance heuristic over light tracing.
        let mis = Mis::new(
            Heuristic::Balance,
            light_paths as f32,
            false,
            Merges::default(),
        );
        let pass = Pass {
            scene,
            tracing: Tracing::STORE,
            max_depth: self.max_depth,
            russian_roulette: self.russian_roulette,
            max_vertex_mib: self.max_vertex_mib,
            mis,
            radii: [0.0; Merge::COUNT],
            norms: [0.0; Merge::COUNT],
            light_paths,
            beam_paths: 0,
            layers: &self.layers,
            keep_segments: self.keep_segments,
            radius_layers: Vec::new(),
            selection: None,
        };
        let mut store = self.store.lock().unwrap_or_else(|e| e.into_inner());
        let mut stats = trace_light_paths(&pass, seed, iteration, &mut store);
        stats.vertex_bytes = store.vertex_store_bytes() as u64;
        (f(&store), stats)
    }
}
