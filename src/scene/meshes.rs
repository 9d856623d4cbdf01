//! Mesh data and its readers: OBJ and PLY files, checked so that compiling a mesh
//! cannot index out of bounds whatever the file said. Below both the scene loader and
//! the Mitsuba importer, which read meshes; imports only `error` and `math`.

use super::error::{Result, SceneError};
use crate::math::{Vec2, Vec3};
use ply_rs::ply::{Property, PropertyAccess};
use std::io::BufRead;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Triangle soup with optional per-vertex normals and texture coordinates.
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    /// Mitsuba's convention: v grows downwards in the image (OBJ's `vt` is flipped).
    pub uvs: Option<Vec<Vec2>>,
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
        if self.uvs.as_ref().is_some_and(|uvs| uvs.len() != n) {
            return Err(err("texture coordinates do not match the vertices".into()));
        }
        Ok(self)
    }
}

/// The message of a panic caught in a third-party reader of `format`.
fn reader_panic(format: &str, panic: Box<dyn std::any::Any + Send>) -> String {
    let text = (panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown error".into());
    format!("the {format} reader failed: {text}")
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
    // tobj's index arithmetic overflows on huge indices (a panic where overflow is
    // checked): an error, like any other malformed file.
    let loaded = catch_unwind(AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut reader, &opts, no_materials).map_err(|e| e.to_string())
    }));
    let (models, _) = loaded
        .unwrap_or_else(|panic| Err(reader_panic("OBJ", panic)))
        .map_err(mesh_error(field, name))?;
    let mut out = MeshData {
        positions: Vec::new(),
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        indices: Vec::new(),
    };
    for m in models {
        append_model(&mut out, m.mesh);
    }
    out.checked(mesh_error(field, name))
}

fn append_model(out: &mut MeshData, mesh: tobj::Mesh) {
    // Past u32 (which no upload reaches), the indices saturate and `checked` refuses
    // them, rather than wrapping onto vertices of an earlier model.
    let base = u32::try_from(out.positions.len()).unwrap_or(u32::MAX);
    let has_normals = mesh.normals.len() == mesh.positions.len();
    match (&mut out.normals, has_normals) {
        (Some(n), true) => n.extend(
            mesh.normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        ),
        _ => out.normals = None,
    }
    // OBJ's v grows upwards in the image, Mitsuba's downwards: flipped on load, as
    // Mitsuba's own OBJ reader does.
    let has_uvs = 2 * mesh.positions.len() == 3 * mesh.texcoords.len();
    match (&mut out.uvs, has_uvs) {
        (Some(uv), true) => uv.extend(
            mesh.texcoords
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0], 1.0 - c[1])),
        ),
        _ => out.uvs = None,
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

/// Parses a PLY file (ASCII, or binary of either byte order): `vertex` elements with
/// numeric `x y z` (and `nx ny nz`, used when every vertex has them), `face` elements
/// with a `vertex_indices` (or `vertex_index`) list; polygons become triangle fans.
/// Elements are read one at a time straight into the mesh: ply-rs's own
/// `DefaultElement` is a map from names to values per vertex, some 50 times the
/// file's size in memory.
pub fn parse_ply(mut reader: impl BufRead, field: &str, name: &str) -> Result<MeshData> {
    let err = mesh_error(field, name);
    // ply-rs panics on some malformed headers (it unwraps numbers too large for
    // their type): an uploaded file must be an error, not a dead worker.
    catch_unwind(AssertUnwindSafe(|| read_ply_mesh(&mut reader)))
        .unwrap_or_else(|panic| Err(reader_panic("PLY", panic)))
        .map_err(&err)?
        .checked(err)
}

fn read_ply_mesh(reader: &mut impl BufRead) -> std::result::Result<MeshData, String> {
    let header = ply_rs::parser::Parser::<PlySkip>::new()
        .read_header(reader)
        .map_err(|e| e.to_string())?;
    check_ply_header(&header)?;
    let mut mesh = PlyMesh::new();
    for def in header.elements.values() {
        match def.name.as_str() {
            "vertex" => read_elements(reader, &header, def, |v: PlyVertex| mesh.vertex(v)),
            "face" => read_elements(reader, &header, def, |f: PlyFace| mesh.face(f)),
            _ => read_elements(reader, &header, def, |_: PlySkip| Ok(())),
        }?;
    }
    Ok(mesh.finish())
}

