//! Every file reader against hostile input: headers that claim more than a server may
//! allocate, OBJ `mtllib` lines naming server files, errors that must not show the
//! server's own paths, and the inputs the fuzzers (tests/fuzz) found.

use caustic::film::{decode_exr, Image};
use caustic::job::{Service, ServiceConfig};
use caustic::scene::Scene;
use exr::prelude::{self as x, AnyChannel, AnyChannels, FlatSamples, Layer, LayerAttributes};
use glam::Vec3;
use serde_json::{json, Value};
use std::path::Path;
use std::process::Command;
use std::sync::mpsc;
use std::time::Duration;

// ------------------------------------------------------------------ helpers

/// An RGB float32 EXR of `w` x `h` pixels of one colour, one part per name in `parts`.
fn flat_exr(w: usize, h: usize, compression: x::Compression, parts: &[&str]) -> Vec<u8> {
    let layers: Vec<_> = parts
        .iter()
        .map(|name| {
            let channels = ["B", "G", "R"]
                .map(|c| AnyChannel::new(c, FlatSamples::F32(vec![0.25; w * h])))
                .to_vec();
            let encoding = x::Encoding {
                compression,
                blocks: x::Blocks::ScanLines,
                line_order: x::LineOrder::Increasing,
            };
            let attributes = LayerAttributes::named(*name);
            Layer::new(
                (w, h),
                attributes,
                encoding,
                AnyChannels::sort(channels.into()),
            )
        })
        .collect();
    let image = x::Image::from_layers(
        x::ImageAttributes::new(x::IntegerBounds::from_dimensions((w, h))),
        layers,
    );
    let mut out = std::io::Cursor::new(Vec::new());
    x::WritableImage::write(&image)
        .to_buffered(&mut out)
        .unwrap();
    out.into_inner()
}

/// Where the value of the `nth` (0-based) attribute called `name` of type `kind` starts.
fn attribute(bytes: &[u8], name: &str, kind: &str, nth: usize) -> usize {
    let key = format!("{name}\0{kind}\0");
    let at = bytes
        .windows(key.len())
        .enumerate()
        .filter(|(_, win)| *win == key.as_bytes())
        .nth(nth)
        .unwrap_or_else(|| panic!("no {key:?}"))
        .0;
    at + key.len() + 4 // after the attribute's byte count
}

/// `bytes` (scan lines, `lines` per block) with the `nth` part's data window widened
/// to `w` x `h` and its chunk count to match, and zeros appended so that an offset
/// table that long can be read: a consistent header that only lies about the size.
fn claiming(mut bytes: Vec<u8>, nth: usize, lines: i32, w: i32, h: i32) -> Vec<u8> {
    let window = attribute(&bytes, "dataWindow", "box2i", nth);
    bytes[window + 8..window + 12].copy_from_slice(&(w - 1).to_le_bytes());
    bytes[window + 12..window + 16].copy_from_slice(&(h - 1).to_le_bytes());
    let chunks = (h + lines - 1) / lines;
    let count = attribute(&bytes, "chunkCount", "int", nth);
    bytes[count..count + 4].copy_from_slice(&chunks.to_le_bytes());
    bytes.resize(bytes.len() + chunks as usize * 8, 0);
    bytes
}

fn huge_exr() -> Vec<u8> {
    claiming(
        flat_exr(1, 1, x::Compression::ZIP16, &["rgb"]),
        0,
        16,
        100_000,
        100_000,
    )
}

fn tiny_scene() -> Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 45},
        "film": {"width": 8, "height": 8},
        "materials": {"m": {"type": "diffuse", "reflectance": [0.6, 0.5, 0.4]}},
        "shapes": [{"type": "sphere", "radius": 0.8, "material": "m"}],
        "lights": [{"type": "point", "position": [1, 3, 2], "intensity": [8, 8, 8]}]
    })
}

fn with_envmap(file: &str) -> Value {
    let mut s = tiny_scene();
    s["lights"] = json!([{"type": "envmap", "filename": file}]);
    s
}

