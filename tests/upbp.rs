//! `upbp` (unifying points, beams and paths): every technique subset that can render
//! the whole image agrees with `volpath` block by block within the renders' noise on
//! the fog-filled Cornell box, the spot-light shaft and the smoke room (heterogeneous);
//! the volume techniques alone agree with each other on the medium's part; the beam
//! estimators' bias is measured to shrink with their radius (the technique layers:
//! tests/layers.rs); no dropped samples in extreme media; the image does not depend on the
//! thread count; bad technique sets are refused by name.

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::integrator::Settings;
use caustic::scene::Scene;
use common::{extreme_media, fog_box, on_threads, render, settings, shipped_media};
use serde_json::{json, Value};
use stats::{assert_agree, blocks, mean_z2, run, Rect, Run};

const SIZE: u32 = 16;
const BLOCK: u32 = 4;
const MAX_DEPTH: u32 = 8;

fn shipped(name: &str) -> Scene {
    shipped_media(name, SIZE, MAX_DEPTH)
}

/// upbp with `techniques`, radii fit for 16 x 16 pixels, and `extra` on top.
fn upbp(techniques: &[&str], extra: Value) -> Settings {
    let mut p = json!({
        "max_depth": MAX_DEPTH, "techniques": techniques, "light_paths": 8,
        "beam_paths": 0.25, "radius": 0.03, "medium_radius": 0.05,
        "pb2d_radius": 0.03, "bb1d_radius": 0.02
    });
    for (k, v) in extra.as_object().unwrap() {
        p[k] = v.clone();
    }
    settings("upbp", p)
}

fn volpath(scene: &Scene, regions: &[Rect]) -> Run {
    let s = settings("volpath", json!({ "max_depth": MAX_DEPTH }));
    let r = run(scene, &s, 101, 4000, regions);
    assert_eq!(r.dropped, 0);
    r
}

/// Each technique set agrees with volpath block by block, with `extra` settings.
fn agree_with(scene: &Scene, sets: &[&[&str]], iterations: u64, extra: Value) {
    let regions = blocks(SIZE, SIZE, BLOCK);
    let vp = volpath(scene, &regions);
    for (k, set) in sets.iter().enumerate() {
        let s = upbp(set, extra.clone());
        let r = run(scene, &s, 7 + k as u64, iterations, &regions);
        assert_eq!(r.dropped, 0, "upbp {set:?}: dropped samples");
        eprintln!("upbp {set:?}, {extra}:");
        assert_agree(&vp, &r, &regions);
    }
}

/// The same with the default (short) query beams.
fn agree(scene: &Scene, sets: &[&[&str]], iterations: u64) {
    agree_with(scene, sets, iterations, json!({}));
}

const ALL: &[&str] = &["bpt", "surf", "pp3d", "pb2d", "bb1d"];

#[test]
fn every_complete_technique_set_agrees_with_volpath_in_fog() {
    // Each volume estimator alone (with surface photons for the surfaces), with
    // connections, and all together.
    let sets: &[&[&str]] = &[
        ALL,
        &["bpt"],
        &["surf", "pp3d"],
        &["surf", "pb2d"],
        &["surf", "bb1d"],
        &["bpt", "pb2d", "bb1d"],
    ];
    agree(&shipped("fog-cornell"), sets, 150);
}

/// Long query beams (to the next surface, weighted by transmittance) estimate the
/// same image, with the long beams' MIS weights (1 / T larger densities) and with the
/// short beams' ones.
#[test]
fn long_query_beams_agree_with_volpath_too() {
    let sets: &[&[&str]] = &[ALL, &["bpt", "pb2d", "bb1d"], &["surf", "bb1d"]];
    let scene = shipped("fog-cornell");
    agree_with(&scene, sets, 150, json!({ "query_beams": "long" }));
    let short_weights = json!({ "query_beams": "long", "long_beam_weights": false });
    agree_with(&scene, &[ALL], 150, short_weights);
}

