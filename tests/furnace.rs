//! Furnace tests: inside a closed diffuse enclosure whose walls have albedo a and emit
//! Le, radiance is Le (1 - a^D) / (1 - a) everywhere for max_depth D (Mitsuba's
//! meaning), which tends to Le / (1 - a).

mod common;
use common::*;
use serde_json::json;

fn furnace_scene(albedo: f32, le: f32, width: u32) -> serde_json::Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0.1, -0.2, 0.3], "target": [1, 0.5, -0.2], "up": [0, 0, 1]},
                   "fov": 80},
        "film": {"width": width, "height": width},
        "materials": {"wall": {"type": "diffuse", "reflectance": [albedo, albedo, albedo]}},
        "shapes": [{"type": "cube", "material": "wall", "flip_normals": true,
                    "transform": {"scale": [2, 3, 1.5]},
                    "emission": {"radiance": [le, le, le]}}]
    })
}

fn check_furnace(albedo: f32, le: f32, heuristic: &str) {
    check_furnace_with(albedo, le, json!({"heuristic": heuristic}));
}

/// The furnace with `pt` parameters `params` (max_depth 64 added).
fn check_furnace_with(albedo: f32, le: f32, mut params: serde_json::Value) {
    let scene = compile(furnace_scene(albedo, le, 24));
    let depth = 64u32;
    params["max_depth"] = json!(depth);
    let s = settings("pt", params);
    let (film, n) = render(&scene, &s, 5, 32);
    assert_eq!(film.dropped(), 0);
    let a = albedo as f64;
    let expected = le as f64 * (1.0 - a.powi(depth as i32)) / (1.0 - a);
    for c in 0..3 {
        let (m, se) = mean_se(&channel(&film, n, c));
        assert!(
            (m - expected).abs() < 4.0 * se + 1e-6,
            "albedo {albedo}: channel {c} mean {m} vs {expected} (se {se})"
        );
        // The estimate must also be precise enough for the test to mean something.
        assert!(se < 0.02 * expected, "se {se} too large");
    }
}

#[test]
fn white_furnace_converges_to_le_over_one_minus_albedo() {
    check_furnace(0.5, 1.0, "power");
    check_furnace(0.8, 0.25, "balance");
}

/// SmallVCM's roulette (survival = albedo at every vertex, and in the BSDF's MIS
/// density): the walls are emitters, so both strategies meet at every vertex and
/// weights that left the survival out of one side would not sum to one.
#[test]
fn albedo_roulette_converges_to_the_same_furnace() {
    for (albedo, heuristic) in [(0.5, "power"), (0.3, "balance")] {
        let params = json!({"heuristic": heuristic, "roulette": "albedo", "rr_depth": 0});
        check_furnace_with(albedo, 1.0, params);
    }
}

#[test]
fn max_depth_truncates_the_neumann_series() {
    // With max_depth 3 only emission after 0, 1 and 2 bounces counts: Le (1 + a + a^2).
    let scene = compile(furnace_scene(0.6, 1.0, 16));
    let s = settings("pt", json!({"max_depth": 3}));
    let (film, n) = render(&scene, &s, 9, 32);
    let (m, se) = mean_se(&channel(&film, n, 1));
    let expected = 1.0 + 0.6 + 0.36;
    assert!(
        (m - expected).abs() < 4.0 * se + 1e-6,
        "{m} vs {expected} (se {se})"
    );
}