fn with_shape(kind: &str, file: &str) -> Value {
    let mut s = tiny_scene();
    s["shapes"] = json!([{"type": kind, "filename": file, "material": "m"}]);
    s
}

fn tar_with(entries: &[(&str, &[u8])]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    for (name, data) in entries {
        let mut h = tar::Header::new_gnu();
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        b.append_data(&mut h, name, *data).unwrap();
    }
    b.into_inner().unwrap()
}

/// Uploads a bundle of `scene.json` and `files` to a fresh service; the error
/// message, or `Ok` with the scene's id.
fn upload(scene: &Value, files: &[(&str, &[u8])]) -> (Result<String, String>, String) {
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
    let text = scene.to_string();
    let mut entries = vec![("scene.json", text.as_bytes())];
    entries.extend_from_slice(files);
    let result = svc
        .upload_scene(&tar_with(&entries))
        .map(|info| info.id)
        .map_err(|e| e.to_string());
    svc.shutdown();
    (result, dir.path().display().to_string())
}

/// A scene folder holding `scene.json` and `files`.
fn folder(scene: &Value, files: &[(&str, &[u8])]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.json"), scene.to_string()).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

fn load_err(dir: &Path) -> String {
    match Scene::load(&dir.join("scene.json")) {
        Ok(_) => panic!("scene in {} loaded", dir.display()),
        Err(e) => e.to_string(),
    }
}

const QUAD_OBJ: &str = "v -2 -1 -2\nv 2 -1 -2\nv 2 -1 2\nv -2 -1 2\nf 4 3 2 1\n";

// ------------------------------------------------------------------ EXR caps

#[test]
fn exr_claiming_100000_squared_pixels_is_refused_before_allocating() {
    let bytes = huge_exr();
    assert!(bytes.len() < 1 << 20, "{} bytes", bytes.len());
    let err = decode_exr(&bytes).unwrap_err();
    assert!(err.to_string().contains("100000 x 100000"), "{err}");
}

#[test]
fn exr_with_a_huge_second_part_is_refused() {
    let two = flat_exr(2, 2, x::Compression::ZIP16, &["a", "b"]);
    assert_eq!(decode_exr(&two).unwrap().size(), (2, 2));
    let err = decode_exr(&claiming(two, 1, 16, 90_000, 90_000)).unwrap_err();
    assert!(err.to_string().contains("90000 x 90000"), "{err}");
}

#[test]
fn exr_claiming_more_than_its_bytes_could_hold_is_refused() {
    // 4000 x 4000 RGB float32 is 192 MB, under the pixel and sample caps, but a
    // file of a few KiB cannot hold it under any compression but DWA.
    use x::Compression::*;
    for (c, lines) in [(ZIP16, 16), (RLE, 1), (Uncompressed, 1)] {
        let bytes = claiming(flat_exr(1, 1, c, &["rgb"]), 0, lines, 4000, 4000);
        let err = decode_exr(&bytes).unwrap_err().to_string();
        assert!(err.contains("file can hold"), "{c:?}: {err}");
    }
}

#[test]
fn exr_images_that_compress_as_well_as_possible_still_read() {
    // A flat image is the best case of every lossless compression: the bound on
    // what a byte can stand for must still let it through.
    use x::Compression::*;
    for c in [ZIP16, ZIP1, RLE, PIZ, PXR24, Uncompressed] {
        let img = decode_exr(&flat_exr(512, 512, c, &["rgb"])).unwrap();
        assert_eq!(img.size(), (512, 512), "{c:?}");
        assert_eq!(img.get(511, 511), Vec3::splat(0.25), "{c:?}");
    }
}

#[test]
fn huge_exr_as_reference_upload_is_a_bad_request() {
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
    let err = svc.upload_reference(&huge_exr()).unwrap_err().to_string();
    svc.shutdown();
    assert!(err.contains("100000 x 100000"), "{err}");
}

#[test]
fn huge_exr_as_environment_map_is_refused_and_named_as_the_scene_names_it() {
    let exr = huge_exr();
    let scene = with_envmap("maps/sky.exr");
    let (result, data_dir) = upload(&scene, &[("maps/sky.exr", &exr)]);
    let err = result.unwrap_err();
    assert!(err.contains("lights[0].filename"), "{err}");
    assert!(
        err.contains("maps/sky.exr") && err.contains("100000 x 100000"),
        "{err}"
    );
    assert!(!err.contains(&data_dir), "server path shown: {err}");

    let dir = folder(&with_envmap("sky.exr"), &[("sky.exr", &exr)]);
    let err = load_err(dir.path());
    assert!(err.contains("100000 x 100000"), "{err}");
    assert!(!err.contains(&dir.path().display().to_string()), "{err}");
}

/// The inputs a fuzzer found, in tests/data/fuzz/TARGET/.
fn findings(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz")
        .join(target);
    let mut out: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no inputs in {}", dir.display());
    out
}

#[test]
fn exr_files_that_panicked_the_decoder_do_not() {
    // Found by the exr fuzz target: B44 blocks whose arithmetic overflows, and a
    // chunk that trips a debug assertion in the crate. Both panic only where
    // overflow and debug assertions are checked (the fuzzer's build, debug builds),
    // and the B44 ones on the crate's decompression threads, where a panic aborts
    // the process; release builds wrap and decode garbage.
    for (name, bytes) in findings("exr") {
        if let Err(e) = decode_exr(&bytes) {
            assert!(e.to_string().contains("<memory>"), "{name}: {e}");
        }
    }
}

#[test]
fn exr_blocks_larger_than_the_image_count_against_the_caps() {
    // Found by the exr fuzz target: 470 bytes, a DWAA part of 16777244 x 3 pixels of
    // three f16 channels (300 MB, within the caps), whose 32-line blocks come to
    // 3.2 GB: the crate reserved a chunk's claimed size up to that, 1.8 GB here.
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/exr/dwa_block_claims_3gb.exr"),
    )
    .unwrap();
    let err = decode_exr(&bytes).unwrap_err().to_string();
    assert!(err.contains("bytes of samples, more than the"), "{err}");
}

