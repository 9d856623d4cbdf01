//! Participating media and phase functions, as a scene file describes them.

use super::shape::TransformDesc;
use super::{one, one3, V3};
use serde::{Deserialize, Serialize};

/// Participating media (per unit length of scene units). Shapes name them as
/// `interior` / `exterior`, the camera as `medium`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MediumDesc {
    /// Constant coefficients: `sigma_a` + `sigma_s`, or `sigma_t` + `albedo`.
    Homogeneous {
        #[serde(default)]
        sigma_a: Option<V3>,
        #[serde(default)]
        sigma_s: Option<V3>,
        #[serde(default)]
        sigma_t: Option<V3>,
        #[serde(default)]
        albedo: Option<V3>,
        /// Multiplies the coefficients (a unit change).
        #[serde(default = "one")]
        scale: f32,
        #[serde(default)]
        phase: PhaseDesc,
    },
    /// A voxel grid of density: sigma_t(x) = density(x) * sigma_t * scale, trilinear
    /// between voxel centres. `file` is a Mitsuba `.vol`, an OpenVDB `.vdb` (grid
    /// `grid`, default "density") or a `.json` header of a raw float32 file.
    Grid {
        file: String,
        #[serde(default)]
        grid: Option<String>,
        sigma_t: V3,
        #[serde(default = "one3")]
        albedo: V3,
        /// Optional grey albedo grid (same formats), multiplying `albedo`.
        #[serde(default)]
        albedo_file: Option<String>,
        #[serde(default = "one")]
        scale: f32,
        /// World box of the volume (or give `transform`; grids whose file has
        /// bounds may omit both).
        #[serde(default)]
        bounds: Option<BoundsDesc>,
        /// Maps the unit cube [0, 1]^3 to the world.
        #[serde(default)]
        transform: Option<TransformDesc>,
        #[serde(default)]
        phase: PhaseDesc,
    },
    /// Fractal Perlin noise: density = clamp((1/2 + v - threshold) / (1 - threshold),
    /// 0, 1), v the octave sum divided by the sum of octave amplitudes (|v| < ~0.6).
    Procedural {
        sigma_t: V3,
        #[serde(default = "one3")]
        albedo: V3,
        #[serde(default = "one")]
        scale: f32,
        #[serde(default = "default_octaves")]
        octaves: u32,
        #[serde(default = "two")]
        lacunarity: f32,
        #[serde(default = "half")]
        gain: f32,
        /// Cycles of the first octave across the volume.
        #[serde(default = "four")]
        frequency: f32,
        #[serde(default)]
        seed: u64,
        #[serde(default)]
        threshold: f32,
        /// World box of the volume (or give `transform`; grids whose file has
        /// bounds may omit both).
        #[serde(default)]
        bounds: Option<BoundsDesc>,
        /// Maps the unit cube [0, 1]^3 to the world.
        #[serde(default)]
        transform: Option<TransformDesc>,
        #[serde(default)]
        phase: PhaseDesc,
    },
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoundsDesc {
    pub min: V3,
    pub max: V3,
}

/// Phase functions; isotropic by default.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum PhaseDesc {
    #[default]
    Isotropic,
    /// Henyey-Greenstein with asymmetry g in (-1, 1) (g > 0 scatters forward).
    #[serde(alias = "hg")]
    HenyeyGreenstein {
        g: f32,
    },
    /// Schlick's approximation with k in (-1, 1) (k ~ 1.55 g - 0.55 g^3).
    Schlick {
        k: f32,
    },
    Rayleigh,
}

fn default_octaves() -> u32 {
    4
}
fn two() -> f32 {
    2.0
}
fn half() -> f32 {
    0.5
}
fn four() -> f32 {
    4.0
}
