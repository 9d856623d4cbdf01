//! Mixtures of materials (`mixture`, `blend`, Mitsuba's `mixturebsdf` and
//! `blendbsdf`) and textured roughness: a white furnace against quadrature, the delta
//! lobes a mixture holds as the photon and gather methods follow them, the scene
//! format and its errors, textured parameters that equal constants bit for bit, and
//! every algorithm against `pt` on a Cornell box holding them.

mod common;

use caustic::material::microfacet::{Distribution, Microfacet};
use caustic::material::{Conductor, Dielectric, Diffuse, Material, Mixture, Mode};
use caustic::math::{Rgb, Rng, Vec3};
use caustic::scene::load::parse_scene;
use caustic::scene::Scene;
use common::{assert_same_image, compile, mean_se, render, settings};
use serde_json::{json, Value};
use std::f64::consts::PI;

fn mix(weights: &[f32], components: Vec<Material>) -> Material {
    Material::Mixture(Box::new(Mixture {
        components,
        weights: weights.to_vec(),
    }))
}

fn diffuse(r: f32) -> Material {
    Material::Diffuse(Diffuse {
        reflectance: Rgb::splat(r),
        two_sided: false,
    })
}

/// Mitsuba's conductor "none" (eta 0, k 1): Fresnel 1, so all it loses is masking.
fn white_metal(alpha: f32) -> Material {
    Material::Conductor(Conductor {
        eta: Rgb::ZERO,
        k: Rgb::ONE,
        distribution: Microfacet::new(Distribution::Ggx, alpha, alpha),
        specular_reflectance: Rgb::ONE,
        two_sided: false,
    })
}

fn glass() -> Material {
    Material::Dielectric(Dielectric {
        eta: 1.5,
        specular_reflectance: Rgb::ONE,
        specular_transmittance: Rgb::ONE,
    })
}

