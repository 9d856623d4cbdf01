//! Area lights whose radiance is a texture (issue 37): the radiance a ray finds on the
//! light, the radiance light sampling and emission sampling report for the points
//! they pick, the light's power, and images by every algorithm.
//!
//! The independent estimator: a rectangle light with a checkerboard radiance is the
//! same light as its checks made separate rectangles of constant radiance (each
//! picked by its own power, sampled over its own area). pt on both must agree pixel
//! by pixel (within noise measured from independent batches); every other algorithm
//! must agree with pt on the textured light.

mod common;

use caustic::geometry::Ray;
use caustic::light::{AreaLight, Light};
use caustic::math::{Rng, Vec3};
use caustic::scene::load::parse_scene;
use caustic::scene::Scene;
use common::{compile, render, settings};
use serde_json::{json, Value};
use std::path::Path;

const C0: [f32; 3] = [4.0, 2.0, 1.0];
const C1: [f32; 3] = [0.5, 1.0, 3.0];
/// The checkerboard's `to_uv`: (0.75 u, 0.75 v), so the checks change at u = 2/3 and
/// v = 2/3 ([`U_EDGES`], [`V_EDGES`]): a large `color0` check, two of `color1` and a
/// small `color0` one, a pattern that neither a swap of the colours nor a flip of an
/// axis leaves alone, and coarse enough that the floor's lighting shows it.
const TO_UV: [[f32; 3]; 2] = [[0.75, 0.0, 0.0], [0.0, 0.75, 0.0]];
const U_EDGES: [f32; 3] = [0.0, 2.0 / 3.0, 1.0];
const V_EDGES: [f32; 3] = [0.0, 2.0 / 3.0, 1.0];

/// The light's corners: a vertical square of side 1.2 at the back of the floor,
/// facing the camera (-y); u runs from corner 0 to 1 (+x), v from corner 0 to 3 (+z).
const CORNERS: [[f32; 3]; 4] = [
    [-0.6, 0.8, 0.05],
    [0.6, 0.8, 0.05],
    [0.6, 0.8, 1.25],
    [-0.6, 0.8, 1.25],
];

fn checker(color0: [f32; 3], color1: [f32; 3]) -> Value {
    json!({"type": "checkerboard", "color0": color0, "color1": color1, "to_uv": TO_UV})
}

/// The checkerboard's colour at (u, v), computed here from Mitsuba's definition:
/// `color0` where the fractional parts of the mapped coordinates are on the same
/// side of 1/2.
fn check_colour(u: f32, v: f32) -> [f32; 3] {
    let high = |x: f32| x - x.floor() > 0.5;
    let (x, y) = (TO_UV[0][0] * u + TO_UV[0][2], TO_UV[1][1] * v + TO_UV[1][2]);
    if high(x) == high(y) {
        C0
    } else {
        C1
    }
}

/// The checks: (u0, u1, v0, v1, colour).
fn checks() -> Vec<(f32, f32, f32, f32, [f32; 3])> {
    let mut out = Vec::new();
    for u in U_EDGES.windows(2) {
        for v in V_EDGES.windows(2) {
            let colour = check_colour(0.5 * (u[0] + u[1]), 0.5 * (v[0] + v[1]));
            out.push((u[0], u[1], v[0], v[1], colour));
        }
    }
    out
}

/// A floor and a side wall lit by `lights` (emitting rectangles), seen from the
/// front, the lights' emitting side in view.
fn stage(lights: Vec<Value>) -> Value {
    let mut shapes = vec![
        json!({"type": "rectangle", "material": "floor", "transform": {"scale": 1.5}}),
        json!({"type": "rectangle", "material": "wall", "corners":
            [[-1.2, -1.5, 0], [-1.2, 1.5, 0], [-1.2, 1.5, 1.5], [-1.2, -1.5, 1.5]]}),
    ];
    shapes.extend(lights);
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0.2, -2.4, 1.2], "target": [0, -0.4, 0],
                               "up": [0, 0, 1]}, "fov": 55},
        "film": {"width": 24, "height": 24},
        "materials": {
            "floor": {"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]},
            "wall": {"type": "diffuse", "reflectance": [0.5, 0.6, 0.7]},
            "black": {"type": "diffuse", "reflectance": 0}
        },
        "shapes": shapes
    })
}