/// Vertices need x, y, z and faces a vertex list, checked once here rather than per
/// element (which also makes skipping elements without properties safe).
fn check_ply_header(header: &ply_rs::ply::Header) -> std::result::Result<(), String> {
    let has = |def: &ply_rs::ply::ElementDef, names: &[&str]| {
        def.count == 0 || names.iter().all(|n| def.properties.contains_key(*n))
    };
    let vertex = header.elements.get("vertex").ok_or("no vertex element")?;
    if !has(vertex, &["x", "y", "z"]) {
        return Err("vertex without numeric x, y, z".into());
    }
    if let Some(face) = header.elements.get("face") {
        if !has(face, &["vertex_indices"]) && !has(face, &["vertex_index"]) {
            return Err("face without a vertex_indices list".into());
        }
    }
    Ok(())
}

/// Reads `def.count` elements of type `E`, handing each to `take`.
fn read_elements<E: PropertyAccess>(
    reader: &mut impl BufRead,
    header: &ply_rs::ply::Header,
    def: &ply_rs::ply::ElementDef,
    mut take: impl FnMut(E) -> std::result::Result<(), String>,
) -> std::result::Result<(), String> {
    use ply_rs::ply::Encoding;
    if def.properties.is_empty() {
        // Nothing to read, however many a header claims (a loop of 2^64 no-ops).
        return Ok(());
    }
    let parser = ply_rs::parser::Parser::<E>::new();
    let mut line = String::new();
    for i in 0..def.count {
        let element = match header.encoding {
            Encoding::Ascii => {
                line.clear();
                if reader.read_line(&mut line).map_err(|e| e.to_string())? == 0 {
                    return Err(format!(
                        "the file ends at {} {i} of {}",
                        def.name, def.count
                    ));
                }
                parser.read_ascii_element(&line, def)
            }
            Encoding::BinaryLittleEndian => parser.read_little_endian_element(reader, def),
            Encoding::BinaryBigEndian => parser.read_big_endian_element(reader, def),
        };
        take(element.map_err(|e| format!("{} {i}: {e}", def.name))?)?;
    }
    Ok(())
}

/// A PLY element caustic does not use: read (to get past it) and dropped.
struct PlySkip;

impl PropertyAccess for PlySkip {
    fn new() -> Self {
        PlySkip
    }
}

/// The numeric properties of a vertex that caustic uses.
#[derive(Default)]
struct PlyVertex {
    p: [Option<f32>; 3],
    n: [Option<f32>; 3],
    uv: [Option<f32>; 2],
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: String, value: Property) {
        let slot = match name.as_str() {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            // The names Mitsuba's PLY reader takes for texture coordinates.
            "u" | "s" | "texture_u" | "texture_s" => &mut self.uv[0],
            "v" | "t" | "texture_v" | "texture_t" => &mut self.uv[1],
            _ => return,
        };
        *slot = ply_number(&value);
    }
}

fn ply_number(p: &Property) -> Option<f32> {
    Some(match *p {
        Property::Float(v) => v,
        Property::Double(v) => v as f32,
        Property::Int(v) => v as f32,
        Property::UInt(v) => v as f32,
        Property::Short(v) => v as f32,
        Property::UShort(v) => v as f32,
        Property::Char(v) => v as f32,
        Property::UChar(v) => v as f32,
        _ => return None,
    })
}

/// A face's vertex list, as u32 (a negative index becomes one out of range).
#[derive(Default)]
struct PlyFace(Option<Vec<u32>>);

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: String, value: Property) {
        if name != "vertex_indices" && name != "vertex_index" {
            return;
        }
        self.0 = match value {
            Property::ListUInt(l) => Some(l),
            Property::ListInt(l) => Some(l.iter().map(|&i| i as u32).collect()),
            Property::ListUChar(l) => Some(l.iter().map(|&i| i as u32).collect()),
            Property::ListChar(l) => Some(l.iter().map(|&i| i as u32).collect()),
            Property::ListShort(l) => Some(l.iter().map(|&i| i as u32).collect()),
            Property::ListUShort(l) => Some(l.iter().map(|&i| i as u32).collect()),
            _ => None,
        };
    }
}