/// int f(wo, wi) cos over the hemisphere by the midpoint rule in (cos theta, phi).
fn hemisphere_quadrature(m: &Material, wo: Vec3) -> f64 {
    let n = 600;
    let mut sum = 0.0;
    for i in 0..n {
        let z = (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        for j in 0..n {
            let phi = 2.0 * PI * (j as f64 + 0.5) / n as f64;
            let wi = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            // eval includes |cos theta_i|; d omega = d(cos theta) d phi.
            sum += m.eval(wo, wi, Mode::Radiance).x as f64;
        }
    }
    sum * 2.0 * PI / (n * n) as f64
}

/// A white furnace: a half-and-half mixture of a white diffuse and a white rough
/// metal reflects 1/2 + A/2, A the metal's albedo by quadrature of its own `eval`;
/// the mixture's sampled weights must average to that (4 standard errors plus the
/// quadrature's error).
#[test]
fn white_furnace_mixture_matches_quadrature() {
    for (alpha, theta) in [(0.2f32, 30.0f32), (0.5, 70.0)] {
        let metal = white_metal(alpha);
        let t = theta.to_radians();
        let wo = Vec3::new(t.sin(), 0.0, t.cos());
        let expect = 0.5 + 0.5 * hemisphere_quadrature(&metal, wo);
        let m = mix(&[0.5, 0.5], vec![diffuse(1.0), metal]);
        let mut rng = Rng::new(37, alpha.to_bits() as u64, 0);
        let w: Vec<f64> = (0..400_000)
            .map(|_| {
                m.sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                    .map_or(0.0, |s| s.weight.x as f64)
            })
            .collect();
        let (mean, se) = mean_se(&w);
        assert!(
            (mean - expect).abs() <= 4.0 * se + 2e-3,
            "alpha {alpha} theta {theta}: sampled albedo {mean} +- {se} vs quadrature {expect}"
        );
        assert!(expect > 0.75 && expect <= 1.0, "{expect}");
    }
}

/// A mixture's delta lobes as `stop_or_follow_delta` uses them: `delta_probability`
/// is the share of `sample`'s delta samples, and `sample_delta`'s weight times that
/// probability estimates the delta lobes' albedo as `sample` does. Checked on a blend
/// of glass and diffuse and on a nested mixture whose delta lobe is a plastic's.
#[test]
fn delta_lobes_of_a_mixture_are_sampled_as_sample_does() {
    let plastic = Material::Plastic(caustic::material::Plastic {
        coating: caustic::material::Coating {
            diffuse_reflectance: Rgb::new(0.6, 0.3, 0.2),
            specular_reflectance: Rgb::ONE,
            eta: 1.49,
            nonlinear: false,
        },
        two_sided: false,
    });
    let cases = [
        (
            "blend of glass and diffuse",
            mix(&[0.7, 0.3], vec![glass(), diffuse(0.8)]),
        ),
        (
            "mixture of a blend of plastic and metal, and diffuse",
            mix(
                &[0.6, 0.3],
                vec![
                    mix(&[0.5, 0.5], vec![plastic, white_metal(0.3)]),
                    diffuse(0.5),
                ],
            ),
        ),
    ];
    for (name, m) in cases {
        let wo = Vec3::new(0.5, 0.1, 0.8).normalize();
        let p = m.delta_probability(wo) as f64;
        assert!(p > 0.01 && p < 0.95, "{name}: {p}");
        let n = 200_000;
        let mut rng = Rng::new(38, 0, 0);
        let (mut hits, mut via_sample) = (0.0, Vec::with_capacity(n));
        for _ in 0..n {
            let s = m.sample(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance);
            let delta = s.is_some_and(|s| s.delta);
            hits += delta as u32 as f64;
            via_sample.push(s.filter(|s| s.delta).map_or(0.0, |s| s.weight.x as f64));
        }
        let share = hits / n as f64;
        let se = (p * (1.0 - p) / n as f64).sqrt();
        assert!(
            (share - p).abs() <= 4.0 * se,
            "{name}: share {share} vs {p}"
        );
        let via_delta: Vec<f64> = (0..n)
            .map(|_| {
                m.sample_delta(wo, rng.next_f32(), rng.next_2d(), Mode::Radiance)
                    .map_or(0.0, |s| {
                        assert!(s.delta, "{name}");
                        s.weight.x as f64 * p
                    })
            })
            .collect();
        let (a, sa) = mean_se(&via_sample);
        let (b, sb) = mean_se(&via_delta);
        assert!(
            (a - b).abs() <= 4.0 * (sa * sa + sb * sb).sqrt(),
            "{name}: delta albedo {a} +- {sa} by sample, {b} +- {sb} by sample_delta"
        );
    }
}

/// A mixture of deltas only is a delta BSDF; one of continuous lobes only has none.
#[test]
fn delta_classification() {
    let mirror_like = mix(&[0.5, 0.5], vec![glass(), white_metal(0.0)]);
    assert!(mirror_like.is_delta());
    let rough = mix(&[0.5, 0.5], vec![diffuse(0.5), white_metal(0.3)]);
    assert!(!rough.is_delta());
    assert_eq!(rough.delta_probability(Vec3::Z), 0.0);
    // A zero weight is never sampled.
    let only_diffuse = mix(&[1.0, 0.0], vec![diffuse(0.5), glass()]);
    assert_eq!(only_diffuse.delta_probability(Vec3::Z), 0.0);
}

/// The scene file, parsed and validated (`Scene::compile` validates first).
fn parse(v: Value) -> Result<caustic::scene::SceneFile, String> {
    let f = parse_scene(&v.to_string()).map_err(|e| e.to_string())?;
    Scene::compile(&f, None).map_err(|e| e.to_string())?;
    Ok(f)
}

fn one_material_scene(m: Value) -> Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": 8, "height": 8},
        "materials": {"m": m},
        "shapes": [{"type": "sphere", "material": "m"}],
        "lights": [{"type": "constant", "radiance": [1, 1, 1]}]
    })
}

