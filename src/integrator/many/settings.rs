//! Parameters of the many-light integrators `vpl`, `vrl` and `vbl`. Each struct's doc
//! comment is its parameter table (the README repeats it).

use super::lights::{Kinds, Lights};
use crate::integrator::drive::pixels::tile_memory;
use crate::integrator::many::vrl::Sampler;
use crate::integrator::memory::{paths_driver, Estimate, Facts};
use crate::integrator::paths::store::{store_memory, StorePlan};
use crate::integrator::paths::Tracing;
use crate::integrator::transport::light_paths::check_light_pass;
pub use crate::integrator::transport::light_paths::LightPaths;
use crate::integrator::transport::params::ParamError;
use crate::integrator::transport::params::{check_alpha, check_radius};
use serde::{Deserialize, Deserializer, Serialize};

/// Most virtual lights drawn per query.
pub const MAX_VL_SAMPLES: u32 = 4096;

/// How `vpl` bounds the singularity of a connection's geometry term
/// G = |cos_x| |cos_y| / d^2 (cosines are 1 at medium points).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Clamp {
    /// Unbiased; close virtual lights make bright splotches.
    #[default]
    None,
    /// G capped at `clamp_limit`: biased, the image darker near corners and in media.
    Clamp,
    /// The cap, plus the energy it removed re-estimated by continuing the camera path
    /// (Kollig and Keller 2004): unbiased.
    Compensate,
}

/// `vpl`: virtual point lights.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path in segments (Mitsuba's meaning), over the camera path, the connection and the light path together |
/// | `light_paths` | `{"count": 1024}` | light subpaths per iteration: a number is a multiple of the pixel count, `{"count": N}` an absolute count (at most 2^24) |
/// | `vl_samples` | 8 | virtual lights drawn per gather point and per camera segment in a medium, by a cheap bound on their contribution (the estimate divides by the probability); 0 gathers every one |
/// | `clamp` | `none` | `none` (unbiased), `clamp` (G capped at `clamp_limit`, biased), `compensate` (capped, plus Kollig and Keller's compensation: unbiased) |
/// | `clamp_limit` | none | the cap on G in 1 / (scene unit)^2; none: 1 / (0.1 R)^2 with R the scene's bounding-sphere radius |
/// | `max_vertex_mib` | 512 | budget for the light vertices stored per iteration |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct VplSettings {
    pub max_depth: u32,
    pub light_paths: LightPaths,
    pub vl_samples: u32,
    pub clamp: Clamp,
    pub clamp_limit: Option<f32>,
    pub max_vertex_mib: f32,
}

impl Default for VplSettings {
    fn default() -> Self {
        VplSettings {
            max_depth: 64,
            light_paths: DEFAULT_PATHS,
            vl_samples: 8,
            clamp: Clamp::None,
            clamp_limit: None,
            max_vertex_mib: 512.0,
        }
    }
}

const DEFAULT_PATHS: LightPaths = LightPaths::Count { count: 1024 };

/// `vrl`: virtual ray lights.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | as `vpl` |
/// | `light_paths` | `{"count": 1024}` | as `vpl` |
/// | `vl_samples` | 8 | ray lights (and surface VPLs) drawn per camera segment and per gather point, as `vpl` |
/// | `sampler` | `joint_advanced` | how the pair of points on a ray light and a camera segment is drawn: `uniform`, `exponential`, `uniform_equiangular`, `joint_simple`, `joint_advanced` (a name, or `{"type": "joint_advanced", "nodes": 10}`) |
/// | `max_vertex_mib` | 512 | budget for the light vertices and segments stored per iteration |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct VrlSettings {
    pub max_depth: u32,
    pub light_paths: LightPaths,
    pub vl_samples: u32,
    #[serde(deserialize_with = "sampler_by_name_or_object")]
    pub sampler: Sampler,
    pub max_vertex_mib: f32,
}

impl Default for VrlSettings {
    fn default() -> Self {
        VrlSettings {
            max_depth: 64,
            light_paths: DEFAULT_PATHS,
            vl_samples: 8,
            sampler: DEFAULT_SAMPLER,
            max_vertex_mib: 512.0,
        }
    }
}

const DEFAULT_SAMPLER: Sampler = Sampler::JointAdvanced { nodes: 10 };

/// `vbl`: virtual beam lights, progressive.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth`, `light_paths`, `vl_samples`, `sampler`, `max_vertex_mib` | | as `vrl` |
/// | `radius` | none | beam radius of the first iteration in scene units; overrides `radius_factor` |
/// | `radius_factor` | 0.01 | beam radius of the first iteration as a fraction of the scene's bounding-sphere radius |
/// | `alpha` | 2/3 | r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1): the beam's cross-section (a disk) shrinks as progressive photon mapping's 2D kernel; 1 keeps the radius fixed |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct VblSettings {
    pub max_depth: u32,
    pub light_paths: LightPaths,
    pub vl_samples: u32,
    #[serde(deserialize_with = "sampler_by_name_or_object")]
    pub sampler: Sampler,
    pub max_vertex_mib: f32,
    pub radius: Option<f32>,
    pub radius_factor: f32,
    pub alpha: f32,
}

