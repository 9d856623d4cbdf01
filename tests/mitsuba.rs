//! Mitsuba 3 XML import: Mitsuba's own Cornell box renders bit for bit as the JSON
//! scene built from it; every supported plugin imports and renders; every class of
//! error names the element and its line.

mod common;
mod server_common;

use caustic::scene::mitsuba::{import_file, Import};
use caustic::scene::{load::read_scene_file, Scene};
use serde_json::json;
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
        ("bsdf-roughconductor.xml", &[]),
        ("bsdf-roughdielectric.xml", &[]),
        ("bsdf-thindielectric.xml", &[]),
        ("bsdf-roughplastic.xml", &[]),
        ("bsdf-twosided.xml", &[]),
        ("bsdf-plastic.xml", &[]),
        ("bsdf-normalmap.xml", &[]),
        ("bsdf-bumpmap.xml", &[]),
        ("bsdf-blendbsdf.xml", &[]),
        ("bsdf-rough-textured.xml", &[]),
        ("v06-bsdf-mixturebsdf.xml", &[]),
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

/// `blendbsdf` (weight a float or texture, nested BSDFs in document order whatever
/// their names, as Mitsuba 3.9 orders them), 0.x's `mixturebsdf` (a weights string),
/// and textured roughness and colours of the rough materials. A checkerboard read as
/// one number (a weight, a roughness) has its colours swapped, as Mitsuba's `eval_1`
/// swaps them (`mitsuba::texture::scalar`).
#[test]
fn mixtures_and_textured_rough_materials_import() {
    use caustic::scene::format::MaterialDesc;
    let has = |file: &str, want: serde_json::Value| {
        let m = import(file).scene.materials;
        let want = json::<MaterialDesc>(want);
        assert!(m.values().any(|d| *d == want), "{file}: {m:#?}");
    };
    has(
        "bsdf-blendbsdf.xml",
        serde_json::json!({"type": "blend",
            "weight": {"type": "checkerboard", "color0": 0.9, "color1": 0.2},
            "materials": [{"type": "dielectric"}, {"type": "diffuse", "reflectance": [0.2, 0.5, 0.8]}]}),
    );
    has(
        "bsdf-blendbsdf.xml",
        serde_json::json!({"type": "blend", "weight": 0.25, "materials": [
            {"type": "roughconductor", "alpha": 0.2},
            {"type": "blend", "materials": [{"type": "diffuse", "reflectance": 0.5}, {"type": "plastic"}]}]}),
    );
    has(
        "v06-bsdf-mixturebsdf.xml",
        serde_json::json!({"type": "mixture", "weights": [0.7, 0.2], "materials": [
            {"type": "conductor", "eta": [4.36968, 2.9167, 1.6547], "k": [5.20643, 4.23136, 3.75469]},
            {"type": "diffuse", "reflectance": [0.7, 1.0, 0.7]}]}),
    );
    has(
        "bsdf-rough-textured.xml",
        serde_json::json!({"type": "roughconductor", "distribution": "ggx",
            "alpha_u": {"type": "checkerboard", "color0": 0.3, "color1": 0.05}, "alpha_v": 0.2,
            "specular_reflectance": {"type": "checkerboard"}}),
    );
    has(
        "bsdf-rough-textured.xml",
        serde_json::json!({"type": "roughdielectric",
            "alpha": {"type": "checkerboard", "color0": 0.4, "color1": 0.1},
            "specular_transmittance": {"type": "checkerboard", "color0": [0.9, 0.9, 1], "color1": [1, 0.8, 0.8]}}),
    );
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
        == json::<MaterialDesc>(
            serde_json::json!({"type": "roughconductor", "distribution": "ggx",
            "alpha": 0.2, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.45, 2.1]})
        )));
    let m = import("bsdf-roughdielectric.xml").scene.materials;
    assert!(m
        .values()
        .any(|d| *d == json::<MaterialDesc>(serde_json::json!({"type": "roughdielectric"}))));
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(
            serde_json::json!({"type": "roughdielectric", "distribution": "ggx",
            "alpha_u": 0.05, "alpha_v": 0.3, "int_ior": 1.333, "ext_ior": 1.000277})
        )));
    let m = import("bsdf-thindielectric.xml").scene.materials;
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(serde_json::json!({"type": "thindielectric", "int_ior": 1.5}))));
    let m = import("bsdf-plastic.xml").scene.materials;
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(serde_json::json!({"type": "plastic",
            "diffuse_reflectance": [0.1, 0.27, 0.36], "int_ior": 1.9}))));
    let m = import("bsdf-roughplastic.xml").scene.materials;
    assert!(m.values().any(|d| *d
        == json::<MaterialDesc>(
            serde_json::json!({"type": "roughplastic", "distribution": "ggx",
            "alpha": 0.3, "nonlinear": true, "two_sided": true})
        )));
    assert!(m
        .values()
        .any(|d| *d == json::<MaterialDesc>(serde_json::json!({"type": "roughplastic"}))));

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