fn light(radiance: Value) -> Value {
    json!({"type": "rectangle", "material": "black", "corners": CORNERS,
           "emission": {"radiance": radiance}})
}

fn textured_stage() -> Scene {
    compile(stage(vec![light(checker(C0, C1))]))
}

/// Point (u, v) of the light: corner 0 plus u times the edge to corner 1 plus v times
/// the edge to corner 3.
fn on_light(u: f32, v: f32) -> [f32; 3] {
    let [p0, p1, _, p3] = CORNERS.map(Vec3::from);
    (p0 + (p1 - p0) * u + (p3 - p0) * v).into()
}

/// The same light as one rectangle of constant radiance per check.
fn cells_stage() -> Scene {
    let lights = (checks().into_iter())
        .map(|(u0, u1, v0, v1, colour)| {
            let corners = [
                on_light(u0, v0),
                on_light(u1, v0),
                on_light(u1, v1),
                on_light(u0, v1),
            ];
            json!({"type": "rectangle", "material": "black", "corners": corners,
                   "emission": {"radiance": colour}})
        })
        .collect();
    compile(stage(lights))
}

/// Per pixel and channel, the mean over independent batches of a render and the
/// variance of that mean (from the batches' spread).
struct Estimate {
    mean: Vec<[f64; 3]>,
    var: Vec<[f64; 3]>,
}

const BATCHES: u64 = 8;

/// `spp` iterations of `alg` on `scene`, in [`BATCHES`] batches of their own seeds;
/// no sample may be dropped.
fn estimate(scene: &Scene, alg: &str, spp: u64, seed: u64) -> Estimate {
    let s = settings(alg, json!({"max_depth": 4}));
    let batches: Vec<Vec<[f64; 3]>> = (0..BATCHES)
        .map(|b| {
            let (film, n) = render(scene, &s, seed * 100 + b, spp / BATCHES);
            assert_eq!(film.dropped(), 0, "{alg}");
            film.sums()
                .iter()
                .map(|p| p.map(|v| v / n as f64))
                .collect()
        })
        .collect();
    let k = BATCHES as f64;
    let pixels = batches[0].len();
    let mut out = Estimate {
        mean: vec![[0.0; 3]; pixels],
        var: vec![[0.0; 3]; pixels],
    };
    for i in 0..pixels {
        for c in 0..3 {
            let m = batches.iter().map(|b| b[i][c]).sum::<f64>() / k;
            let ss = batches.iter().map(|b| (b[i][c] - m).powi(2)).sum::<f64>();
            out.mean[i][c] = m;
            out.var[i][c] = ss / (k - 1.0) / k;
        }
    }
    out
}

/// Pixel values (per channel) where `b` and `a` differ by more than four standard
/// errors of the difference, plus `bias` times the pixel's and the image's mean
/// value (consistent methods' kernel bias); where neither varies (a light seen
/// directly by pt), they must agree to rounding. With batch variances (7 degrees of
/// freedom each) a few of the 1728 values exceed four standard errors by chance.
fn outliers(a: &Estimate, b: &Estimate, bias: f64) -> Vec<String> {
    let mut out = Vec::new();
    for c in 0..3 {
        let level = a.mean.iter().map(|p| p[c]).sum::<f64>() / a.mean.len() as f64;
        for i in 0..a.mean.len() {
            let (x, y) = (a.mean[i][c], b.mean[i][c]);
            let se = (a.var[i][c] + b.var[i][c]).sqrt();
            let slack = bias * (x + level) + 1e-5 * (x.abs() + y.abs());
            if (y - x).abs() > 4.0 * se + slack {
                out.push(format!("pixel {i} channel {c}: {y} against {x} (se {se})"));
            }
        }
    }
    out
}

/// At most 1 % of the pixel values of `b` are [`outliers`] against `a`.
fn assert_same_image(a: &Estimate, b: &Estimate, bias: f64, what: &str) {
    let o = outliers(a, b, bias);
    assert!(
        o.len() * 100 <= a.mean.len() * 3,
        "{what}: {} outliers: {o:#?}",
        o.len()
    );
}

/// Renders the textured stage with pt and with each `(algorithm, spp, bias)` and
/// asserts that the images agree pixel by pixel.
fn assert_agree_with_pt(cases: &[(&str, u64, f64)]) {
    let scene = textured_stage();
    let reference = estimate(&scene, "pt", 1024, 1);
    for &(alg, spp, bias) in cases {
        assert_same_image(&reference, &estimate(&scene, alg, spp, 2), bias, alg);
    }
}

