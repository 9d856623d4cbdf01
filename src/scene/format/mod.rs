//! The scene file format (JSON, `"format": 1`). These serde types are the contract with
//! users: every field is documented here and in README.md. Unknown fields are errors.

mod light;
mod material;
mod medium;
mod param;
mod shape;

pub use crate::film::Filter;
pub use crate::light::LightSelection;
pub use light::LightDesc;
pub use material::{alphas, DistributionDesc, MaterialDesc, DEFAULT_ALPHA};
pub use medium::{BoundsDesc, MediumDesc, PhaseDesc};
pub use param::{Param, Scalar, TextureDesc};
use serde::{Deserialize, Serialize};
pub use shape::{
    EmissionDesc, GeometryDesc, Rotation, Scale, ShapeCommon, ShapeDesc, TransformDesc,
};
use std::collections::BTreeMap;

pub type V3 = [f32; 3];

/// The whole scene file.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Format version; only 1 exists.
    pub format: u32,
    pub camera: CameraDesc,
    pub film: FilmDesc,
    /// Named materials, referred to by shapes.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    /// Named participating media, referred to by shapes' `interior` / `exterior` and by
    /// the camera's `medium`.
    #[serde(default)]
    pub media: BTreeMap<String, MediumDesc>,
    #[serde(default)]
    pub shapes: Vec<ShapeDesc>,
    /// Lights that are not shapes (area lights are shapes with `emission`).
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// How a light is picked for next-event estimation and emission sampling.
    #[serde(default)]
    pub light_selection: LightSelection,
    /// Default integrator settings (`{"algorithm": "pt", ...}`); requests may override.
    #[serde(default)]
    pub integrator: Option<serde_json::Value>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LookAt {
    pub origin: V3,
    pub target: V3,
    pub up: V3,
}

#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FovAxis {
    #[default]
    X,
    Y,
}

/// A pinhole camera, or a thin lens when `aperture_radius` > 0.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    #[serde(rename = "type", default = "default_camera_type")]
    pub kind: String,
    pub look_at: LookAt,
    /// Field of view in degrees across `fov_axis`.
    pub fov: f32,
    #[serde(default)]
    pub fov_axis: FovAxis,
    /// Thin-lens aperture radius in scene units (0 = pinhole).
    #[serde(default)]
    pub aperture_radius: f32,
    /// Distance to the plane in focus; defaults to |target - origin|.
    #[serde(default)]
    pub focus_distance: Option<f32>,
    /// Medium the camera sits in, if any.
    #[serde(default)]
    pub medium: Option<String>,
}

fn default_camera_type() -> String {
    "pinhole".into()
}

/// The pixel filter: a filter's name (`"box"`, one pixel wide, is the default; another
/// name takes its default parameters) or an object, `{"type": "gaussian", "stddev":
/// 0.25}`, with Mitsuba 3's parameters ([`Filter`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterDesc(pub Filter);

impl Serialize for FilterDesc {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0.is_pixel_box() {
            s.serialize_str("box")
        } else {
            self.0.serialize(s)
        }
    }
}

impl<'de> Deserialize<'de> for FilterDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let v = match serde_json::Value::deserialize(d)? {
            serde_json::Value::String(name) => serde_json::json!({ "type": name }),
            v => v,
        };
        Filter::deserialize(v)
            .map(FilterDesc)
            .map_err(D::Error::custom)
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    #[serde(default)]
    pub filter: FilterDesc,
}

fn one() -> f32 {
    1.0
}

fn one3() -> V3 {
    [1.0; 3]
}