/// The same in the spot-light shaft, whose beam of light crosses deep fog.
#[test]
fn long_query_beams_agree_with_volpath_in_a_spot_light_shaft() {
    let sets: &[&[&str]] = &[ALL, &["surf", "bb1d"]];
    agree_with(
        &shipped("spot-shaft"),
        sets,
        150,
        json!({ "query_beams": "long" }),
    );
}

/// The default `merge_depth: first` (merges in media only up to the camera's first
/// scattering in a medium, the other techniques taking the paths they leave) is what
/// the tests above render; `all` merges at every camera segment and vertex.
#[test]
fn merges_at_every_camera_depth_agree_with_volpath() {
    let all = json!({ "merge_depth": "all" });
    let sets: &[&[&str]] = &[ALL, &["surf", "pp3d"]];
    agree_with(&shipped("fog-cornell"), sets, 150, all);
    let long = json!({ "merge_depth": "all", "query_beams": "long" });
    agree_with(&shipped("spot-shaft"), &[ALL, &["surf", "bb1d"]], 150, long);
}

#[test]
fn upbp_agrees_with_volpath_in_a_spot_light_shaft() {
    agree(&shipped("spot-shaft"), &[ALL, &["surf", "bb1d"]], 150);
}

#[test]
fn upbp_agrees_with_volpath_in_heterogeneous_smoke() {
    agree(&shipped("smoke-room"), &[ALL, &["surf", "pb2d"]], 150);
    // D = sigma_t(x) and T by quadrature in the MIS: another partition of unity.
    let local = json!({ "local_media_mis": true, "query_beams": "long" });
    agree_with(&shipped("smoke-room"), &[ALL], 150, local);
}

/// Photon beams from a light at infinity: on a light subpath's first segment the MIS
/// has no distance, only the transmittance ([TR] sec. 5.1), at a beam's points as at
/// its first vertex (a fog cube over a floor under a constant sky).
#[test]
fn photon_beams_from_a_light_at_infinity_agree_with_volpath() {
    let scene = common::compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": SIZE, "height": SIZE},
        "materials": {"white": {"type": "diffuse", "reflectance": [0.7, 0.7, 0.7]},
                      "boundary": {"type": "null"}},
        "media": {"fog": {"type": "homogeneous", "sigma_t": [1.5, 1.5, 1.5], "albedo": [0.9, 0.9, 0.9]}},
        "shapes": [
            {"type": "rectangle", "corners": [[-3, -1, 3], [3, -1, 3], [3, -1, -3], [-3, -1, -3]], "material": "white"},
            {"type": "cube", "material": "boundary", "interior": "fog"}
        ],
        "lights": [{"type": "constant", "radiance": [1, 1, 1]}]
    }));
    let sets: &[&[&str]] = &[&["bpt", "bb1d"], ALL];
    agree_with(&scene, sets, 600, json!({ "merge_depth": "all" }));
}

/// Without surface photons or connections the volume techniques render only light
/// that scattered in the medium last; point x point, point x beam and beam x beam
/// each estimate that same part.
#[test]
fn the_volume_estimators_alone_agree_with_each_other() {
    let scene = shipped("fog-cornell");
    let regions = blocks(SIZE, SIZE, BLOCK);
    // Point x point 3D is the heaviest-tailed (a rare photon within a small ball):
    // it gets more iterations, which cost it the least.
    let runs: Vec<Run> = [("pp3d", 600), ("pb2d", 150), ("bb1d", 150)]
        .iter()
        .enumerate()
        .map(|(k, (t, n))| run(&scene, &upbp(&[t], json!({})), 30 + k as u64, *n, &regions))
        .collect();
    for r in &runs {
        assert_eq!(r.dropped, 0);
    }
    assert_agree(&runs[0], &runs[1], &regions);
    assert_agree(&runs[0], &runs[2], &regions);
}

