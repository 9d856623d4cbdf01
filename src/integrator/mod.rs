//! Light-transport algorithms. Each is one module with its settings (serde, tagged by
//! `algorithm`) and its kernel; this file is the registry and the progressive driver.
//!
//! An iteration is the unit of work (one camera sample per pixel, or one light pass);
//! iteration i depends only on (scene, settings, seed, i), so iterations can run
//! anywhere, in any order, and be summed. The image is sum / iterations.

pub mod bidir;
mod debug;
pub mod drive;
pub mod estimators;
pub mod many;
pub mod memory;
pub(crate) mod paths;
pub mod photon;
pub(crate) mod pilot;
pub mod pt;
pub mod transport;
pub mod volpath;

use crate::film::Film;
use crate::scene::Scene;
use bidir::Technique;
use photon::{ppb, sppm, vpm};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

/// Work counters of one or more iterations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RenderStats {
    /// Closest-hit rays traced.
    pub rays: u64,
    /// Shadow (any-hit) rays traced.
    pub shadow_rays: u64,
    /// Camera samples (or light paths) taken.
    pub samples: u64,
    /// Light-subpath vertices (or photons) stored for connection and merging.
    pub light_vertices: u64,
    /// Vertex connections evaluated (light sampling, light-vertex and camera connections).
    pub connections: u64,
    /// Merges: stored vertices found within the merge radius of a camera vertex.
    pub merges: u64,
    /// Merge radius of the latest iteration (0 for algorithms that do not merge).
    pub merge_radius: f32,
    /// Bytes of light-vertex storage the latest iteration used.
    pub vertex_bytes: u64,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.samples += o.samples;
        self.light_vertices += o.light_vertices;
        self.connections += o.connections;
        self.merges += o.merges;
        // Per-iteration figures: the later iteration's value stands.
        if o.merge_radius > 0.0 {
            self.merge_radius = o.merge_radius;
        }
        self.vertex_bytes = self.vertex_bytes.max(o.vertex_bytes);
    }
}

/// Thread-shared counters, added to once per tile.
#[derive(Default)]
pub struct Counters {
    rays: AtomicU64,
    shadow_rays: AtomicU64,
    samples: AtomicU64,
    connections: AtomicU64,
    merges: AtomicU64,
}

impl Counters {
    pub fn add(&self, s: &RenderStats) {
        self.rays.fetch_add(s.rays, Ordering::Relaxed);
        self.shadow_rays.fetch_add(s.shadow_rays, Ordering::Relaxed);
        self.samples.fetch_add(s.samples, Ordering::Relaxed);
        self.connections.fetch_add(s.connections, Ordering::Relaxed);
        self.merges.fetch_add(s.merges, Ordering::Relaxed);
    }

    pub fn get(&self) -> RenderStats {
        RenderStats {
            rays: self.rays.load(Ordering::Relaxed),
            shadow_rays: self.shadow_rays.load(Ordering::Relaxed),
            samples: self.samples.load(Ordering::Relaxed),
            connections: self.connections.load(Ordering::Relaxed),
            merges: self.merges.load(Ordering::Relaxed),
            ..Default::default()
        }
    }
}

/// A progressive algorithm. Implementations are pure functions of their inputs.
pub trait Integrator: Send + Sync {
    /// Adds iteration `iteration` of a job with `seed` into `film`.
    fn iterate(&self, scene: &Scene, seed: u64, iteration: u64, film: &mut Film) -> RenderStats;

    /// State carried from one iteration to the next, for algorithms whose iterations
    /// are not independent (SPPM's per-pixel statistics). Saved with checkpoints so a
    /// restarted job continues exactly; `None` for stateless algorithms.
    fn save_state(&self) -> Option<Vec<u8>> {
        None
    }

    /// Restores what `save_state` returned, before the next iteration runs.
    fn load_state(&self, _bytes: &[u8]) -> Result<(), String> {
        Ok(())
    }

    /// Whether `iterate` rewrites the film with the job's running totals (SPPM)
    /// instead of adding one iteration's samples to it; such iterations run in order,
    /// on one film (`driver::iterate_exact`).
    fn chained(&self) -> bool {
        false
    }
}