/// The error importing `files[0]` of `files`, written to a fresh folder.
fn import_error(files: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    match import_file(&dir.path().join(files[0].0)) {
        Ok(_) => panic!("{} imported", files[0].0),
        Err(e) => e.to_string(),
    }
}

fn assert_error(files: &[(&str, &str)], at: &str, words: &[&str]) {
    let err = import_error(files);
    assert!(err.starts_with(at), "want {at}: {err}");
    for w in words {
        assert!(err.contains(w), "want {w}: {err}");
    }
}

/// A scene whose body starts on line 2.
fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n")
}

#[test]
fn every_error_names_the_element_and_its_line() {
    // Unknown plugins, of every kind.
    let cases = [
        ("<shape type=\"sphere\">\n  <bsdf type=\"velvet\"/>\n</shape>", "s.xml:3:3: <bsdf type=\"velvet\">", "unknown or unsupported BSDF plugin"),
        ("<shape type=\"bezier\"/>", "s.xml:2:1: <shape type=\"bezier\">", "unknown or unsupported shape plugin"),
        ("<emitter type=\"sky\"/>", "s.xml:2:1: <emitter type=\"sky\">", "unknown or unsupported emitter plugin"),
        ("<sensor type=\"orthographic\"/>", "s.xml:2:1: <sensor type=\"orthographic\">", "unknown sensor plugin"),
        ("<shapegroup/>", "s.xml:2:1: <shapegroup>", "unknown element"),
        // A feature caustic lacks.
        ("<shape type=\"sphere\">\n  <bsdf type=\"roughplastic\">\n    <float name=\"alpha_u\" value=\"0.1\"/>\n    <float name=\"alpha_v\" value=\"0.2\"/>\n  </bsdf>\n</shape>", "s.xml:3:3: <bsdf type=\"roughplastic\">", "roughplastic is isotropic"),
        ("<shape type=\"sphere\">\n  <bsdf type=\"diffuse\">\n    <texture type=\"bitmap\" name=\"reflectance\"/>\n  </bsdf>\n</shape>", "s.xml:4:5: <texture type=\"bitmap\" name=\"reflectance\">", "needs a filename"),
        // Mixtures: counts that do not match, a weight that is no number, a texture where
        // Mitsuba takes a float, a blend that holds itself.
        ("<shape type=\"sphere\">\n  <bsdf type=\"blendbsdf\">\n    <bsdf type=\"diffuse\"/>\n  </bsdf>\n</shape>", "s.xml:3:3: <bsdf type=\"blendbsdf\">", "needs two nested <bsdf>s, not 1"),
        ("<shape type=\"sphere\">\n  <bsdf type=\"mixturebsdf\">\n    <string name=\"weights\" value=\"0.5, x\"/>\n    <bsdf type=\"diffuse\"/>\n  </bsdf>\n</shape>", "s.xml:4:5: <string name=\"weights\">", "weight \"x\" is not a number"),
        ("<shape type=\"sphere\">\n  <bsdf type=\"mixturebsdf\">\n    <string name=\"weights\" value=\"0.5, 0.5\"/>\n    <bsdf type=\"diffuse\"/>\n  </bsdf>\n</shape>", "s.xml:4:5: <string name=\"weights\">", "2 weights for 1 nested"),
        ("<shape type=\"sphere\">\n  <bsdf type=\"roughplastic\">\n    <texture type=\"checkerboard\" name=\"alpha\"/>\n  </bsdf>\n</shape>", "s.xml:3:3: <bsdf type=\"roughplastic\">", "roughplastic's alpha is a number"),
        ("<bsdf type=\"blendbsdf\" id=\"b\">\n  <bsdf type=\"diffuse\"/>\n  <ref id=\"b\"/>\n</bsdf>\n<shape type=\"sphere\">\n  <ref id=\"b\"/>\n</shape>", "s.xml:3:3: <bsdf type=\"diffuse\">", "nested more than 16 deep"),
        // Missing files.
        ("<shape type=\"obj\">\n  <string name=\"filename\" value=\"gone.obj\"/>\n</shape>", "s.xml:3:3: <string name=\"filename\">", "file \"gone.obj\" not found"),
        ("<include filename=\"gone.xml\"/>", "s.xml:2:1: <include>", "\"gone.xml\""),
        ("<shape type=\"ply\">\n  <string name=\"filename\" value=\"../up.ply\"/>\n</shape>", "s.xml:3:3: <string name=\"filename\">", "relative path inside the scene's folder"),
        // Bad values.
        ("<shape type=\"sphere\">\n  <float name=\"radius\" value=\"big\"/>\n</shape>", "s.xml:3:3: <float name=\"radius\">", "\"big\" is not a number"),
        ("<shape type=\"sphere\">\n  <bsdf type=\"diffuse\">\n    <rgb name=\"reflectance\" value=\"1, 2\"/>\n  </bsdf>\n</shape>", "s.xml:4:5: <rgb name=\"reflectance\">", "not one value or three"),
        ("<shape type=\"sphere\">\n  <bsdf type=\"diffuse\">\n    <spectrum name=\"reflectance\" value=\"400:0.1, 700:0.5\"/>\n  </bsdf>\n</shape>", "s.xml:4:5: <spectrum name=\"reflectance\">", "spectra given by wavelength"),
        ("<shape type=\"sphere\">\n  <boolean name=\"flip_normals\" value=\"yes\"/>\n</shape>", "s.xml:3:3: <boolean name=\"flip_normals\">", "not true or false"),
        ("<shape type=\"sphere\">\n  <float name=\"radius\" value=\"$r\"/>\n</shape>", "s.xml:3:3: <float name=\"radius\">", "\"$r\" has no value"),
        // Unknown references.
        ("<shape type=\"sphere\">\n  <ref id=\"glass\"/>\n</shape>", "s.xml:3:3: <ref id=\"glass\">", "unknown reference \"glass\""),
        ("<bsdf type=\"diffuse\" id=\"a\"/>\n<medium type=\"homogeneous\" id=\"a\"/>", "s.xml:3:1: <medium type=\"homogeneous\" id=\"a\">", "already used at s.xml:2:1"),
        // Unsupported attributes and parameters.
        ("<shape type=\"sphere\" scale=\"2\"/>", "s.xml:2:1: <shape type=\"sphere\">", "unsupported attribute \"scale\""),
        ("<shape type=\"sphere\">\n  <bsdf type=\"diffuse\">\n    <float name=\"roughness\" value=\"0.5\"/>\n  </bsdf>\n</shape>", "s.xml:4:5: <float name=\"roughness\">", "unsupported parameter of <bsdf type=\"diffuse\">"),
        ("<shape type=\"rectangle\">\n  <emitter type=\"point\"/>\n</shape>", "s.xml:3:3: <emitter type=\"point\">", "must be type=\"area\""),
        // Not XML at all.
        ("<shape type=\"sphere\">", "s.xml:", "not well-formed XML"),
    ];
    for (body, at, words) in cases {
        assert_error(&[("s.xml", &scene(body))], at, &[words]);
    }
    assert_error(
        &[("s.xml", "<shape/>")],
        "s.xml:1:1: <shape>",
        &["root element must be <scene>"],
    );
    assert_error(
        &[("s.xml", &scene(""))],
        "s.xml:1:1: <scene>",
        &["no <sensor>"],
    );
}

