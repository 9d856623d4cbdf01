//! Material parameters that may vary over a surface: in the scene file a number
//! (grey), an `[r, g, b]` triple, or a texture object (`{"type": "bitmap", ...}`), as
//! Mitsuba lets any reflectance be a texture.

use super::V3;
use crate::material::texture::{Filter, Wrap};
use serde::de::{self, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;

/// A colour (or grey) parameter: a constant or a texture.
#[derive(Clone, Debug, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Param {
    Value(V3),
    Texture(Box<TextureDesc>),
}

impl Param {
    pub const fn grey(v: f32) -> Param {
        Param::Value([v; 3])
    }

    /// The value when it is a constant.
    pub fn constant(&self) -> Option<V3> {
        match self {
            Param::Value(v) => Some(*v),
            Param::Texture(_) => None,
        }
    }

    pub fn is_texture(&self) -> bool {
        matches!(self, Param::Texture(_))
    }

    /// The image files the parameter names, each with its field (`field.filename`,
    /// `field.texture.filename`, ...).
    pub fn filenames_mut<'a>(&'a mut self, field: String, out: &mut Vec<(String, &'a mut String)>) {
        let Param::Texture(t) = self else {
            return;
        };
        match &mut **t {
            TextureDesc::Bitmap { filename, .. } => {
                out.push((format!("{field}.filename"), filename))
            }
            TextureDesc::Checkerboard { color0, color1, .. } => {
                color0.filenames_mut(format!("{field}.color0"), out);
                color1.filenames_mut(format!("{field}.color1"), out);
            }
            TextureDesc::Scale { texture, scale } => {
                texture.filenames_mut(format!("{field}.texture"), out);
                scale.filenames_mut(format!("{field}.scale"), out);
            }
        }
    }
}

impl From<V3> for Param {
    fn from(v: V3) -> Self {
        Param::Value(v)
    }
}

/// Textures of the scene format, as Mitsuba 3 names them.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum TextureDesc {
    /// An image file (PNG, JPEG, OpenEXR, Radiance HDR) relative to the scene file.
    /// 8-bit images are sRGB-decoded unless `raw`; (u, v) = (0, 0) is the top-left
    /// corner.
    Bitmap {
        filename: String,
        #[serde(default)]
        raw: bool,
        #[serde(default = "bilinear")]
        filter: Filter,
        #[serde(default = "repeat")]
        wrap: Wrap,
        /// `[[a, b, c], [d, e, f]]`: (u, v) becomes (a u + b v + c, d u + e v + f).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        to_uv: Option<[[f32; 3]; 2]>,
    },
    /// `color0` where the fractional parts of u and v are on the same side of 1/2.
    Checkerboard {
        #[serde(default = "dark")]
        color0: Param,
        #[serde(default = "darker")]
        color1: Param,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        to_uv: Option<[[f32; 3]; 2]>,
    },
    /// `texture` times `scale`.
    Scale { texture: Param, scale: Param },
}

fn bilinear() -> Filter {
    Filter::Bilinear
}
fn repeat() -> Wrap {
    Wrap::Repeat
}
// Mitsuba 3's checkerboard defaults.
fn dark() -> Param {
    Param::grey(0.4)
}
fn darker() -> Param {
    Param::grey(0.2)
}

impl<'de> Deserialize<'de> for Param {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(ParamVisitor)
    }
}

struct ParamVisitor;

