//! A job's exact sums do not depend on how its iterations are grouped into ranges or
//! in which order the ranges are added (film::exact, drive::iterate_exact): what lets
//! a pool of workers render the same image, bit for bit, as one process.

mod common;
use caustic::film::{ExactSums, Film};
use caustic::integrator::drive::iterate_exact;
use caustic::integrator::Integrator;
use caustic::scene::Scene;
use common::*;
use serde_json::json;
use std::ops::Range;

/// The sums of `iterations`, rendered in order from fresh state.
fn range_sums(scene: &Scene, integ: &dyn Integrator, iterations: Range<u64>) -> ExactSums {
    let (w, h) = (scene.width(), scene.height());
    let (mut scratch, mut sums) = (Film::new(w, h), ExactSums::new(w, h));
    for i in iterations {
        iterate_exact(scene, integ, 7, i, &mut scratch, &mut sums);
    }
    sums
}

#[test]
fn ranges_merged_in_any_order_equal_the_sequential_sums() {
    let scene = shipped_media("fog-cornell", 24, 6);
    let cases = [
        ("pt", json!({})),
        // Light tracing splats from every thread into shared pixels.
        ("bpt", json!({})),
        ("vcm", json!({"technique_layers": true})),
        ("upbp", json!({"technique_layers": true})),
    ];
    for (alg, params) in cases {
        let integ = settings(alg, params).build();
        let whole = range_sums(&scene, integ.as_ref(), 0..6);
        let mut merged = ExactSums::new(scene.width(), scene.height());
        for r in [4..6, 0..1, 1..4] {
            merged
                .merge(&range_sums(&scene, integ.as_ref(), r))
                .unwrap();
        }
        assert_eq!(merged, whole, "{alg}");
        assert!(whole.to_film().sums().iter().any(|p| p[0] > 0.0), "{alg}");
        if alg != "pt" && alg != "bpt" {
            assert!(!whole.to_film().layer_images().is_empty(), "{alg}");
        }
    }
}

/// The exact image agrees with the plain f64 accumulation of the same iterations to
/// rounding (it is the same estimate).
#[test]
fn exact_sums_hold_the_plain_render() {
    let scene = shipped_media("fog-cornell", 24, 6);
    let integ = settings("bpt", json!({})).build();
    let mut film = Film::new(scene.width(), scene.height());
    for i in 0..4 {
        integ.iterate(&scene, 7, i, &mut film);
    }
    let exact = range_sums(&scene, integ.as_ref(), 0..4).to_film();
    for (a, b) in exact.sums().iter().zip(film.sums()) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-12 * b[c].abs() + 1e-18);
        }
    }
    assert_eq!(exact.dropped(), film.dropped());
}