#[test]
fn an_include_cycle_is_an_error_at_the_include() {
    assert_error(
        &[
            ("a.xml", &scene("<include filename=\"b.xml\"/>")),
            ("b.xml", &scene("<!-- b -->\n<include filename=\"a.xml\"/>")),
        ],
        "b.xml:3:1: <include>",
        &["\"a.xml\" includes itself (an include cycle)"],
    );
    assert_error(
        &[("a.xml", &scene("<include filename=\"a.xml\"/>"))],
        "a.xml:2:1: <include>",
        &["include cycle"],
    );
}

/// Hostile uploads: elements nested a hundred thousand deep (which would overflow a
/// recursive reader's stack and abort the server), deep include chains, DTD entity
/// expansion and `$name` references to a long default are 4xx answers that name the problem, and the server stays up.
#[test]
fn hostile_xml_uploads_are_refused_and_the_server_survives() {
    let s = server_common::TestServer::start(None);
    let n = 100_000;
    let deep = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<bsdf type=\"twosided\">".repeat(n),
        "</bsdf>".repeat(n)
    );
    let (code, body) = s.post_bytes("/v1/scenes", deep.as_bytes());
    assert!((400..500).contains(&code), "{code} {body}");
    assert!(
        body.to_string().contains("nested more than 64 deep"),
        "{body}"
    );
    let lol = "<?xml version=\"1.0\"?><!DOCTYPE l [<!ENTITY a \"aaaaaaaa\">\
               <!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;\">]>\
               <scene version=\"3.0.0\"><default name=\"x\" value=\"&b;\"/></scene>";
    let (code, body) = s.post_bytes("/v1/scenes", lol.as_bytes());
    assert!((400..500).contains(&code), "{code} {body}");
    assert!(body.to_string().contains("DTD"), "{body}");
    // A megabyte default referenced a hundred thousand times would be 100 GB.
    let bomb = format!(
        "<scene version=\"3.0.0\"><default name=\"a\" value=\"{}\"/>\
         <shape type=\"sphere\" id=\"{}\"/></scene>",
        "x".repeat(1 << 20),
        "$a".repeat(100_000)
    );
    let (code, body) = s.post_bytes("/v1/scenes", bomb.as_bytes());
    assert!((400..500).contains(&code), "{code} {body}");
    assert!(
        body.to_string().contains("references expand to more than"),
        "{body}"
    );
    // Includes count towards the depth: a chain of 100 files, each including the next.
    let files: Vec<(String, String)> = (0..100)
        .map(|i| {
            let body = if i < 99 {
                format!("<include filename=\"f{}.xml\"/>", i + 1)
            } else {
                String::new()
            };
            (format!("f{i}.xml"), scene(&body))
        })
        .collect();
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    assert!(import_error(&refs).contains("nested more than 64 deep"));
    assert_eq!(s.get_json("/healthz").0, 200);
}

