//! What every target does with one input, shared by the AFL binaries (src/bin) and
//! by `repro`, which runs one saved input through a target without AFL.

use caustic::job::scenes::SceneStore;
use std::sync::OnceLock;

/// Target names, as `run.sh` and `repro` take them.
pub const TARGETS: &[&str] = &[
    "scene_json",
    "bundle",
    "exr",
    "hdr",
    "png",
    "jpeg",
    "obj",
    "ply",
    "vol",
    "raw_grid",
    "vdb",
];

/// Feeds `data` to the reader `target` and says how it went ("ok" or the error);
/// errors are fine, panics and aborts are what the fuzzer looks for. `None` for an
/// unknown target.
pub fn run(target: &str, data: &[u8]) -> Option<String> {
    use caustic::{film, medium::grid_io, scene::load};
    Some(match target {
        "scene_json" => scene_json(data),
        "bundle" => bundle(data),
        "exr" => outcome(film::decode_exr(data)),
        "hdr" => outcome(film::decode_hdr(data)),
        // Textures: sRGB-decoded 8-bit images through the `image` crate, with the size
        // checked before decoding.
        "png" | "jpeg" => outcome(caustic::material::texture::decode(data, "fuzz", false)),
        "obj" => outcome(load::parse_obj(data, "shapes[0]", "fuzz.obj")),
        "ply" => outcome(load::parse_ply(data, "shapes[0]", "fuzz.ply")),
        "vol" => outcome(grid_io::decode_vol(data)),
        "raw_grid" => raw_grid(data),
        "vdb" => vdb(data),
        _ => return None,
    })
}

fn outcome<T, E: std::fmt::Display>(r: Result<T, E>) -> String {
    match r {
        Ok(_) => "ok".into(),
        Err(e) => format!("error: {e}"),
    }
}

/// Parses, validates and compiles a scene without a folder (file references are
/// refused), as built-in scenes are.
fn scene_json(data: &[u8]) -> String {
    let Ok(text) = std::str::from_utf8(data) else {
        return "error: not UTF-8".into();
    };
    match caustic::scene::load::parse_scene(text) {
        Ok(file) => outcome(caustic::scene::Scene::compile(&file, None)),
        Err(e) => format!("error: {e}"),
    }
}

/// The header JSON, a NUL byte, then the data file's bytes.
fn raw_grid(data: &[u8]) -> String {
    let split = data.iter().position(|&b| b == 0).unwrap_or(data.len());
    let rest = data.get(split + 1..).unwrap_or(&[]);
    outcome(caustic::medium::grid_io::decode_raw(&data[..split], rest))
}

/// An OpenVDB file, read in process (as a local render reads it; servers read them
/// in a child process, `grid_io::vdb_child`) from a file in /dev/shm, since the
/// reader takes a path. Its aborts are the findings: each is kept as a regression
/// input that the child process must survive (tests/readers.rs).
fn vdb(data: &[u8]) -> String {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let shm = std::path::Path::new("/dev/shm");
        let dir = if shm.is_dir() {
            tempfile::tempdir_in(shm)
        } else {
            tempfile::tempdir()
        };
        dir.expect("temp dir for vdb inputs")
    });
    let path = dir.path().join("input.vdb");
    std::fs::write(&path, data).expect("write the input");
    outcome(caustic::medium::grid_io::load_grid(&path, Some("density")))
}

/// Largest bundle the target accepts, and so the most it may unpack.
const BUNDLE_LIMIT: u64 = 1 << 20;

/// An upload as the server takes it (JSON, tar or zip): unpacked, validated and
/// compiled in a scene store made once per process, then deleted so that the next
/// run of the same bytes does the same work.
fn bundle(data: &[u8]) -> String {
    static STORE: OnceLock<(tempfile::TempDir, SceneStore)> = OnceLock::new();
    let (_, store) = STORE.get_or_init(|| {
        let shm = std::path::Path::new("/dev/shm");
        let dir = if shm.is_dir() {
            tempfile::tempdir_in(shm)
        } else {
            tempfile::tempdir()
        };
        let dir = dir.expect("temp dir for the scene store");
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build();
        let pool = std::sync::Arc::new(pool.expect("compile pool"));
        let store = SceneStore::new(dir.path(), BUNDLE_LIMIT, pool).expect("scene store");
        (dir, store)
    });
    let id = match store.upload(data) {
        Ok(id) => id,
        Err(e) => return format!("error: {e}"),
    };
    store.delete(&id).expect("delete the uploaded scene");
    "ok".into()
}
