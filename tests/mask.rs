//! Masks (cut-outs): a ray, a shadow ray or a light path stops at a masked surface with
//! probability equal to its opacity. Under a uniform sky, a one-sided diffuse mask of
//! opacity a with nothing behind it shows a rho L + (1 - a) L; in a closed scene every
//! algorithm must see the same holes in its shadows.

mod common;
use caustic::math::{Vec2, Vec3};
use caustic::scene::Scene;
use common::*;
use serde_json::json;

const L: f64 = 1.5;
const RHO: f64 = 0.6;
const OPACITY: [f64; 2] = [0.25, 0.75];

fn masked_rectangle() -> Scene {
    compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 30},
        "film": {"width": 32, "height": 32},
        "materials": {"m": {"type": "mask",
            "opacity": {"type": "checkerboard", "color0": OPACITY[0], "color1": OPACITY[1]},
            "material": {"type": "diffuse", "reflectance": RHO}}},
        "shapes": [{"type": "rectangle", "material": "m"}],
        "lights": [{"type": "constant", "radiance": [L, L, L]}]
    }))
}

/// Pixels whose corners and centre all fall inside one check of the rectangle (its
/// (u, v) is ((x + 1) / 2, (y + 1) / 2), so checks of 1 x 1 in the plane z = 0).
fn classes(scene: &Scene) -> [Vec<usize>; 2] {
    let mut out = [Vec::new(), Vec::new()];
    for y in 0..32u32 {
        for x in 0..32u32 {
            let at = |dx: f32, dy: f32| {
                let ray = (scene.camera)
                    .generate_ray(Vec2::new(x as f32 + dx, y as f32 + dy), Default::default());
                let t = -ray.o.z / ray.d.z;
                let p: Vec3 = ray.o + ray.d * t;
                (p.x.abs() < 1.0 && p.y.abs() < 1.0)
                    .then(|| usize::from((p.x >= 0.0) != (p.y >= 0.0)))
            };
            let k = [
                at(0.01, 0.01),
                at(0.99, 0.01),
                at(0.01, 0.99),
                at(0.99, 0.99),
                at(0.5, 0.5),
            ];
            if let Some(c) = k[0] {
                if k.iter().all(|&v| v == Some(c)) {
                    out[c].push((y * 32 + x) as usize);
                }
            }
        }
    }
    out
}

#[test]
fn a_mask_shows_its_opacity_of_the_surface_and_the_rest_of_the_sky() {
    let scene = masked_rectangle();
    let classes = classes(&scene);
    for (alg, spp) in [("pt", 64), ("bpt", 64)] {
        let (film, n) = render(&scene, &settings(alg, json!({"max_depth": 2})), 5, spp);
        assert_eq!(film.dropped(), 0);
        let img = channel(&film, n, 1);
        for (k, pixels) in classes.iter().enumerate() {
            assert!(pixels.len() >= 20, "class {k}: {} pixels", pixels.len());
            let (m, se) = mean_se(&pixels.iter().map(|&i| img[i]).collect::<Vec<_>>());
            let a = OPACITY[k];
            let want = a * RHO * L + (1.0 - a) * L;
            assert!(
                (m - want).abs() <= 4.0 * se + 1e-6,
                "{alg} class {k}: {m} vs {want} (se {se})"
            );
        }
    }
}

/// The Cornell box with a masked panel under the light: the panel's shadow has holes,
/// and pt, bpt, lt, vcm and vpl must agree on them pixel by pixel (within four
/// standard errors of the mean difference; vcm's merges allowed 2 % of the image mean).
#[test]
fn every_algorithm_sees_the_same_holes() {
    let path = format!("{}/scenes/cornell-box.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": 24, "height": 24});
    v["materials"]["leaf"] = json!({"type": "mask",
        "opacity": {"type": "checkerboard", "color0": 0.1, "color1": 0.9,
            "to_uv": [[3, 0, 0], [0, 3, 0]]},
        "material": {"type": "diffuse", "reflectance": [0.2, 0.7, 0.2], "two_sided": true}});
    v["shapes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"type": "rectangle", "material": "leaf",
        "corners": [[-0.6, 0.3, -0.6], [-0.6, 0.3, 0.6], [0.6, 0.3, 0.6], [0.6, 0.3, -0.6]]}));
    let scene = compile(v);
    let depth = json!({"max_depth": 3});
    let (reference, n) = render(&scene, &settings("pt", depth.clone()), 1, 1024);
    for (alg, spp, bias) in [
        ("bpt", 256, 0.0),
        ("lt", 1024, 0.0),
        ("vcm", 256, 0.02),
        ("vpl", 64, 0.0),
    ] {
        let (film, m) = render(&scene, &settings(alg, depth.clone()), 2, spp);
        assert_eq!(film.dropped(), 0, "{alg}");
        for c in 0..3 {
            assert_same_image(&reference, n, &film, m, c, bias, alg);
        }
    }
}

#[test]
fn mask_errors_name_the_field() {
    for (m, field) in [
        (
            json!({"type": "mask", "opacity": 1.5, "material": {"type": "diffuse", "reflectance": 0.5}}),
            "materials.m.opacity",
        ),
        (
            json!({"type": "mask", "opacity": 0.5, "material": {"type": "null"}}),
            "materials.m.material",
        ),
        (
            json!({"type": "mask", "opacity": 0.5, "material": {"type": "diffuse", "reflectance": 2}}),
            "materials.m.material.reflectance",
        ),
    ] {
        let v = json!({
            "format": 1,
            "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 30},
            "film": {"width": 8, "height": 8},
            "materials": {"m": m},
            "shapes": [{"type": "rectangle", "material": "m"}],
            "lights": [{"type": "constant", "radiance": [1, 1, 1]}]
        });
        let e = caustic::scene::load::parse_scene(&v.to_string())
            .and_then(|f| Scene::compile(&f, None))
            .err()
            .expect("refused")
            .to_string();
        assert!(e.contains(field), "{m}: {e}");
    }
}

/// Mitsuba's `mask` (in either order with `twosided`) imports as a mask around the
/// nested material; a mask that holds itself through a twosided is an error.
#[test]
fn mitsuba_masks_import() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |bsdf: &str| {
        format!(
            r#"<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/></sensor>
  {bsdf}
  <shape type="rectangle"><ref id="leaf"/></shape>
</scene>"#
        )
    };
    let import = |bsdf: &str| {
        let path = dir.path().join("s.xml");
        std::fs::write(&path, scene(bsdf)).unwrap();
        caustic::scene::mitsuba::import_file(&path)
    };
    use caustic::scene::format::{MaterialDesc, Param};
    for xml in [
        r#"<bsdf type="mask" id="leaf"><float name="opacity" value="0.3"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>"#,
        r#"<bsdf type="twosided" id="leaf"><bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf></bsdf>"#,
    ] {
        let out = import(xml).unwrap();
        let m = out.scene.materials.values().next().unwrap();
        let MaterialDesc::Mask { opacity, material } = m else {
            panic!("{m:?}")
        };
        assert_eq!(*opacity, Param::grey(0.3));
        assert!(
            matches!(
                **material,
                MaterialDesc::Diffuse {
                    two_sided: true,
                    ..
                }
            ),
            "{material:?}"
        );
    }
    let itself =
        r#"<bsdf type="mask" id="leaf"><bsdf type="twosided"><ref id="leaf"/></bsdf></bsdf>"#;
    let Err(e) = import(itself) else {
        panic!("a mask in itself was accepted");
    };
    let e = e.to_string();
    assert!(e.contains("a mask inside a mask"), "{e}");
}
