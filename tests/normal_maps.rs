//! Normal and bump maps (Mitsuba 3's `normalmap` and `bumpmap`): maps that change
//! nothing render bit for bit as no map; a constant tilt of the normal renders as the
//! analytic value of a Lambertian plane under a distant light (and as the same plane
//! tilted), with Estevez et al.'s shadowing term or without it; a bump map of a
//! linear ramp tilts the normal by the ramp's slope; every algorithm agrees with `pt`
//! on a Cornell box whose back wall is normal-mapped and whose floor is bump-mapped.

mod common;
use caustic::math::Vec3;
use caustic::scene::{load::parse_scene, Scene};
use common::*;
use serde_json::{json, Value};
use std::path::Path;

const RHO: f64 = 0.5;
const E: f64 = 2.0;
const SIZE: u32 = 8;

/// A large plane (z = 0, normal +z) seen from above, under a distant light from
/// `to_light` (and a constant sky of radiance `sky`, which exercises BSDF sampling).
fn plane(material: Value, to_light: Vec3, sky: f32, transform: Value) -> Value {
    let mut lights = vec![json!({"type": "directional",
        "direction": [-to_light.x, -to_light.y, -to_light.z], "irradiance": [E, E, E]})];
    if sky > 0.0 {
        lights.push(json!({"type": "constant", "radiance": [sky, sky, sky]}));
    }
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 10},
        "film": {"width": SIZE, "height": SIZE},
        "materials": {"m": material},
        "shapes": [{"type": "rectangle", "material": "m", "transform": transform}],
        "lights": lights
    })
}

fn big() -> Value {
    json!({"scale": 100})
}

fn compile_in(v: Value, dir: &Path) -> Scene {
    Scene::compile(&parse_scene(&v.to_string()).unwrap(), Some(dir)).unwrap()
}

fn diffuse() -> Value {
    json!({"type": "diffuse", "reflectance": RHO})
}

fn sums(scene: &Scene, spp: u64) -> Vec<[f64; 3]> {
    let (film, n) = render(scene, &settings("pt", json!({"max_depth": 3})), 5, spp);
    assert_eq!((n, film.dropped()), (spp, 0));
    film.sums().to_vec()
}

/// Every pixel's mean (channel 0) is `want`, to float precision: a diffuse plane
/// under a distant light and no sky has one value everywhere and no noise.
fn assert_uniform(scene: &Scene, want: f64, what: &str) {
    let (film, n) = render(scene, &settings("pt", json!({"max_depth": 2})), 5, 2);
    assert_eq!(film.dropped(), 0);
    for v in channel(&film, n, 0) {
        assert!(
            (v - want).abs() <= 1e-4 * want,
            "{what}: pixel {v}, analytic {want}"
        );
    }
}

/// Estevez et al.'s G for a light at cosine `cos_l` from the geometric normal and a
/// shading normal at cosine `cos_n`.
fn estevez(cos_l: f64, cos_n: f64) -> f64 {
    let tan2 = |c: f64| (1.0 - c * c) / (c * c);
    let a2 = (tan2(cos_n) / 8.0).min(1.0);
    2.0 / (1.0 + (1.0 + a2 * tan2(cos_l)).sqrt())
}

fn normal_map(map: Value, shadowing: bool) -> Value {
    json!({"type": "normalmap", "normalmap": map, "material": diffuse(),
        "use_shadowing_function": shadowing})
}

#[test]
fn a_flat_normal_map_or_a_constant_bump_renders_as_no_map() {
    let l = Vec3::new(0.3, 0.2, 0.9).normalize();
    let plain = sums(&compile(plane(diffuse(), l, 0.4, big())), 4);
    let flat = normal_map(json!([0.5, 0.5, 1.0]), true);
    assert_eq!(sums(&compile(plane(flat, l, 0.4, big())), 4), plain);
    let bump = json!({"type": "bumpmap", "texture": 0.7, "scale": 3.0, "material": diffuse()});
    assert_eq!(sums(&compile(plane(bump, l, 0.4, big())), 4), plain);
}

/// A map tilting the normal by 30 degrees towards +x (dp/du on Mitsuba's rectangle):
/// rho / pi E cos(n', l), times G(l) with the shadowing term; without it, the same as
/// the plane itself tilted by 30 degrees.
#[test]
fn a_constant_tilt_is_the_analytic_tilted_plane() {
    let a = 30f64.to_radians();
    let n = [a.sin(), 0.0, a.cos()];
    let map = json!([0.5 + 0.5 * n[0], 0.5, 0.5 + 0.5 * n[2]]);
    let l = Vec3::new(0.5, 0.1, 0.8).normalize();
    let cos_nl = n[0] * l.x as f64 + n[2] * l.z as f64;
    let lambert = RHO / std::f64::consts::PI * E * cos_nl;
    let plain = compile(plane(normal_map(map.clone(), false), l, 0.0, big()));
    assert_uniform(&plain, lambert, "normal map, no shadowing");
    let tilted = compile(plane(
        diffuse(),
        l,
        0.0,
        json!({"scale": 100, "rotate": [{"axis": [0, 1, 0], "angle": 30}]}),
    ));
    assert_uniform(&tilted, lambert, "tilted plane");
    let shadowed = compile(plane(normal_map(map, true), l, 0.0, big()));
    let g = estevez(l.z as f64, n[2]);
    assert!(g < 0.999, "{g}");
    assert_uniform(&shadowed, lambert * g, "normal map with shadowing");
}

