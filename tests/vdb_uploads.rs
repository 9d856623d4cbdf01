//! OpenVDB files in uploaded bundles (issue 40): the server reads them in a child
//! process with memory and time limits, so a file that aborts the reader fails only
//! that upload, with a 422 naming the file, and the server goes on.

mod server_common;

use caustic::medium::grid_io::{isolate_vdb, Isolation};
use serde_json::{json, Value};
use server_common::{tar_with, TestServer};
use std::path::Path;

/// As `serve` does at start: `.vdb` files are read by a child `caustic vdb-grid`.
fn server() -> TestServer {
    isolate_vdb(Isolation::server(env!("CARGO_BIN_EXE_caustic").into()));
    TestServer::start(None)
}

fn data(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name),
    )
    .unwrap()
}

/// A small scene with a grid medium read from `smoke.vdb` (grid `grid`) in a box.
fn smoke_scene(grid: &str) -> Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": 12, "height": 12},
        "materials": {"boundary": {"type": "null"}},
        "media": {"smoke": {"type": "grid", "file": "smoke.vdb", "grid": grid,
                            "sigma_t": [4, 4, 4], "albedo": [0.8, 0.8, 0.8],
                            "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}}},
        "shapes": [{"type": "cube", "material": "boundary", "interior": "smoke"}],
        "lights": [{"type": "point", "position": [0, 3, 2], "intensity": [20, 20, 20]}]
    })
}

fn upload(s: &TestServer, scene: &Value, vdb: &[u8]) -> (u16, Value) {
    let text = scene.to_string();
    let bundle = tar_with(&[("scene.json", text.as_bytes()), ("smoke.vdb", vdb)]);
    s.post_bytes("/v1/scenes", &bundle)
}

#[test]
fn an_uploaded_vdb_grid_renders() {
    let s = server();
    let (code, body) = upload(&s, &smoke_scene("density"), &data("density_zip.vdb"));
    assert!((200..300).contains(&code), "{code} {body}");
    let id = body["id"].as_str().unwrap();
    let (code, job) = s.post_json("/v1/jobs", &json!({"scene": id, "halt": {"spp": 2}}));
    assert!((200..300).contains(&code), "{code} {job}");
    let done = s.wait_job(job["id"].as_str().unwrap());
    assert_eq!(done["state"], "completed", "{done}");
    assert_eq!(done["dropped"], 0, "{done}");
}

#[test]
fn a_vdb_that_aborts_its_reader_fails_only_its_upload() {
    let s = server();
    let forged = data("fuzz/vdb/alloc_4g.vdb");
    let (code, body) = upload(&s, &smoke_scene("density"), &forged);
    assert_eq!(code, 422, "{body}");
    let text = body.to_string();
    assert!(
        text.contains("smoke.vdb") && text.contains("stopped"),
        "{text}"
    );
    let dir = s.dir.path().display().to_string();
    assert!(!text.contains(&dir) && !text.contains("/tmp"), "{text}");
    // The server is still there, and a good upload still works.
    let (code, body) = upload(&s, &smoke_scene("density"), &data("density_zip.vdb"));
    assert!((200..300).contains(&code), "{code} {body}");
}

#[test]
fn a_vdb_without_the_named_grid_is_a_422_listing_what_it_holds() {
    let s = server();
    let (code, body) = upload(&s, &smoke_scene("smoke"), &data("grids.vdb"));
    assert_eq!(code, 422, "{body}");
    let text = body.to_string();
    assert!(
        text.contains("smoke.vdb") && text.contains("density"),
        "{text}"
    );
}
