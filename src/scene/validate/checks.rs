//! The checks every part of a scene file uses: finite, non-negative and unit
//! colours, ranges, textures, and references to media by name. Imports only `format`.

use super::super::error::{Result, SceneError};
use super::super::format::*;

pub(super) fn finite3(path: &str, v: V3) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("{v:?} is not finite")))
    }
}

pub(super) fn non_negative3(path: &str, v: V3) -> Result<()> {
    finite3(path, v)?;
    if v.iter().all(|&x| x >= 0.0) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("{v:?} has a negative value")))
    }
}

pub(super) fn unit3(path: &str, v: V3) -> Result<()> {
    non_negative3(path, v)?;
    if v.iter().all(|&x| x <= 1.0) {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("{v:?} exceeds 1 (albedo above 1 creates energy)"),
        ))
    }
}

/// A reflectance: a constant within [0, 1], or a texture (whose values are used as
/// the images give them, as in Mitsuba).
pub(super) fn unit_param(path: &str, p: &Param) -> Result<()> {
    match p {
        Param::Value(v) => unit3(path, *v),
        Param::Texture(t) => validate_texture(path, t),
    }
}

/// A non-negative colour, or a texture (an emitter's radiance).
pub(super) fn non_negative_param(path: &str, p: &Param) -> Result<()> {
    match p {
        Param::Value(v) => non_negative3(path, *v),
        Param::Texture(t) => validate_texture(path, t),
    }
}

pub(super) fn validate_texture(path: &str, t: &TextureDesc) -> Result<()> {
    let to_uv = |rows: &Option<[[f32; 3]; 2]>| match rows {
        Some(r) if !r.iter().flatten().all(|x| x.is_finite()) => Err(SceneError::new(
            format!("{path}.to_uv"),
            format!("{r:?} is not finite"),
        )),
        _ => Ok(()),
    };
    let inner = |field: &str, p: &Param| non_negative_param(&format!("{path}.{field}"), p);
    match t {
        TextureDesc::Bitmap {
            filename, to_uv: r, ..
        } => {
            crate::scene::files::check_relative(&format!("{path}.filename"), filename)?;
            to_uv(r)
        }
        TextureDesc::Checkerboard {
            color0,
            color1,
            to_uv: r,
        } => {
            inner("color0", color0)?;
            inner("color1", color1)?;
            to_uv(r)
        }
        TextureDesc::Scale { texture, scale } => {
            inner("texture", texture)?;
            match scale {
                Param::Value(v) => non_negative3(&format!("{path}.scale"), *v),
                Param::Texture(_) => Err(SceneError::new(
                    format!("{path}.scale"),
                    "must be a number or an [r, g, b] array",
                )),
            }
        }
    }
}

pub(super) fn in_range(path: &str, x: f32, lo: f32, hi: f32, what: &str) -> Result<()> {
    if x.is_finite() && x >= lo && x <= hi {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("{x} is out of range: {what}"),
        ))
    }
}

pub(super) fn positive(path: &str, x: f32) -> Result<()> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("{x} must be positive and finite"),
        ))
    }
}

pub(super) fn nonzero3(path: &str, v: V3) -> Result<()> {
    finite3(path, v)?;
    if v.iter().any(|&x| x != 0.0) {
        Ok(())
    } else {
        Err(SceneError::new(path, "must not be the zero vector"))
    }
}

pub(super) fn medium_ref(scene: &SceneFile, path: &str, name: &str) -> Result<()> {
    if scene.media.contains_key(name) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("unknown medium \"{name}\"")))
    }
}
