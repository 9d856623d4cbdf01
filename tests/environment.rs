//! Environment lighting: a diffuse sphere under uniform sky radiance L reflects rho L
//! at every point (it is convex, so each point sees a whole hemisphere of sky). The
//! constant light and an EXR environment map holding the same value must both agree.

mod common;
use caustic::film::{write_exr, Image};
use caustic::math::Rgb;
use caustic::scene::{load::parse_scene, Scene};
use common::*;
use serde_json::json;

const RHO: f64 = 0.7;
const L: f32 = 1.5;

fn sphere_scene(light: serde_json::Value) -> serde_json::Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": 32, "height": 32},
        "materials": {"m": {"type": "diffuse", "reflectance": [RHO, RHO, RHO]}},
        "shapes": [{"type": "sphere", "radius": 1, "material": "m"}],
        "lights": [light]
    })
}

/// Pixels whose centre ray hits the sphere well inside its silhouette, and ones that
/// miss it entirely, so the box filter never mixes the two.
fn classify(scene: &Scene) -> (Vec<usize>, Vec<usize>) {
    let (mut on, mut off) = (Vec::new(), Vec::new());
    for y in 0..32u32 {
        for x in 0..32u32 {
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
            let hits = corners
                .iter()
                .filter(|(dx, dy)| {
                    let s = caustic::math::Vec2::new(x as f32 + dx, y as f32 + dy);
                    scene
                        .intersect(&scene.camera.generate_ray(s, Default::default()))
                        .is_some()
                })
                .count();
            let i = (y * 32 + x) as usize;
            match hits {
                4 => on.push(i),
                0 => off.push(i),
                _ => {}
            }
        }
    }
    (on, off)
}

fn check(scene: &Scene) {
    let (film, n) = render(scene, &settings("pt", json!({"max_depth": 2})), 4, 64);
    assert_eq!(film.dropped(), 0);
    let img = channel(&film, n, 1);
    let (on, off) = classify(scene);
    assert!(on.len() > 100 && off.len() > 100);
    let vals: Vec<f64> = on.iter().map(|&i| img[i]).collect();
    let (m, se) = mean_se(&vals);
    let expected = RHO * L as f64;
    assert!(
        (m - expected).abs() < 4.0 * se + 1e-6,
        "sphere: {m} vs {expected} (se {se})"
    );
    for &i in &off {
        assert!((img[i] - L as f64).abs() < 1e-5, "background {}", img[i]);
    }
}

#[test]
fn diffuse_sphere_under_constant_sky() {
    check(&compile(sphere_scene(
        json!({"type": "constant", "radiance": [L, L, L]}),
    )));
}

#[test]
fn diffuse_sphere_under_uniform_environment_map() {
    let dir = tempfile::tempdir().unwrap();
    let map = Image::from_pixels(16, 8, vec![Rgb::splat(L); 16 * 8]);
    write_exr(dir.path().join("sky.exr"), &map).unwrap();
    let v = sphere_scene(json!({"type": "envmap", "filename": "sky.exr",
        "transform": {"rotate": [{"axis": [1, 0, 0], "angle": 30}]}}));
    let scene = Scene::compile(&parse_scene(&v.to_string()).unwrap(), Some(dir.path())).unwrap();
    check(&scene);
}

/// With a bright patch in the map, light sampling and BSDF sampling disagree strongly,
/// so MIS only stays unbiased if `sample_li` and `pdf_li` agree on every density. Power
/// and balance heuristics weight the two strategies differently: any mismatch shows as
/// different means.
#[test]
fn power_and_balance_heuristics_agree_under_a_peaked_environment_map() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (32, 16);
    let mut px = vec![Rgb::splat(0.2); w * h];
    for y in 2..5 {
        for x in 10..14 {
            px[y * w + x] = Rgb::splat(20.0);
        }
    }
    write_exr(
        dir.path().join("sky.exr"),
        &Image::from_pixels(w as u32, h as u32, px),
    )
    .unwrap();
    let v = sphere_scene(json!({"type": "envmap", "filename": "sky.exr"}));
    let scene = Scene::compile(&parse_scene(&v.to_string()).unwrap(), Some(dir.path())).unwrap();
    let (a, n) = render(&scene, &settings("pt", json!({"max_depth": 2})), 1, 64);
    let (b, _) = render(
        &scene,
        &settings("pt", json!({"max_depth": 2, "heuristic": "balance"})),
        2,
        64,
    );
    assert_eq!(a.dropped() + b.dropped(), 0);
    let (on, _) = classify(&scene);
    let va: Vec<f64> = on.iter().map(|&i| channel(&a, n, 0)[i]).collect();
    let vb: Vec<f64> = on.iter().map(|&i| channel(&b, n, 0)[i]).collect();
    let (ma, sa) = mean_se(&va);
    let (mb, sb) = mean_se(&vb);
    assert!(
        (ma - mb).abs() < 4.0 * (sa * sa + sb * sb).sqrt(),
        "{ma} vs {mb}"
    );
}
