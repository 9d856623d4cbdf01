//! The integrators' own EXR layers: per-strategy images of `bpt`, the connection and
//! merging parts of `vcm` and the five technique layers of `upbp` add up to the image
//! they split.

mod common;
use caustic::film::Image;
use caustic::scene::{load::read_scene_file, Scene};
use common::*;
use serde_json::json;
use std::path::Path;

fn small_cornell() -> Scene {
    let mut f = read_scene_file(Path::new("scenes/cornell-box.json")).unwrap();
    f.film.width = 24;
    f.film.height = 24;
    Scene::compile(&f, Some(Path::new("scenes"))).unwrap()
}

/// Largest per-pixel difference between `image` and the sum of `parts`, relative to
/// the image's brightest value.
fn parts_mismatch(image: &Image, parts: &[(String, Image)]) -> f32 {
    let peak = image
        .pixels()
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max);
    let mut worst = 0.0f32;
    for (i, p) in image.pixels().iter().enumerate() {
        let sum = parts.iter().map(|(_, l)| l.pixels()[i]).sum::<glam::Vec3>();
        worst = worst.max((sum - *p).abs().max_element() / peak);
    }
    worst
}

#[test]
fn bpt_strategy_images_sum_to_the_image() {
    let scene = small_cornell();
    let s = settings("bpt", json!({"max_depth": 3, "strategy_images": 3}));
    let (film, n) = render(&scene, &s, 5, 4);
    let layers = film.layer_images();
    let names: Vec<&str> = layers.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        ["s0_t2", "s1_t1", "s0_t3", "s1_t2", "s2_t1", "s0_t4", "s1_t3", "s2_t2", "s3_t1"]
    );
    let image = film.to_image(1.0 / n as f64);
    let worst = parts_mismatch(&image, &layers);
    assert!(worst < 1e-4, "strategies differ from the image by {worst}");
    // Every strategy that can carry light in the box does (s1_t1 is a light point seen
    // by a pinhole: it only exists for light tracing of emitters).
    for (name, l) in &layers {
        let total: f32 = l.pixels().iter().map(|p| p.element_sum()).sum();
        assert!(total > 0.0 || *name == "s1_t1", "{name} is black");
    }
}

#[test]
fn vcm_connection_and_merging_parts_sum_to_the_image() {
    let scene = small_cornell();
    let s = settings(
        "vcm",
        json!({"max_depth": 6, "technique_layers": true, "radius_factor": 0.02}),
    );
    let (film, n) = render(&scene, &s, 9, 4);
    let layers = film.layer_images();
    assert_eq!(layers.len(), 2);
    assert_eq!((layers[0].0.as_str(), layers[1].0.as_str()), ("vc", "vm"));
    let image = film.to_image(1.0 / n as f64);
    let worst = parts_mismatch(&image, &layers);
    assert!(worst < 1e-4, "vc + vm differ from the image by {worst}");
    for (name, l) in &layers {
        let total: f32 = l.pixels().iter().map(|p| p.element_sum()).sum();
        assert!(total > 0.0, "{name} is black");
    }
}

#[test]
fn upbp_technique_layers_sum_to_the_image() {
    let scene = shipped_media("fog-cornell", 16, 8);
    let p = json!({"technique_layers": true, "light_paths": 2, "beam_paths": 0.5,
                   "pb2d_radius": 0.03, "bb1d_radius": 0.02, "medium_radius": 0.05});
    let (film, n) = render(&scene, &settings("upbp", p), 4, 2);
    let layers = film.layer_images();
    let names: Vec<&str> = layers.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["bpt", "surf", "pp3d", "pb2d", "bb1d"]);
    let image = film.to_image(1.0 / n as f64);
    let worst = parts_mismatch(&image, &layers);
    assert!(
        worst < 1e-4,
        "the technique layers differ from the image by {worst}"
    );
    for (name, l) in &layers {
        let total: f32 = l.pixels().iter().map(|p| p.element_sum()).sum();
        assert!(total > 0.0, "{name} is black");
    }
}

/// `depth_layers` splits each merge layer by the camera vertex or segment the merge
/// sits at: the split layers add up to the technique's layer of the same render (same
/// seed and settings otherwise), and merges happen beyond the first camera segment.
#[test]
fn upbp_depth_layers_split_each_merge_layer() {
    let scene = shipped_media("fog-cornell", 16, 8);
    let p = json!({"technique_layers": true, "light_paths": 2, "beam_paths": 0.5,
                   "pb2d_radius": 0.03, "bb1d_radius": 0.02, "medium_radius": 0.05});
    let (whole, n) = render(&scene, &settings("upbp", p.clone()), 4, 2);
    let mut p_depth = p;
    p_depth["depth_layers"] = json!(true);
    let (split, n_split) = render(&scene, &settings("upbp", p_depth), 4, 2);
    assert_eq!(n, n_split);
    let whole = whole.layer_images();
    let split = split.layer_images();
    let names: Vec<&str> = split.iter().map(|(n, _)| n.as_str()).collect();
    let mut expected = vec!["bpt".to_string()];
    for t in ["surf", "pp3d", "pb2d", "bb1d"] {
        expected.extend(["c1", "c2", "c3+"].map(|c| format!("{t}_{c}")));
    }
    assert_eq!(names, expected);
    assert_eq!(split[0].1.pixels(), whole[0].1.pixels(), "bpt changed");
    for (k, (name, layer)) in whole.iter().enumerate().skip(1) {
        let parts = &split[1 + 3 * (k - 1)..4 + 3 * (k - 1)];
        let worst = parts_mismatch(layer, parts);
        assert!(
            worst < 1e-4,
            "{name}'s depth layers differ from it by {worst}"
        );
    }
    // Camera paths in the fog merge past their first segment too.
    let deeper: f32 = split
        .iter()
        .filter(|(n, _)| n.ends_with("_c2"))
        .flat_map(|(_, l)| l.pixels().iter().map(|p| p.element_sum()))
        .sum();
    assert!(
        deeper > 0.0,
        "no merge at the second camera vertex or segment"
    );
}

#[test]
fn layer_options_are_checked() {
    let map = |v: serde_json::Value| v.as_object().cloned().unwrap();
    let err = caustic::integrator::Settings::resolve(
        Some("bpt"),
        None,
        &map(json!({"technique_layers": true})),
    )
    .unwrap_err();
    assert!(err.to_string().contains("technique_layers"), "{err}");
    let err = caustic::integrator::Settings::resolve(
        Some("upbp"),
        None,
        &map(json!({"depth_layers": true})),
    )
    .unwrap_err();
    assert!(err.to_string().contains("depth_layers"), "{err}");
    let err = caustic::integrator::Settings::resolve(
        Some("bpt"),
        None,
        &map(json!({"strategy_images": 99})),
    )
    .unwrap_err();
    assert!(err.to_string().contains("strategy_images"), "{err}");
}
