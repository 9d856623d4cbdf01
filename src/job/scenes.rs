//! Scene storage: uploads (one JSON document or Mitsuba XML scene, or a tar / zip
//! bundle with its meshes and maps) are validated, stored under
//! `<data-dir>/scenes/<id>/` with id = hash of the upload (an XML scene imported into
//! `scene.json`; only `scene.json` and the files it names are kept), and compiled once
//! per id, shared by every job on that scene.

use super::{keep, JobError};
use crate::integrator::Settings;
use crate::scene::{files, load::read_scene_file, mitsuba, CompileBudget, Scene, SceneError};
use sha2::{Digest, Sha256};
use std::collections::{HashMap, HashSet};
use std::io::Read;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Scenes shipped inside the binary, so a fresh server has something to render.
pub const BUILTIN: &[(&str, &str)] = &[
    ("cornell-box", include_str!("../../scenes/cornell-box.json")),
    (
        "smallvcm-gbs_s",
        include_str!("../../scenes/smallvcm/gbs_s.json"),
    ),
    (
        "smallvcm-glm_c",
        include_str!("../../scenes/smallvcm/glm_c.json"),
    ),
    (
        "smallvcm-gbs_p",
        include_str!("../../scenes/smallvcm/gbs_p.json"),
    ),
    (
        "smallvcm-gbs_b",
        include_str!("../../scenes/smallvcm/gbs_b.json"),
    ),
    (
        "vrl-cornell-gm09",
        include_str!("../../scenes/media/vrl-cornell-gm09.json"),
    ),
    (
        "vrl-cornell-g0",
        include_str!("../../scenes/media/vrl-cornell-g0.json"),
    ),
    (
        "vrl-cornell-g09",
        include_str!("../../scenes/media/vrl-cornell-g09.json"),
    ),
    (
        "vrl-cornell-dense-gm09",
        include_str!("../../scenes/media/vrl-cornell-dense-gm09.json"),
    ),
    (
        "vrl-cornell-dense-g0",
        include_str!("../../scenes/media/vrl-cornell-dense-g0.json"),
    ),
    (
        "vrl-cornell-dense-g09",
        include_str!("../../scenes/media/vrl-cornell-dense-g09.json"),
    ),
    (
        "vrl-point-gm09",
        include_str!("../../scenes/media/vrl-point-gm09.json"),
    ),
    (
        "vrl-point-g0",
        include_str!("../../scenes/media/vrl-point-g0.json"),
    ),
    (
        "vrl-point-g09",
        include_str!("../../scenes/media/vrl-point-g09.json"),
    ),
];

/// What the API shows about a scene.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq, utoipa::ToSchema)]
pub struct SceneInfo {
    pub id: String,
    pub builtin: bool,
    pub width: u32,
    pub height: u32,
    pub shapes: usize,
    pub lights: usize,
    /// Bytes of the stored bundle (0 for built-ins).
    pub size_bytes: u64,
    /// What the upload changed, one line each: what the import of a Mitsuba XML
    /// scene approximated, and the bundle's files that were not stored because the
    /// scene does not name them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// Where an upload's warnings are kept, next to its `scene.json` (the name is older
/// than warnings about anything but imports).
const WARNINGS: &str = "import-warnings.txt";

pub struct SceneStore {
    dir: PathBuf,
    max_upload: u64,
    cache: Mutex<HashMap<String, Arc<Scene>>>,
    compilations: AtomicU64,
    /// The server's (or worker's) render pool: every compile runs there, so that the
    /// BVH build's parallel parts use its threads, not rayon's global pool.
    pool: Arc<rayon::ThreadPool>,
    /// Taken by callers from outside the pool while they compile (see `compiled`).
    compiling: Mutex<()>,
    budget: CompileBudget,
}

fn bad(msg: impl Into<String>) -> JobError {
    JobError::BadRequest(msg.into())
}

impl SceneStore {
    pub fn new(
        data_dir: &Path,
        max_upload: u64,
        pool: Arc<rayon::ThreadPool>,
    ) -> Result<Self, JobError> {
        let dir = data_dir.join("scenes");
        std::fs::create_dir_all(&dir).map_err(|e| JobError::io(&dir, e))?;
        Ok(SceneStore {
            dir,
            max_upload,
            cache: Mutex::new(HashMap::new()),
            compilations: AtomicU64::new(0),
            pool,
            compiling: Mutex::new(()),
            budget: CompileBudget::SERVER,
        })
    }

