//! Reading a scene file and the assets it names. File references are relative to the
//! scene's folder and may not leave it: servers accept uploaded bundles.

use super::error::{Result, SceneError};
use super::format::{Scale, SceneFile, TransformDesc};
use crate::math::{Mat4, Quat, Vec3};
use std::path::{Component, Path, PathBuf};

/// Parses scene JSON; serde errors carry the JSON path of the field.
pub fn parse_scene(text: &str) -> Result<SceneFile> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        SceneError::new(path, e.inner().to_string())
    })
}

pub fn read_scene_file(path: &Path) -> Result<SceneFile> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(path.display().to_string(), e.to_string()))?;
    parse_scene(&text).map_err(|e| {
        SceneError::new(
            if e.path.is_empty() {
                path.display().to_string()
            } else {
                e.path
            },
            e.message,
        )
    })
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

/// Triangle soup with optional per-vertex normals.
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub indices: Vec<[u32; 3]>,
}

pub fn load_obj(path: &Path, field: &str) -> Result<MeshData> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &opts)
        .map_err(|e| SceneError::new(field, format!("{}: {e}", path.display())))?;
    let mut out = MeshData {
        positions: Vec::new(),
        normals: Some(Vec::new()),
        indices: Vec::new(),
    };
    for m in models {
        let mesh = m.mesh;
        let base = out.positions.len() as u32;
        let pos: Vec<Vec3> = mesh
            .positions
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let has_normals = mesh.normals.len() == mesh.positions.len();
        match (&mut out.normals, has_normals) {
            (Some(n), true) => n.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2])),
            ),
            _ => out.normals = None,
        }
        out.positions.extend(pos);
        out.indices.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|c| [c[0] + base, c[1] + base, c[2] + base]),
        );
    }
    Ok(out)
}

pub fn load_ply(path: &Path, field: &str) -> Result<MeshData> {
    use ply_rs::parser::Parser;
    use ply_rs::ply::{DefaultElement, Property};
    let err = |m: String| SceneError::new(field, format!("{}: {m}", path.display()));
    let file = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
    let mut reader = std::io::BufReader::new(file);
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut reader)
        .map_err(|e| err(e.to_string()))?;
    let num = |p: Option<&Property>| -> Option<f32> {
        match p? {
            Property::Float(v) => Some(*v),
            Property::Double(v) => Some(*v as f32),
            Property::Int(v) => Some(*v as f32),
            Property::UInt(v) => Some(*v as f32),
            Property::Short(v) => Some(*v as f32),
            Property::UShort(v) => Some(*v as f32),
            Property::Char(v) => Some(*v as f32),
            Property::UChar(v) => Some(*v as f32),
            _ => None,
        }
    };
    let verts = ply
        .payload
        .get("vertex")
        .ok_or_else(|| err("no vertex element".into()))?;
    let mut positions = Vec::with_capacity(verts.len());
    let mut normals = Some(Vec::with_capacity(verts.len()));
    for v in verts {
        let p = (num(v.get("x")), num(v.get("y")), num(v.get("z")));
        let (Some(x), Some(y), Some(z)) = p else {
            return Err(err("vertex without numeric x, y, z".into()));
        };
        positions.push(Vec3::new(x, y, z));
        match (num(v.get("nx")), num(v.get("ny")), num(v.get("nz"))) {
            (Some(a), Some(b), Some(c)) => {
                if let Some(n) = normals.as_mut() {
                    n.push(Vec3::new(a, b, c))
                }
            }
            _ => normals = None,
        }
    }
    let mut indices = Vec::new();
    for f in ply.payload.get("face").map(|f| f.as_slice()).unwrap_or(&[]) {
        let list: Vec<u32> = match f.get("vertex_indices").or_else(|| f.get("vertex_index")) {
            Some(Property::ListInt(l)) => l.iter().map(|&i| i as u32).collect(),
            Some(Property::ListUInt(l)) => l.clone(),
            Some(Property::ListUChar(l)) => l.iter().map(|&i| i as u32).collect(),
            Some(Property::ListShort(l)) => l.iter().map(|&i| i as u32).collect(),
            Some(Property::ListUShort(l)) => l.iter().map(|&i| i as u32).collect(),
            _ => return Err(err("face without a vertex_indices list".into())),
        };
        if list.iter().any(|&i| i as usize >= positions.len()) {
            return Err(err("face index out of range".into()));
        }
        // Polygons become triangle fans.
        for k in 1..list.len().saturating_sub(1) {
            indices.push([list[0], list[k], list[k + 1]]);
        }
    }
    Ok(MeshData {
        positions,
        normals,
        indices,
    })
}
