//! Shape checks: references to materials and media, transforms, geometry.
//! Imports `checks`.

use super::super::error::{Result, SceneError};
use super::super::format::*;
use super::checks::*;

pub(super) fn validate_shape(scene: &SceneFile, path: &str, s: &ShapeDesc) -> Result<()> {
    let c = &s.common;
    if !scene.materials.contains_key(&c.material) {
        return Err(SceneError::new(
            format!("{path}.material"),
            format!("unknown material \"{}\"", c.material),
        ));
    }
    if let Some(e) = &c.emission {
        non_negative_param(&format!("{path}.emission.radiance"), &e.radiance)?;
        if matches!(
            scene.materials.get(&c.material),
            Some(MaterialDesc::Null {})
        ) {
            return Err(SceneError::new(
                format!("{path}.emission"),
                "a `null` (index-matched) boundary cannot emit: rays pass through it unseen",
            ));
        }
    }
    if let Some(m) = &c.interior {
        medium_ref(scene, &format!("{path}.interior"), m)?;
    }
    if let Some(m) = &c.exterior {
        medium_ref(scene, &format!("{path}.exterior"), m)?;
    }
    if let Some(t) = &c.transform {
        validate_transform(&format!("{path}.transform"), t)?;
    }
    validate_geometry(path, &s.geometry)
}

pub fn validate_transform(path: &str, t: &TransformDesc) -> Result<()> {
    if t.matrix.is_some() && (t.translate.is_some() || !t.rotate.is_empty() || t.scale.is_some()) {
        return Err(SceneError::new(
            path,
            "give either `matrix` or translate/rotate/scale, not both",
        ));
    }
    if let Some(m) = &t.matrix {
        if m.iter().any(|x| !x.is_finite()) {
            return Err(SceneError::new(format!("{path}.matrix"), "is not finite"));
        }
    }
    if let Some(v) = t.translate {
        finite3(&format!("{path}.translate"), v)?;
    }
    for (i, r) in t.rotate.iter().enumerate() {
        nonzero3(&format!("{path}.rotate[{i}].axis"), r.axis)?;
        in_range(
            &format!("{path}.rotate[{i}].angle"),
            r.angle,
            -1e6,
            1e6,
            "degrees",
        )?;
    }
    match t.scale {
        Some(Scale::Uniform(s)) if !(s.is_finite() && s != 0.0) => Err(SceneError::new(
            format!("{path}.scale"),
            "must be finite and non-zero",
        )),
        Some(Scale::PerAxis(v)) if !v.iter().all(|x| x.is_finite() && *x != 0.0) => Err(
            SceneError::new(format!("{path}.scale"), "must be finite and non-zero"),
        ),
        _ => Ok(()),
    }
}

pub(super) fn validate_geometry(path: &str, g: &GeometryDesc) -> Result<()> {
    match g {
        GeometryDesc::Sphere { center, radius } => {
            finite3(&format!("{path}.center"), *center)?;
            positive(&format!("{path}.radius"), *radius)
        }
        GeometryDesc::Rectangle { corners } => {
            for (i, c) in corners.iter().flatten().enumerate() {
                finite3(&format!("{path}.corners[{i}]"), *c)?;
            }
            Ok(())
        }
        GeometryDesc::Cube {} | GeometryDesc::Disk {} => Ok(()),
        GeometryDesc::Mesh {
            positions,
            indices,
            normals,
            uvs,
        } => {
            for (i, p) in positions.iter().enumerate() {
                finite3(&format!("{path}.positions[{i}]"), *p)?;
            }
            for (i, tri) in indices.iter().enumerate() {
                if let Some(&bad) = tri.iter().find(|&&k| k as usize >= positions.len()) {
                    return Err(SceneError::new(
                        format!("{path}.indices[{i}]"),
                        format!("vertex {bad} out of range ({} positions)", positions.len()),
                    ));
                }
            }
            if let Some(n) = normals {
                if n.len() != positions.len() {
                    return Err(SceneError::new(
                        format!("{path}.normals"),
                        format!("{} normals for {} positions", n.len(), positions.len()),
                    ));
                }
                for (i, v) in n.iter().enumerate() {
                    nonzero3(&format!("{path}.normals[{i}]"), *v)?;
                }
            }
            if let Some(t) = uvs {
                if t.len() != positions.len() {
                    return Err(SceneError::new(
                        format!("{path}.uvs"),
                        format!("{} uvs for {} positions", t.len(), positions.len()),
                    ));
                }
                if let Some(i) = t.iter().position(|c| !c.iter().all(|x| x.is_finite())) {
                    return Err(SceneError::new(
                        format!("{path}.uvs[{i}]"),
                        "must be finite",
                    ));
                }
            }
            Ok(())
        }
        GeometryDesc::Obj { filename } | GeometryDesc::Ply { filename } => {
            crate::scene::files::check_relative(&format!("{path}.filename"), filename).map(|_| ())
        }
    }
}
