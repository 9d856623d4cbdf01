//! Reading a scene file: JSON, or Mitsuba 3 XML through the importer; and the matrix
//! of a scene's transforms. May import `format`, `error`, `files`, `meshes` and
//! `mitsuba`; the mesh readers and the path checks are re-exported here, where callers
//! have always found them.

use super::error::{Result, SceneError};
use super::format::{Scale, SceneFile, TransformDesc};
use crate::math::{Mat4, Quat, Vec3};
use std::path::Path;

pub use super::files::{check_relative, resolve};
pub use super::meshes::{load_obj, load_ply, parse_obj, parse_ply, MeshData};

/// Parses scene JSON; serde errors carry the JSON path of the field.
/// A number is reported as written when it does not fit its field (every number of
/// a scene is an `f32` or an integer).
pub fn parse_scene(text: &str) -> Result<SceneFile> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let file = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        let message = crate::json_numbers::name_out_of_range(&e.inner().to_string(), text);
        SceneError::new(path, message)
    })?;
    if let Some((path, number)) = crate::json_numbers::beyond_f32(text) {
        return Err(SceneError::new(
            path,
            format!(
                "number {number} is out of range (at most {})",
                crate::json_numbers::f32_limit()
            ),
        ));
    }
    Ok(file)
}

/// Reads and parses a scene file: JSON, or Mitsuba 3 XML (by its `.xml` name or its
/// content), whose import warnings go to the log. Errors name the file by its file
/// name alone: the server keeps uploads under its data folder, whose path is none of
/// a client's business.
pub fn read_scene_file(path: &Path) -> Result<SceneFile> {
    if super::mitsuba::is_xml_path(path) {
        let import = super::mitsuba::import_file(path)?;
        for w in &import.warnings {
            tracing::warn!("{w}");
        }
        return Ok(import.scene);
    }
    let shown = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    );
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::new(&shown, e.to_string()))?;
    parse_scene(&text)
        .map_err(|e| SceneError::new(if e.path.is_empty() { shown } else { e.path }, e.message))
}

/// The 4x4 matrix of a transform: `matrix` is row-major; otherwise
/// translate * rotate[0] * ... * scale.
pub fn transform_matrix(t: Option<&TransformDesc>) -> Mat4 {
    let Some(t) = t else {
        return Mat4::IDENTITY;
    };
    if let Some(m) = t.matrix {
        return Mat4::from_cols_array(&m).transpose();
    }
    let mut m = Mat4::from_translation(t.translate.map_or(Vec3::ZERO, Vec3::from));
    for r in &t.rotate {
        let q = Quat::from_axis_angle(Vec3::from(r.axis).normalize(), r.angle.to_radians());
        m *= Mat4::from_quat(q);
    }
    match t.scale {
        Some(Scale::Uniform(s)) => m *= Mat4::from_scale(Vec3::splat(s)),
        Some(Scale::PerAxis(v)) => m *= Mat4::from_scale(Vec3::from(v)),
        None => {}
    }
    m
}