/// The scene format: mixtures and blends round-trip, rough materials' constants keep
/// their JSON form, and mistakes name their field.
#[test]
fn scene_format_reads_mixtures_and_names_errors() {
    let blend = json!({"type": "blend", "weight": {"type": "checkerboard", "color0": 0.2, "color1": 0.9},
        "materials": [{"type": "dielectric"},
                      {"type": "roughconductor", "alpha_u": 0.1, "alpha_v": {"type": "checkerboard"}}]});
    let mixture = json!({"type": "mixture", "weights": [0.3, 0.5],
        "materials": [{"type": "diffuse", "reflectance": 0.5}, blend]});
    let f = parse(one_material_scene(mixture.clone())).expect("parses");
    let back = serde_json::to_value(&f.materials["m"]).unwrap();
    let again: caustic::scene::format::MaterialDesc = serde_json::from_value(back.clone()).unwrap();
    assert_eq!(again, f.materials["m"]);
    // Constants stay numbers (the JSON the importer writes is unchanged).
    let rough = json!({"type": "roughconductor", "alpha": 0.25});
    let f = parse(one_material_scene(rough)).unwrap();
    let text = serde_json::to_string(&f.materials["m"]).unwrap();
    assert!(text.contains("\"alpha\":0.25"), "{text}");
    assert!(
        text.contains("\"specular_reflectance\":[1.0,1.0,1.0]"),
        "{text}"
    );

    for (m, field) in [
        (
            json!({"type": "mixture", "weights": [0.5], "materials": [{"type": "diffuse", "reflectance": 0.5}, {"type": "diffuse", "reflectance": 0.5}]}),
            "materials.m.weights",
        ),
        (
            json!({"type": "mixture", "weights": [0.5, -1], "materials": [{"type": "diffuse", "reflectance": 0.5}, {"type": "diffuse", "reflectance": 0.5}]}),
            "materials.m.weights[1]",
        ),
        (
            json!({"type": "blend", "materials": [{"type": "diffuse", "reflectance": 0.5}]}),
            "materials.m.materials",
        ),
        (
            json!({"type": "blend", "weight": 1.5, "materials": [{"type": "null"}, {"type": "null"}]}),
            "materials.m.weight",
        ),
        (
            json!({"type": "blend", "materials": [{"type": "null"}, {"type": "diffuse", "reflectance": 0.5}]}),
            "materials.m.materials[0]",
        ),
        (
            json!({"type": "blend", "materials": [{"type": "diffuse", "reflectance": 2}, {"type": "diffuse", "reflectance": 0.5}]}),
            "materials.m.materials[0].reflectance",
        ),
        (
            json!({"type": "roughdielectric", "alpha": 11}),
            "materials.m.alpha",
        ),
    ] {
        let e = parse(one_material_scene(m.clone())).expect_err(&m.to_string());
        assert!(e.contains(field), "{m}: {e}");
    }
    let e = parse(one_material_scene(
        json!({"type": "roughconductor", "alpha": [0.1, 0.2, 0.3]}),
    ))
    .unwrap_err();
    assert!(e.contains("a number or a texture object"), "{e}");
}

/// A texture that is the same everywhere (a checkerboard of two equal values) gives
/// the image its constant gives, bit for bit: for the alphas of a rough metal and of
/// rough glass (also where it is smooth), their colours, and a blend's weight.
#[test]
fn constant_textures_render_as_their_constants() {
    let flat = |v: f32| json!({"type": "checkerboard", "color0": v, "color1": v});
    let flat3 = |v: [f32; 3]| json!({"type": "checkerboard", "color0": v, "color1": v});
    let pairs = [
        (
            json!({"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.1, "alpha_v": 0.4,
                   "specular_reflectance": [0.9, 0.6, 0.3]}),
            json!({"type": "roughconductor", "distribution": "ggx", "alpha_u": flat(0.1), "alpha_v": flat(0.4),
                   "specular_reflectance": flat3([0.9, 0.6, 0.3])}),
        ),
        (
            json!({"type": "roughdielectric", "alpha": 0.3, "specular_transmittance": [0.8, 0.9, 1.0]}),
            json!({"type": "roughdielectric", "alpha": flat(0.3), "specular_transmittance": flat3([0.8, 0.9, 1.0])}),
        ),
        (
            json!({"type": "roughdielectric", "alpha": 0}),
            json!({"type": "roughdielectric", "alpha": flat(0.0)}),
        ),
        (
            json!({"type": "blend", "weight": 0.3, "materials": [
                {"type": "dielectric"}, {"type": "roughconductor", "alpha": 0.2}]}),
            json!({"type": "blend", "weight": flat(0.3), "materials": [
                {"type": "dielectric"}, {"type": "roughconductor", "alpha": flat(0.2)}]}),
        ),
    ];
    let s = settings("pt", json!({"max_depth": 4}));
    for (constant, textured) in pairs {
        let a = compile(one_material_scene(constant.clone()));
        let b = compile(one_material_scene(textured));
        let (fa, _) = render(&a, &s, 5, 4);
        let (fb, _) = render(&b, &s, 5, 4);
        assert!(fa.sums().iter().any(|p| p[0] > 0.0), "{constant}");
        assert_eq!(fa.sums(), fb.sums(), "{constant}");
    }
}