#[test]
fn pt_on_the_checker_light_matches_its_checks_as_separate_lights() {
    let textured = estimate(&textured_stage(), "pt", 4096, 1);
    let cells = estimate(&cells_stage(), "pt", 4096, 2);
    assert_same_image(
        &cells,
        &textured,
        0.0,
        "pt: textured against separate checks",
    );
    // The test can fail: the checks swapped, or mirrored in u, give other images.
    for (what, radiance) in [
        ("swapped", checker(C1, C0)),
        ("mirrored", {
            let mut c = checker(C0, C1);
            c["to_uv"] = json!([[-0.75, 0, 0.75], [0, 0.75, 0]]);
            c
        }),
    ] {
        let other = estimate(&compile(stage(vec![light(radiance)])), "pt", 256, 3);
        let caught = outliers(&cells, &other, 0.0).len();
        assert!(caught > 200, "{what}: only {caught} outliers");
    }
}

#[test]
fn unbiased_algorithms_agree_with_pt() {
    assert_agree_with_pt(&[
        ("volpath", 512, 0.0),
        ("lt", 1024, 0.0),
        ("bpt", 512, 0.0),
        ("vpl", 64, 0.0),
    ]);
}

/// The methods that merge or gather blur the image: a kernel bias bounded here by 3 %
/// of the pixel's value plus 3 % of the image mean, at their default radii.
#[test]
fn merging_algorithms_agree_with_pt() {
    assert_agree_with_pt(&[
        ("vcm", 256, 0.03),
        ("sppm", 128, 0.03),
        ("vpm", 256, 0.03),
        ("ppb", 256, 0.03),
        ("upbp", 256, 0.03),
        ("vrl", 64, 0.03),
        ("vbl", 64, 0.03),
    ]);
}

/// bpm's estimates are sparse at a test's budget (most batches find no photon in a
/// pixel, so batch variances miss its noise), and ppm traces each pixel's eye ray
/// once (no antialiasing where the light's edge crosses a pixel): both are held to
/// pt's image mean instead (`common::assert_same_image`, channels 0 and 2).
#[test]
fn bpm_and_ppm_agree_with_pt_on_the_image_mean() {
    common::assert_algorithms_agree_with_pt(
        &textured_stage(),
        json!({"max_depth": 4}),
        1024,
        &[("bpm", 1024, 0.03), ("ppm", 256, 0.03)],
    );
}

/// Looking straight at the light, which fills the view: each pixel inside a check
/// shows that check's colour exactly (rays that hit the light read the texture at
/// the hit's (u, v), Mitsuba's rectangle parametrisation (u, v) = ((x + 1) / 2,
/// (y + 1) / 2), image row 0 at the top).
#[test]
fn the_camera_sees_the_texture_on_the_light() {
    let scene = compile(json!({
        "format": 1,
        // tan(45 deg) at distance 1: the image covers exactly [-1, 1]^2.
        "camera": {"look_at": {"origin": [0, 0, 1], "target": [0, 0, 0], "up": [0, 1, 0]},
                   "fov": 90},
        "film": {"width": 36, "height": 36},
        "materials": {"black": {"type": "diffuse", "reflectance": 0}},
        "shapes": [{"type": "rectangle", "material": "black",
                    "emission": {"radiance": checker(C0, C1)}}]
    }));
    let (film, n) = render(&scene, &settings("pt", json!({"max_depth": 1})), 1, 4);
    let near_edge = |x: f32, edges: &[f32]| edges.iter().any(|e| (x - e).abs() < 1.5 / 36.0);
    let mut checked = 0;
    for (i, px) in film.sums().iter().enumerate() {
        // u along +x, v along +y (up the image).
        let u = ((i % 36) as f32 + 0.5) / 36.0;
        let v = 1.0 - ((i / 36) as f32 + 0.5) / 36.0;
        if near_edge(u, &U_EDGES) || near_edge(v, &V_EDGES) {
            continue;
        }
        checked += 1;
        let want = check_colour(u, v);
        for c in 0..3 {
            let got = px[c] / n as f64;
            assert!(
                (got - want[c] as f64).abs() < 1e-5,
                "pixel {i} at (u, v) = ({u}, {v}) channel {c}: {got}, want {}",
                want[c]
            );
        }
    }
    assert!(checked > 500, "{checked}");
}