/// Every algorithm's settings, tagged by `algorithm`. Unknown fields are errors.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "algorithm", rename_all = "snake_case", deny_unknown_fields)]
pub enum Settings {
    /// Unidirectional path tracing with next-event estimation and MIS.
    Pt(pt::PtSettings),
    /// Volumetric path tracing (what `pt` runs on scenes with media).
    Volpath(volpath::VolpathSettings),
    /// Light tracing: light paths splatted to the camera.
    Lt(bidir::BidirSettings),
    /// Bidirectional path tracing with all (s, t) connections.
    Bpt(bidir::BidirSettings),
    /// Bidirectional photon mapping: merging at every non-specular camera vertex.
    Bpm(bidir::BidirSettings),
    /// Vertex connection and merging.
    Vcm(bidir::BidirSettings),
    /// Unifying points, beams and paths: connections, surface photons and the three
    /// volume estimators (any subset) under one MIS.
    Upbp(bidir::BidirSettings),
    /// Progressive photon mapping (visible points fixed per pixel).
    Ppm(sppm::SppmSettings),
    /// Stochastic progressive photon mapping (new visible points every pass).
    Sppm(sppm::SppmSettings),
    /// Volumetric photon mapping, progressive (point query or beam radiance estimate).
    Vpm(vpm::VpmSettings),
    /// Virtual point lights, with optional clamping and bias compensation.
    Vpl(many::VplSettings),
    /// Virtual ray lights in media, virtual point lights on surfaces.
    Vrl(many::VrlSettings),
    /// Progressive virtual beam lights: ray lights blurred over a shrinking disk.
    Vbl(many::VblSettings),
    /// Progressive photon beams in media; surfaces path traced.
    Ppb(ppb::PpbSettings),
    /// Debug: shading normal at the first hit, mapped to [0, 1] as (n + 1) / 2.
    /// (Empty struct variants, so that serde refuses parameters they do not take.)
    Normals {},
    /// Debug: the material's reflectance at the first hit.
    Albedo {},
}

/// Names accepted for `algorithm`.
pub const ALGORITHMS: &[&str] = &[
    "pt", "volpath", "lt", "bpt", "ppm", "sppm", "bpm", "vcm", "upbp", "vpm", "ppb", "vpl", "vrl",
    "vbl", "normals", "albedo",
];

/// Scene-default parameters that carry over to another algorithm that takes them
/// (a scene written for `pt` with max_depth 10 means the same paths for `vcm`).
const SHARED_PARAMS: &[&str] = &["max_depth"];

#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("unknown algorithm \"{0}\" (known: {list})", list = ALGORITHMS.join(", "))]
    UnknownAlgorithm(String),
    #[error("integrator settings: {0}")]
    Invalid(String),
}

