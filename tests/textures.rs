//! Textured materials under a uniform sky: a convex diffuse surface that sees the
//! whole sky over each point reflects rho(u, v) L there, so every pixel whose
//! footprint lies inside one texel or check has a known value. The (u, v) of each
//! pixel is computed here from the hit point with Mitsuba's parametrisation,
//! independently of the renderer's own, so the tests check the mapping (which check
//! is `color0`, image row order, sRGB decoding) as well as every algorithm's handling
//! of textured vertices (camera vertices, stored light vertices, visible points,
//! virtual lights).

mod common;
use caustic::math::{Vec2, Vec3};
use caustic::scene::{load::parse_scene, Scene};
use common::*;
use serde_json::json;

const L: f32 = 1.5;
const SIZE: u32 = 32;

fn sky_scene(material: serde_json::Value, shape: serde_json::Value) -> serde_json::Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": SIZE, "height": SIZE},
        "materials": {"m": material},
        "shapes": [shape],
        "lights": [{"type": "constant", "radiance": [L, L, L]}]
    })
}

/// Pixel indices by class: a pixel belongs to class k when its corners and centre all
/// hit the surface at points `class` puts in k.
fn classify(scene: &Scene, class: impl Fn(Vec3) -> Option<usize>, n: usize) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); n];
    for y in 0..SIZE {
        for x in 0..SIZE {
            let points = [
                (0.01, 0.01),
                (0.99, 0.01),
                (0.01, 0.99),
                (0.99, 0.99),
                (0.5, 0.5),
            ];
            let classes: Vec<Option<usize>> = (points.iter())
                .map(|(dx, dy)| {
                    let s = Vec2::new(x as f32 + dx, y as f32 + dy);
                    let ray = scene.camera.generate_ray(s, Default::default());
                    scene.intersect(&ray).and_then(|it| class(it.p))
                })
                .collect();
            if let Some(k) = classes[0] {
                if classes.iter().all(|&c| c == Some(k)) {
                    out[k].push((y * SIZE + x) as usize);
                }
            }
        }
    }
    out
}

/// Renders with `alg` and checks each class's mean pixel value (channel `c`) against
/// `expected[k] L`, within four standard errors.
#[allow(clippy::needless_range_loop)] // c indexes the film's channels and the expectations alike
fn check(
    scene: &Scene,
    alg: &str,
    params: serde_json::Value,
    spp: u64,
    classes: &[Vec<usize>],
    expected: &[[f64; 3]],
) {
    let (film, n) = render(scene, &settings(alg, params), 7, spp);
    assert_eq!(film.dropped(), 0, "{alg}");
    for c in 0..3 {
        let img = channel(&film, n, c);
        for (k, pixels) in classes.iter().enumerate() {
            assert!(pixels.len() >= 8, "class {k} has {} pixels", pixels.len());
            let vals: Vec<f64> = pixels.iter().map(|&i| img[i]).collect();
            let (m, se) = mean_se(&vals);
            let want = expected[k][c] * L as f64;
            assert!(
                (m - want).abs() <= 4.0 * se + 1e-4 * want,
                "{alg}: class {k} channel {c}: {m} vs {want} (se {se})"
            );
        }
    }
}

/// Mitsuba's sphere (u, v): the azimuth from +x over 2 pi, the polar angle from +z
/// over pi.
fn sphere_uv(p: Vec3) -> Vec2 {
    let d = p.normalize();
    let phi = d.y.atan2(d.x);
    let phi = if phi < 0.0 {
        phi + 2.0 * std::f32::consts::PI
    } else {
        phi
    };
    Vec2::new(
        phi / (2.0 * std::f32::consts::PI),
        d.z.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
    )
}

/// Mitsuba's checkerboard: `color0` where u and v are in the same half of their unit.
fn check_class(uv: Vec2) -> usize {
    let high = |x: f32| x - x.floor() > 0.5;
    usize::from(high(uv.x) != high(uv.y))
}

const RHO0: [f64; 3] = [0.8, 0.5, 0.2];
const RHO1: [f64; 3] = [0.1, 0.3, 0.6];

fn checker_sphere() -> Scene {
    let material = json!({"type": "diffuse", "reflectance": {
        "type": "checkerboard", "color0": RHO0, "color1": RHO1,
        "to_uv": [[4, 0, 0], [0, 4, 0]]}});
    compile(sky_scene(
        material,
        json!({"type": "sphere", "radius": 1, "material": "m"}),
    ))
}

fn checker_classes(scene: &Scene) -> Vec<Vec<usize>> {
    classify(scene, |p| Some(check_class(sphere_uv(p) * 4.0)), 2)
}

#[test]
fn checkerboard_sphere_path_tracing() {
    let scene = checker_sphere();
    let classes = checker_classes(&scene);
    check(
        &scene,
        "pt",
        json!({"max_depth": 2}),
        16,
        &classes,
        &[RHO0, RHO1],
    );
}