/// Light selection weighs the light by its mean radiance over the surface (the
/// checks' colours weighted by their areas) times pi times its area.
#[test]
fn power_is_the_mean_radiance_times_pi_times_the_area() {
    let scene = textured_stage();
    let power = scene.lights[0].power(&scene.sphere);
    let area = 1.2 * 1.2;
    for c in 0..3 {
        let mean: f32 = (checks().iter())
            .map(|(u0, u1, v0, v1, colour)| (u1 - u0) * (v1 - v0) * colour[c])
            .sum();
        let want = mean * std::f32::consts::PI * area;
        assert!(
            (power[c] - want).abs() < 0.02 * want,
            "channel {c}: {} against {want}",
            power[c]
        );
    }
}

/// An 8 x 8 raw PNG whose texels all differ, read with nearest filtering: the
/// texture tells (u, v) apart to an eighth, so flips and swaps of the axes show.
fn write_texels(dir: &Path) {
    let img = image::RgbImage::from_fn(8, 8, |x, y| {
        image::Rgb([30 + 28 * x as u8, 30 + 28 * y as u8, 100])
    });
    img.save(dir.join("texels.png")).unwrap();
}

fn area(scene: &Scene) -> &AreaLight {
    match &scene.lights[0] {
        Light::Area(a) => a,
        _ => panic!("not an area light"),
    }
}

/// The radiance the ray found going back into the light along -n from just off the
/// point `p` with normal `n`, or None when it hit elsewhere.
fn found_at(scene: &Scene, p: Vec3, n: Vec3) -> Option<caustic::math::Rgb> {
    let it = scene.intersect(&Ray::new(p + n * 0.25, -n))?;
    ((it.p - p).length() < 1e-4).then(|| area(scene).le(&it, n))
}