impl Default for VblSettings {
    fn default() -> Self {
        VblSettings {
            max_depth: 64,
            light_paths: DEFAULT_PATHS,
            vl_samples: 8,
            sampler: DEFAULT_SAMPLER,
            max_vertex_mib: 512.0,
            radius: None,
            radius_factor: 0.01,
            alpha: 2.0 / 3.0,
        }
    }
}

/// A sampler written as its name (`"uniform"`) or as the tagged object.
fn sampler_by_name_or_object<'de, D: Deserializer<'de>>(d: D) -> Result<Sampler, D::Error> {
    let v = serde_json::Value::deserialize(d)?;
    let v = match v {
        serde_json::Value::String(name) => serde_json::json!({ "type": name }),
        other => other,
    };
    serde_json::from_value(v).map_err(serde::de::Error::custom)
}

/// A many-light job's memory (module `memory`): the light pass's store, the virtual
/// lights made of it and their trees, and the camera pass's tile buffers. `vpl` says
/// which lights the method makes ([`Kinds::of_vpl`]); the light pass is given by
/// `max_depth`, `light_paths` and `max_vertex_mib`.
fn memory(vpl: bool, light_pass: (u32, LightPaths, f32), facts: &Facts) -> Estimate {
    let (max_depth, light_paths, max_vertex_mib) = light_pass;
    let kinds = Kinds::of_vpl(vpl);
    let mut e = Estimate::default();
    let paths = light_paths.count(facts.pixels() as usize);
    let multiple = match light_paths {
        LightPaths::Multiple(m) => Some(m),
        LightPaths::Count { .. } => None,
    };
    let driver = paths_driver(multiple, paths, facts);
    let plan = StorePlan {
        tracing: Tracing::STORE,
        paths,
        walk: crate::integrator::pilot::walk(facts, max_depth, true),
        keep_segments: kinds.ray_lights,
        max_vertex_mib,
        driver: &driver,
        budget_field: "max_vertex_mib",
    };
    let stored = store_memory(&mut e, &plan, facts.scene.has_media);
    let vpls = match kinds.medium_vpls {
        true => stored.surface + stored.medium,
        false => stored.surface,
    };
    let rays = if kinds.ray_lights {
        stored.segments
    } else {
        0.0
    };
    e.add("virtual lights", &driver, Lights::bytes_for(vpls, rays));
    tile_memory(&mut e, facts);
    e
}

impl VplSettings {
    pub fn memory(&self, facts: &Facts) -> Estimate {
        memory(
            true,
            (self.max_depth, self.light_paths, self.max_vertex_mib),
            facts,
        )
    }
}

impl VrlSettings {
    pub fn memory(&self, facts: &Facts) -> Estimate {
        memory(
            false,
            (self.max_depth, self.light_paths, self.max_vertex_mib),
            facts,
        )
    }
}

impl VblSettings {
    /// As `vrl`'s: the beams are the ray lights, displaced per gather.
    pub fn memory(&self, facts: &Facts) -> Estimate {
        memory(
            false,
            (self.max_depth, self.light_paths, self.max_vertex_mib),
            facts,
        )
    }
}

/// The checks every many-light method shares: the light pass's, then the number of
/// virtual lights a query draws.
pub(crate) fn check_common(
    max_depth: u32,
    light_paths: LightPaths,
    vl_samples: u32,
    max_vertex_mib: f32,
) -> Result<(), ParamError> {
    check_light_pass(max_depth, light_paths, max_vertex_mib)?;
    if vl_samples > MAX_VL_SAMPLES {
        return Err(ParamError::new(
            "vl_samples",
            format!("vl_samples must be at most {MAX_VL_SAMPLES} (0 gathers every virtual light), got {vl_samples}"),
        ));
    }
    Ok(())
}

impl VplSettings {
    pub fn validate(&self) -> Result<(), ParamError> {
        check_common(
            self.max_depth,
            self.light_paths,
            self.vl_samples,
            self.max_vertex_mib,
        )?;
        if let Some(b) = self.clamp_limit {
            if !(b.is_finite() && b > 0.0) {
                return Err(ParamError::new(
                    "clamp_limit",
                    format!("clamp_limit must be positive and finite, got {b}"),
                ));
            }
            if self.clamp == Clamp::None {
                return Err(ParamError::new(
                    "clamp_limit",
                    "clamp_limit needs clamp: clamp or compensate",
                ));
            }
        }
        Ok(())
    }
}

impl VrlSettings {
    pub fn validate(&self) -> Result<(), ParamError> {
        check_common(
            self.max_depth,
            self.light_paths,
            self.vl_samples,
            self.max_vertex_mib,
        )
    }
}

impl VblSettings {
    pub fn validate(&self) -> Result<(), ParamError> {
        check_common(
            self.max_depth,
            self.light_paths,
            self.vl_samples,
            self.max_vertex_mib,
        )?;
        check_radius(self.radius, self.radius_factor)?;
        check_alpha(self.alpha)
    }
}