    /// The store with another compile budget than [`CompileBudget::SERVER`].
    pub fn with_budget(self, budget: CompileBudget) -> Self {
        SceneStore { budget, ..self }
    }

    /// The turn to compile, for a caller from outside the pool; a pool thread takes
    /// none (see `compiled`). Compiles from outside happen one at a time, so their
    /// memory peaks do not add up.
    fn turn(&self) -> Option<std::sync::MutexGuard<'_, ()>> {
        let outside = self.pool.current_thread_index().is_none();
        outside.then(|| self.compiling.lock().expect("compile turn"))
    }

    /// Compiles the scene file at `path` on the pool, within the budget, in turn.
    fn compile_file(&self, path: &Path) -> Result<Scene, SceneError> {
        let _turn = self.turn();
        self.load_on_pool(path)
    }

    fn load_on_pool(&self, path: &Path) -> Result<Scene, SceneError> {
        self.pool.install(|| Scene::load_within(path, &self.budget))
    }

    /// How many times a scene was compiled (BVH built) since start.
    pub fn compilations(&self) -> u64 {
        self.compilations.load(Ordering::Relaxed)
    }

    fn builtin(id: &str) -> Option<&'static str> {
        BUILTIN.iter().find(|(n, _)| *n == id).map(|(_, t)| *t)
    }

    /// A valid id names a built-in or is 16 lowercase hex digits.
    fn check_id(id: &str) -> Result<(), JobError> {
        let hex = id.len() == 16
            && id
                .bytes()
                .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase());
        if hex || Self::builtin(id).is_some() {
            Ok(())
        } else {
            Err(JobError::NotFound(format!("scene {id}")))
        }
    }

    fn scene_dir(&self, id: &str) -> PathBuf {
        self.dir.join(id)
    }

    /// Validates and stores an upload; uploading the same bytes twice gives the same id.
    pub fn upload(&self, bytes: &[u8]) -> Result<String, JobError> {
        if bytes.len() as u64 > self.max_upload {
            return Err(JobError::TooLarge(format!(
                "upload of {} bytes exceeds the limit of {} bytes",
                bytes.len(),
                self.max_upload
            )));
        }
        let id = hex16(&Sha256::digest(bytes));
        if self.scene_dir(&id).join("scene.json").exists() {
            return Ok(id);
        }
        let tmp = self.dir.join(format!(".upload-{}", uuid::Uuid::new_v4()));
        let result = self.unpack_and_check(bytes, &tmp);
        match result {
            Ok(()) => {
                let dest = self.scene_dir(&id);
                match std::fs::rename(&tmp, &dest) {
                    Ok(()) => Ok(id),
                    // A concurrent upload of the same bytes won the race: same content.
                    Err(_) if dest.join("scene.json").exists() => {
                        let _ = std::fs::remove_dir_all(&tmp);
                        Ok(id)
                    }
                    Err(e) => {
                        let _ = std::fs::remove_dir_all(&tmp);
                        Err(JobError::io(&dest, e))
                    }
                }
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&tmp);
                Err(e)
            }
        }
    }

    fn unpack_and_check(&self, bytes: &[u8], tmp: &Path) -> Result<(), JobError> {
        std::fs::create_dir_all(tmp).map_err(|e| JobError::io(tmp, e))?;
        let first = bytes.iter().find(|b| !b.is_ascii_whitespace()).copied();
        if first == Some(b'{') {
            std::fs::write(tmp.join("scene.json"), bytes).map_err(|e| JobError::io(tmp, e))?;
        } else if mitsuba::is_xml(bytes) {
            std::fs::write(tmp.join("scene.xml"), bytes).map_err(|e| JobError::io(tmp, e))?;
        } else if bytes.starts_with(b"PK\x03\x04") {
            unpack_zip(bytes, tmp, self.max_upload)?;
        } else if bytes.len() > 262 && &bytes[257..262] == b"ustar" {
            unpack_tar(bytes, tmp, self.max_upload)?;
        } else {
            return Err(bad(
                "upload must be a scene JSON document, a Mitsuba XML scene, a tar archive or a \
                 zip archive",
            ));
        }
        let main = find_scene_json(tmp)?;
        let (mut warnings, sources) = if mitsuba::is_xml_path(&main) {
            let import = import_xml(&main, tmp)?;
            (import.warnings, import.sources)
        } else {
            if main != tmp.join("scene.json") {
                std::fs::rename(&main, tmp.join("scene.json")).map_err(|e| JobError::io(tmp, e))?;
            }
            (Vec::new(), Vec::new())
        };
        let path = tmp.join("scene.json");
        {
            let scene = self
                .compile_file(&path)
                .map_err(|e| JobError::InvalidScene(without_folder(&e.to_string(), tmp)))?;
            // The scene's integrator section is every job's default: checked as a
            // job's settings are, or each job on the scene would fail.
            Settings::for_scene_defaults(&scene)
                .map_err(|e| JobError::InvalidScene(e.to_string()).at_field(e.field()))?;
        }
        warnings.extend(keep_only_needed(tmp, &sources)?);
        if !warnings.is_empty() {
            let text = warnings.join("\n");
            std::fs::write(tmp.join(WARNINGS), text).map_err(|e| JobError::io(tmp, e))?;
        }
        Ok(())
    }

    /// Scene `id` as a tar of its stored directory, for workers that fetch it by id
    /// (`remote`); None for a built-in scene, which every binary has.
    pub fn bundle(&self, id: &str) -> Result<Option<Vec<u8>>, JobError> {
        Self::check_id(id)?;
        if Self::builtin(id).is_some() {
            return Ok(None);
        }
        let dir = self.scene_dir(id);
        if !dir.join("scene.json").exists() {
            return Err(JobError::NotFound(format!("scene {id}")));
        }
        let mut tar = tar::Builder::new(Vec::new());
        tar.append_dir_all(".", &dir)
            .and_then(|()| tar.into_inner())
            .map(Some)
            .map_err(|e| JobError::io(&dir, e))
    }

    pub fn exists(&self, id: &str) -> bool {
        Self::check_id(id).is_ok()
            && (Self::builtin(id).is_some() || self.scene_dir(id).join("scene.json").exists())
    }

    /// The compiled scene, from the cache or compiled now (once per id).
    ///
    /// The compile runs on the pool, and no lock a pool thread may wait for is held
    /// while it does: the scheduler asks for scenes from the pool's threads, and one
    /// of them blocked on a lock held by a thread that waits for the pool would wait
    /// forever (with `--workers 1`, at once). So callers from outside the pool take
    /// turns (and find the scene cached when theirs comes), while the pool's threads
    /// never wait for another's compile; in the rare race both compile, and the first
    /// one stays.
    pub fn compiled(&self, id: &str) -> Result<Arc<Scene>, JobError> {
        Self::check_id(id)?;
        if let Some(s) = self.cached(id) {
            return Ok(s);
        }
        let _turn = self.turn();
        if let Some(s) = self.cached(id) {
            return Ok(s);
        }
        let scene = if let Some(text) = Self::builtin(id) {
            let file = crate::scene::load::parse_scene(text)
                .map_err(|e| JobError::Internal(format!("built-in {id}: {e}")))?;
            self.pool
                .install(|| Scene::compile_within(&file, None, &self.budget))
        } else {
            let path = self.scene_dir(id).join("scene.json");
            if !path.exists() {
                return Err(JobError::NotFound(format!("scene {id}")));
            }
            self.load_on_pool(&path)
        }
        .map_err(|e| JobError::InvalidScene(e.to_string()))?;
        self.compilations.fetch_add(1, Ordering::Relaxed);
        tracing::info!(
            scene = id,
            bvh_ms = scene.stats.bvh_build.as_secs_f64() * 1e3,
            bvh_threads = scene.stats.bvh_threads,
            "compiled scene"
        );
        let mut cache = self.cache.lock().expect("scene cache");
        Ok(cache
            .entry(id.to_string())
            .or_insert_with(|| Arc::new(scene))
            .clone())
    }

    fn cached(&self, id: &str) -> Option<Arc<Scene>> {
        self.cache.lock().expect("scene cache").get(id).cloned()
    }

    pub fn info(&self, id: &str) -> Result<SceneInfo, JobError> {
        let builtin = Self::builtin(id).is_some();
        let file = if let Some(text) = Self::builtin(id) {
            crate::scene::load::parse_scene(text).map_err(|e| JobError::Internal(e.to_string()))?
        } else {
            Self::check_id(id)?;
            let path = self.scene_dir(id).join("scene.json");
            if !path.exists() {
                return Err(JobError::NotFound(format!("scene {id}")));
            }
            read_scene_file(&path).map_err(|e| JobError::Internal(e.to_string()))?
        };
        Ok(SceneInfo {
            id: id.to_string(),
            builtin,
            width: file.film.width,
            height: file.film.height,
            shapes: file.shapes.len(),
            lights: file.lights.len()
                + file
                    .shapes
                    .iter()
                    .filter(|s| s.common.emission.is_some())
                    .count(),
            size_bytes: if builtin {
                0
            } else {
                super::disk::dir_size(&self.scene_dir(id))
            },
            warnings: std::fs::read_to_string(self.scene_dir(id).join(WARNINGS))
                .map(|t| t.lines().map(str::to_string).collect())
                .unwrap_or_default(),
        })
    }

    pub fn list(&self) -> Vec<SceneInfo> {
        let mut ids: Vec<String> = BUILTIN.iter().map(|(n, _)| n.to_string()).collect();
        let mut uploaded: Vec<String> = std::fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| e.file_name().into_string().ok())
            .filter(|n| !n.starts_with('.'))
            .collect();
        uploaded.sort();
        ids.extend(uploaded);
        ids.iter().filter_map(|id| self.info(id).ok()).collect()
    }

    /// Removes an uploaded scene (the caller checks no job uses it).
    pub fn delete(&self, id: &str) -> Result<(), JobError> {
        if Self::builtin(id).is_some() {
            return Err(JobError::Conflict(format!("scene {id} is built in")));
        }
        Self::check_id(id)?;
        let dir = self.scene_dir(id);
        if !dir.exists() {
            return Err(JobError::NotFound(format!("scene {id}")));
        }
        self.cache.lock().expect("scene cache").remove(id);
        std::fs::remove_dir_all(&dir).map_err(|e| JobError::io(&dir, e))
    }
}