impl Settings {
    pub fn name(&self) -> &'static str {
        match self {
            Settings::Pt(_) => "pt",
            Settings::Volpath(_) => "volpath",
            Settings::Lt(_) => "lt",
            Settings::Bpt(_) => "bpt",
            Settings::Bpm(_) => "bpm",
            Settings::Vcm(_) => "vcm",
            Settings::Upbp(_) => "upbp",
            Settings::Ppm(_) => "ppm",
            Settings::Sppm(_) => "sppm",
            Settings::Vpm(_) => "vpm",
            Settings::Vpl(_) => "vpl",
            Settings::Vrl(_) => "vrl",
            Settings::Vbl(_) => "vbl",
            Settings::Ppb(_) => "ppb",
            Settings::Normals {} => "normals",
            Settings::Albedo {} => "albedo",
        }
    }

    /// Settings for `algorithm`: the scene's defaults when they name the same
    /// algorithm, then `overrides` (a JSON object of parameters) on top.
    /// The settings a job on `scene` runs with: [`Settings::resolve`] with the scene's
    /// defaults, then [`Settings::check_scene`].
    pub fn for_scene(
        algorithm: Option<&str>,
        scene: &Scene,
        overrides: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Settings, SettingsError> {
        let s = Settings::resolve(algorithm, scene.integrator.as_ref(), overrides)?;
        s.check_scene(scene)?;
        Ok(s)
    }

    /// The settings a scene's own `integrator` section gives a job that sets none,
    /// checked as a job's settings are; a parameter that does not parse is named
    /// `integrator.<name>`, where the scene says it. What uploads and local renders
    /// check, so that a scene cannot be stored that no job on it could render.
    pub fn scene_defaults(section: Option<&serde_json::Value>) -> Result<Settings, SettingsError> {
        let mut params = section
            .and_then(serde_json::Value::as_object)
            .cloned()
            .unwrap_or_default();
        let algorithm = params.remove("algorithm");
        Settings::resolve_named(
            algorithm.as_ref().and_then(|a| a.as_str()),
            None,
            &params,
            "integrator",
        )
    }

    /// [`Settings::scene_defaults`] of a compiled scene, with [`Settings::check_scene`].
    pub fn for_scene_defaults(scene: &Scene) -> Result<Settings, SettingsError> {
        let s = Settings::scene_defaults(scene.integrator.as_ref())?;
        s.check_scene(scene)?;
        Ok(s)
    }

    pub fn resolve(
        algorithm: Option<&str>,
        scene_default: Option<&serde_json::Value>,
        overrides: &serde_json::Map<String, serde_json::Value>,
    ) -> Result<Settings, SettingsError> {
        Settings::resolve_named(algorithm, scene_default, overrides, "params")
    }

    /// [`Settings::resolve`], naming an override that does not parse `{prefix}.{name}`.
    fn resolve_named(
        algorithm: Option<&str>,
        scene_default: Option<&serde_json::Value>,
        overrides: &serde_json::Map<String, serde_json::Value>,
        prefix: &str,
    ) -> Result<Settings, SettingsError> {
        let scene_alg = scene_default
            .and_then(|v| v.get("algorithm"))
            .and_then(|a| a.as_str());
        let alg = algorithm.or(scene_alg).unwrap_or("pt");
        if overrides.contains_key("algorithm") {
            return Err(SettingsError::Invalid(
                "`algorithm` is chosen by name, not as a parameter".into(),
            ));
        }
        if !ALGORITHMS.contains(&alg) {
            return Err(SettingsError::UnknownAlgorithm(alg.to_string()));
        }
        // Every parameter is an f32 or an integer: one beyond f32 would be infinity.
        if let Some((path, n)) = crate::json_numbers::value_beyond_f32(overrides) {
            return Err(SettingsError::Invalid(format!(
                "params.{path}: number {n} is out of range (at most {})",
                crate::json_numbers::f32_limit()
            )));
        }
        let mut obj = serde_json::Map::new();
        let mut shared = serde_json::Map::new();
        if let Some(serde_json::Value::Object(m)) = scene_default {
            if scene_alg == Some(alg) {
                obj.extend(m.clone());
            } else {
                shared.extend(
                    m.iter()
                        .filter(|(k, _)| SHARED_PARAMS.contains(&k.as_str()))
                        .map(|(k, v)| (k.clone(), v.clone())),
                );
            }
        }
        obj.extend(overrides.clone());
        obj.insert("algorithm".into(), alg.into());
        let parse = |o: serde_json::Map<String, serde_json::Value>| {
            serde_json::from_value::<Settings>(serde_json::Value::Object(o))
        };
        let mut with_shared = shared;
        with_shared.extend(obj.clone());
        // Shared defaults apply only where the algorithm has such a parameter.
        let settings = parse(with_shared)
            .or_else(|_| parse(obj.clone()))
            .map_err(|e| {
                // serde cannot tell where inside a tagged enum it failed: find the
                // parameter without which the settings parse, and name it.
                let culprit = overrides.keys().find(|k| {
                    let mut without = obj.clone();
                    without.remove(*k);
                    parse(without).is_ok()
                });
                SettingsError::Invalid(match culprit {
                    Some(k) => format!("{prefix}.{k}: {e}"),
                    None => e.to_string(),
                })
            })?;
        settings.validate()?;
        Ok(settings)
    }

    /// An algorithm's parameters with their default values (the settings a job gets
    /// when it sets none), without the `algorithm` tag.
    pub fn defaults(
        algorithm: &str,
    ) -> Result<serde_json::Map<String, serde_json::Value>, SettingsError> {
        let s = Settings::resolve(Some(algorithm), None, &serde_json::Map::new())?;
        let mut v = match crate::json_numbers::to_value(&s) {
            Ok(serde_json::Value::Object(m)) => m,
            Ok(_) => serde_json::Map::new(),
            Err(e) => return Err(SettingsError::Invalid(e.to_string())),
        };
        v.remove("algorithm");
        Ok(v)
    }

    /// Refuses settings that contradict what the scene holds. Every algorithm renders
    /// media; only `pt`'s albedo roulette assumes there are none.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), SettingsError> {
        if let (Settings::Pt(s), true) = (self, scene.has_media) {
            if s.roulette == pt::Roulette::Albedo {
                return Err(SettingsError::Invalid(
                    "roulette = albedo applies to scenes without media; this scene has media, where pt renders as volpath with throughput roulette (leave roulette out, or set it to throughput)".into(),
                ));
            }
        }
        Ok(())
    }

    fn validate(&self) -> Result<(), SettingsError> {
        match self {
            Settings::Pt(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Volpath(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Lt(s) => s
                .validate(bidir::Technique::Lt)
                .map_err(SettingsError::Invalid),
            Settings::Bpt(s) => s
                .validate(bidir::Technique::Bpt)
                .map_err(SettingsError::Invalid),
            Settings::Bpm(s) => s
                .validate(bidir::Technique::Bpm)
                .map_err(SettingsError::Invalid),
            Settings::Upbp(s) => s
                .validate(s.technique_of("upbp"))
                .map_err(SettingsError::Invalid),
            Settings::Vcm(s) => s
                .validate(bidir::Technique::Vcm)
                .map_err(SettingsError::Invalid),
            Settings::Ppm(s) | Settings::Sppm(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Vpm(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Vpl(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Vrl(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Vbl(s) => s.validate().map_err(SettingsError::Invalid),
            Settings::Ppb(s) => s.validate().map_err(SettingsError::Invalid),
            _ => Ok(()),
        }
    }

    /// The peak memory of a job with these settings on `scene`, by part (module
    /// [`memory`]): the algorithm's own stores, then the film and exact sums every
    /// job keeps (twice the sums for a chained integrator, whose sums are rebuilt
    /// each iteration).
    pub fn memory(&self, scene: &Scene) -> memory::Estimate {
        let f = memory::Facts::new(scene);
        let mut e = match self {
            Settings::Pt(s) => s.memory(&f),
            Settings::Volpath(s) => s.memory(&f),
            Settings::Lt(s) => s.memory(bidir::Technique::Lt, &f),
            Settings::Bpt(s) => s.memory(bidir::Technique::Bpt, &f),
            Settings::Bpm(s) => s.memory(bidir::Technique::Bpm, &f),
            Settings::Vcm(s) => s.memory(bidir::Technique::Vcm, &f),
            Settings::Upbp(s) => s.memory(s.technique_of("upbp"), &f),
            Settings::Ppm(s) | Settings::Sppm(s) => s.memory(&f),
            Settings::Vpm(s) => s.memory(&f),
            Settings::Vpl(s) => s.memory(&f),
            Settings::Vrl(s) => s.memory(&f),
            Settings::Vbl(s) => s.memory(&f),
            Settings::Ppb(s) => s.memory(&f),
            Settings::Normals {} | Settings::Albedo {} => debug::DebugIntegrator::memory(&f),
        };
        let (w, h) = (scene.width(), scene.height());
        let layers = self.layers();
        let chained = matches!(self, Settings::Ppm(_) | Settings::Sppm(_));
        let sums = crate::film::ExactSums::bytes_for(w, h, layers) * (1 + chained as u64);
        let film = crate::film::Film::bytes_for(w, h, layers) + sums + self.filter_bytes(scene);
        let what = match layers {
            0 => f.film(),
            n => format!("{} with {n} layers", f.film()),
        };
        e.add("film", what, film as f64);
        e
    }

    /// What a filter wider than the pixel box adds to the film and the exact sums
    /// (weights, and splat images for the algorithms that splat); nothing for the
    /// photon mappers, whose per-pixel statistics take the pixel box whatever the
    /// scene's filter.
    pub fn filter_bytes(&self, scene: &Scene) -> u64 {
        let splats = match self {
            Settings::Lt(_) => Technique::Lt.splats(),
            Settings::Bpt(_) => Technique::Bpt.splats(),
            Settings::Bpm(_) => Technique::Bpm.splats(),
            Settings::Vcm(_) => Technique::Vcm.splats(),
            Settings::Upbp(s) => s.technique_of("upbp").splats(),
            Settings::Ppm(_) | Settings::Sppm(_) => return 0,
            _ => false,
        };
        let (w, h, layers) = (scene.width(), scene.height(), self.layers());
        if scene.filter.is_pixel_box() {
            return 0;
        }
        crate::film::Film::filter_bytes_for(w, h, layers, splats)
            + crate::film::ExactSums::filter_bytes_for(w, h, layers, splats)
    }

    /// The extra images (layers) a job with these settings writes.
    pub fn layers(&self) -> usize {
        match self {
            Settings::Lt(s) => s.layer_count(bidir::Technique::Lt),
            Settings::Bpt(s) => s.layer_count(bidir::Technique::Bpt),
            Settings::Bpm(s) => s.layer_count(bidir::Technique::Bpm),
            Settings::Vcm(s) => s.layer_count(bidir::Technique::Vcm),
            Settings::Upbp(s) => s.layer_count(s.technique_of("upbp")),
            _ => 0,
        }
    }

    pub fn build(&self) -> Box<dyn Integrator> {
        match self {
            Settings::Pt(s) => Box::new(pt::PathTracer::new(s.clone())),
            Settings::Volpath(s) => Box::new(volpath::VolPath::new(s.clone())),
            Settings::Lt(s) => Box::new(bidir::Bidir::new(bidir::Technique::Lt, s.clone())),
            Settings::Bpt(s) => Box::new(bidir::Bidir::new(bidir::Technique::Bpt, s.clone())),
            Settings::Bpm(s) => Box::new(bidir::Bidir::new(bidir::Technique::Bpm, s.clone())),
            Settings::Vcm(s) => Box::new(bidir::Bidir::new(bidir::Technique::Vcm, s.clone())),
            Settings::Upbp(s) => Box::new(bidir::Bidir::new(s.technique_of("upbp"), s.clone())),
            Settings::Ppm(s) => Box::new(sppm::PhotonMapper::new(s.clone(), sppm::Variant::Ppm)),
            Settings::Sppm(s) => Box::new(sppm::PhotonMapper::new(s.clone(), sppm::Variant::Sppm)),
            Settings::Vpm(s) => Box::new(vpm::Vpm::new(s.clone())),
            Settings::Vpl(s) => Box::new(many::ManyLights::vpl(s.clone())),
            Settings::Vrl(s) => Box::new(many::ManyLights::vrl(s.clone())),
            Settings::Vbl(s) => Box::new(many::ManyLights::vbl(s.clone())),
            Settings::Ppb(s) => Box::new(ppb::Ppb::new(s.clone())),
            Settings::Normals {} => Box::new(debug::DebugIntegrator::Normals),
            Settings::Albedo {} => Box::new(debug::DebugIntegrator::Albedo),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_round_trip_and_reject_unknown_fields() {
        let s = Settings::resolve(Some("pt"), None, &serde_json::Map::new()).unwrap();
        let back: Settings = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(s, back);
        let mut bad = serde_json::Map::new();
        bad.insert("max_dept".into(), 3.into());
        let err = Settings::resolve(Some("pt"), None, &bad).unwrap_err();
        assert!(err.to_string().contains("max_dept"), "{err}");
        assert!(matches!(
            Settings::resolve(Some("vcmm"), None, &serde_json::Map::new()),
            Err(SettingsError::UnknownAlgorithm(_))
        ));
    }

    #[test]
    fn scene_defaults_apply_only_to_their_algorithm() {
        let scene = serde_json::json!({"algorithm": "pt", "max_depth": 7});
        let s = Settings::resolve(None, Some(&scene), &serde_json::Map::new()).unwrap();
        assert_eq!(
            s,
            Settings::Pt(pt::PtSettings {
                max_depth: 7,
                ..Default::default()
            })
        );
        let s = Settings::resolve(Some("normals"), Some(&scene), &serde_json::Map::new()).unwrap();
        assert_eq!(s, Settings::Normals {});
    }

    /// pt renders scenes with media as volpath, which has no albedo roulette: asking
    /// for it there is refused with a message, not silently dropped.
    #[test]
    fn pt_refuses_albedo_roulette_on_scenes_with_media() {
        let fog = r#"{"format": 1,
            "camera": {"look_at": {"origin": [0, 0, 1.5], "target": [0, 0, 0], "up": [0, 1, 0]},
                       "fov": 40, "medium": "fog"},
            "film": {"width": 4, "height": 4},
            "media": {"fog": {"type": "homogeneous", "sigma_t": [1, 1, 1], "albedo": [1, 1, 1]}},
            "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [1, 1, 1]}]}"#;
        let scene = crate::scene::load::parse_scene(fog)
            .and_then(|f| Scene::compile(&f, None))
            .unwrap();
        let params = |r: &str| {
            let mut m = serde_json::Map::new();
            m.insert("roulette".into(), r.into());
            m
        };
        let albedo = Settings::resolve(Some("pt"), None, &params("albedo")).unwrap();
        let err = albedo.check_scene(&scene).unwrap_err().to_string();
        assert!(err.contains("roulette") && err.contains("media"), "{err}");
        let throughput = Settings::resolve(Some("pt"), None, &params("throughput")).unwrap();
        throughput.check_scene(&scene).unwrap();
    }
}
