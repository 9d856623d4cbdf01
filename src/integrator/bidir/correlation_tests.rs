//! Correlation-aware MIS in the renderer: it moves weight between techniques on the
//! same subpaths, so each image must equal the plain one's expectation (paired over
//! seeds: the same subpaths, different weights) while differing from it sample by
//! sample. The weights themselves are checked against the explicit definition in
//! `mis/tests/correlated.rs`.

use super::selection::tests::{bidir, glass_lamp_box, image, scene};
use crate::scene::Scene;

/// Per quarter of the image, the sum of all channels, per seed.
fn quarters(scene: &Scene, alg: &str, params: &serde_json::Value, seeds: u64) -> Vec<[f64; 4]> {
    let w = scene.width() as usize;
    let h = scene.height() as usize;
    (0..seeds)
        .map(|seed| {
            let img = image(scene, &bidir(alg, params.clone()), 200 + seed, 2);
            let mut q = [0.0f64; 4];
            for (i, p) in img.pixels().iter().enumerate() {
                let (x, y) = (i % w, i / w);
                q[usize::from(x >= w / 2) + 2 * usize::from(y >= h / 2)] +=
                    (p.x + p.y + p.z) as f64;
                assert!(p.is_finite(), "pixel {i} is {p:?}");
            }
            q
        })
        .collect()
}

/// `alg` with `params` against the same with `correlation_aware` (for `upbp`, `params`
/// select `all`, which correlation-aware jobs take): per quarter, the
/// paired mean difference within 4 standard errors; and the largest single-seed
/// difference relative to the quarter's mean, which the caller asserts is not
/// rounding (the weights do move).
fn agrees(scene: &Scene, alg: &str, params: serde_json::Value, seeds: u64) -> f64 {
    let mut aware = params.clone();
    aware["correlation_aware"] = serde_json::json!(true);
    let a = quarters(scene, alg, &aware, seeds);
    let b = quarters(scene, alg, &params, seeds);
    let mut moved = 0.0f64;
    for q in 0..4 {
        let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x[q] - y[q]).collect();
        let n = d.len() as f64;
        let m = d.iter().sum::<f64>() / n;
        let var = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
        let z = m.abs() / (var / n).sqrt().max(1e-300);
        let mean = b.iter().map(|x| x[q]).sum::<f64>() / n;
        let largest = d.iter().fold(0.0f64, |l, x| l.max(x.abs()));
        moved = moved.max(largest / mean.abs().max(1e-300));
        eprintln!("{alg} quarter {q}: mean {mean:.4e}, difference {m:.3e} ({z:.2} se), largest {largest:.3e}");
        assert!(z < 4.0, "{alg} quarter {q}: {z} standard errors");
    }
    moved
}

/// vcm and bpm on the Cornell box seen through glass and lit through glass (caustic
/// paths that only merges find, at every camera depth).
///
/// Both weightings are unbiased only as the radius shrinks: a merge evaluates each
/// side at its own vertex (the photon and the camera point, up to r apart), so at a
/// fixed radius the merge kernel's blur is weighed differently, and the images differ
/// by O(r). Measured with 3000 paired seeds: at radius_factor 0.05 vcm's quarters
/// differ by up to 1.3% of their mean (12.6 standard errors), at 0.0125 by at most
/// 0.3% (2.2), while plain vcm itself moves 2.6% between the two radii. Hence the
/// small radius here, where that difference is below the noise of 300 seeds.
#[test]
fn correlation_aware_vcm_and_bpm_keep_their_expectation() {
    let scene = glass_lamp_box(16);
    let params = serde_json::json!({"max_depth": 8, "radius_factor": 0.0125, "merge_depth": "all"});
    for alg in ["vcm", "bpm"] {
        let moved = agrees(&scene, alg, params.clone(), 300);
        assert!(moved > 1e-4, "{alg}: the weights did not move ({moved})");
    }
}

/// upbp with surface and point x point merges in fog, a lit shaft and heterogeneous
/// smoke: merges in media at every camera vertex, their rho from volume footprints
/// (small radii, as above).
#[test]
fn correlation_aware_upbp_keeps_its_expectation_in_media() {
    for file in ["fog-cornell", "spot-shaft", "smoke-room"] {
        let scene = scene(&format!("scenes/media/{file}.json"), 16);
        let params = serde_json::json!({
            "max_depth": 6, "merge_depth": "all", "techniques": "bpt+surf+pp3d",
            "radius_factor": 0.0125, "medium_radius_factor": 0.01, "selection": "all"
        });
        let moved = agrees(&scene, "upbp", params, 100);
        assert!(moved > 1e-4, "{file}: the weights did not move ({moved})");
    }
}

/// upbp with every estimator: point x beam 2D and beam x beam 1D take their rho at
/// points on the query beam and on photon beams, which no stored link stands for (the
/// links are built there as the subpaths would build them). Short query beams in the
/// fog and the shaft, long ones (weighted as long beams) in the smoke.
#[test]
fn correlation_aware_upbp_with_beams_keeps_its_expectation() {
    for (file, beams) in [
        ("fog-cornell", "short"),
        ("spot-shaft", "short"),
        ("smoke-room", "long"),
    ] {
        let scene = scene(&format!("scenes/media/{file}.json"), 16);
        let params = serde_json::json!({
            "max_depth": 6, "merge_depth": "all", "query_beams": beams,
            "radius_factor": 0.0125, "medium_radius_factor": 0.01,
            "pb2d_radius_factor": 0.005, "bb1d_radius_factor": 0.0025, "selection": "all"
        });
        let moved = agrees(&scene, "upbp", params, 100);
        assert!(moved > 1e-4, "{file}: the weights did not move ({moved})");
    }
}
