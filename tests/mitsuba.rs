//! Mitsuba 3 XML import: Mitsuba's own Cornell box renders bit for bit as the JSON
//! scene built from it; every supported plugin imports and renders; every class of
//! error names the element and its line.

mod common;

use caustic::scene::mitsuba::{import_file, Import};
use caustic::scene::{load::read_scene_file, Scene};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/mitsuba")
        .join(name)
}

fn import(name: &str) -> Import {
    import_file(&data(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The summed film of `spp` iterations of the scene's own integrator.
fn render_sums(scene: &Scene, spp: u64) -> Vec<[f64; 3]> {
    let s = caustic::integrator::Settings::for_scene(None, scene, &Default::default())
        .expect("settings");
    let (film, n) = common::render(scene, &s, 3, spp);
    assert_eq!(n, spp);
    film.sums().to_vec()
}

#[test]
fn mitsuba_cornell_box_renders_bit_identical_to_the_json_scene() {
    let xml = import("cornell-box.xml");
    assert_eq!(xml.spp, Some(64));
    // Only the ignored clipping planes are worth a word.
    assert_eq!(xml.warnings.len(), 1, "{:?}", xml.warnings);
    assert!(xml.warnings[0].contains("cornell-box.xml:12:5: <sensor type=\"perspective\">"));
    let json_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.json");
    let json = read_scene_file(&json_path).unwrap();
    assert_eq!(xml.scene.camera, json.camera);
    assert_eq!(xml.scene.film, json.film);
    assert_eq!(xml.scene.integrator, json.integrator);
    assert_eq!(xml.scene.materials, json.materials);
    // The same geometry, down to the bits of every corner and transform.
    let shapes = |f: &caustic::scene::SceneFile| {
        let mut v: Vec<String> = f
            .shapes
            .iter()
            .map(|s| {
                let mut s = s.clone();
                s.common.name = None;
                serde_json::to_string(&s).unwrap()
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(shapes(&xml.scene), shapes(&json));
    let a = Scene::compile(&xml.scene, None).unwrap();
    let b = Scene::compile(&json, None).unwrap();
    assert_eq!(render_sums(&a, 2), render_sums(&b, 2));
}

/// Imports, validates and renders 2 iterations of the scene's own integrator.
fn import_and_render(name: &str) -> Import {
    let import = import(name);
    let scene =
        Scene::compile(&import.scene, Some(&data(""))).unwrap_or_else(|e| panic!("{name}: {e}"));
    let s = caustic::integrator::Settings::for_scene(None, &scene, &Default::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let (film, n) = common::render(&scene, &s, 1, 2);
    assert_eq!((n, film.dropped()), (2, 0), "{name}");
    assert!(
        film.sums().iter().flatten().any(|&v| v > 0.0),
        "{name}: black image"
    );
    import
}

/// The one shape a fixture adds after lit.xml's floor (or the first of base.xml's).
fn last_shape(i: &Import) -> serde_json::Value {
    serde_json::to_value(i.scene.shapes.last().unwrap()).unwrap()
}

fn json<T: serde::de::DeserializeOwned>(v: serde_json::Value) -> T {
    serde_json::from_value(v).unwrap()
}

#[test]
fn every_plugin_fixture_imports_and_renders() {
    let fixtures = [
        ("shape-sphere.xml", &[][..]),
        ("shape-disk.xml", &[]),
        ("shape-cube.xml", &[]),
        ("shape-rectangle.xml", &[]),
        ("shape-obj.xml", &[]),
        ("shape-ply.xml", &[]),
        ("shape-serialized.xml", &[]),
        ("bsdf-dielectric.xml", &[]),
        ("bsdf-conductor.xml", &[]),
        ("bsdf-roughconductor.xml", &["bsdf-roughconductor.xml:16:9: <bsdf type=\"roughconductor\">: the Beckmann distribution"]),
        ("bsdf-twosided.xml", &[]),
        ("bsdf-plastic.xml", &["bsdf-plastic.xml:5:9: <bsdf type=\"plastic\">: caustic has no plastic: substituted a diffuse"]),
        ("bsdf-null.xml", &["base.xml:4:5: <integrator type=\"path\">: Mitsuba's path integrator ignores media"]),
        ("emitter-point.xml", &[]),
        ("emitter-spot.xml", &[]),
        ("emitter-directional.xml", &[]),
        ("emitter-constant.xml", &[]),
        ("emitter-envmap.xml", &["emitter-envmap.xml:6:5: <emitter type=\"envmap\">: caustic looks environment maps up by nearest texel"]),
        ("medium-homogeneous.xml", &[]),
        ("medium-heterogeneous.xml", &[]),
        (
            "sensor-thinlens.xml",
            &[
                "sensor-thinlens.xml:2:5: <integrator type=\"bdpt\">: rr_depth is ignored",
                "sensor-thinlens.xml:21:13: <rfilter type=\"gaussian\">: the gaussian filter is replaced by a one-pixel box",
                "sensor-thinlens.xml:15:9: <sampler type=\"stratified\">: caustic samples with independent random numbers",
            ],
        ),
    ];
    for (name, warnings) in fixtures {
        let i = import_and_render(name);
        assert_eq!(i.warnings.len(), warnings.len(), "{name}: {:?}", i.warnings);
        for (got, want) in i.warnings.iter().zip(warnings) {
            assert!(got.starts_with(want), "{name}: {got}");
        }
    }
}

#[test]
fn a_fixture_imports_to_the_hand_written_scene() {
    let want: caustic::scene::SceneFile = json(serde_json::json!({
        "format": 1,
        "camera": {
            "look_at": {"origin": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0]},
            "fov": 45
        },
        "film": {"width": 32, "height": 24},
        "integrator": {"algorithm": "pt", "max_depth": 6},
        "materials": {
            "mitsuba-default": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
            "bsdf@stage.xml:10": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
        },
        "shapes": [
            {
                "name": "floor", "type": "rectangle", "material": "bsdf@stage.xml:10",
                "corners": [[-3, -1, 3], [3, -1, 3], [3, -1, -3], [-3, -1, -3]]
            },
            {
                "type": "sphere", "center": [0.2, 0, 0], "radius": 0.5,
                "material": "mitsuba-default", "transform": {"translate": [0, 0.1, 0]}
            }
        ],
        "lights": [{"type": "point", "position": [0, 3, 1], "intensity": [10, 10, 10]}]
    }));
    let got = import("shape-sphere.xml");
    assert_eq!(got.scene, want);
    assert_eq!(got.spp, Some(4));
}

#[test]
fn plugins_become_their_caustic_equivalents() {
    use caustic::scene::format::{CameraDesc, LightDesc, MaterialDesc, MediumDesc};
    use caustic::scene::format::{GeometryDesc, TransformDesc};
    let cube = import("shape-cube.xml").scene.shapes.pop().unwrap();
    assert_eq!(
        cube.common.transform,
        Some(json::<TransformDesc>(
            serde_json::json!({"translate": [0.1, 0, 0], "scale": [0.5, 0.25, 0.5],
            "rotate": [{"axis": [1, 0, 0], "angle": 10}, {"axis": [0, 1, 0], "angle": 30}]})
        ))
    );
    // Mirrored by scale x = -0.5: the corners turn round, the normal stays +z.
    let rect = import("shape-rectangle.xml").scene.shapes.pop().unwrap();
    assert_eq!(
        rect.geometry,
        json::<GeometryDesc>(serde_json::json!({"type": "rectangle",
            "corners": [[0.5, -0.5, 0.5], [0.5, 0.5, 0.5], [-0.5, 0.5, 0.5], [-0.5, -0.5, 0.5]]}))
    );
    let obj = last_shape(&import("shape-obj.xml"));
    assert_eq!(obj["filename"], "meshes/tri.obj");
    assert_eq!(obj["transform"]["matrix"][11], 0.5);
    let ser = last_shape(&import("shape-serialized.xml"));
    assert_eq!(ser["type"], "mesh");
    assert_eq!(ser["indices"], serde_json::json!([[0, 1, 2]]));

    let m = import("bsdf-conductor.xml").scene.materials;
    assert_eq!(
        m["gold"],
        json::<MaterialDesc>(serde_json::json!({"type": "conductor",
            "eta": [0.143119, 0.374957, 1.44248], "k": [3.98316, 2.38572, 1.60322]}))
    );
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(
            serde_json::json!({"type": "mirror", "reflectance": [0.8, 0.8, 0.8]})
        )));
    let m = import("bsdf-dielectric.xml").scene.materials;
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(serde_json::json!({"type": "dielectric", "int_ior": 1.333,
            "ext_ior": 1.0, "specular_transmittance": [0.9, 0.95, 1.0]}))));
    let m = import("bsdf-twosided.xml").scene.materials;
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(serde_json::json!({"type": "diffuse", "reflectance": [0.2, 0.5, 0.8], "two_sided": true}))));
    let m = import("bsdf-roughconductor.xml").scene.materials;
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(serde_json::json!({"type": "conductor", "roughness": 0.2,
            "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.45, 2.1]}))));

    let light = |name: &str| import(name).scene.lights.last().unwrap().clone();
    assert_eq!(
        light("emitter-point.xml"),
        json::<LightDesc>(
            serde_json::json!({"type": "point", "position": [0.5, 1, 0.5], "intensity": [5, 5, 5]})
        )
    );
    assert_eq!(
        light("emitter-spot.xml"),
        json::<LightDesc>(
            serde_json::json!({"type": "spot", "position": [0, 2, 0], "target": [0, -0.5, 0],
            "intensity": [20, 20, 20], "cutoff_angle": 30, "beam_width": 20})
        )
    );
    assert_eq!(
        light("emitter-directional.xml"),
        json::<LightDesc>(
            serde_json::json!({"type": "directional", "direction": [0.2, -1, -0.3], "irradiance": [2, 2, 2]})
        )
    );
    // Mitsuba's map turned half a turn about +y: rotate_y(90) * rotate_y(180).
    assert_eq!(
        light("emitter-envmap.xml"),
        json::<LightDesc>(
            serde_json::json!({"type": "envmap", "filename": "sky.exr", "scale": 2,
            "transform": {"matrix": [0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1]}})
        )
    );

    let i = import("medium-homogeneous.xml");
    assert_eq!(
        i.scene.integrator,
        Some(serde_json::json!({"algorithm": "volpath", "max_depth": 8, "rr_depth": 3}))
    );
    assert_eq!(
        *i.scene.media.values().next().unwrap(),
        json::<MediumDesc>(
            serde_json::json!({"type": "homogeneous", "sigma_t": [1, 2, 3],
            "albedo": [0.9, 0.8, 0.7], "scale": 0.5, "phase": {"type": "hg", "g": 0.5}})
        )
    );
    let i = import("medium-heterogeneous.xml");
    assert_eq!(
        *i.scene.media.values().next().unwrap(),
        json::<MediumDesc>(
            serde_json::json!({"type": "grid", "file": "density.vol", "sigma_t": [1, 1, 1],
            "albedo": [0.9, 0.9, 0.9], "scale": 4,
            "transform": {"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}})
        )
    );

    let i = import("sensor-thinlens.xml");
    let fov_x = 2.0
        * ((15f64.to_radians().tan()) * 30.0 / 1300f64.sqrt())
            .atan()
            .to_degrees();
    assert_eq!(
        i.scene.camera,
        json::<CameraDesc>(serde_json::json!({"type": "thinlens",
            "look_at": {"origin": [0, 0, 4], "target": [0, 0, 3], "up": [0, 1, 0]},
            "fov": fov_x as f32, "aperture_radius": 0.05, "focus_distance": 4}))
    );
    assert_eq!((i.spp, i.scene.film.width), (Some(9), 30));
    assert_eq!(
        i.scene.integrator,
        Some(serde_json::json!({"algorithm": "bpt", "max_depth": 5}))
    );
}
