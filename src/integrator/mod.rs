//! Light-transport algorithms. Each is one module with its settings (serde, tagged by
//! `algorithm`) and its kernel. This file is the facade: the `Integrator` trait, the
//! `Settings` of every algorithm with how a job's are resolved and checked, and their
//! errors, which name the parameter at fault; `registry` is the table of algorithms.
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
pub mod registry;
pub mod transport;
pub mod volpath;

use crate::film::Film;
use crate::scene::Scene;
use photon::{ppb, sppm, vpm};
use registry::FilmUse;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

pub use transport::params::ParamError;

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

/// Every algorithm's settings, tagged by `algorithm`: the wire format of a job's
/// settings. Unknown fields are errors. Each variant is a row of [`registry::TABLE`],
/// which says what the algorithm computes; [`Settings::parts`] maps one to the other.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "algorithm", rename_all = "snake_case", deny_unknown_fields)]
pub enum Settings {
    Pt(pt::PtSettings),
    Volpath(volpath::VolpathSettings),
    Lt(bidir::BidirSettings),
    Bpt(bidir::BidirSettings),
    Bpm(bidir::BidirSettings),
    Vcm(bidir::BidirSettings),
    Upbp(bidir::BidirSettings),
    Ppm(sppm::SppmSettings),
    Sppm(sppm::SppmSettings),
    Vpm(vpm::VpmSettings),
    Vpl(many::VplSettings),
    Vrl(many::VrlSettings),
    Vbl(many::VblSettings),
    Ppb(ppb::PpbSettings),
    /// (Empty struct variants, so that serde refuses parameters they do not take.)
    Normals {},
    Albedo {},
}

/// Names accepted for `algorithm`, in the order of [`registry::TABLE`].
pub const ALGORITHMS: &[&str] = &registry::names::<{ registry::TABLE.len() }>();

/// Scene-default parameters that carry over to another algorithm that takes them
/// (a scene written for `pt` with max_depth 10 means the same paths for `vcm`).
const SHARED_PARAMS: &[&str] = &["max_depth"];

/// A JSON object of parameters.
type ParamMap = serde_json::Map<String, serde_json::Value>;

#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("unknown algorithm \"{0}\" (known: {list})", list = ALGORITHMS.join(", "))]
    UnknownAlgorithm(String),
    /// Settings that do not parse or validate. `field` names the parameter at fault as
    /// the request wrote it (`params.radius`, or `integrator.radius` for a scene's own
    /// default), when one is.
    #[error("integrator settings: {message}")]
    Invalid {
        field: Option<String>,
        message: String,
    },
}

impl SettingsError {
    /// The parameter at fault, as the request wrote it (`params.radius`).
    pub fn field(&self) -> Option<&str> {
        match self {
            SettingsError::Invalid { field, .. } => field.as_deref(),
            SettingsError::UnknownAlgorithm(_) => None,
        }
    }
}

/// Where a job's parameters came from, to name a bad one as the request wrote it:
/// `{prefix}.<name>` (`params`, a job's own), unless only the scene's `integrator`
/// section gave it (`integrator.<name>`).
struct Sources<'a> {
    prefix: &'a str,
    overrides: &'a ParamMap,
    /// What the scene's defaults gave.
    scene: &'a ParamMap,
}

impl Sources<'_> {
    /// `path` (`radius`, `light_paths.count`) as the request wrote it.
    fn name(&self, path: &str) -> String {
        let top = top_name(path);
        let from_scene = !self.overrides.contains_key(top) && self.scene.contains_key(top);
        let prefix = if from_scene {
            "integrator"
        } else {
            self.prefix
        };
        format!("{prefix}.{path}")
    }

    fn refuse(&self, e: ParamError) -> SettingsError {
        SettingsError::Invalid {
            field: Some(self.name(&e.field)),
            message: e.message,
        }
    }

    /// A parameter that does not parse, named by its path: the message names the
    /// parameter (`params.light_paths: ...`), the field its full path.
    fn unparsed(&self, e: registry::ParseError) -> SettingsError {
        let path = e.path().to_string();
        let e = e.into_inner();
        // serde_path_to_error writes an empty path as ".".
        let top = (path != ".").then(|| top_name(&path));
        SettingsError::Invalid {
            message: match top {
                Some(top) => format!("{}: {e}", self.name(top)),
                None => e.to_string(),
            },
            field: top.map(|_| self.name(&path)),
        }
    }
}