/// Light vertices on the sphere connect to the camera and to camera vertices: they must
/// carry their (u, v).
#[test]
fn checkerboard_sphere_bidirectional() {
    let scene = checker_sphere();
    let classes = checker_classes(&scene);
    check(
        &scene,
        "bpt",
        json!({"max_depth": 2}),
        16,
        &classes,
        &[RHO0, RHO1],
    );
    check(
        &scene,
        "lt",
        json!({"max_depth": 2}),
        64,
        &classes,
        &[RHO0, RHO1],
    );
}

/// Visible points (sppm) and virtual point lights (vpl) evaluate the material after
/// the walk that found them. Both are consistent rather than unbiased; on a convex
/// shape under a uniform sky photons and VPLs only add the one bounce that is absent
/// (max_depth 2: direct light only), so the image is the direct one.
#[test]
fn checkerboard_sphere_stored_vertices() {
    let scene = checker_sphere();
    let classes = checker_classes(&scene);
    check(
        &scene,
        "sppm",
        json!({"max_depth": 2}),
        8,
        &classes,
        &[RHO0, RHO1],
    );
    check(
        &scene,
        "vpl",
        json!({"max_depth": 2}),
        8,
        &classes,
        &[RHO0, RHO1],
    );
}

/// A 2 x 2 PNG (sRGB) on a rectangle seen from above, nearest filtering: row 0 of the
/// image is at v = 0, which Mitsuba's rectangle puts at y = -1 (the bottom of this
/// camera's image).
#[test]
fn bitmap_rectangle_rows_and_srgb() {
    let dir = tempfile::tempdir().unwrap();
    let texels: [[u8; 3]; 4] = [[200, 30, 90], [10, 250, 120], [128, 128, 128], [255, 0, 60]];
    let mut png = image::RgbImage::new(2, 2);
    for (i, t) in texels.iter().enumerate() {
        png.put_pixel(i as u32 % 2, i as u32 / 2, image::Rgb(*t));
    }
    png.save(dir.path().join("tex.png")).unwrap();
    let material = json!({"type": "diffuse", "reflectance": {
        "type": "bitmap", "filename": "tex.png", "filter": "nearest"}});
    let mut v = sky_scene(material, json!({"type": "rectangle", "material": "m"}));
    v["camera"]["fov"] = json!(30);
    let file = parse_scene(&v.to_string()).unwrap();
    std::fs::write(dir.path().join("scene.json"), v.to_string()).unwrap();
    let scene = Scene::compile(&file, Some(dir.path())).unwrap();
    let class = |p: Vec3| {
        let uv = Vec2::new((p.x + 1.0) / 2.0, (p.y + 1.0) / 2.0);
        let inside = uv.cmpge(Vec2::ZERO).all() && uv.cmplt(Vec2::ONE).all();
        inside.then(|| (uv.y * 2.0) as usize * 2 + (uv.x * 2.0) as usize)
    };
    let classes = classify(&scene, class, 4);
    // The sRGB transfer function (IEC 61966-2-1).
    let linear = |b: u8| {
        let c = b as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let expected: Vec<[f64; 3]> = texels.iter().map(|t| t.map(linear)).collect();
    check(
        &scene,
        "pt",
        json!({"max_depth": 2}),
        8,
        &classes,
        &expected,
    );
}

/// One image named by two materials (and by the same material twice) is decoded once.
#[test]
fn one_image_is_loaded_once_per_scene() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(64, 64, image::Rgb([100, 100, 100]))
        .save(dir.path().join("t.png"))
        .unwrap();
    let bitmap = json!({"type": "bitmap", "filename": "t.png"});
    let v = json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": 8, "height": 8},
        "materials": {
            "a": {"type": "diffuse", "reflectance": bitmap},
            "b": {"type": "dielectric", "specular_reflectance": bitmap, "specular_transmittance": bitmap},
            "c": {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": "t.png", "raw": true}}
        },
        "shapes": [
            {"type": "sphere", "radius": 1, "material": "a"},
            {"type": "sphere", "radius": 1, "center": [3, 0, 0], "material": "b"},
            {"type": "sphere", "radius": 1, "center": [-3, 0, 0], "material": "c"}
        ],
        "lights": [{"type": "constant", "radiance": [1, 1, 1]}]
    });
    let file = parse_scene(&v.to_string()).unwrap();
    let scene = Scene::compile(&file, Some(dir.path())).unwrap();
    // 64 x 64 x 3 bytes, once as sRGB and once raw.
    assert_eq!(scene.stats.texture_bytes, 2 * 64 * 64 * 3);
}

