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

/// Reads and parses a scene file. Errors name it by its file name alone: the server
/// keeps uploads under its data folder, whose path is none of a client's business.
pub fn read_scene_file(path: &Path) -> Result<SceneFile> {
    let shown = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    );
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::new(&shown, e.to_string()))?;
    parse_scene(&text)
        .map_err(|e| SceneError::new(if e.path.is_empty() { shown } else { e.path }, e.message))
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

impl MeshData {
    /// Every index names a vertex and normals (if any) match the vertices, so that
    /// compiling the mesh cannot index out of bounds whatever the file said.
    fn checked(self, err: impl Fn(String) -> SceneError) -> Result<MeshData> {
        let n = self.positions.len();
        if let Some(bad) = self.indices.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(err(format!("face index {bad} out of range ({n} vertices)")));
        }
        if self.normals.as_ref().is_some_and(|ns| ns.len() != n) {
            return Err(err("normals do not match the vertices".into()));
        }
        Ok(self)
    }
}

/// A mesh file's error: the scene field, then the file as the scene names it.
fn mesh_error<'a>(field: &'a str, name: &'a str) -> impl Fn(String) -> SceneError + 'a {
    move |m| SceneError::new(field, format!("\"{name}\": {m}"))
}

/// Reads the OBJ file at `path`, which the scene names `name` in `field`.
pub fn load_obj(path: &Path, field: &str, name: &str) -> Result<MeshData> {
    let file = std::fs::File::open(path).map_err(|e| mesh_error(field, name)(e.to_string()))?;
    parse_obj(std::io::BufReader::new(file), field, name)
}

/// Parses OBJ text. `mtllib` lines are ignored: caustic takes materials from the
/// scene, and the loader would otherwise open whatever path a line names
/// (`mtllib /etc/passwd`, or `/dev/zero`, which never ends).
pub fn parse_obj(mut reader: impl std::io::BufRead, field: &str, name: &str) -> Result<MeshData> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let no_materials = |_: &Path| Ok((Vec::new(), Default::default()));
    let (models, _) = tobj::load_obj_buf(&mut reader, &opts, no_materials)
        .map_err(|e| mesh_error(field, name)(e.to_string()))?;
    let mut out = MeshData {
        positions: Vec::new(),
        normals: Some(Vec::new()),
        indices: Vec::new(),
    };
    for m in models {
        append_model(&mut out, m.mesh);
    }
    out.checked(mesh_error(field, name))
}

fn append_model(out: &mut MeshData, mesh: tobj::Mesh) {
    let base = out.positions.len() as u32;
    let has_normals = mesh.normals.len() == mesh.positions.len();
    match (&mut out.normals, has_normals) {
        (Some(n), true) => n.extend(
            mesh.normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        ),
        _ => out.normals = None,
    }
    out.positions.extend(
        mesh.positions
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2])),
    );
    out.indices.extend(
        mesh.indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]].map(|i| i.saturating_add(base))),
    );
}

/// Reads the PLY file at `path`, which the scene names `name` in `field`.
pub fn load_ply(path: &Path, field: &str, name: &str) -> Result<MeshData> {
    let file = std::fs::File::open(path).map_err(|e| mesh_error(field, name)(e.to_string()))?;
    parse_ply(std::io::BufReader::new(file), field, name)
}

/// Parses a PLY file (ASCII or binary).
pub fn parse_ply(mut reader: impl std::io::BufRead, field: &str, name: &str) -> Result<MeshData> {
    use ply_rs::parser::Parser;
    use ply_rs::ply::{DefaultElement, Property};
    let err = mesh_error(field, name);
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
    MeshData {
        positions,
        normals,
        indices,
    }
    .checked(err)
}