/// The total work of an import is bounded, not only its depth: the include tree, a
/// few KB, kept a server thread busy for hours; now it is a 422 at the include that
/// passes the limit, at once, and the server goes on.
#[test]
fn an_include_tree_that_multiplies_is_refused_quickly_and_the_server_survives() {
    let s = server_common::TestServer::start(None);
    let files = server_common::include_tree();
    let entries: Vec<(&str, &[u8])> = files
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_bytes()))
        .collect();
    let bundle = server_common::tar_with(&entries);
    assert!(bundle.len() < 40 << 10, "{} bytes", bundle.len());
    let t = std::time::Instant::now();
    let (code, body) = s.post_bytes("/v1/scenes", &bundle);
    let took = t.elapsed();
    assert_eq!(code, 422, "{body}");
    let msg = body["error"]["message"].as_str().unwrap_or_default();
    assert!(msg.contains("more than 16384 <include>s"), "{msg}");
    assert!(at_an_include(msg), "names no file and line: {msg}");
    // Hours before the fix; a bound generous for a loaded machine.
    assert!(took < std::time::Duration::from_secs(30), "took {took:?}");
    assert_eq!(s.get_json("/healthz").0, 200);
    let good = std::fs::read(data("cornell-box.xml")).unwrap();
    assert_eq!(s.post_bytes("/v1/scenes", &good).0, 201);
}

/// Does the message hold `NAME.xml:LINE:COL: <include>`, where a limit was crossed?
fn at_an_include(msg: &str) -> bool {
    let Some(i) = msg.find(".xml:") else {
        return false;
    };
    let rest = &msg[i + 5..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == ':'))
        .unwrap_or(0);
    end > 0 && rest[end..].starts_with(" <include>")
}

#[test]
fn references_that_loop_are_errors_and_shapes_are_bounded_in_all() {
    // A twosided naming itself, directly or through another, recursed until the
    // stack overflowed, which aborts the whole server.
    let selfish = "<bsdf type=\"twosided\" id=\"b\">\n  <ref id=\"b\"/>\n</bsdf>\n\
                   <shape type=\"sphere\">\n  <ref id=\"b\"/>\n</shape>";
    assert_error(
        &[("s.xml", &scene(selfish))],
        "s.xml:2:1: <bsdf type=\"twosided\" id=\"b\">",
        &["refers to itself"],
    );
    let pair = "<bsdf type=\"twosided\" id=\"a\"><ref id=\"b\"/></bsdf>\n\
                <bsdf type=\"twosided\" id=\"b\"><ref id=\"a\"/></bsdf>\n\
                <shape type=\"sphere\"><ref id=\"a\"/></shape>";
    assert_error(
        &[("s.xml", &scene(pair))],
        "s.xml:3:1: <bsdf type=\"twosided\" id=\"b\">",
        &["twosided inside a twosided"],
    );
    // 4097 inclusions of 64 spheres: 262,208 shapes from a few KB.
    let spheres = scene(&"<shape type=\"sphere\"/>\n".repeat(64));
    let includes = scene(&"<include filename=\"many.xml\"/>\n".repeat(4097));
    assert_error(
        &[("s.xml", &includes), ("many.xml", &spheres)],
        "many.xml:",
        &["more than 262144 shapes"],
    );
}

/// Numbers in a file that index the file are checked: a `serialized` offset of
/// 2^64 - 2 wrapped around to byte 2 (and would panic in a debug build); now it is an
/// error naming the element and the file.
#[test]
fn a_serialized_offset_past_the_end_is_an_error_naming_the_file() {
    let mut bytes = std::fs::read(data("meshes/tri.serialized")).unwrap();
    bytes.truncate(bytes.len() - 12); // one offset (u64) and the count (u32)
    for offset in [0, u64::MAX - 1] {
        bytes.extend(offset.to_le_bytes());
    }
    bytes.extend(2u32.to_le_bytes());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.serialized"), &bytes).unwrap();
    let xml = scene(
        "<shape type=\"serialized\">\n  <string name=\"filename\" value=\"bad.serialized\"/>\n  \
         <integer name=\"shape_index\" value=\"1\"/>\n</shape>",
    );
    std::fs::write(dir.path().join("s.xml"), xml).unwrap();
    let e = import_file(&dir.path().join("s.xml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("s.xml:2:1: <shape type=\"serialized\">: \"bad.serialized\": "),
        "{e}"
    );
    assert!(
        e.contains("start at byte 18446744073709551614, past the end"),
        "{e}"
    );
}

