//! Scale invariance, thread-count determinism and the Cornell box's known values.

mod common;
use caustic::scene::format::{GeometryDesc, Scale, SceneFile, TransformDesc};
use caustic::scene::{load::read_scene_file, Scene};
use common::*;
use serde_json::json;
use std::path::Path;

fn cornell(width: u32) -> SceneFile {
    let mut f = read_scene_file(Path::new("scenes/cornell-box.json")).unwrap();
    f.film.width = width;
    f.film.height = width;
    f
}

/// The same scene with every length multiplied by `k`.
fn scaled(mut f: SceneFile, k: f32) -> SceneFile {
    let s3 = |v: &mut [f32; 3]| v.iter_mut().for_each(|x| *x *= k);
    s3(&mut f.camera.look_at.origin);
    s3(&mut f.camera.look_at.target);
    for shape in &mut f.shapes {
        match &mut shape.geometry {
            GeometryDesc::Rectangle { corners: Some(c) } => c.iter_mut().for_each(s3),
            GeometryDesc::Cube {} => {
                let t = shape
                    .common
                    .transform
                    .get_or_insert_with(TransformDesc::default);
                if let Some(tr) = t.translate.as_mut() {
                    s3(tr);
                }
                t.scale = Some(match t.scale.take() {
                    Some(Scale::PerAxis(mut v)) => {
                        s3(&mut v);
                        Scale::PerAxis(v)
                    }
                    Some(Scale::Uniform(u)) => Scale::Uniform(u * k),
                    None => Scale::Uniform(k),
                });
            }
            g => panic!("unexpected shape {g:?}"),
        }
    }
    f
}

fn mean_luminance_stats(scene: &Scene, seed: u64, spp: u64) -> (Vec<f64>, f64, f64, u64) {
    let (film, n) = render(scene, &settings("pt", json!({})), seed, spp);
    let lum: Vec<f64> = film
        .sums()
        .iter()
        .map(|p| (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) / n as f64)
        .collect();
    let (m, se) = mean_se(&lum);
    (lum, m, se, film.dropped())
}

fn rms(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>() / a.len() as f64).sqrt()
}

#[test]
fn cornell_box_scaled_by_1e_minus3_and_1e4_renders_the_same_image() {
    let base = Scene::compile(&cornell(48), None).unwrap();
    let (img0, m0, se0, d0) = mean_luminance_stats(&base, 1, 32);
    let (img_b, _, _, _) = mean_luminance_stats(&base, 2, 32);
    // Two independent renders of the same scene set the noise floor.
    let noise = rms(&img0, &img_b);
    assert_eq!(d0, 0);
    for k in [1e-3f32, 1e4] {
        let scene = Scene::compile(&scaled(cornell(48), k), None).unwrap();
        let (img, m, se, dropped) = mean_luminance_stats(&scene, 3, 32);
        assert_eq!(dropped, 0, "scale {k}: dropped samples");
        let bound = 4.0 * (se * se + se0 * se0).sqrt();
        assert!(
            (m - m0).abs() < bound,
            "scale {k}: mean {m} vs {m0} (bound {bound})"
        );
        // Light leaks or self-intersection would show as per-pixel differences far
        // above the noise of two independent renders.
        let d = rms(&img, &img0);
        assert!(d < 1.25 * noise, "scale {k}: rms {d} vs noise {noise}");
    }
}

#[test]
fn image_does_not_depend_on_thread_count() {
    let scene = Scene::compile(&cornell(40), None).unwrap();
    let s = settings("pt", json!({}));
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&scene, &s, 42, 3).0)
    };
    let one = run(1);
    let two = run(2);
    let three = run(3);
    assert!(one.sums().iter().any(|p| p[0] > 0.0));
    assert_eq!(one.sums(), two.sums());
    assert_eq!(one.sums(), three.sums());
    // A different seed gives a different image.
    let other = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| render(&scene, &s, 43, 3).0);
    assert_ne!(one.sums(), other.sums());
}

#[test]
fn cornell_light_pixels_read_emission_plus_reflection() {
    // The spec: light pixels read about (18.66, 14.09, 6.79): Le plus the white
    // material's reflection of the lit ceiling region around it.
    let scene = Scene::compile(&cornell(256), None).unwrap();
    let (film, n) = render(&scene, &settings("pt", json!({})), 7, 8);
    // Pixel (128, 36) lies inside the light's image (rows 32 to 41, columns 107 to 149).
    let p = film.sums()[36 * 256 + 128];
    let v: Vec<f64> = p.iter().map(|x| x / n as f64).collect();
    let expect = [18.66, 14.09, 6.79];
    for c in 0..3 {
        assert!(
            (v[c] - expect[c]).abs() < 0.05 * expect[c],
            "channel {c}: {} vs {}",
            v[c],
            expect[c]
        );
    }
}
