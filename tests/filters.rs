//! Pixel filters (issue 37) in whole renders: the scene format's `filter`, a flat
//! emitter seen through every filter, camera samples against light-tracing splats, and
//! images that do not depend on the thread count or on how iterations are grouped.
//! The filter functions themselves are tested in `film::filter`, the film's
//! normalisation (edges included) in `film::accum`.

mod common;
use caustic::film::{ExactSums, Film, Filter};
use caustic::integrator::drive::iterate_exact;
use caustic::integrator::Integrator;
use caustic::scene::format::FilterDesc;
use caustic::scene::{load::parse_scene, Scene};
use common::*;
use serde_json::{json, Value};

/// Every filter at Mitsuba 3's defaults, in the scene format's object form.
fn all_filters() -> Vec<Value> {
    vec![
        json!("box"),
        json!({"type": "box", "radius": 1.5}),
        json!("tent"),
        json!("gaussian"),
        json!({"type": "mitchell", "B": 0, "C": 0.5}),
        json!("mitchell"),
        json!("lanczos"),
    ]
}

/// Radiance of the flat emitter, per channel.
const LE: [f64; 3] = [0.5, 1.0, 2.0];

/// A camera looking straight at a one-sided emitter just larger than its view (which
/// spans +-0.58 by +-0.51 at the emitter), so that most light paths reach the film.
fn flat_emitter(filter: Value) -> Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 1], "target": [0, 0, 0], "up": [0, 1, 0]},
                   "fov": 60},
        "film": {"width": 16, "height": 14, "filter": filter},
        "materials": {"black": {"type": "diffuse", "reflectance": [0, 0, 0]}},
        "shapes": [{"type": "rectangle", "material": "black",
                    "transform": {"scale": [0.7, 0.6, 1]},
                    "emission": {"radiance": LE}}]
    })
}

/// The Cornell box at `size` x `size` with `filter`.
fn cornell(size: u32, filter: Value) -> Scene {
    let path = format!("{}/scenes/cornell-box.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": size, "height": size, "filter": filter});
    compile(v)
}

#[test]
fn filters_parse_round_trip_and_default_to_the_box() {
    let mut v = flat_emitter(json!("box"));
    v["film"].as_object_mut().unwrap().remove("filter");
    let f = parse_scene(&v.to_string()).unwrap();
    assert_eq!(f.film.filter.0, Filter::Box { radius: 0.5 });
    let written = serde_json::to_value(&f.film).unwrap();
    assert_eq!(
        written["filter"],
        json!("box"),
        "the default is written as before"
    );
    let cases = [
        (json!("gaussian"), Filter::Gaussian { stddev: 0.5 }),
        (
            json!({"type": "gaussian", "stddev": 0.25}),
            Filter::Gaussian { stddev: 0.25 },
        ),
        (json!({"type": "tent"}), Filter::Tent { radius: 1.0 }),
        (
            json!({"type": "mitchell", "C": 0.5}),
            Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 0.5,
            },
        ),
        (
            json!({"type": "lanczos", "lobes": 2}),
            Filter::Lanczos { lobes: 2 },
        ),
    ];
    for (json, want) in cases {
        let f = parse_scene(&flat_emitter(json.clone()).to_string()).unwrap();
        assert_eq!(f.film.filter.0, want, "{json}");
        let text = serde_json::to_string(&f.film.filter).unwrap();
        let back: FilterDesc = serde_json::from_str(&text).unwrap();
        assert_eq!(back, f.film.filter, "{text}");
    }
}

/// A bad filter is refused with the field's path and the parameter named.
#[test]
fn bad_filters_name_the_field() {
    let cases = [
        (json!("sinc"), "sinc"),
        (json!({"type": "gaussian", "sigma": 1}), "sigma"),
        (json!({"type": "gaussian", "stddev": 0}), "stddev 0"),
        (json!({"type": "gaussian", "stddev": 1.5}), "stddev 1.5"),
        (json!({"type": "box", "radius": 5}), "radius 5"),
        (json!({"type": "tent", "radius": -1}), "radius -1"),
        (json!({"type": "mitchell", "B": 1.5}), "B 1.5"),
        (json!({"type": "lanczos", "lobes": 0}), "lobes 0"),
        (json!({"type": "lanczos", "lobes": 5}), "lobes 5"),
        (json!(3), "film.filter"),
    ];
    for (filter, words) in cases {
        let text = flat_emitter(filter.clone()).to_string();
        let e = match parse_scene(&text) {
            Err(e) => e,
            Ok(f) => match Scene::compile(&f, None) {
                Err(e) => e,
                Ok(_) => panic!("accepted: {text}"),
            },
        };
        assert_eq!(e.path, "film.filter", "{filter}: {e}");
        assert!(e.to_string().contains(words), "{filter}: {e}");
    }
}