/// `message` with the upload's folder taken out of any file name in it: the readers
/// name files by their full path, and a client must learn the name inside its bundle,
/// not where the server keeps it.
fn without_folder(message: &str, folder: &Path) -> String {
    let mut out = message.to_string();
    let canonical = folder.canonicalize().ok();
    for f in std::iter::once(folder).chain(canonical.as_deref()) {
        out = out.replace(&format!("{}/", f.display()), "");
        out = out.replace(&f.display().to_string(), "<bundle>");
    }
    out
}

fn hex16(digest: &[u8]) -> String {
    digest[..8].iter().map(|b| format!("{b:02x}")).collect()
}

/// Imports the Mitsuba XML scene `main` of an upload in `dir` into `dir/scene.json`.
fn import_xml(main: &Path, dir: &Path) -> Result<mitsuba::Import, JobError> {
    let import = mitsuba::import_file(main)
        .map_err(|e| JobError::InvalidScene(without_folder(&e.to_string(), dir)))?;
    let json = serde_json::to_vec_pretty(&import.scene)
        .map_err(|e| JobError::Internal(format!("imported scene: {e}")))?;
    std::fs::write(dir.join("scene.json"), json).map_err(|e| JobError::io(dir, e))?;
    Ok(import)
}

/// Drops what the upload in `dir` holds beside its scene and the files the scene
/// needs; returns the warning saying so, unless all that went is what the import
/// read (`sources`, names in the bundle). The id stays the hash of the upload, so
/// the same upload finds the same stored scene, and workers fetch what is stored.
fn keep_only_needed(dir: &Path, sources: &[String]) -> Result<Option<String>, JobError> {
    let root = dir.canonicalize().map_err(|e| JobError::io(dir, e))?;
    let scene_path = root.join("scene.json");
    let mut scene = read_scene_file(&scene_path)
        .map_err(|e| JobError::Internal(format!("stored scene: {e}")))?;
    let mut needed: HashSet<PathBuf> = files::needed(&mut scene, &root).into_iter().collect();
    needed.insert(scene_path);
    let dropped = keep::drop_all_but(&root, &needed).map_err(|e| JobError::io(dir, e))?;
    let expected: HashSet<PathBuf> = (sources.iter().map(PathBuf::from))
        .chain([PathBuf::from(WARNINGS)])
        .collect();
    Ok(keep::warning(&dropped, &expected))
}