/// For every shape Mitsuba parametrises (rectangle, disk mirrored, sphere turned,
/// cube) and a mesh with its own (u, v): the radiance light sampling and emission
/// sampling report for a point is the radiance a ray finds there.
#[test]
fn sampled_points_carry_the_radiance_a_ray_finds_there() {
    let dir = tempfile::tempdir().unwrap();
    write_texels(dir.path());
    let texture = json!({"type": "bitmap", "filename": "texels.png", "raw": true,
                         "filter": "nearest"});
    let shapes = [
        json!({"type": "rectangle", "transform": {"scale": 0.7,
            "rotate": [{"axis": [1, 1, 0], "angle": 30}]}}),
        json!({"type": "disk", "transform": {"scale": [-0.5, 0.5, 0.5]}}),
        json!({"type": "sphere", "radius": 0.5,
            "transform": {"rotate": [{"axis": [0, 1, 1], "angle": 70}]}}),
        json!({"type": "cube", "transform": {"scale": 0.4}}),
        json!({"type": "mesh", "positions": [[0, 0, 0], [1, 0, 0], [0.2, 1, 0]],
            "indices": [[0, 1, 2]], "uvs": [[0.9, 0.1], [0.2, 0.3], [0.5, 0.95]]}),
    ];
    for mut shape in shapes {
        let what = shape["type"].as_str().unwrap().to_string();
        shape["material"] = json!("black");
        shape["emission"] = json!({"radiance": texture});
        let file = json!({"format": 1,
            "camera": {"look_at": {"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0]},
                   "fov": 40},
            "film": {"width": 4, "height": 4},
            "materials": {"black": {"type": "diffuse", "reflectance": 0}},
            "shapes": [shape]});
        let scene =
            Scene::compile(&parse_scene(&file.to_string()).unwrap(), Some(dir.path())).unwrap();
        let light = &scene.lights[0];
        let mut rng = Rng::new(7, 0, 0);
        let (mut checked, mut differ) = (0, 0);
        let mut seen = std::collections::HashSet::new();
        for _ in 0..2000 {
            let from = Vec3::new(0.3, -0.2, 2.0);
            if let Some(ls) = light.sample_li(from, rng.next_2d()) {
                if let Some(le) = found_at(&scene, ls.p(), ls.n()) {
                    checked += 1;
                    differ += (le != ls.li()) as u32;
                    seen.insert(ls.li().to_array().map(f32::to_bits));
                }
            }
            let es = light.sample_le(&scene.sphere, rng.next_2d(), rng.next_2d());
            if let Some(es) = es {
                if let Some(le) = found_at(&scene, es.p, es.n) {
                    checked += 1;
                    differ += (le != es.le) as u32;
                    seen.insert(es.le.to_array().map(f32::to_bits));
                }
            }
        }
        // A few points fall within rounding of a texel's edge.
        assert!(checked > 1500, "{what}: only {checked} points checked");
        assert!(
            differ * 200 < checked,
            "{what}: {differ} of {checked} differ"
        );
        assert!(seen.len() >= 8, "{what}: {} texels seen", seen.len());
    }
}

/// A negative colour in the radiance's texture, or a negative or NaN texel in its
/// image, is refused, naming the field.
#[test]
fn scene_errors_name_the_emission_field() {
    let dir = tempfile::tempdir().unwrap();
    let texels = vec![
        Vec3::ONE,
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::ONE,
        Vec3::splat(f32::NAN),
    ];
    let img = caustic::film::Image::from_pixels(2, 2, texels);
    caustic::film::write_exr(dir.path().join("bad.exr"), &img).unwrap();
    for (radiance, field, words) in [
        (
            json!({"type": "checkerboard", "color0": [1, -1, 1]}),
            "shapes[0].emission.radiance.color0",
            "negative",
        ),
        (
            json!({"type": "bitmap", "filename": "bad.exr"}),
            "shapes[0].emission.radiance",
            "NaN, infinite or negative",
        ),
    ] {
        let bad = json!({"format": 1,
            "camera": {"look_at": {"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0]},
                       "fov": 40},
            "film": {"width": 4, "height": 4},
            "materials": {"black": {"type": "diffuse", "reflectance": 0}},
            "shapes": [{"type": "rectangle", "material": "black",
                        "emission": {"radiance": radiance}}]});
        let file = parse_scene(&bad.to_string()).unwrap();
        let e = Scene::compile(&file, Some(dir.path()))
            .err()
            .expect("refused");
        assert_eq!(e.path, field, "{e}");
        assert!(e.to_string().contains(words), "{e}");
    }
}

/// Mitsuba's `area` emitter with a `<texture name="radiance">` (checkerboard with a
/// `to_uv`, bitmap) imports as textured emission and renders.
#[test]
fn mitsuba_textured_area_lights_import() {
    use caustic::scene::mitsuba::import_file;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba");
    let import = import_file(&dir.join("emitter-area-textured.xml")).unwrap();
    assert!(import.warnings.is_empty(), "{:?}", import.warnings);
    let emission: Vec<Value> = (import.scene.shapes.iter())
        .filter_map(|s| s.common.emission.as_ref())
        .map(|e| serde_json::to_value(e).unwrap())
        .collect();
    let checker = json!({"radiance": {"type": "checkerboard", "color0": [4.0, 2.0, 1.0],
        "color1": [0.5, 1.0, 3.0], "to_uv": [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0]]},
        "two_sided": false});
    let bitmap = json!({"radiance": {"type": "bitmap", "filename": "heights.png",
        "raw": false, "filter": "nearest", "wrap": "repeat"}, "two_sided": false});
    assert_eq!(emission, [checker, bitmap]);
    // The image is one of the scene's files (what an upload keeps, what `caustic
    // import` copies).
    let mut file = import.scene.clone();
    let refs = caustic::scene::files::references_mut(&mut file);
    // The disk, last, has the bitmap.
    let last = import.scene.shapes.len() - 1;
    assert!(
        refs.iter().any(
            |(f, name)| *f == format!("shapes[{last}].emission.radiance.filename")
                && name.as_str() == "heights.png"
        ),
        "{:?}",
        refs.iter().map(|(f, _)| f).collect::<Vec<_>>()
    );
    let scene = Scene::compile(&import.scene, Some(&dir)).unwrap();
    assert_eq!(
        scene
            .lights
            .iter()
            .filter(|l| matches!(l, Light::Area(_)))
            .count(),
        2
    );
    let (film, n) = render(&scene, &settings("pt", json!({"max_depth": 3})), 1, 2);
    assert_eq!(film.dropped(), 0);
    assert!(common::channel(&film, n, 0).iter().any(|&v| v > 0.0));
}