#[test]
fn ply_headers_that_panicked_the_parser_are_errors() {
    // Found by the ply fuzz target: a number too large for its type in the header
    // (here the format version), which ply-rs's grammar unwraps.
    for (name, bytes) in findings("ply") {
        let err = caustic::scene::load::parse_ply(&bytes[..], "shapes[0].filename", &name)
            .err()
            .unwrap_or_else(|| panic!("{name} loaded"))
            .to_string();
        assert!(err.contains(&name), "{err}");
    }
}

#[test]
fn obj_indices_that_overflowed_the_loader_are_not_panics() {
    // Found by the obj fuzz target: a texture (and a normal) index so large that
    // tobj's index arithmetic overflows, a panic where overflow is checked (the
    // fuzzer's and debug builds); release builds wrap.
    for (name, bytes) in findings("obj") {
        let loaded = caustic::scene::load::parse_obj(&bytes[..], "shapes[0].filename", &name);
        if let Err(e) = loaded {
            assert!(e.to_string().contains(&name), "{e}");
        }
    }
}

// ------------------------------------------------------------------ paths in errors

#[test]
fn mesh_and_grid_errors_name_the_file_as_the_scene_does() {
    let bad_obj = b"v 0 0 0\nf 1 2 3\n".as_slice();
    let bad_ply = b"ply\nformat ascii 1.0\nelement vertex 1\nend_header\n".as_slice();
    let bad_vol = b"VOL\x03 not a volume".as_slice();
    let mut grid = tiny_scene();
    grid["media"] = json!({"fog": {"type": "grid", "file": "fog.vol", "sigma_t": [1, 1, 1]}});
    grid["camera"]["medium"] = json!("fog");
    let cases = [
        (with_shape("obj", "bad.obj"), "bad.obj", bad_obj),
        (with_shape("ply", "bad.ply"), "bad.ply", bad_ply),
        (grid, "fog.vol", bad_vol),
    ];
    for (scene, name, bytes) in cases {
        let dir = folder(&scene, &[(name, bytes)]);
        let err = load_err(dir.path());
        assert!(err.contains(name), "{err}");
        let abs = dir.path().canonicalize().unwrap();
        assert!(!err.contains(&abs.display().to_string()), "{err}");
        assert!(!err.contains(&dir.path().display().to_string()), "{err}");
        let (result, data_dir) = upload(&scene, &[(name, bytes)]);
        let err = result.unwrap_err();
        assert!(err.contains(name) && !err.contains(&data_dir), "{err}");
    }
}