/// `pt` sees the emitter in every sample, so every pixel is its radiance, edges and
/// corners included, whatever the filter (camera samples are weighted means).
#[test]
fn a_flat_emitter_is_flat_through_every_filter() {
    for filter in all_filters() {
        let scene = compile(flat_emitter(filter.clone()));
        let (film, n) = render(&scene, &settings("pt", json!({"max_depth": 1})), 3, 2);
        let img = film.to_image(1.0 / n as f64);
        for (i, p) in img.pixels().iter().enumerate() {
            for c in 0..3 {
                let d = (p[c] as f64 - LE[c]).abs();
                assert!(d < 1e-6 * LE[c], "{filter}: pixel {i} {p}");
            }
        }
    }
}

/// Per-seed means of `f` over the `images` of several independent renders.
fn seed_means(
    images: &[caustic::film::Image],
    f: impl Fn(&caustic::film::Image) -> f64,
) -> (f64, f64) {
    mean_se(&images.iter().map(f).collect::<Vec<_>>())
}

/// The image of `iterations` iterations of `alg` with seed `seed`.
fn image(
    scene: &Scene,
    alg: &str,
    params: Value,
    seed: u64,
    iterations: u64,
) -> caustic::film::Image {
    let (film, n) = render(scene, &settings(alg, params), seed, iterations);
    assert_eq!(film.dropped(), 0);
    film.to_image(1.0 / n as f64)
}

/// The mean of channel `c` over the pixels at least `inset` (pixel centres) from
/// every edge; all pixels with an inset of 0.
fn inner_mean(img: &caustic::film::Image, c: usize, inset: f64) -> f64 {
    let (w, h) = (img.width(), img.height());
    let mut sum = (0.0, 0u32);
    for y in 0..h {
        for x in 0..w {
            let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
            if [cx, w as f64 - cx, cy, h as f64 - cy]
                .iter()
                .all(|&d| d >= inset)
            {
                sum = (sum.0 + img.get(x, y)[c] as f64, sum.1 + 1);
            }
        }
    }
    sum.0 / sum.1 as f64
}

/// `lt` splats the same emitter: the image keeps its energy (its mean is the
/// radiance) and pixels two radii in from the edges converge to the radiance, with
/// every filter.
#[test]
fn light_tracing_a_flat_emitter_keeps_its_energy() {
    for filter in all_filters() {
        let scene = compile(flat_emitter(filter.clone()));
        let inset = 2.0 * scene.filter.filter().radius();
        let images: Vec<_> = (0..8)
            .map(|s| image(&scene, "lt", json!({"max_depth": 1}), 11 + s, 48))
            .collect();
        for (c, le) in LE.iter().enumerate() {
            for (what, inset) in [("all", 0.0), ("interior", inset)] {
                let (m, se) = seed_means(&images, |img| inner_mean(img, c, inset));
                assert!(se > 0.0 && se < 0.05 * le, "{filter} {what}: se {se}");
                assert!((m - le).abs() < 4.0 * se, "{filter} {what} {c}: {m} ± {se}");
            }
        }
    }
}