/// `scene.json` at the top, else the only top-level `.json` file; else a Mitsuba
/// scene: `scene.xml`, or the only top-level `.xml` file.
fn find_scene_json(dir: &Path) -> Result<PathBuf, JobError> {
    let top = |ext: &str| -> Result<Vec<PathBuf>, JobError> {
        Ok(std::fs::read_dir(dir)
            .map_err(|e| JobError::io(dir, e))?
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case(ext)))
            .collect())
    };
    for (name, ext) in [("scene.json", "json"), ("scene.xml", "xml")] {
        let direct = dir.join(name);
        if direct.exists() {
            return Ok(direct);
        }
        match top(ext)?.as_slice() {
            [one] => return Ok(one.clone()),
            [] => {}
            _ => {
                return Err(bad(format!(
                    "bundle holds several top-level .{ext} files: name the scene {name}"
                )))
            }
        }
    }
    Err(bad(
        "bundle holds no scene: put scene.json (or a Mitsuba scene.xml) at its top level",
    ))
}

/// A bundle entry's path, refused when absolute, climbing out with `..`, too deep,
/// with too long a name, or holding a NUL byte.
fn safe_entry(name: &Path) -> Result<PathBuf, JobError> {
    let mut out = PathBuf::new();
    let refuse = |why: &str| {
        let shown: String = name.to_string_lossy().chars().take(120).collect();
        Err(bad(format!("bundle entry \"{shown}\": {why}")))
    };
    for c in name.components() {
        match c {
            Component::Normal(p) if p.len() > MAX_ENTRY_NAME => {
                return refuse(&format!("a name is longer than {MAX_ENTRY_NAME} bytes"))
            }
            Component::Normal(p) if p.as_encoded_bytes().contains(&0) => {
                return refuse("a name holds a NUL byte")
            }
            Component::Normal(_) if out.components().count() >= MAX_ENTRY_DEPTH => {
                return refuse(&format!("folders deeper than {MAX_ENTRY_DEPTH}"))
            }
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            _ => {
                return Err(bad(format!(
                    "bundle entry \"{}\" is not a relative path inside the bundle",
                    name.display()
                )))
            }
        }
    }
    Ok(out)
}

