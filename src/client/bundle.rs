//! Local scenes: which files a scene names, and the deterministic tar bundle that
//! uploads them with it.

use super::{file_error, Client, ClientError, Result};
use crate::scene::mitsuba;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};

/// Does `scene` name a local file rather than a scene id?
fn looks_like_path(scene: &str) -> bool {
    scene.contains('/')
        || scene.contains('\\')
        || [".json", ".xml", ".tar", ".zip"]
            .iter()
            .any(|x| scene.to_ascii_lowercase().ends_with(x))
}

/// A scene as a job names it.
pub struct ResolvedScene {
    /// The id of a built-in or uploaded scene.
    pub id: String,
    /// The sample count a Mitsuba XML scene's sampler asks for (`sample_count`).
    pub spp: Option<u32>,
}

/// A scene id for `scene`: a local file (relative to `base_dir` if given) is uploaded
/// first; anything else is taken as the id of a built-in or uploaded scene.
pub fn resolve_scene(client: &Client, scene: &str, base_dir: Option<&Path>) -> Result<String> {
    Ok(resolve_scene_spp(client, scene, base_dir)?.id)
}

/// [`resolve_scene`], with the sample count of an uploaded XML scene.
pub fn resolve_scene_spp(
    client: &Client,
    scene: &str,
    base_dir: Option<&Path>,
) -> Result<ResolvedScene> {
    let path = match base_dir {
        Some(d) => d.join(scene),
        None => PathBuf::from(scene),
    };
    if path.is_file() {
        let upload = prepare_upload(&path)?;
        let id = client.upload_scene(&upload.bytes, upload.content_type)?;
        let files = upload.files;
        eprintln!(
            "uploaded {} as scene {id} ({} file{}, {:.1} KiB)",
            path.display(),
            files,
            if files == 1 { "" } else { "s" },
            upload.bytes.len() as f64 / 1024.0
        );
        Ok(ResolvedScene {
            id,
            spp: upload.spp,
        })
    } else if looks_like_path(scene) {
        Err(file_error(&path, "no such scene file"))
    } else {
        Ok(ResolvedScene {
            id: scene.to_string(),
            spp: None,
        })
    }
}

/// What is uploaded for a local scene file.
struct SceneUpload {
    bytes: Vec<u8>,
    content_type: &'static str,
    /// How many files the bytes hold.
    files: usize,
    /// An XML scene's `sample_count`.
    spp: Option<u32>,
}

/// The bytes to upload for a local scene file, their content type and how many files
/// they hold. A JSON scene naming other files becomes a tar bundle; archives (tar, zip)
/// are sent as they are. A Mitsuba XML scene is imported here (its warnings printed)
/// and sent as the JSON scene it becomes.
pub fn scene_upload(path: &Path) -> Result<(Vec<u8>, &'static str, usize)> {
    let u = prepare_upload(path)?;
    Ok((u.bytes, u.content_type, u.files))
}