/// The beam estimators' bias at a fixed radius (alpha 1), measured as in tests/ppb.rs:
/// mean z^2 against volpath far above 1 at a large radius, within the noise's bound at
/// a small one.
#[test]
fn the_beam_estimators_bias_shrinks_with_their_radius() {
    let scene = shipped("fog-cornell");
    let regions = blocks(SIZE, SIZE, BLOCK);
    let vp = volpath(&scene, &regions);
    let bound = 1.0 + 4.0 * (2.0f64 / 16.0).sqrt();
    for (t, big, small) in [("pb2d", 0.8, 0.02), ("bb1d", 0.4, 0.01)] {
        let z2 = |r: f64| {
            let extra = json!({ format!("{t}_radius"): r, format!("{t}_alpha"): 1.0 });
            let run = run(&scene, &upbp(&["surf", t], extra), 3, 400, &regions);
            assert_eq!(run.dropped, 0);
            mean_z2(&run, &vp, regions.len())
        };
        let (b, s) = (z2(big), z2(small));
        eprintln!(
            "{t}: mean z^2 against volpath: r {big} {b:.2}, r {small} {s:.2} (bound {bound:.2})"
        );
        assert!(b > 2.0 * bound, "{t}: no bias measured at r = {big}: {b}");
        assert!(s < bound, "{t}: bias left at r = {small}: {s}");
    }
}

#[test]
fn extreme_media_render_without_dropped_samples() {
    // Plain, and with correlation-aware weights (whose footprints are volumes there).
    let correlated = json!({"max_depth": 12, "merge_depth": "all", "correlation_aware": true});
    for medium in extreme_media() {
        let scene = fog_box(8, medium.clone());
        for extra in [json!({"max_depth": 12}), correlated.clone()] {
            let r = run(&scene, &upbp(ALL, extra.clone()), 3, 2, &[]);
            assert_eq!(r.dropped, 0, "upbp {extra} in {medium}");
            let m = r.whole().mean;
            assert!(
                m.iter().all(|c| c.is_finite() && *c >= 0.0),
                "upbp {extra} in {medium}"
            );
        }
    }
}

#[test]
fn upbp_does_not_depend_on_the_thread_count() {
    let scene = shipped("fog-cornell");
    let s = upbp(ALL, json!({}));
    let one = on_threads(1, || render(&scene, &s, 5, 2).0);
    let two = on_threads(2, || render(&scene, &s, 5, 2).0);
    assert_eq!(one.sums(), two.sums());
}

#[test]
fn bad_technique_sets_are_refused_by_name() {
    let bad = |alg: &str, p: Value, word: &str| {
        let map = p.as_object().cloned().unwrap();
        let err = Settings::resolve(Some(alg), None, &map)
            .unwrap_err()
            .to_string();
        assert!(err.contains(word), "{alg} {p}: {err}");
    };
    bad("upbp", json!({"techniques": []}), "techniques");
    bad("upbp", json!({"techniques": ["bpt", "bpt"]}), "twice");
    bad("upbp", json!({"techniques": ["pp4d"]}), "techniques");
    bad("upbp", json!({"techniques": "surf+pp4d"}), "pp4d");
    // The joined form names the same sets as lists.
    let map = |v: Value| v.as_object().cloned().unwrap();
    let joined = Settings::resolve(Some("upbp"), None, &map(json!({"techniques": "surf+pb2d"})));
    let listed = Settings::resolve(
        Some("upbp"),
        None,
        &map(json!({"techniques": ["surf", "pb2d"]})),
    );
    assert_eq!(joined.unwrap(), listed.unwrap());
    let all = Settings::resolve(Some("upbp"), None, &map(json!({"techniques": "all"})));
    assert_eq!(all.unwrap(), settings("upbp", json!({})));
    bad("vcm", json!({"techniques": ["bpt"]}), "upbp");
    bad("upbp", json!({"beam_paths": 0}), "beam_paths");
    bad("upbp", json!({"bb1d_radius": -1}), "bb1d_radius");
    bad("upbp", json!({"pb2d_alpha": 2}), "pb2d_alpha");
}