/// The mesh as its elements arrive.
struct PlyMesh {
    positions: Vec<Vec3>,
    /// `None` from the first vertex without a full normal on.
    normals: Option<Vec<Vec3>>,
    /// `None` from the first vertex without both texture coordinates on.
    uvs: Option<Vec<Vec2>>,
    indices: Vec<[u32; 3]>,
}

impl PlyMesh {
    fn new() -> Self {
        PlyMesh {
            positions: Vec::new(),
            normals: Some(Vec::new()),
            uvs: Some(Vec::new()),
            indices: Vec::new(),
        }
    }

    fn vertex(&mut self, v: PlyVertex) -> std::result::Result<(), String> {
        let [Some(x), Some(y), Some(z)] = v.p else {
            return Err("vertex without numeric x, y, z".into());
        };
        self.positions.push(Vec3::new(x, y, z));
        match (v.n, &mut self.normals) {
            ([Some(a), Some(b), Some(c)], Some(n)) => n.push(Vec3::new(a, b, c)),
            _ => self.normals = None,
        }
        match (v.uv, &mut self.uvs) {
            ([Some(u), Some(w)], Some(uv)) => uv.push(Vec2::new(u, w)),
            _ => self.uvs = None,
        }
        Ok(())
    }

    /// Polygons become triangle fans.
    fn face(&mut self, f: PlyFace) -> std::result::Result<(), String> {
        let list = f.0.ok_or("face without a vertex_indices list")?;
        for k in 1..list.len().saturating_sub(1) {
            self.indices.push([list[0], list[k], list[k + 1]]);
        }
        Ok(())
    }

    fn finish(self) -> MeshData {
        MeshData {
            positions: self.positions,
            normals: self.normals,
            uvs: self.uvs,
            indices: self.indices,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "comment a vertex with extra properties, an element caustic skips\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty double z\n\
        property uchar red\nproperty float nx\nproperty float ny\nproperty float nz\n\
        element material 1\nproperty int id\nproperty list uchar float weights\n";

    const POSITIONS: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.5], [0., 1., -2.]];
    const FACES: [&[u32]; 2] = [&[0, 1, 2, 3], &[3, 2, 1]];