#[test]
fn a_broken_scene_file_is_named_by_its_file_name_only() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.json");
    std::fs::write(&path, "not json").unwrap();
    let err = Scene::load(&path).err().expect("refused").to_string();
    assert!(err.starts_with("broken.json: "), "{err}");
}

// ------------------------------------------------------------------ OBJ mtllib

/// Loads `scene.json` of `dir` on another thread: `None` if it took over 10 s.
fn load_within_10s(dir: &Path) -> Option<Result<Scene, String>> {
    let path = dir.join("scene.json");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(Scene::load(&path).map_err(|e| e.to_string()));
    });
    rx.recv_timeout(Duration::from_secs(10)).ok()
}

#[test]
fn obj_mtllib_opens_no_file() {
    // Opening a FIFO for reading blocks until a writer comes: a loader that opened
    // the named material library would never return.
    let dir = folder(&with_shape("obj", "quad.obj"), &[]);
    let fifo = dir.path().join("lib.fifo");
    let c_path = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(c_path.as_ptr(), 0o600) }, 0);
    let obj = format!("mtllib {}\n{QUAD_OBJ}", fifo.display());
    std::fs::write(dir.path().join("quad.obj"), obj).unwrap();
    let loaded = load_within_10s(dir.path()).expect("the loader opened the mtllib FIFO");
    assert_eq!(loaded.unwrap().stats.triangles, 2);
}

#[test]
fn obj_mtllib_of_server_files_reads_nothing() {
    let obj = format!("mtllib /etc/passwd\nmtllib /dev/zero\nmtllib ../../x.mtl\n{QUAD_OBJ}");
    let scene = with_shape("obj", "quad.obj");
    let (result, _) = upload(&scene, &[("quad.obj", obj.as_bytes())]);
    result.unwrap();
    let dir = folder(&scene, &[("quad.obj", obj.as_bytes())]);
    let loaded = load_within_10s(dir.path()).expect("the loader read /dev/zero");
    assert_eq!(loaded.unwrap().stats.triangles, 2);
}

// ------------------------------------------------------------------ scene folder

#[test]
fn render_of_a_bare_scene_file_name_in_its_own_folder_works() {
    let dir = folder(
        &with_shape("obj", "quad.obj"),
        &[("quad.obj", QUAD_OBJ.as_bytes())],
    );
    let out = Command::new(env!("CARGO_BIN_EXE_caustic"))
        .current_dir(dir.path())
        .args(["render", "scene.json", "--spp", "1", "-o", "out.exr"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    let img: Image = caustic::film::read_exr(dir.path().join("out.exr")).unwrap();
    assert_eq!(img.size(), (8, 8));
}

// ------------------------------------------------------------------ mesh memory

/// A measurement, not a check: loads the mesh named by `CAUSTIC_MESH` (a .ply or
/// .obj file) so that its peak memory can be read, e.g.
/// `CAUSTIC_MESH=grid.ply /usr/bin/time -v target/release/deps/readers-* --ignored
/// --exact load_a_mesh_for_measuring`.
#[test]
#[ignore = "a measurement: set CAUSTIC_MESH and run under /usr/bin/time -v"]
fn load_a_mesh_for_measuring() {
    let path = std::path::PathBuf::from(std::env::var("CAUSTIC_MESH").expect("CAUSTIC_MESH"));
    let name = path.display().to_string();
    let mesh = if name.ends_with(".obj") {
        caustic::scene::load::load_obj(&path, "mesh", &name)
    } else {
        caustic::scene::load::load_ply(&path, "mesh", &name)
    }
    .unwrap();
    eprintln!(
        "{}: {} vertices, {} triangles",
        name,
        mesh.positions.len(),
        mesh.indices.len()
    );
    assert!(!mesh.indices.is_empty());
}

// ------------------------------------------------------------------ OpenVDB in a child process

fn vdb_fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn isolation(time: Duration) -> caustic::medium::grid_io::Isolation {
    caustic::medium::grid_io::Isolation {
        time,
        ..caustic::medium::grid_io::Isolation::server(env!("CARGO_BIN_EXE_caustic").into())
    }
}

#[test]
fn a_vdb_grid_read_by_the_child_process_is_the_grid_read_in_process() {
    use caustic::medium::grid_io::{load_grid, read_vdb_in_child};
    let iso = isolation(Duration::from_secs(60));
    for (file, grid) in [
        ("density_zip.vdb", "density"),
        ("grids.vdb", "density"),
        ("temperature_active.vdb", "temperature"),
    ] {
        // This test binary never isolates: load_grid reads in process.
        let here = load_grid(&vdb_fixture(file), Some(grid)).unwrap();
        let child = read_vdb_in_child(&iso, &vdb_fixture(file), grid).unwrap();
        assert_eq!(child.dims, here.dims, "{file}");
        assert_eq!(child.bounds, here.bounds, "{file}");
        let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&child.data), bits(&here.data), "{file}");
    }
}