/// Copies one bundle entry to `dest/rel`. A failure to read the entry (corrupt
/// compressed data, a bad checksum, a truncated archive) is the upload's fault and a
/// 400 naming the entry; a failure to write is the server's.
fn write_entry(
    dest: &Path,
    rel: &Path,
    mut r: impl Read,
    budget: &mut u64,
) -> Result<(), JobError> {
    use std::io::Write;
    let path = dest.join(rel);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| entry_error(rel, parent, e))?;
    }
    let mut f = std::fs::File::create(&path).map_err(|e| entry_error(rel, &path, e))?;
    let mut buf = vec![0u8; 64 << 10];
    loop {
        let n = match r.read(&mut buf) {
            Ok(0) => return Ok(()),
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => {
                return Err(bad(format!(
                    "bundle entry \"{}\" cannot be read: {e}",
                    rel.display()
                )))
            }
        };
        // Count what is really written: headers can lie about sizes (zip bombs).
        *budget = budget.checked_sub(n as u64).ok_or_else(|| {
            JobError::TooLarge("bundle expands beyond the upload size limit".into())
        })?;
        f.write_all(&buf[..n]).map_err(|e| JobError::io(&path, e))?;
    }
}

/// A failure to create a bundle entry's file or folder: the server's fault when its
/// disk is full or read-only, otherwise the entry's (a name clash such as a file `m`
/// and a file `m/a.obj`, a name the file system refuses).
fn entry_error(rel: &Path, path: &Path, e: std::io::Error) -> JobError {
    use std::io::ErrorKind as K;
    match e.kind() {
        K::StorageFull | K::QuotaExceeded | K::ReadOnlyFilesystem | K::PermissionDenied => {
            JobError::io(path, e)
        }
        _ => bad(format!(
            "bundle entry \"{}\" cannot be stored: {e}",
            rel.display()
        )),
    }
}