/// Elements of a file included many times share their base name; each copy gets
/// the next free `#k` (found in constant time, not by trying every k again).
#[test]
fn copies_of_an_included_bsdf_get_numbered_names() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).unwrap();
    write(
        "camera.xml",
        &std::fs::read_to_string(data("camera.xml")).unwrap(),
    );
    write(
        "one.xml",
        &scene("<shape type=\"sphere\">\n<bsdf type=\"diffuse\"/>\n</shape>"),
    );
    let copies = 3000;
    let body = "<include filename=\"camera.xml\"/>\n".to_string()
        + &"<include filename=\"one.xml\"/>\n".repeat(copies);
    write("s.xml", &scene(&body));
    let i = import_file(&dir.path().join("s.xml")).unwrap();
    assert_eq!(i.scene.shapes.len(), copies);
    assert_eq!(i.scene.materials.len(), copies);
    assert!(i.scene.materials.contains_key("bsdf@one.xml:3"));
    assert!(i
        .scene
        .materials
        .contains_key(&format!("bsdf@one.xml:3#{copies}")));
}

#[test]
fn post_scenes_takes_xml_and_bundles_holding_it_and_returns_the_warnings() {
    let s = server_common::TestServer::start(None);
    let read = |name: &str| std::fs::read(data(name)).unwrap();
    let (code, info) = s.post_bytes("/v1/scenes", &read("cornell-box.xml"));
    assert_eq!(code, 201, "{info}");
    assert_eq!(
        (info["width"].as_u64(), info["shapes"].as_u64()),
        (Some(256), Some(8))
    );
    let warnings = info["warnings"].as_array().expect("warnings");
    assert_eq!(warnings.len(), 1);
    assert!(
        warnings[0]
            .as_str()
            .unwrap()
            .starts_with("scene.xml:12:5: <sensor"),
        "{info}"
    );
    // Uploading the same bytes again answers the same, warnings included.
    let (code, again) = s.post_bytes("/v1/scenes", &read("cornell-box.xml"));
    assert_eq!((code, &again), (201, &info));
    // The stored scene renders as the built-in Cornell box it equals.
    let id = info["id"].as_str().unwrap();
    let stored = s.dir.path().join("scenes").join(id).join("scene.json");
    let ours = Scene::load(&stored).unwrap();
    let json_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.json");
    let builtin = Scene::load(&json_path).unwrap();
    assert_eq!(render_sums(&ours, 1), render_sums(&builtin, 1));

    // A bundle: the XML (under any name), the files it includes and the mesh.
    let mut entries: Vec<(&str, Vec<u8>)> = [
        "lit.xml",
        "base.xml",
        "camera.xml",
        "stage.xml",
        "meshes/tri.obj",
    ]
    .iter()
    .map(|n| (*n, read(n)))
    .collect();
    entries.push(("tri-scene.xml", read("shape-obj.xml")));
    let tar_of = |entries: &[(&str, Vec<u8>)]| {
        let refs: Vec<(&str, &[u8])> = entries.iter().map(|(n, d)| (*n, d.as_slice())).collect();
        server_common::tar_with(&refs)
    };
    let (code, info) = s.post_bytes("/v1/scenes", &tar_of(&entries));
    // lit.xml and others are also top-level .xml files: the scene must be named.
    assert_eq!(code, 400, "{info}");
    assert!(
        info.to_string().contains("name the scene scene.xml"),
        "{info}"
    );
    entries.pop();
    entries.push(("scene.xml", read("shape-obj.xml")));
    let (code, info) = s.post_bytes("/v1/scenes", &tar_of(&entries));
    assert_eq!(code, 201, "{info}");
    assert_eq!(info["shapes"].as_u64(), Some(2));
    assert!(info.get("warnings").is_none(), "{info}");

    // An import error is a 422 naming the line.
    let bad = b"<scene version=\"3.0.0\">\n<shape type=\"bezier\"/>\n</scene>";
    let (code, body) = s.post_bytes("/v1/scenes", bad);
    assert_eq!(code, 422, "{body}");
    assert!(
        body.to_string()
            .contains("scene.xml:2:1: <shape type=\\\"bezier\\\">"),
        "{body}"
    );
}

/// An XML bundle stores `scene.json` and the files it names; the XML files and the
/// `serialized` meshes it inlined go without a word, anything else with a warning.
#[test]
fn an_xml_bundle_keeps_the_json_and_the_files_it_names() {
    let s = server_common::TestServer::start(None);
    let read = |name: &str| std::fs::read(data(name)).unwrap();
    let files = [
        "lit.xml",
        "base.xml",
        "camera.xml",
        "stage.xml",
        "meshes/tri.obj",
        "meshes/tri.serialized",
    ];
    let cases = [
        (
            "shape-obj.xml",
            vec!["meshes/tri.obj"],
            "meshes/tri.serialized (",
        ),
        ("shape-serialized.xml", vec![], "meshes/tri.obj ("),
    ];
    for (main, kept, dropped) in cases {
        let mut entries: Vec<(&str, Vec<u8>)> = files.iter().map(|n| (*n, read(n))).collect();
        entries.push(("scene.xml", read(main)));
        let refs: Vec<(&str, &[u8])> = entries.iter().map(|(n, d)| (*n, d.as_slice())).collect();
        let (code, info) = s.post_bytes("/v1/scenes", &server_common::tar_with(&refs));
        assert_eq!(code, 201, "{main}: {info}");
        let dir = s
            .dir
            .path()
            .join("scenes")
            .join(info["id"].as_str().unwrap());
        let mut want = vec!["import-warnings.txt", "scene.json"];
        want.extend(kept);
        want.sort();
        assert_eq!(server_common::stored_files(&dir).0, want, "{main}");
        let warnings = info["warnings"].to_string();
        let line = "not stored: 1 file of the bundle that the scene does not name";
        assert!(warnings.contains(line), "{main}: {warnings}");
        assert!(warnings.contains(dropped), "{main}: {warnings}");
    }
}