/// The parameter a path is in (`light_paths` of `light_paths.count`).
fn top_name(path: &str) -> &str {
    path.split(['.', '[']).next().unwrap_or(path)
}

impl Settings {
    pub fn name(&self) -> &'static str {
        self.parts().0
    }

    /// The settings a job on `scene` runs with: [`Settings::resolve`] with the scene's
    /// defaults, then [`Settings::check_scene`].
    pub fn for_scene(
        algorithm: Option<&str>,
        scene: &Scene,
        overrides: &ParamMap,
    ) -> Result<Settings, SettingsError> {
        let s = Settings::resolve(algorithm, scene.integrator.as_ref(), overrides)?;
        let none = ParamMap::new();
        let sources = Sources {
            prefix: "params",
            overrides,
            scene: scene
                .integrator
                .as_ref()
                .and_then(serde_json::Value::as_object)
                .unwrap_or(&none),
        };
        s.check_scene(scene).map_err(|e| sources.refuse(e))?;
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
        let none = ParamMap::new();
        let sources = Sources {
            prefix: "integrator",
            overrides: &none,
            scene: &none,
        };
        s.check_scene(scene).map_err(|e| sources.refuse(e))?;
        Ok(s)
    }

    /// Settings for `algorithm`: the scene's defaults when they name the same
    /// algorithm (and the shared ones when they do not), then `overrides` (a JSON
    /// object of parameters) on top.
    pub fn resolve(
        algorithm: Option<&str>,
        scene_default: Option<&serde_json::Value>,
        overrides: &ParamMap,
    ) -> Result<Settings, SettingsError> {
        Settings::resolve_named(algorithm, scene_default, overrides, "params")
    }

    /// [`Settings::resolve`], naming a parameter of `overrides` that is refused
    /// `{prefix}.{name}`, and one of the scene's defaults `integrator.{name}`.
    fn resolve_named(
        algorithm: Option<&str>,
        scene_default: Option<&serde_json::Value>,
        overrides: &ParamMap,
        prefix: &str,
    ) -> Result<Settings, SettingsError> {
        let scene_alg = scene_default
            .and_then(|v| v.get("algorithm"))
            .and_then(|a| a.as_str());
        let name = algorithm.or(scene_alg).unwrap_or("pt");
        if overrides.contains_key("algorithm") {
            return Err(SettingsError::Invalid {
                field: Some(format!("{prefix}.algorithm")),
                message: "`algorithm` is chosen by name, not as a parameter".into(),
            });
        }
        let alg = registry::find(name)
            .ok_or_else(|| SettingsError::UnknownAlgorithm(name.to_string()))?;
        // Every parameter is an f32 or an integer: one beyond f32 would be infinity.
        if let Some((path, n)) = crate::json_numbers::value_beyond_f32(overrides) {
            return Err(SettingsError::Invalid {
                field: Some(format!("{prefix}.{path}")),
                message: format!(
                    "{prefix}.{path}: number {n} is out of range (at most {})",
                    crate::json_numbers::f32_limit()
                ),
            });
        }
        let scene = scene_params(alg, scene_alg, scene_default);
        let mut params = scene.clone();
        params.extend(overrides.clone());
        let sources = Sources {
            prefix,
            overrides,
            scene: &scene,
        };
        let settings = alg.parse(params).map_err(|e| sources.unparsed(e))?;
        settings.validate().map_err(|e| sources.refuse(e))?;
        Ok(settings)
    }

    /// An algorithm's parameters with their default values (the settings a job gets
    /// when it sets none), without the `algorithm` tag.
    pub fn defaults(algorithm: &str) -> Result<ParamMap, SettingsError> {
        let alg = registry::find(algorithm)
            .ok_or_else(|| SettingsError::UnknownAlgorithm(algorithm.to_string()))?;
        alg.defaults().map_err(|e| SettingsError::Invalid {
            field: None,
            message: e.to_string(),
        })
    }

    /// Refuses settings that contradict what the scene holds. Every algorithm renders
    /// media; only `pt`'s albedo roulette assumes there are none.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), ParamError> {
        if let (Settings::Pt(s), true) = (self, scene.has_media) {
            if s.roulette == pt::Roulette::Albedo {
                return Err(ParamError::new(
                    "roulette",
                    "roulette = albedo applies to scenes without media; this scene has media, where pt renders as volpath with throughput roulette (leave roulette out, or set it to throughput)",
                ));
            }
        }
        Ok(())
    }

    fn validate(&self) -> Result<(), ParamError> {
        let (name, params) = self.parts();
        params.validate(name)
    }

    /// The peak memory of a job with these settings on `scene`, by part (module
    /// [`memory`]): the algorithm's own stores, then the film, exact sums and noise
    /// estimate every job keeps (twice the sums for a chained integrator, whose sums
    /// are rebuilt each iteration, and no noise estimate).
    pub fn memory(&self, scene: &Scene) -> memory::Estimate {
        let f = memory::Facts::new(scene);
        let (name, params) = self.parts();
        let mut e = params.memory(name, &f);
        let (w, h) = (scene.width(), scene.height());
        let layers = self.layers();
        let chained = matches!(params.film(name), FilmUse::Chained);
        let sums = crate::film::ExactSums::bytes_for(w, h, layers) * (1 + chained as u64);
        // The noise estimate, made at each snapshot (none for a chained film).
        let noise = crate::film::Noise::bytes_for(w, h) * !chained as u64;
        let film =
            crate::film::Film::bytes_for(w, h, layers) + sums + noise + self.filter_bytes(scene);
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
        let (name, params) = self.parts();
        let splats = match params.film(name) {
            FilmUse::Chained => return 0,
            FilmUse::Adds { splats, .. } => splats,
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
        let (name, params) = self.parts();
        match params.film(name) {
            FilmUse::Adds { layers, .. } => layers,
            FilmUse::Chained => 0,
        }
    }

    /// The radius layers (`radii`) a job with these settings renders: each layer's
    /// name, initial merge radius and initial medium radius (None: the job's
    /// `medium_radius`, or the one derived from the scene). Each is a whole image, as a
    /// job with that radius renders it.
    pub fn radius_layers(&self) -> Vec<(String, f32, Option<f32>)> {
        let (Settings::Bpm(s) | Settings::Vcm(s) | Settings::Upbp(s)) = self else {
            return Vec::new();
        };
        let medium = |i: usize| s.layer_radii(i)[1];
        let layer = |(i, &r): (usize, &f32)| (bidir::radius_layer_name(i), r, medium(i));
        s.radii.iter().enumerate().map(layer).collect()
    }

    /// Whether the radius layers are not what separate jobs of one radius each (these
    /// settings without `radii`) would render: their `selection: auto` differs.
    pub fn layers_differ_from_separate_jobs(&self) -> bool {
        let (name, Settings::Bpm(s) | Settings::Vcm(s) | Settings::Upbp(s)) = (self.name(), self)
        else {
            return false;
        };
        s.radii_change_selection(s.technique_of(name))
    }

    pub fn build(&self) -> Box<dyn Integrator> {
        let (name, params) = self.parts();
        params.build(name)
    }
}

/// What the scene's defaults give algorithm `alg`: all of them when they name it, else
/// the shared ones that it takes.
fn scene_params(
    alg: &registry::Algorithm,
    scene_alg: Option<&str>,
    scene_default: Option<&serde_json::Value>,
) -> ParamMap {
    let Some(serde_json::Value::Object(m)) = scene_default else {
        return ParamMap::new();
    };
    if scene_alg == Some(alg.name) {
        let mut own = m.clone();
        own.remove("algorithm");
        return own;
    }
    let takes = alg.defaults().unwrap_or_default();
    m.iter()
        .filter(|(k, _)| SHARED_PARAMS.contains(&k.as_str()) && takes.contains_key(*k))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
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
        let err = Settings::for_scene(Some("pt"), &scene, &params("albedo")).unwrap_err();
        assert_eq!(err.field(), Some("params.roulette"), "{err}");
        assert!(
            err.to_string().contains("roulette = albedo applies"),
            "{err}"
        );
        let throughput = Settings::resolve(Some("pt"), None, &params("throughput")).unwrap();
        throughput.check_scene(&scene).unwrap();
    }
}