/// Bundle entry names: folders at most this deep, names at most this long (most file
/// systems stop at 255 bytes).
const MAX_ENTRY_DEPTH: usize = 32;
const MAX_ENTRY_NAME: usize = 255;

fn unpack_tar(bytes: &[u8], dest: &Path, limit: u64) -> Result<(), JobError> {
    let mut ar = tar::Archive::new(bytes);
    let mut budget = limit;
    for entry in ar.entries().map_err(|e| bad(format!("tar: {e}")))? {
        let entry = entry.map_err(|e| bad(format!("tar: {e}")))?;
        let name = entry
            .path()
            .map_err(|e| bad(format!("tar: {e}")))?
            .into_owned();
        let rel = safe_entry(&name)?;
        match entry.header().entry_type() {
            tar::EntryType::Regular => write_entry(dest, &rel, entry, &mut budget)?,
            tar::EntryType::Directory => {
                std::fs::create_dir_all(dest.join(&rel)).map_err(|e| entry_error(&rel, dest, e))?
            }
            t => {
                return Err(bad(format!(
                "bundle entry \"{}\" is a {t:?}: only files and folders are accepted (no links)",
                name.display()
            )))
            }
        }
    }
    Ok(())
}

fn unpack_zip(bytes: &[u8], dest: &Path, limit: u64) -> Result<(), JobError> {
    let mut ar =
        zip::ZipArchive::new(std::io::Cursor::new(bytes)).map_err(|e| bad(format!("zip: {e}")))?;
    let mut budget = limit;
    for i in 0..ar.len() {
        let file = ar.by_index(i).map_err(|e| bad(format!("zip: {e}")))?;
        let name = PathBuf::from(file.name());
        let rel = safe_entry(&name)?;
        if file.is_symlink() {
            return Err(bad(format!(
                "bundle entry \"{}\" is a symbolic link: only files and folders are accepted",
                name.display()
            )));
        }
        if file.is_dir() {
            std::fs::create_dir_all(dest.join(&rel)).map_err(|e| entry_error(&rel, dest, e))?;
        } else {
            write_entry(dest, &rel, file, &mut budget)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;
    use std::time::Duration;

    fn pool(threads: usize) -> Arc<rayon::ThreadPool> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
        Arc::new(pool.unwrap())
    }

    /// Compiles see the store's pool (one thread more than rayon's global pool has),
    /// for built-in and uploaded scenes alike.
    #[test]
    fn scenes_compile_on_the_stores_pool() {
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) + 1;
        let dir = tempfile::tempdir().unwrap();
        let store = SceneStore::new(dir.path(), 1 << 20, pool(threads)).unwrap();
        assert_eq!(
            store.compiled("cornell-box").unwrap().stats.bvh_threads,
            threads
        );
        let id = store.upload(BUILTIN[1].1.as_bytes()).unwrap();
        assert_eq!(store.compiled(&id).unwrap().stats.bvh_threads, threads);
        assert_eq!(store.compilations(), 2);
    }

    /// A pool thread asking for a scene while a caller from outside compiles it must
    /// not wait for that compile: it is queued for the pool's one thread. Here the
    /// thread is kept busy until the outside caller has had time to start (and queue)
    /// its compile, then asks for the same scene; a deadlock shows as a time-out.
    #[test]
    fn a_pool_thread_never_waits_for_an_outside_compile() {
        let dir = tempfile::tempdir().unwrap();
        let one = pool(1);
        let store = Arc::new(SceneStore::new(dir.path(), 1 << 20, one.clone()).unwrap());
        let (done, finished) = mpsc::channel();
        let (go, wait) = mpsc::channel::<()>();
        let (s, d) = (store.clone(), done.clone());
        one.spawn(move || {
            wait.recv().unwrap();
            d.send(s.compiled("cornell-box").map(|_| ())).unwrap();
        });
        let s = store.clone();
        std::thread::spawn(move || done.send(s.compiled("cornell-box").map(|_| ())).unwrap());
        std::thread::sleep(Duration::from_millis(300));
        go.send(()).unwrap();
        for _ in 0..2 {
            let r = finished.recv_timeout(Duration::from_secs(60));
            r.expect("a compile never finished").unwrap();
        }
    }
}