    /// The same mesh in `format` ("ascii", "binary_little_endian" or
    /// "binary_big_endian"), its faces as `list COUNT int NAME`.
    fn ply(format: &str, count: &str, name: &str) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat {format} 1.0\n{HEADER}element face 2\n\
             property list {count} int {name}\nproperty int flags\nend_header\n"
        )
        .into_bytes();
        let big = format == "binary_big_endian";
        let mut put = |b: &[u8]| {
            let mut b = b.to_vec();
            if big {
                b.reverse();
            }
            out.extend_from_slice(&b);
        };
        if format == "ascii" {
            let mut text = String::new();
            for p in POSITIONS {
                text += &format!("{} {} {} 7 0 0 1\n", p[0], p[1], p[2]);
            }
            text += "5 2 0.5 0.25\n";
            for f in FACES {
                let idx: Vec<String> = f.iter().map(|i| i.to_string()).collect();
                text += &format!("{} {} 9\n", f.len(), idx.join(" "));
            }
            out.extend_from_slice(text.as_bytes());
            return out;
        }
        for p in POSITIONS {
            put(&p[0].to_le_bytes());
            put(&p[1].to_le_bytes());
            put(&(p[2] as f64).to_le_bytes());
            put(&[7]);
            for n in [0f32, 0., 1.] {
                put(&n.to_le_bytes());
            }
        }
        put(&5i32.to_le_bytes());
        put(&[2]);
        put(&0.5f32.to_le_bytes());
        put(&0.25f32.to_le_bytes());
        for f in FACES {
            match count {
                "uchar" => put(&[f.len() as u8]),
                _ => put(&(f.len() as i32).to_le_bytes()),
            }
            for &i in f {
                put(&(i as i32).to_le_bytes());
            }
            put(&9i32.to_le_bytes());
        }
        out
    }

    fn parse(bytes: &[u8]) -> Result<MeshData> {
        parse_ply(bytes, "shapes[0].filename", "m.ply")
    }

    #[test]
    fn ply_encodings_count_types_and_index_names_give_the_same_mesh() {
        let want_pos: Vec<Vec3> = POSITIONS.iter().map(|&p| Vec3::from(p)).collect();
        let want_idx = vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]];
        for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
            for (count, name) in [("uchar", "vertex_indices"), ("int", "vertex_index")] {
                let mesh = parse(&ply(format, count, name)).unwrap();
                let what = format!("{format} {count} {name}");
                assert_eq!(mesh.positions, want_pos, "{what}");
                assert_eq!(mesh.indices, want_idx, "{what}");
                assert_eq!(mesh.normals, Some(vec![Vec3::Z; 4]), "{what}");
            }
        }
    }

    #[test]
    fn ply_without_full_normals_or_faces() {
        let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty int x\nproperty int y\n\
                    property short z\nproperty float nx\nend_header\n1 2 3 0\n4 5 6 0\n";
        let mesh = parse(text.as_bytes()).unwrap();
        assert_eq!(
            mesh.positions,
            [Vec3::new(1., 2., 3.), Vec3::new(4., 5., 6.)]
        );
        assert!(mesh.normals.is_none());
        assert!(mesh.indices.is_empty());
    }

    #[test]
    fn ply_errors_name_the_file_and_what_is_wrong() {
        let cases = [
            (
                "ply\nformat ascii 1.0\nelement face 0\nend_header\n",
                "no vertex element",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
                "numeric x, y, z",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 100000000\nproperty float x\n\
                 property float y\nproperty float z\nend_header\n0 0 0\n",
                "ends at vertex 1",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                 end_header\n0 0 0\n3 0 0 1\n",
                "face index 1 out of range",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty int n\nend_header\n0 0 0\n3\n",
                "face without a vertex_indices list",
            ),
            ("not a ply file\n", "m.ply"),
        ];
        for (text, words) in cases {
            let err = parse(text.as_bytes()).err().expect(text).to_string();
            assert!(err.starts_with("shapes[0].filename: \"m.ply\": "), "{err}");
            assert!(err.contains(words), "{words}: {err}");
        }
    }

    #[test]
    fn ply_elements_without_properties_cost_nothing_however_many() {
        // ply-rs alone pushes an empty element per claimed one: 2^64 of them.
        let text = "ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\n\
                    element vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
                    end_header\n";
        let mut bytes = text.as_bytes().to_vec();
        bytes.extend([0u8; 12]);
        let mesh = parse(&bytes).unwrap();
        assert_eq!(mesh.positions, [Vec3::ZERO]);
    }

    /// Mitsuba 3.9 read `vt 0.1 0.2` as (0.1, 0.8) (OBJ's v flipped) and a PLY's
    /// `u v`, `s t` or `texture_u texture_v` as written.
    #[test]
    fn texture_coordinates_as_mitsuba_reads_them() {
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0.1 0.2\nvt 0.9 0.2\nvt 0.9 0.7\nf 1/1 2/2 3/3\n";
        let m = parse_obj(obj.as_bytes(), "f", "t.obj").unwrap();
        let uvs = m.uvs.unwrap();
        let want = [[0.1, 0.8], [0.9, 0.8], [0.9, 0.3]];
        for (got, want) in uvs.iter().zip(want) {
            assert!(
                (*got - Vec2::from(want)).abs().max_element() < 1e-6,
                "{uvs:?}"
            );
        }
        let bare = parse_obj(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n".as_bytes(),
            "f",
            "t.obj",
        );
        assert!(bare.unwrap().uvs.is_none());
        for (u, v) in [("u", "v"), ("s", "t"), ("texture_u", "texture_v")] {
            let ply = format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nproperty float {u}\nproperty float {v}\nelement face 1\n\
                 property list uchar int vertex_indices\nend_header\n0 0 0 0.1 0.2\n\
                 1 0 0 0.9 0.2\n1 1 0 0.9 0.7\n3 0 1 2\n"
            );
            let m = parse_ply(ply.as_bytes(), "f", "t.ply").unwrap();
            let uvs = m.uvs.unwrap();
            assert_eq!(uvs[2], Vec2::new(0.9, 0.7), "{u} {v}");
        }
    }
}