/// Below the surface, behind the incoming direction: Mitsuba mirrors the normal's
/// tangential part about the unperturbed normal. A camera looking from the -x side
/// at grazing angles sees the 60 degree tilt towards +x from behind, so the normal
/// used is the one tilted towards -x.
#[test]
fn invalid_normals_flip_as_in_mitsuba() {
    let a = 60f64.to_radians();
    let map = json!([0.5 + 0.5 * a.sin(), 0.5, 0.5 + 0.5 * a.cos()]);
    let l = Vec3::new(-0.6, 0.0, 0.8);
    let material = json!({"type": "normalmap", "normalmap": map, "material": diffuse(),
        "use_shadowing_function": false});
    let mut v = plane(material, l, 0.0, big());
    v["camera"]["look_at"] = json!({"origin": [-4, 0, 0.8], "target": [0, 0, 0], "up": [0, 0, 1]});
    let scene = compile(v);
    let mirrored = RHO / std::f64::consts::PI * E * (-a.sin() * -0.6 + a.cos() * 0.8);
    assert_uniform(&scene, mirrored, "flipped normal");
}

/// A 64 x 1 grey ramp (raw, bilinear) rising by 4/255 per texel, as a bump map of
/// scale s on the plane of side 200: h rises by s 64 (4/255) per unit u, and u by
/// 1/200 per unit x, so the normal is (-slope, 0, 1) with slope s 64 (4/255) / 200.
#[test]
fn a_linear_ramp_bump_is_the_tilt_of_its_slope() {
    let dir = tempfile::tempdir().unwrap();
    let ramp = image::GrayImage::from_fn(64, 1, |x, _| image::Luma([(4 * x) as u8]));
    ramp.save(dir.path().join("ramp.png")).unwrap();
    let scale = 120.0;
    // Mitsuba's luminance weights of a grey texel (their sum in f32).
    let lum = 0.212671f32 + 0.715160 + 0.072169;
    let slope = scale * 64.0 * (4.0 / 255.0) * lum as f64 / 200.0;
    let n = [-slope, 0.0, 1.0];
    let len = (1.0 + slope * slope).sqrt();
    let l = Vec3::new(-0.5, 0.2, 0.8).normalize();
    let cos_nl = (n[0] * l.x as f64 + n[2] * l.z as f64) / len;
    let lambert = RHO / std::f64::consts::PI * E * cos_nl;
    for shadowing in [false, true] {
        let material = json!({"type": "bumpmap", "scale": scale, "material": diffuse(),
            "texture": {"type": "bitmap", "filename": "ramp.png", "raw": true, "wrap": "clamp"},
            "use_shadowing_function": shadowing});
        let scene = compile_in(plane(material, l, 0.0, big()), dir.path());
        let g = if shadowing {
            estevez(l.z as f64, 1.0 / len)
        } else {
            1.0
        };
        assert_uniform(&scene, lambert * g, &format!("ramp, shadowing {shadowing}"));
    }
}

/// Writes an 8 x 8 normal map of bumps tilted up to 45 degrees and a 16 x 16
/// height map of ripples into `dir`.
fn write_maps(dir: &Path) {
    let normals = image::RgbImage::from_fn(8, 8, |x, y| {
        let (a, b) = ((x as f32 - 3.5) / 3.5, (y as f32 - 3.5) / 3.5);
        let n = Vec3::new(a, b, 1.0).normalize();
        let enc = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
        image::Rgb([enc(n.x), enc(n.y), enc(n.z)])
    });
    normals.save(dir.join("normals.png")).unwrap();
    let heights = image::GrayImage::from_fn(16, 16, |x, y| {
        let h = ((x as f32 * 0.8).sin() + (y as f32 * 0.5).cos()) * 0.25 + 0.5;
        image::Luma([(h * 255.0) as u8])
    });
    heights.save(dir.join("heights.png")).unwrap();
}