#[test]
fn a_vdb_file_that_aborts_its_reader_is_an_error_naming_the_file_only() {
    use caustic::medium::grid_io::read_vdb_in_child;
    // A size field forged to 2^31 - 1: vdb-rs asks for about 4 GiB and the
    // child, past its address-space limit, aborts (found by scanning mutations).
    let forged = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/vdb/alloc_4g.vdb");
    let err = read_vdb_in_child(&isolation(Duration::from_secs(60)), &forged, "density")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("alloc_4g.vdb") && err.contains("stopped"),
        "{err}"
    );
    // The child ran in the file's folder with its name alone: what it says names no
    // folder (the caller's path comes first, and uploads show the scene's name there).
    let folder = forged.parent().unwrap().display().to_string();
    assert!(!child_says(&err).contains(&folder), "{err}");
}

/// Every input that crashed the in-process reader under the fuzzer
/// (tests/fuzz, target `vdb`) is an error from the child process, in time.
#[test]
fn every_vdb_fuzz_finding_is_an_error_from_the_child_process() {
    use caustic::medium::grid_io::read_vdb_in_child;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/vdb");
    let iso = isolation(Duration::from_secs(60));
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let result = read_vdb_in_child(&iso, &path, "density");
        assert!(result.is_err(), "{} was read", path.display());
        n += 1;
    }
    assert!(n >= 1, "no findings in {}", dir.display());
}

/// The part of a VDB error that came from the child process.
fn child_says(err: &str) -> &str {
    err.split_once("cannot read OpenVDB data: ")
        .map_or(err, |(_, m)| m)
}

#[test]
fn a_vdb_reader_past_its_deadline_is_stopped() {
    use caustic::medium::grid_io::read_vdb_in_child;
    let err = read_vdb_in_child(
        &isolation(Duration::ZERO),
        &vdb_fixture("grids.vdb"),
        "density",
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("longer than 0 s"), "{err}");
}

#[test]
fn vdb_errors_reported_by_the_child_keep_their_text() {
    use caustic::medium::grid_io::read_vdb_in_child;
    let iso = isolation(Duration::from_secs(60));
    let err = read_vdb_in_child(&iso, &vdb_fixture("grids.vdb"), "smoke")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("no grid named \"smoke\"") && err.contains("density"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let not_vdb = dir.path().join("plain.vdb");
    std::fs::write(&not_vdb, b"not a vdb file at all").unwrap();
    let err = read_vdb_in_child(&iso, &not_vdb, "density")
        .unwrap_err()
        .to_string();
    assert!(err.contains("plain.vdb"), "{err}");
    assert!(
        !child_says(&err).contains(&dir.path().display().to_string()),
        "{err}"
    );
}
