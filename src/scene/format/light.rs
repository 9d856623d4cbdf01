//! Lights that are not shapes, as a scene file describes them. Imports `shape`.

use super::shape::TransformDesc;
use super::{one, V3};
use serde::{Deserialize, Serialize};

/// Lights that are not shapes.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightDesc {
    /// Isotropic point light; `intensity` in W/sr per channel.
    Point { position: V3, intensity: V3 },
    /// Spot light with Mitsuba's falloff: full intensity inside `beam_width`, falling
    /// linearly in angle to zero at `cutoff_angle` (degrees, half-angles).
    Spot {
        position: V3,
        target: V3,
        intensity: V3,
        #[serde(default = "default_cutoff")]
        cutoff_angle: f32,
        /// Defaults to 3/4 of the cutoff angle.
        #[serde(default)]
        beam_width: Option<f32>,
    },
    /// Distant light: photons travel along `direction`; `irradiance` on a surface
    /// facing it.
    Directional { direction: V3, irradiance: V3 },
    /// Uniform radiance from every direction at infinity.
    Constant { radiance: V3 },
    /// Lat-long environment map from an EXR file, importance sampled. With the identity
    /// transform, +y is up and the image centre looks along -z.
    Envmap {
        filename: String,
        #[serde(default = "one")]
        scale: f32,
        #[serde(default)]
        transform: Option<TransformDesc>,
    },
}

fn default_cutoff() -> f32 {
    20.0
}
