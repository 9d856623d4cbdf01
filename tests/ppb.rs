//! Progressive photon beams (`ppb`): short and long beams against `volpath` on the
//! fog-filled Cornell box, the smoke room (heterogeneous) and a point light in an
//! unbounded medium, block by block within the renders' noise; the bias measured to
//! shrink with the radius; no dropped samples in extreme media; images independent
//! of the thread count; the beam budget respected; bad parameters refused by name.

mod common;
#[allow(dead_code)]
#[path = "bidirectional/stats.rs"]
mod stats;

use caustic::film::Film;
use caustic::integrator::{RenderStats, Settings};
use caustic::scene::Scene;
use common::{extreme_media, fog_box, on_threads, settings, shipped_media};
use serde_json::{json, Value};
use stats::{assert_agree, blocks, mean_z2, run, Rect, Run};

const SIZE: u32 = 16;
const BLOCK: u32 = 4;
const MAX_DEPTH: u32 = 8;

/// A shipped scene at SIZE x SIZE with MAX_DEPTH.
fn shipped(name: &str) -> Scene {
    shipped_media(name, SIZE, MAX_DEPTH)
}
fn ppb(params: Value) -> Settings {
    let mut p = params;
    p["max_depth"] = json!(MAX_DEPTH);
    settings("ppb", p)
}

fn volpath(scene: &Scene, iterations: u64, regions: &[Rect]) -> Run {
    let r = run(
        scene,
        &settings("volpath", json!({ "max_depth": MAX_DEPTH })),
        101,
        iterations,
        regions,
    );
    assert_eq!(r.dropped, 0);
    r
}

/// Both beam forms agree with volpath block by block.
fn agree(scene: &Scene, reference: u64, params: Value, iterations: u64) {
    let regions = blocks(SIZE, SIZE, BLOCK);
    let vp = volpath(scene, reference, &regions);
    for (k, form) in ["short", "long"].into_iter().enumerate() {
        let mut p = params.clone();
        p["beams"] = json!(form);
        let r = run(scene, &ppb(p.clone()), 7 + k as u64, iterations, &regions);
        assert_eq!(r.dropped, 0, "ppb {p}: dropped samples");
        eprintln!("ppb {p}:");
        assert_agree(&vp, &r, &regions);
    }
}

#[test]
fn fog_cornell_agrees_with_volpath() {
    agree(
        &shipped("fog-cornell"),
        4000,
        json!({"radius": 0.01, "light_paths": {"count": 64}}),
        300,
    );
}

#[test]
fn smoke_room_agrees_with_volpath() {
    // A radius of 0.01 in this dense smoke (sigma_t 25) leaves an estimate so
    // heavy-tailed that 300 iterations underestimate its noise; 0.04 does not.
    agree(
        &shipped("smoke-room"),
        4000,
        json!({"radius": 0.04, "light_paths": {"count": 64}}),
        300,
    );
}

#[test]
fn point_light_in_an_unbounded_medium_agrees_with_volpath() {
    agree(
        &shipped("vrl-point-g0"),
        4000,
        json!({"radius": 0.01, "light_paths": {"count": 64}}),
        300,
    );
}

/// The bias of a fixed radius (alpha = 1), measured: the mean over blocks and channels
/// of z^2, the squared difference from volpath in units of the two renders' noise. With
/// no bias it is 1, within sqrt(2 / 16) per standard error (chi-square with one degree
/// of freedom per term; the three channels of a block move together, so 16 independent
/// terms, not 48). At r = 0.3 (a tenth of the box) the blur's bias stands far out; at
/// r = 0.01 nothing is left beyond the noise.
#[test]
fn the_bias_shrinks_with_the_radius() {
    let scene = shipped("fog-cornell");
    let regions = blocks(SIZE, SIZE, BLOCK);
    let vp = volpath(&scene, 4000, &regions);
    let mean_z2 = |r: f64| {
        let p = json!({"radius": r, "alpha": 1.0, "light_paths": 1.0});
        let run = run(&scene, &ppb(p), 3, 200, &regions);
        assert_eq!(run.dropped, 0);
        mean_z2(&run, &vp, regions.len())
    };
    let (big, small) = (mean_z2(0.3), mean_z2(0.01));
    let bound = 1.0 + 4.0 * (2.0f64 / 16.0).sqrt();
    eprintln!("mean z^2 against volpath: r 0.3 {big:.2}, r 0.01 {small:.2} (no bias: 1, bound {bound:.2})");
    assert!(big > 2.0 * bound, "no bias measured at r = 0.3: {big}");
    assert!(small < bound, "bias left at r = 0.01: {small}");
}

#[test]
fn extreme_media_render_without_dropped_samples() {
    for medium in extreme_media() {
        let scene = fog_box(8, medium.clone());
        for form in ["short", "long"] {
            let p = json!({"beams": form, "light_paths": 2.0, "radius": 0.05});
            let r = run(&scene, &ppb(p.clone()), 3, 2, &[]);
            assert_eq!(r.dropped, 0, "ppb {p} in {medium}");
            let m = r.whole().mean;
            assert!(
                m.iter().all(|c| c.is_finite() && *c >= 0.0),
                "{p} in {medium}"
            );
        }
    }
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    for name in ["fog-cornell", "smoke-room"] {
        let scene = shipped(name);
        let s = ppb(json!({"light_paths": 0.5}));
        let films: Vec<(Film, RenderStats)> = [1, 2]
            .into_iter()
            .map(|threads| {
                on_threads(threads, || {
                    let integ = s.build();
                    let mut film = Film::new(scene.width(), scene.height());
                    let mut st = RenderStats::default();
                    for i in 0..3 {
                        st += integ.iterate(&scene, 5, i, &mut film);
                    }
                    (film, st)
                })
            })
            .collect();
        assert_eq!(films[0].0, films[1].0, "{name}: 1 vs 2 threads");
        let st = &films[0].1;
        assert!(st.light_vertices > 0 && st.merges > 0, "{name}: {st:?}");
    }
}

/// A budget too small for the iteration's beams stores fewer of them (and renders).
#[test]
fn the_beam_budget_bounds_the_beams_stored() {
    let scene = shipped("fog-cornell");
    let beams = |mib: f64| {
        let integ = ppb(json!({"light_paths": 4.0, "max_beam_mib": mib})).build();
        let mut film = Film::new(scene.width(), scene.height());
        let st = integ.iterate(&scene, 1, 0, &mut film);
        assert_eq!(film.dropped(), 0);
        st.light_vertices
    };
    let (full, tight) = (beams(512.0), beams(0.01));
    // 0.01 MiB holds about 190 segments of 56 bytes.
    assert!(full > 400 && tight < 250 && tight > 0, "{full} vs {tight}");
}

#[test]
fn bad_parameters_are_refused_by_name() {
    for (p, word) in [
        (json!({"beams": "medium"}), "beams"),
        (json!({"radius": -1.0}), "radius"),
        (json!({"radius_factor": 0.0}), "radius_factor"),
        (json!({"alpha": 1.5}), "alpha"),
        (json!({"max_beam_mib": 0.0}), "max_beam_mib"),
        (json!({"light_paths": {"count": 0}}), "light_paths"),
        (json!({"nodes": 3}), "nodes"),
    ] {
        let map = p.as_object().cloned().unwrap();
        let e = Settings::resolve(Some("ppb"), None, &map)
            .map(|s| format!("accepted: {s:?}"))
            .unwrap_or_else(|e| e.to_string());
        assert!(e.contains(word) && !e.starts_with("accepted"), "{p}: {e}");
    }
}
