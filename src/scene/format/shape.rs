//! Shapes as a scene file describes them: geometry, transform, emission and the
//! fields every shape has. Imports `param`.

use super::param::Param;
use super::{one, V3};
use serde::{Deserialize, Serialize};

/// A rotation: `axis` and `angle` in degrees (right-handed).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    pub axis: V3,
    pub angle: f32,
}

/// Either a row-major 4x4 `matrix`, or `translate * rotate[0] * rotate[1] ... * scale`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(default)]
    pub matrix: Option<[f32; 16]>,
    #[serde(default)]
    pub translate: Option<V3>,
    /// Applied right to left, like matrices: the last rotation acts first.
    #[serde(default)]
    pub rotate: Vec<Rotation>,
    /// A number (uniform) or three numbers.
    #[serde(default)]
    pub scale: Option<Scale>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    PerAxis(V3),
}

/// Area emission of a shape: Lambertian, on the side its normal points to.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// A colour, or a texture over the shape's (u, v) (Mitsuba's textured `area`).
    pub radiance: Param,
    #[serde(default)]
    pub two_sided: bool,
}

/// A shape: its geometry (tagged by `type`) and the fields every shape has.
/// Deserialised by hand because serde cannot combine `flatten` with
/// `deny_unknown_fields`, and a misspelt field must be an error.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShapeDesc {
    #[serde(flatten)]
    pub geometry: GeometryDesc,
    #[serde(flatten)]
    pub common: ShapeCommon,
}

/// Fields every shape has.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ShapeCommon {
    /// Name of a material in `materials`.
    pub material: String,
    #[serde(default)]
    pub transform: Option<TransformDesc>,
    #[serde(default)]
    pub emission: Option<EmissionDesc>,
    /// Reverses the normals (and so the emitting / front side).
    #[serde(default)]
    pub flip_normals: bool,
    /// Medium on the side opposite the normal.
    #[serde(default)]
    pub interior: Option<String>,
    /// Medium on the side the normal points to.
    #[serde(default)]
    pub exterior: Option<String>,
    /// Optional label for error messages and statistics.
    #[serde(default)]
    pub name: Option<String>,
}

const COMMON_SHAPE_FIELDS: [&str; 7] = [
    "material",
    "transform",
    "emission",
    "flip_normals",
    "interior",
    "exterior",
    "name",
];

impl<'de> Deserialize<'de> for ShapeDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut geometry = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let mut common = serde_json::Map::new();
        for key in COMMON_SHAPE_FIELDS {
            if let Some(v) = geometry.remove(key) {
                common.insert(key.to_string(), v);
            }
        }
        let common = ShapeCommon::deserialize(serde_json::Value::Object(common))
            .map_err(D::Error::custom)?;
        let geometry = GeometryDesc::deserialize(serde_json::Value::Object(geometry))
            .map_err(D::Error::custom)?;
        Ok(ShapeDesc { geometry, common })
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum GeometryDesc {
    /// Analytic sphere (not tessellated). A transform may only translate, rotate and
    /// scale uniformly.
    Sphere {
        #[serde(default)]
        center: V3,
        #[serde(default = "one")]
        radius: f32,
    },
    /// A quad. With `corners` (counter-clockwise seen from the front), the quad is
    /// exactly those four points; without, it is [-1,1]^2 at z = 0 facing +z.
    Rectangle {
        #[serde(default)]
        corners: Option<[V3; 4]>,
    },
    /// [-1,1]^3 with outward normals. (Struct variants with no fields, so that serde
    /// refuses unknown fields on them too.)
    Cube {},
    /// Unit disk at z = 0 facing +z (analytic, not tessellated).
    Disk {},
    /// Inline triangle mesh.
    Mesh {
        positions: Vec<V3>,
        /// Triangles as vertex index triples, counter-clockwise = front.
        indices: Vec<[u32; 3]>,
        #[serde(default)]
        normals: Option<Vec<V3>>,
        /// Texture coordinates per vertex, Mitsuba's convention (v grows downwards
        /// in the image).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        uvs: Option<Vec<[f32; 2]>>,
    },
    /// Wavefront OBJ file, relative to the scene file.
    Obj { filename: String },
    /// PLY file (ASCII or binary), relative to the scene file.
    Ply { filename: String },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_round_trip_through_json() {
        let text = r#"{"type":"sphere","center":[1,2,3],"radius":0.5,"material":"m",
            "emission":{"radiance":[1,1,1]},"interior":"fog"}"#;
        let s: ShapeDesc = serde_json::from_str(text).unwrap();
        let back: ShapeDesc = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(s, back);
    }
}