/// The path tracer (camera samples, weighted means) and the light tracer (splats,
/// normalised weights) agree within noise on the Cornell box through a Gaussian and
/// a Lanczos filter, away from the edges where Mitsuba's splat normalisation differs
/// by design. Without either normalisation the Gaussian's images would differ by half.
#[test]
fn pt_and_lt_agree_through_a_filter() {
    for filter in [json!("gaussian"), json!("lanczos")] {
        let scene = cornell(20, filter.clone());
        let inset = 2.0 * scene.filter.filter().radius();
        let params = json!({"max_depth": 4});
        let pt: Vec<_> = (0..6)
            .map(|s| image(&scene, "pt", params.clone(), 100 + s, 64))
            .collect();
        let lt: Vec<_> = (0..6)
            .map(|s| image(&scene, "lt", params.clone(), 200 + s, 64))
            .collect();
        for c in 0..3 {
            let (a, sa) = seed_means(&pt, |img| inner_mean(img, c, inset));
            let (b, sb) = seed_means(&lt, |img| inner_mean(img, c, inset));
            let tol = 4.0 * (sa * sa + sb * sb).sqrt() + 2e-3 * a;
            assert!(tol < 0.05 * a, "{filter}: too noisy to tell ({tol} vs {a})");
            assert!(
                (a - b).abs() < tol,
                "{filter} channel {c}: pt {a} ± {sa}, lt {b} ± {sb}"
            );
        }
    }
}

/// A filtered film (camera samples spread over tiles' borders, splats from every
/// thread, layers) is the same bit for bit on 1 and 3 threads.
#[test]
fn filtered_images_do_not_depend_on_the_thread_count() {
    let scene = cornell(19, json!("lanczos"));
    for (alg, params) in [
        ("pt", json!({"max_depth": 3})),
        ("bpt", json!({"max_depth": 3})),
        ("vcm", json!({"max_depth": 3, "technique_layers": true})),
    ] {
        let run = |threads| {
            on_threads(threads, || {
                render(&scene, &settings(alg, params.clone()), 9, 3).0
            })
        };
        let (one, three): (Film, Film) = (run(1), run(3));
        assert!(one.weights().is_some(), "{alg}: a filtered film");
        assert_eq!(one.splats().is_some(), alg != "pt", "{alg}");
        assert_eq!(one, three, "{alg}");
        let bits = |f: &Film| -> Vec<u32> {
            f.to_image(1.0 / 3.0)
                .pixels()
                .iter()
                .flat_map(|p| p.to_array())
                .map(f32::to_bits)
                .collect()
        };
        assert_eq!(bits(&one), bits(&three), "{alg}");
    }
}

/// The sums of `iterations` in order from fresh state.
fn range_sums(
    scene: &Scene,
    integ: &dyn Integrator,
    iterations: std::ops::Range<u64>,
) -> ExactSums {
    let (w, h) = (scene.width(), scene.height());
    let (mut scratch, mut sums) = (Film::new(w, h), ExactSums::new(w, h));
    for i in iterations {
        iterate_exact(scene, integ, 7, i, &mut scratch, &mut sums);
    }
    sums
}

/// Ranges of iterations merged in any order, and sums that went through a
/// checkpoint's bytes (a resume), give the sequential sums exactly: the weights and
/// splats are exact sums too.
#[test]
fn filtered_ranges_and_resumes_equal_the_sequential_sums() {
    let scene = cornell(12, json!({"type": "gaussian", "stddev": 0.7}));
    let integ = settings("bpt", json!({"max_depth": 3})).build();
    let whole = range_sums(&scene, integ.as_ref(), 0..5);
    let mut merged = ExactSums::new(12, 12);
    for r in [3..5, 0..1, 1..3] {
        let part = range_sums(&scene, integ.as_ref(), r);
        let resumed = ExactSums::decode(&part.encode()).unwrap();
        merged.merge(&resumed).unwrap();
    }
    assert_eq!(merged, whole);
    let film = whole.to_film();
    assert!(film.weights().is_some() && film.splats().is_some());
}

/// A filtered film's layers (camera parts over the image's summed weights, splats
/// normalised as the image's) still add up to the image they split.
#[test]
fn filtered_strategy_images_sum_to_the_image() {
    let scene = cornell(18, json!("mitchell"));
    let s = settings("bpt", json!({"max_depth": 3, "strategy_images": 3}));
    let (film, n) = render(&scene, &s, 5, 4);
    let image = film.to_image(1.0 / n as f64);
    let layers = film.layer_images();
    assert_eq!(layers.len(), 9);
    let peak = image
        .pixels()
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max);
    for (i, p) in image.pixels().iter().enumerate() {
        let sum: glam::Vec3 = layers.iter().map(|(_, l)| l.pixels()[i]).sum();
        let d = (sum - *p).abs().max_element() / peak;
        assert!(d < 1e-4, "pixel {i}: layers {sum} vs image {p}");
    }
}