#[test]
fn texture_errors_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.png"), b"\x89PNG\r\n\x1a\nnot a png").unwrap();
    let cases = [
        (
            json!({"type": "bitmap", "filename": "missing.png"}),
            "materials.m.reflectance.filename",
            "missing.png",
        ),
        (
            json!({"type": "bitmap", "filename": "bad.png"}),
            "materials.m.reflectance.filename",
            "bad.png",
        ),
        (
            json!({"type": "bitmap", "filename": "../x.png"}),
            "materials.m.reflectance.filename",
            "inside the scene",
        ),
        (
            json!({"type": "checkerboard", "color0": [-1, 0, 0]}),
            "materials.m.reflectance.color0",
            "negative",
        ),
        (
            json!({"type": "checkerboard", "to_uv": [[1, 0, 0], [0, 1e39, 0]]}),
            "",
            "out of range",
        ),
    ];
    for (tex, field, what) in cases {
        let v = sky_scene(
            json!({"type": "diffuse", "reflectance": tex}),
            json!({"type": "sphere", "radius": 1, "material": "m"}),
        );
        let e = parse_scene(&v.to_string())
            .and_then(|f| Scene::compile(&f, Some(dir.path())))
            .err()
            .unwrap_or_else(|| panic!("{tex} accepted"));
        let text = e.to_string();
        assert!(text.contains(field), "{tex}: {text}");
        assert!(text.contains(what), "{tex}: {text}");
        assert!(
            !text.contains(dir.path().to_str().unwrap()),
            "names a server path: {text}"
        );
    }
}

/// The Cornell box with every wall a red and blue checkerboard: indirect light comes
/// only from textured surfaces, so every algorithm that stores vertices (bpt and lt
/// connections, vcm merges, vpl's virtual lights, sppm's visible points) must give
/// them their (u, v). Each is compared with pt pixel by pixel: the mean of the
/// differences must be within four of its standard errors (plus 2% of the image mean
/// for the consistent methods' kernel bias).
#[test]
fn textured_box_renders_alike_in_every_algorithm() {
    let checker = json!({"type": "diffuse", "reflectance": CHECKER.clone()});
    textured_box_alike(checker, &["bpt", "lt", "vcm", "vpl", "sppm"]);
}

/// The same with a rough plastic whose base is the checkerboard (the coating's
/// Fresnel and internal reflections over a textured albedo).
#[test]
fn textured_plastic_box_renders_alike() {
    let plastic = json!({"type": "roughplastic", "alpha": 0.3,
        "diffuse_reflectance": CHECKER.clone()});
    textured_box_alike(plastic, &["bpt", "lt"]);
}

static CHECKER: std::sync::LazyLock<serde_json::Value> = std::sync::LazyLock::new(|| {
    json!({"type": "checkerboard", "color0": [0.8, 0.1, 0.1], "color1": [0.1, 0.1, 0.8],
        "to_uv": [[4, 0, 0], [0, 4, 0]]})
});

fn textured_box_alike(material: serde_json::Value, algorithms: &[&str]) {
    let path = format!("{}/scenes/cornell-box.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": 24, "height": 24});
    v["materials"]["checker"] = material;
    for s in v["shapes"].as_array_mut().unwrap() {
        if s["name"] != "light" {
            s["material"] = json!("checker");
        }
    }
    let scene = compile(v);
    let cases: Vec<_> = [
        ("bpt", 256, 0.0),
        ("lt", 1024, 0.0),
        ("vcm", 256, 0.02),
        ("vpl", 64, 0.0),
        ("sppm", 128, 0.02),
    ]
    .into_iter()
    .filter(|(alg, _, _)| algorithms.contains(alg))
    .collect();
    assert_algorithms_agree_with_pt(&scene, json!({"max_depth": 3}), 1024, &cases);
}

/// Under a uniform sky with direct light only, a pixel of a convex shape depends on the
/// material at its camera hits alone: a plastic whose base is a checkerboard renders
/// each pixel inside a check bit for bit as the plastic of that check's constant colour
/// (the same random numbers meet the same material).
#[test]
fn textured_plastic_equals_constant_plastic_check_by_check() {
    let plastic = |base: serde_json::Value| {
        let m = json!({"type": "roughplastic", "alpha": 0.2, "diffuse_reflectance": base});
        compile(sky_scene(
            m,
            json!({"type": "sphere", "radius": 1, "material": "m"}),
        ))
    };
    let textured = plastic(
        json!({"type": "checkerboard", "color0": RHO0, "color1": RHO1,
        "to_uv": [[4, 0, 0], [0, 4, 0]]}),
    );
    let classes = checker_classes(&textured);
    let s = settings("pt", json!({"max_depth": 2}));
    let (film, _) = render(&textured, &s, 3, 4);
    for (k, rho) in [RHO0, RHO1].iter().enumerate() {
        let (flat, _) = render(&plastic(json!(rho)), &s, 3, 4);
        assert!(classes[k].len() >= 8);
        for &i in &classes[k] {
            assert_eq!(film.sums()[i], flat.sums()[i], "class {k} pixel {i}");
        }
    }
}