/// `caustic import X.xml -o elsewhere/scene.json` writes a scene that renders from
/// there: its files are copied beside it, or, when the XML's folder is inside the
/// output's, named by the way down; a different file in the way is an error.
#[test]
fn import_to_another_folder_writes_a_scene_that_renders_there() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    std::fs::create_dir_all(src.join("meshes")).unwrap();
    for name in [
        "shape-obj.xml",
        "lit.xml",
        "base.xml",
        "camera.xml",
        "stage.xml",
        "meshes/tri.obj",
    ] {
        std::fs::copy(data(name), src.join(name)).unwrap();
    }
    let xml = src.join("shape-obj.xml");
    let render = |scene: &Path| {
        let exr = dir.path().join("out.exr");
        let r = caustic(&[
            "render",
            scene.to_str().unwrap(),
            "--spp",
            "1",
            "-o",
            exr.to_str().unwrap(),
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    let import_to =
        |out: &Path| caustic(&["import", xml.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let elsewhere = dir.path().join("elsewhere/deeper/scene.json");
    let r = import_to(&elsewhere);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(String::from_utf8_lossy(&r.stderr).contains("copied 1 file the scene names"));
    assert_eq!(mesh_file(&elsewhere), "meshes/tri.obj");
    render(&elsewhere);
    let above = dir.path().join("above.json");
    assert!(import_to(&above).status.success());
    assert_eq!(mesh_file(&above), "src/meshes/tri.obj");
    render(&above);
    std::fs::write(
        dir.path().join("elsewhere/deeper/meshes/tri.obj"),
        "v 0 0 0\n",
    )
    .unwrap();
    let r = import_to(&elsewhere);
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("already exists and differs"));
}

/// The file the last shape of a written JSON scene names.
fn mesh_file(path: &Path) -> serde_json::Value {
    let scene = read_scene_file(path).unwrap();
    serde_json::to_value(scene.shapes.last().unwrap()).unwrap()["filename"].clone()
}

fn caustic(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_caustic"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn the_command_line_imports_and_renders_xml() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cornell.json");
    let xml = data("cornell-box.xml");
    let r = caustic(&["import", xml.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: cornell-box.xml:12:5: <sensor type=\"perspective\">: near_clip"),
        "{stderr}"
    );
    assert!(stderr.contains("render with --spp 64"), "{stderr}");
    let json = read_scene_file(&out).unwrap();
    assert_eq!(json, import("cornell-box.xml").scene);
    // To standard output without -o.
    let r = caustic(&["import", data("shape-sphere.xml").to_str().unwrap()]);
    assert!(r.status.success());
    let printed: caustic::scene::SceneFile = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(printed, import("shape-sphere.xml").scene);

    // `render` takes the XML, its sample count as the default length, and prints
    // the warnings.
    let exr = dir.path().join("p.exr");
    let r = caustic(&[
        "render",
        data("bsdf-plastic.xml").to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(String::from_utf8_lossy(&r.stdout).starts_with("pt: 4 iterations"));

    let r = caustic(&["import", data("missing.xml").to_str().unwrap()]);
    assert!(!r.status.success());
    let bad = dir.path().join("bad.xml");
    std::fs::write(
        &bad,
        "<scene version=\"3.0.0\">\n  <emitter type=\"sky\"/>\n</scene>\n",
    )
    .unwrap();
    let r = caustic(&["render", bad.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr
            .contains("bad.xml:2:3: <emitter type=\"sky\">: unknown or unsupported emitter plugin"),
        "{stderr}"
    );
    // The file is named once, by the importer.
    assert_eq!(stderr.matches("bad.xml").count(), 1, "{stderr}");
}

#[test]
fn submit_uploads_an_xml_scene_as_its_json_with_the_files_it_names() {
    let (bytes, content_type, files) =
        caustic::client::scene_upload(&data("shape-obj.xml")).unwrap();
    assert_eq!((content_type, files), ("application/x-tar", 2));
    let mut names = Vec::new();
    let mut scene = None;
    for e in tar::Archive::new(bytes.as_slice()).entries().unwrap() {
        let mut e = e.unwrap();
        let name = e.path().unwrap().to_string_lossy().into_owned();
        if name == "scene.json" {
            let mut text = String::new();
            std::io::Read::read_to_string(&mut e, &mut text).unwrap();
            scene = Some(caustic::scene::load::parse_scene(&text).unwrap());
        }
        names.push(name);
    }
    assert_eq!(names, ["scene.json", "meshes/tri.obj"]);
    assert_eq!(scene.unwrap(), import("shape-obj.xml").scene);
    let (bytes, content_type, _) =
        caustic::client::scene_upload(&data("shape-sphere.xml")).unwrap();
    assert_eq!(content_type, "application/json");
    assert_eq!(
        caustic::scene::load::parse_scene(std::str::from_utf8(&bytes).unwrap()).unwrap(),
        import("shape-sphere.xml").scene
    );
}

#[test]
fn transform_elements_apply_in_document_order() {
    let dir = tempfile::tempdir().unwrap();
    let camera = std::fs::read_to_string(data("camera.xml")).unwrap();
    std::fs::write(dir.path().join("camera.xml"), camera).unwrap();
    let xml = scene(
        "<include filename=\"camera.xml\"/>\n\
         <shape type=\"rectangle\">\n\
           <transform name=\"to_world\"><translate x=\"1\"/><rotate z=\"1\" angle=\"90\"/></transform>\n\
         </shape>\n\
         <shape type=\"cube\">\n\
           <transform name=\"to_world\"><translate x=\"1\"/><scale value=\"2\"/></transform>\n\
         </shape>",
    );
    std::fs::write(dir.path().join("t.xml"), xml).unwrap();
    let i = import_file(&dir.path().join("t.xml")).unwrap();
    // Translated first, then turned a quarter about z: (x, y) -> (-y, x + 1).
    let rect: caustic::scene::format::GeometryDesc = json(serde_json::json!({"type": "rectangle",
        "corners": [[1, 0, 0], [1, 2, 0], [-1, 2, 0], [-1, 0, 0]]}));
    assert_eq!(i.scene.shapes[0].geometry, rect);
    // Translated, then scaled: not translate-rotate-scale, so a matrix.
    let cube = i.scene.shapes[1].common.transform.clone().unwrap();
    assert_eq!(
        cube.matrix,
        Some([2., 0., 0., 2., 0., 2., 0., 0., 0., 0., 2., 0., 0., 0., 0., 1.])
    );
}

/// The film of a scene whose sensor's film holds `film` (empty: no `<film>` at all).
fn imported_film(film: &str) -> Result<caustic::scene::format::FilmDesc, String> {
    let dir = tempfile::tempdir().unwrap();
    let film = match film {
        "" => String::new(),
        f => format!("<film type=\"hdrfilm\">{f}</film>"),
    };
    let text = scene(&format!(
        "<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>{film}</sensor>"
    ));
    std::fs::write(dir.path().join("s.xml"), text).unwrap();
    let i = import_file(&dir.path().join("s.xml")).map_err(|e| e.to_string())?;
    // Only the missing integrator is worth a word.
    assert_eq!(i.warnings.len(), 1, "{:?}", i.warnings);
    Ok(i.scene.film)
}

/// Every Mitsuba 3 `rfilter` maps to the filter of the same name and parameters, and
/// Mitsuba's default (no `<rfilter>`, or no `<film>`) is its Gaussian of stddev 0.5.
#[test]
fn rfilters_map_exactly() {
    use caustic::scene::format::Filter;
    let gaussian = Filter::Gaussian { stddev: 0.5 };
    let cases = [
        ("", gaussian),
        ("<integer name=\"width\" value=\"8\"/>", gaussian),
        ("<rfilter type=\"box\"/>", Filter::Box { radius: 0.5 }),
        ("<rfilter type=\"box\"><float name=\"radius\" value=\"1.5\"/></rfilter>", Filter::Box { radius: 1.5 }),
        ("<rfilter type=\"tent\"/>", Filter::Tent { radius: 1.0 }),
        ("<rfilter type=\"tent\"><float name=\"radius\" value=\"2\"/></rfilter>", Filter::Tent { radius: 2.0 }),
        ("<rfilter type=\"gaussian\"/>", gaussian),
        ("<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0.25\"/></rfilter>", Filter::Gaussian { stddev: 0.25 }),
        ("<rfilter type=\"mitchell\"/>", Filter::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 }),
        ("<rfilter type=\"mitchell\"><float name=\"B\" value=\"0.5\"/><float name=\"C\" value=\"0.25\"/></rfilter>", Filter::Mitchell { b: 0.5, c: 0.25 }),
        ("<rfilter type=\"catmullrom\"/>", Filter::Mitchell { b: 0.0, c: 0.5 }),
        ("<rfilter type=\"lanczos\"/>", Filter::Lanczos { lobes: 3 }),
        ("<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"2\"/></rfilter>", Filter::Lanczos { lobes: 2 }),
    ];
    for (film, want) in cases {
        let got = imported_film(film).unwrap_or_else(|e| panic!("{film}: {e}"));
        assert_eq!(got.filter.0, want, "{film}");
    }
    // Out of caustic's range, or not a filter: the element and the parameter named.
    let bad = [
        (
            "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"2\"/></rfilter>",
            "stddev 2",
        ),
        (
            "<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"-1\"/></rfilter>",
            "lobes -1",
        ),
        (
            "<rfilter type=\"mitchell\"><float name=\"B\" value=\"2\"/></rfilter>",
            "B 2",
        ),
        (
            "<rfilter type=\"tent\"><float name=\"stddev\" value=\"1\"/></rfilter>",
            "stddev",
        ),
        (
            "<rfilter type=\"sinc\"/>",
            "unknown rfilter plugin \"sinc\"",
        ),
    ];
    for (film, words) in bad {
        let err = imported_film(film).expect_err(film);
        assert!(
            err.contains("<rfilter type=") && err.contains(words),
            "{film}: {err}"
        );
    }
}

/// Mitsuba's `normalmap` (texture in slot `normalmap`) and `bumpmap` (any nested
/// texture, `scale`) import with their options, around a nested twosided BSDF.
#[test]
fn normal_and_bump_maps_import() {
    use caustic::scene::format::MaterialDesc;
    let m = import("bsdf-normalmap.xml").scene.materials;
    let want = json::<MaterialDesc>(serde_json::json!({"type": "normalmap",
        "normalmap": {"type": "bitmap", "filename": "normals.png", "raw": true},
        "use_shadowing_function": false,
        "material": {"type": "diffuse", "reflectance": [0.2, 0.5, 0.8], "two_sided": true}}));
    assert!(m.values().any(|d| *d == want), "{m:?}");
    let m = import("bsdf-bumpmap.xml").scene.materials;
    let want = json::<MaterialDesc>(serde_json::json!({"type": "bumpmap",
        "texture": {"type": "bitmap", "filename": "heights.png", "raw": true},
        "scale": 0.5, "flip_invalid_normals": false,
        "material": {"type": "roughplastic"}}));
    assert!(m.values().any(|d| *d == want), "{m:?}");
}

/// BSDFs caustic does not implement import as the nearest material it has, with a
/// warning that names the stand-in and what it leaves out.
#[test]
fn uncovered_bsdfs_import_as_stand_ins_with_warnings() {
    let cases = [
        (
            r#"<bsdf type="principled"><rgb name="base_color" value="0.8, 0.2, 0.1"/><float name="roughness" value="0.3"/><float name="sheen" value="0.5"/></bsdf>"#,
            json!({"type": "roughplastic", "distribution": "ggx", "alpha": 0.09f32,
                   "diffuse_reflectance": [0.8, 0.2, 0.1], "specular_reflectance": [1, 1, 1],
                   "int_ior": 1.5, "ext_ior": 1, "nonlinear": false, "two_sided": false}),
            "ignored: sheen",
        ),
        (
            r#"<bsdf type="principled"><float name="metallic" value="1"/><float name="roughness" value="0.5"/></bsdf>"#,
            json!({"type": "roughconductor", "distribution": "ggx", "alpha": 0.25,
                   "eta": [0, 0, 0], "k": [1, 1, 1], "specular_reflectance": [0.5, 0.5, 0.5],
                   "two_sided": false}),
            "roughconductor",
        ),
        (
            r#"<bsdf type="pplastic"><float name="alpha" value="0.2"/></bsdf>"#,
            json!({"type": "roughplastic", "distribution": "ggx", "alpha": 0.2f32,
                   "diffuse_reflectance": [0.5, 0.5, 0.5], "specular_reflectance": [1, 1, 1],
                   "int_ior": 1.49, "ext_ior": 1.000277f32, "nonlinear": false, "two_sided": false}),
            "unpolarized",
        ),
        (
            r#"<bsdf type="hair"><float name="eumelanin" value="1.3"/></bsdf>"#,
            json!({"type": "diffuse", "reflectance": [0.5, 0.5, 0.5], "two_sided": true}),
            "ignored: eumelanin",
        ),
    ];
    for (bsdf, want, words) in cases {
        let dir = tempfile::tempdir().unwrap();
        let text = scene(&format!(
            "<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film></sensor>\n<shape type=\"sphere\">{bsdf}</shape>"
        ));
        std::fs::write(dir.path().join("s.xml"), text).unwrap();
        let i = import_file(&dir.path().join("s.xml")).unwrap_or_else(|e| panic!("{bsdf}: {e}"));
        let got = serde_json::to_value(i.scene.materials.values().next().unwrap()).unwrap();
        // Through the format's own types, so numbers compare as f32 alike.
        let want: caustic::scene::format::MaterialDesc = serde_json::from_value(want).unwrap();
        assert_eq!(got, serde_json::to_value(want).unwrap(), "{bsdf}");
        let w = i.warnings.iter().find(|w| w.contains("caustic has no"));
        let w = w.unwrap_or_else(|| panic!("{bsdf}: no stand-in warning in {:?}", i.warnings));
        assert!(w.contains(words) && w.contains("s.xml:3:"), "{w}");
    }
}