impl<'de> Visitor<'de> for ParamVisitor {
    type Value = Param;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number, an [r, g, b] array or a texture object")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Param, E> {
        let x = v as f32;
        if v.is_finite() && !x.is_finite() {
            return Err(E::custom(format!("number {v} is out of range")));
        }
        Ok(Param::grey(x))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Param, E> {
        self.visit_f64(v as f64)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Param, E> {
        self.visit_f64(v as f64)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Param, A::Error> {
        V3::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(Param::Value)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Param, A::Error> {
        TextureDesc::deserialize(de::value::MapAccessDeserializer::new(map))
            .map(|t| Param::Texture(Box::new(t)))
    }
}

/// A scalar parameter (roughness, a blend's weight): a number or a texture (whose
/// colour counts by its luminance). Held as a grey [`Param`], so that textures,
/// validation and file references treat it as any other parameter; it reads and
/// writes as a number.
#[derive(Clone, Debug, PartialEq)]
pub struct Scalar(pub Param);

impl Scalar {
    pub const fn value(v: f32) -> Scalar {
        Scalar(Param::grey(v))
    }

    /// The value when it is a constant.
    pub fn constant(&self) -> Option<f32> {
        self.0.constant().map(|v| v[0])
    }
}

impl From<f32> for Scalar {
    fn from(v: f32) -> Self {
        Scalar::value(v)
    }
}

impl Serialize for Scalar {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match &self.0 {
            Param::Value(v) => s.serialize_f32(v[0]),
            Param::Texture(t) => t.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Scalar {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(ScalarVisitor)
    }
}

struct ScalarVisitor;

impl<'de> Visitor<'de> for ScalarVisitor {
    type Value = Scalar;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number or a texture object")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Scalar, E> {
        ParamVisitor.visit_f64(v).map(Scalar)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Scalar, E> {
        self.visit_f64(v as f64)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Scalar, E> {
        self.visit_f64(v as f64)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Scalar, A::Error> {
        ParamVisitor.visit_map(map).map(Scalar)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Param, serde_json::Error> {
        serde_json::from_str(s)
    }

    #[test]
    fn numbers_arrays_and_textures() {
        assert_eq!(parse("0.5").unwrap(), Param::grey(0.5));
        assert_eq!(parse("1").unwrap(), Param::grey(1.0));
        assert_eq!(
            parse("[0.1, 0.2, 0.3]").unwrap(),
            Param::Value([0.1, 0.2, 0.3])
        );
        let t = parse(r#"{"type": "checkerboard", "color1": [0, 0.5, 1]}"#).unwrap();
        let Param::Texture(t) = t else { panic!() };
        assert_eq!(
            *t,
            TextureDesc::Checkerboard {
                color0: Param::grey(0.4),
                color1: Param::Value([0.0, 0.5, 1.0]),
                to_uv: None,
            }
        );
        let b = parse(r#"{"type": "bitmap", "filename": "a.png", "raw": true}"#).unwrap();
        let Param::Texture(b) = b else { panic!() };
        assert!(matches!(
            *b,
            TextureDesc::Bitmap {
                raw: true,
                filter: Filter::Bilinear,
                wrap: Wrap::Repeat,
                ..
            }
        ));
    }

    /// A round trip through JSON keeps the value (scenes written by the importer).
    #[test]
    fn serializes_as_it_parses() {
        for s in [
            "[0.1,0.2,0.3]",
            r#"{"type":"scale","texture":{"type":"bitmap","filename":"x.exr","raw":false,"filter":"nearest","wrap":"clamp","to_uv":[[2.0,0.0,0.0],[0.0,2.0,0.5]]},"scale":[2.0,2.0,2.0]}"#,
        ] {
            let p = parse(s).unwrap();
            assert_eq!(serde_json::to_string(&p).unwrap(), s);
        }
    }

    #[test]
    fn scalars_are_numbers_or_textures() {
        let s: Scalar = serde_json::from_str("0.25").unwrap();
        assert_eq!(s, Scalar::value(0.25));
        assert_eq!(serde_json::to_string(&s).unwrap(), "0.25");
        let t = r#"{"type":"checkerboard","color0":0.1,"color1":0.3}"#;
        let s: Scalar = serde_json::from_str(t).unwrap();
        assert!(s.0.is_texture());
        let back: Scalar = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
        let e = serde_json::from_str::<Scalar>("[1, 2, 3]")
            .unwrap_err()
            .to_string();
        assert!(e.contains("a number or a texture object"), "{e}");
    }

    #[test]
    fn errors_say_what_is_wrong() {
        let e = parse(r#""red""#).unwrap_err().to_string();
        assert!(
            e.contains("a number, an [r, g, b] array or a texture object"),
            "{e}"
        );
        let e = parse("[1, 2]").unwrap_err().to_string();
        assert!(e.contains("length 2"), "{e}");
        let e = parse(r#"{"type": "bitmap"}"#).unwrap_err().to_string();
        assert!(e.contains("missing field `filename`"), "{e}");
        let e = parse(r#"{"type": "marble"}"#).unwrap_err().to_string();
        assert!(e.contains("unknown variant `marble`"), "{e}");
        let e = parse(r#"{"type": "bitmap", "filename": "a.png", "gamma": 2}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `gamma`"), "{e}");
        let e = parse("1e39").unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
    }
}
