//! The files a scene names: texture images, mesh files, environment maps, media grids, and the data
//! file a raw grid's header names in turn. One list for whatever needs it: what an
//! upload keeps, what `caustic import` rewrites or copies. And the checks every
//! reference passes: relative, inside the scene's folder (servers accept uploaded
//! bundles). Imports only `format` and `error`.

use super::error::{Result, SceneError};
use super::format::{GeometryDesc, LightDesc, MediumDesc, SceneFile};
use std::path::{Component, Path, PathBuf};

/// Every file reference of a scene, with the field that holds it
/// (`shapes[2].filename`), in the scene's order.
pub fn references_mut(scene: &mut SceneFile) -> Vec<(String, &mut String)> {
    let mut out = Vec::new();
    for (name, m) in scene.materials.iter_mut() {
        for (field, p) in m.params_mut() {
            p.filenames_mut(format!("materials.{name}.{field}"), &mut out);
        }
    }
    for (i, s) in scene.shapes.iter_mut().enumerate() {
        if let GeometryDesc::Obj { filename } | GeometryDesc::Ply { filename } = &mut s.geometry {
            out.push((format!("shapes[{i}].filename"), filename));
        }
        if let Some(e) = &mut s.common.emission {
            (e.radiance).filenames_mut(format!("shapes[{i}].emission.radiance"), &mut out);
        }
    }
    for (i, l) in scene.lights.iter_mut().enumerate() {
        if let LightDesc::Envmap { filename, .. } = l {
            out.push((format!("lights[{i}].filename"), filename));
        }
    }
    for (name, m) in scene.media.iter_mut() {
        if let MediumDesc::Grid {
            file, albedo_file, ..
        } = m
        {
            out.push((format!("media.{name}.file"), file));
            if let Some(albedo) = albedo_file {
                out.push((format!("media.{name}.albedo_file"), albedo));
            }
        }
    }
    out
}

/// The files a scene in `dir` needs, as canonical paths: each reference that
/// exists, and the data file of each raw grid header among them. (Mutable only to
/// share [`references_mut`]; nothing changes.)
pub fn needed(scene: &mut SceneFile, dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for (_, name) in references_mut(scene) {
        let Ok(path) = dir.join(name.as_str()).canonicalize() else {
            continue;
        };
        out.extend(crate::medium::grid_io::raw_data_file(&path));
        out.push(path);
    }
    out
}

/// A relative path as a scene writes it: `/` between components, whatever the system.
pub fn slashed(path: &Path) -> String {
    (path.components())
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// Refuses absolute paths and any `..`: a reference must stay inside the bundle.
pub fn check_relative(field: &str, name: &str) -> Result<PathBuf> {
    let p = Path::new(name);
    if name.is_empty() {
        return Err(SceneError::new(field, "empty file name"));
    }
    for c in p.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            _ => {
                return Err(SceneError::new(
                    field,
                    format!("\"{name}\" must be a relative path inside the scene's folder"),
                ))
            }
        }
    }
    Ok(p.to_path_buf())
}

/// Resolves a reference against the scene folder, also refusing symlinks that lead
/// outside it.
pub fn resolve(base: &Path, field: &str, name: &str) -> Result<PathBuf> {
    let rel = check_relative(field, name)?;
    // `Path::new("scene.json").parent()` is `""`: the scene sits in the current folder.
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let full = base.join(rel);
    let canon_base = base
        .canonicalize()
        .map_err(|e| SceneError::new(field, format!("scene folder: {e}")))?;
    let canon = full
        .canonicalize()
        .map_err(|e| SceneError::new(field, format!("\"{name}\": {e}")))?;
    if !canon.starts_with(&canon_base) {
        return Err(SceneError::new(
            field,
            format!("\"{name}\" leads outside the scene's folder"),
        ));
    }
    Ok(canon)
}