fn prepare_upload(path: &Path) -> Result<SceneUpload> {
    let mut bytes = std::fs::read(path).map_err(|e| file_error(path, e))?;
    let mut spp = None;
    if mitsuba::is_xml_path(path) || mitsuba::is_xml(&bytes) {
        let import = mitsuba::import_file(path).map_err(|e| file_error(path, e))?;
        for w in &import.warnings {
            eprintln!("warning: {w}");
        }
        spp = import.spp;
        bytes = serde_json::to_vec_pretty(&import.scene).map_err(|e| file_error(path, e))?;
    }
    let upload = |bytes, content_type, files| SceneUpload {
        bytes,
        content_type,
        files,
        spp,
    };
    let first = bytes.iter().find(|b| !b.is_ascii_whitespace()).copied();
    if first != Some(b'{') {
        let ct = if bytes.starts_with(b"PK\x03\x04") {
            "application/zip"
        } else {
            "application/x-tar"
        };
        return Ok(upload(bytes, ct, 1));
    }
    let doc: Value = serde_json::from_slice(&bytes).map_err(|e| file_error(path, e))?;
    let mut names = Vec::new();
    referenced_files(&doc, &mut names);
    if names.is_empty() {
        return Ok(upload(bytes, "application/json", 1));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let files = bundle_files(dir, &names)?;
    let n = files.len() + 1;
    let tar = build_tar(&bytes, dir, &files)?;
    Ok(upload(tar, "application/x-tar", n))
}

/// Keys whose string values name files next to the scene: meshes and environment
/// maps (`filename`), media grids (`file`, `albedo_file`).
const FILE_KEYS: [&str; 3] = ["filename", "file", "albedo_file"];

/// Every file a scene document names (see [`FILE_KEYS`]).
pub fn referenced_files(doc: &Value, out: &mut Vec<String>) {
    match doc {
        Value::Object(m) => {
            for (k, v) in m {
                match v {
                    Value::String(s) if FILE_KEYS.contains(&k.as_str()) => out.push(s.clone()),
                    _ => referenced_files(v, out),
                }
            }
        }
        Value::Array(a) => a.iter().for_each(|v| referenced_files(v, out)),
        _ => {}
    }
}

/// A reference as a clean relative path; absolute paths and `..` are refused, as the
/// server would.
fn relative(name: &str) -> Result<PathBuf> {
    let mut out = PathBuf::new();
    for c in Path::new(name).components() {
        match c {
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            _ => {
                return Err(ClientError::Input(format!(
                    "scene references \"{name}\": file references must be relative paths inside the scene's folder"
                )))
            }
        }
    }
    if out.as_os_str().is_empty() {
        return Err(ClientError::Input(
            "scene references an empty file name".into(),
        ));
    }
    Ok(out)
}

/// The referenced files (relative to the scene folder), plus the data file a raw
/// grid's `.json` header names (relative to the header). OBJ material libraries are
/// left out: caustic reads no OBJ materials.
fn bundle_files(dir: &Path, names: &[String]) -> Result<BTreeSet<PathBuf>> {
    let mut files = BTreeSet::new();
    for name in names {
        let rel = relative(name)?;
        let full = dir.join(&rel);
        if !full.is_file() {
            return Err(file_error(&full, "referenced by the scene but not found"));
        }
        let is_json = rel
            .extension()
            .is_some_and(|x| x.eq_ignore_ascii_case("json"));
        if is_json {
            let text = std::fs::read(&full).map_err(|e| file_error(&full, e))?;
            let header: Value = serde_json::from_slice(&text).map_err(|e| file_error(&full, e))?;
            if let Some(data) = header.get("data").and_then(Value::as_str) {
                let folder = rel.parent().map(Path::to_path_buf).unwrap_or_default();
                let data = relative(&folder.join(data).to_string_lossy())?;
                if !dir.join(&data).is_file() {
                    return Err(file_error(
                        &dir.join(&data),
                        "named by a grid header but not found",
                    ));
                }
                files.insert(data);
            }
        }
        files.insert(rel);
    }
    Ok(files)
}

/// A tar archive of `scene.json` and the files, with fixed metadata so the same scene
/// always gives the same bytes (and so the same content-addressed scene id).
fn build_tar(scene: &[u8], dir: &Path, files: &BTreeSet<PathBuf>) -> Result<Vec<u8>> {
    let mut b = tar::Builder::new(Vec::new());
    let mut add = |name: &Path, data: &[u8]| -> std::io::Result<()> {
        let mut h = tar::Header::new_ustar();
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        h.set_mtime(0);
        h.set_entry_type(tar::EntryType::Regular);
        b.append_data(&mut h, name, data)
    };
    add(Path::new("scene.json"), scene).map_err(|e| ClientError::Input(format!("bundle: {e}")))?;
    for rel in files {
        let full = dir.join(rel);
        let data = std::fs::read(&full).map_err(|e| file_error(&full, e))?;
        add(rel, &data).map_err(|e| file_error(&full, e))?;
    }
    b.into_inner()
        .map_err(|e| ClientError::Input(format!("bundle: {e}")))
}