/// The Cornell box with a mixture of diffuse and rough metal (small box), a blend of
/// glass and diffuse by a checkerboard weight (large box: a delta component picked
/// per hit), and a back wall of rough metal whose roughness is a checkerboard.
fn mix_box() -> Scene {
    let path = format!("{}/scenes/cornell-box.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["film"] = json!({"width": 20, "height": 20});
    v["materials"]["mixed"] = json!({"type": "mixture", "weights": [0.5, 0.4], "materials": [
        {"type": "diffuse", "reflectance": [0.8, 0.5, 0.2]},
        {"type": "roughconductor", "distribution": "ggx", "alpha": 0.3,
         "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 1.6]}]});
    v["materials"]["blended"] = json!({"type": "blend",
        "weight": {"type": "checkerboard", "color0": 0.2, "color1": 0.9, "to_uv": [[3, 0, 0], [0, 3, 0]]},
        "materials": [{"type": "diffuse", "reflectance": [0.2, 0.5, 0.8]}, {"type": "dielectric"}]});
    v["materials"]["brushed"] = json!({"type": "roughconductor", "distribution": "beckmann",
        "alpha": {"type": "checkerboard", "color0": 0.05, "color1": 0.4, "to_uv": [[4, 0, 0], [0, 4, 0]]},
        "specular_reflectance": [0.9, 0.9, 0.7]});
    for s in v["shapes"].as_array_mut().unwrap() {
        let m = match s["name"].as_str().unwrap_or("") {
            "small box" => "mixed",
            "large box" => "blended",
            "back" => "brushed",
            _ => continue,
        };
        s["material"] = json!(m);
    }
    compile(v)
}

/// Every algorithm renders the mixture box as `pt` does: pixel by pixel, the mean
/// difference within four of its standard errors, plus 3 % of the image mean for the
/// consistent (density-estimating) methods' kernel bias.
#[test]
fn every_algorithm_agrees_with_pt_on_mixtures() {
    let scene = mix_box();
    let depth = json!({"max_depth": 4});
    let (reference, n) = render(&scene, &settings("pt", depth.clone()), 1, 1024);
    assert_eq!(reference.dropped(), 0);
    for (alg, spp, bias, extra) in [
        ("volpath", 256, 0.0, json!({})),
        ("lt", 1024, 0.0, json!({})),
        ("bpt", 256, 0.0, json!({})),
        ("vcm", 256, 0.03, json!({})),
        ("upbp", 128, 0.03, json!({})),
        ("ppm", 256, 0.03, json!({})),
        ("sppm", 128, 0.03, json!({})),
        ("bpm", 256, 0.03, json!({})),
        ("vpm", 128, 0.03, json!({})),
        ("ppb", 128, 0.03, json!({})),
        ("vpl", 128, 0.0, json!({"clamp": "compensate"})),
        ("vrl", 128, 0.03, json!({})),
    ] {
        let mut params = depth.clone();
        params
            .as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        let (film, m) = render(&scene, &settings(alg, params), 2, spp);
        assert_eq!(film.dropped(), 0, "{alg}");
        for c in 0..3 {
            assert_same_image(&reference, n, &film, m, c, bias, alg);
        }
    }
}

/// A sphere filling the view under a uniform sky of radiance 1.5, made of a half and
/// half blend of white-ish diffuse (0.3) and a perfect mirror: convex, so both lobes
/// see only the sky, and every pixel is 1.5 (0.5 * 0.3 + 0.5 * 1) = 0.975. The
/// mirror is a delta lobe beside a continuous one: sppm's visible points and vpl's
/// gathers must follow it with its probability (`sample_delta`), the connecting
/// methods must leave it to the BSDF sample (light tracing, which cannot, renders the
/// diffuse half exactly). Each algorithm's image mean must be
/// within four standard errors of that (plus 1 % for the density estimators).
#[test]
fn every_algorithm_renders_a_blend_with_a_mirror_exactly() {
    let scene = compile(json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 10},
        "film": {"width": 12, "height": 12},
        "materials": {"m": {"type": "blend", "weight": 0.5, "materials": [
            {"type": "diffuse", "reflectance": 0.3}, {"type": "mirror"}]}},
        "shapes": [{"type": "sphere", "material": "m"}],
        "lights": [{"type": "constant", "radiance": [1.5, 1.5, 1.5]}]
    }));
    let want = 1.5 * (0.5 * 0.3 + 0.5);
    for alg in ALGORITHMS {
        let params = match alg {
            "vpl" => json!({"max_depth": 3, "clamp": "compensate"}),
            _ => json!({"max_depth": 3}),
        };
        let (film, n) = render(&scene, &settings(alg, params), 3, 64);
        assert_eq!(film.dropped(), 0, "{alg}");
        let (m, se) = mean_se(&common::channel(&film, n, 1));
        let bias = if CONSISTENT.contains(&alg) { 0.01 } else { 0.0 };
        // Light tracing reaches the camera only from a non-delta surface: it renders
        // the diffuse half alone.
        let want = if alg == "lt" { 1.5 * 0.5 * 0.3 } else { want };
        assert!(
            (m - want).abs() <= 4.0 * se + bias * want,
            "{alg}: mean {m} +- {se} vs {want}"
        );
    }
}

const ALGORITHMS: [&str; 13] = [
    "pt", "volpath", "lt", "bpt", "vcm", "upbp", "ppm", "sppm", "bpm", "vpm", "ppb", "vpl", "vrl",
];

/// The algorithms that estimate densities (consistent, with a kernel bias).
const CONSISTENT: [&str; 7] = ["vcm", "upbp", "ppm", "sppm", "bpm", "vpm", "ppb"];