/// The Cornell box with a normal-mapped back wall and a bump-mapped floor (shadowing
/// on; flips off: a flipped normal depends on which way the light arrives, which
/// light and camera paths see differently, in Mitsuba as here). Each algorithm
/// against pt pixel by pixel, as tests/textures.rs does for textured walls.
#[test]
fn a_normal_mapped_box_renders_alike_in_every_algorithm() {
    let dir = tempfile::tempdir().unwrap();
    write_maps(dir.path());
    let path = format!("{}/scenes/cornell-box.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": 20, "height": 20});
    let white = v["materials"]["white"].clone();
    v["materials"]["wall"] = json!({"type": "normalmap", "material": white,
        "flip_invalid_normals": false,
        "normalmap": {"type": "bitmap", "filename": "normals.png", "raw": true,
            "to_uv": [[3, 0, 0], [0, 3, 0]]}});
    v["materials"]["bumpy"] = json!({"type": "bumpmap", "material": white, "scale": 0.2,
        "flip_invalid_normals": false,
        "texture": {"type": "bitmap", "filename": "heights.png", "raw": true}});
    for s in v["shapes"].as_array_mut().unwrap() {
        match s["name"].as_str() {
            Some("back") => s["material"] = json!("wall"),
            Some("floor") => s["material"] = json!("bumpy"),
            _ => {}
        }
    }
    let scene = compile_in(v, dir.path());
    let cases = [
        ("bpt", 512, 0.0),
        ("lt", 2048, 0.0),
        ("vcm", 256, 0.02),
        ("vpl", 64, 0.0),
        ("sppm", 128, 0.02),
    ];
    assert_algorithms_agree_with_pt(&scene, json!({"max_depth": 3}), 2048, &cases);
}

/// Light paths store the perturbed normal and evaluate the shadowing term of the
/// direction towards the light (their `wo`), so that light tracing, bidirectional
/// connections, virtual lights and photons estimate what path tracing does: the
/// tilted plane's analytic value, within four standard errors over the pixels.
#[test]
fn every_algorithm_sees_the_perturbed_normal_and_its_shadowing() {
    let a = 40f64.to_radians();
    let n = [a.sin(), 0.0, a.cos()];
    let map = json!([0.5 + 0.5 * n[0], 0.5, 0.5 + 0.5 * n[2]]);
    // Light at 75 degrees from the plane's normal: G(light) is about 0.8, G(camera) 1.
    let b = 75f32.to_radians();
    let l = Vec3::new(b.sin(), 0.0, b.cos());
    let cos_nl = n[0] * l.x as f64 + n[2] * l.z as f64;
    let g = estevez(l.z as f64, n[2]);
    assert!(g < 0.85, "{g}");
    let want = RHO / std::f64::consts::PI * E * cos_nl * g;
    let scene = compile(plane(normal_map(map, true), l, 0.0, json!({"scale": 1})));
    for (alg, spp, bias) in [
        ("lt", 64, 0.0),
        ("bpt", 16, 0.0),
        ("vcm", 16, 0.02),
        ("vpl", 16, 0.0),
        ("sppm", 16, 0.02),
    ] {
        let (film, m) = render(&scene, &settings(alg, json!({"max_depth": 2})), 3, spp);
        assert_eq!(film.dropped(), 0, "{alg}");
        let (mean, se) = mean_se(&channel(&film, m, 0));
        assert!(
            (mean - want).abs() <= 4.0 * se + bias * want + 1e-4 * want,
            "{alg}: {mean} (se {se}), analytic {want}"
        );
    }
}

/// Mitsuba 3 itself (deploy/scripts/mitsuba_normal_maps.py): a plane with a 4 x 4
/// normal map and one with a bump map of scale 0.3, imported from the same XML the
/// script renders; image means per channel within four combined standard errors
/// (over seeds) plus 0.5 %.
#[test]
fn imported_maps_render_as_in_mitsuba() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba");
    let refs: Value =
        serde_json::from_str(&std::fs::read_to_string(data.join("normal-maps-ref.json")).unwrap())
            .unwrap();
    for name in ["normalmap", "bumpmap"] {
        let import =
            caustic::scene::mitsuba::import_file(&data.join(format!("ref-{name}.xml"))).unwrap();
        let scene = Scene::compile(&import.scene, Some(&data)).unwrap();
        let s =
            caustic::integrator::Settings::for_scene(None, &scene, &Default::default()).unwrap();
        let per_seed: Vec<[f64; 3]> = (0..6)
            .map(|seed| {
                let (film, n) = render(&scene, &s, seed, 16);
                assert_eq!(film.dropped(), 0);
                [0, 1, 2].map(|c| mean_se(&channel(&film, n, c)).0)
            })
            .collect();
        for c in 0..3 {
            let (mean, se) = mean_se(&per_seed.iter().map(|m| m[c]).collect::<Vec<_>>());
            let (want, want_se) = (
                refs[name][c][0].as_f64().unwrap(),
                refs[name][c][1].as_f64().unwrap(),
            );
            let tol = 4.0 * (se * se + want_se * want_se).sqrt() + 0.005 * want;
            assert!(
                (mean - want).abs() <= tol,
                "{name} channel {c}: caustic {mean} (se {se}), Mitsuba {want} (se {want_se})"
            );
        }
    }
}
