//! Issue 37's agreement scene: rough glass, a rough plastic, a textured floor, a
//! masked leaf and a normal-mapped wall in one Cornell box, rendered by every
//! algorithm and compared with `pt` pixel by pixel (`common::assert_same_image`: the
//! mean of the per-pixel differences within four of its standard errors, plus a
//! stated fraction of the image mean for the consistent methods' kernel bias). Light
//! tracing through rough glass (the adjoint eta^2 of refraction), light vertices on
//! textured and normal-mapped surfaces, and shadow rays and light paths through the
//! mask's holes all enter each image.

mod common;

use caustic::scene::load::parse_scene;
use caustic::scene::Scene;
use common::assert_algorithms_agree_with_pt;
use serde_json::{json, Value};
use std::path::Path;

/// An 8 x 8 normal map of bumps tilted up to 45 degrees, written into `dir`.
fn write_normal_map(dir: &Path) {
    let normals = image::RgbImage::from_fn(8, 8, |x, y| {
        let (a, b) = ((x as f32 - 3.5) / 3.5, (y as f32 - 3.5) / 3.5);
        let len = (a * a + b * b + 1.0).sqrt();
        let enc = |c: f32| ((c / len * 0.5 + 0.5) * 255.0).round() as u8;
        image::Rgb([enc(a), enc(b), enc(1.0)])
    });
    normals.save(dir.join("normals.png")).unwrap();
}

fn scene(dir: &Path) -> Scene {
    write_normal_map(dir);
    let path = format!("{}/scenes/cornell-box.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": 20, "height": 20});
    let white = v["materials"]["white"].clone();
    let m = &mut v["materials"];
    m["wall"] = json!({"type": "normalmap", "material": white, "flip_invalid_normals": false,
        "normalmap": {"type": "bitmap", "filename": "normals.png", "raw": true,
            "to_uv": [[3, 0, 0], [0, 3, 0]]}});
    m["checker floor"] = json!({"type": "diffuse", "reflectance": {"type": "checkerboard",
        "color0": [0.8, 0.7, 0.6], "color1": [0.2, 0.3, 0.5], "to_uv": [[4, 0, 0], [0, 4, 0]]}});
    m["rough glass"] = json!({"type": "roughdielectric", "distribution": "ggx", "alpha": 0.15,
        "int_ior": 1.5});
    m["plastic"] = json!({"type": "roughplastic", "alpha": 0.2,
        "diffuse_reflectance": [0.2, 0.4, 0.7]});
    m["leaf"] = json!({"type": "mask", "material":
            {"type": "diffuse", "reflectance": [0.2, 0.6, 0.1], "two_sided": true},
        "opacity": {"type": "checkerboard", "color0": [1, 1, 1], "color1": [0, 0, 0],
            "to_uv": [[3, 0, 0], [0, 3, 0]]}});
    for s in v["shapes"].as_array_mut().unwrap() {
        let material = match s["name"].as_str() {
            Some("back") => "wall",
            Some("floor") => "checker floor",
            Some("large box") => "rough glass",
            Some("small box") => "plastic",
            _ => continue,
        };
        s["material"] = json!(material);
    }
    v["shapes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"type": "rectangle", "material": "leaf",
        "transform": {"scale": 0.35, "rotate": [{"axis": [0, 1, 0], "angle": 35}],
            "translate": [-0.35, 0.25, 0.4]}}));
    Scene::compile(&parse_scene(&v.to_string()).unwrap(), Some(dir)).unwrap()
}

/// The unbiased methods, which must match pt's expectation exactly.
#[test]
fn unbiased_algorithms_agree_with_pt() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let cases = [
        ("volpath", 512, 0.0),
        ("lt", 2048, 0.0),
        ("bpt", 512, 0.0),
        ("vpl", 64, 0.0),
    ];
    assert_algorithms_agree_with_pt(&scene, json!({"max_depth": 4}), 2048, &cases);
}

/// The methods that merge or gather (photons, beams, virtual lights in media): their
/// kernels blur the image, a bias bounded here by 3 % of its mean at these radii.
#[test]
fn merging_algorithms_agree_with_pt() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene(dir.path());
    let cases = [
        ("vcm", 256, 0.03),
        ("bpm", 256, 0.03),
        ("upbp", 256, 0.03),
        ("sppm", 128, 0.03),
        ("ppm", 128, 0.03),
        ("vpm", 256, 0.03),
        ("ppb", 256, 0.03),
        ("vrl", 64, 0.03),
        ("vbl", 64, 0.03),
    ];
    assert_algorithms_agree_with_pt(&scene, json!({"max_depth": 4}), 2048, &cases);
}
