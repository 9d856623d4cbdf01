//! Mitsuba 0.x scene files: upgraded as Mitsuba 3 upgrades them, plus the 0.x forms
//! it dropped, so that each imports to the same scene as its Mitsuba 3 form; what
//! describes how to render never blocks an import; what cannot be upgraded is an
//! error that names the element and its line.

use caustic::scene::mitsuba::{import_file, Import};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/mitsuba")
        .join(name)
}

fn import(name: &str) -> Import {
    import_file(&data(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Each warning starts with the one expected at its position.
fn assert_warnings(name: &str, got: &[String], want: &[&str]) {
    assert_eq!(got.len(), want.len(), "{name}: {got:#?}");
    for (got, want) in got.iter().zip(want) {
        assert!(got.starts_with(want), "{name}: {got}\nwant: {want}");
    }
}

#[test]
fn a_mitsuba_0_5_cornell_box_imports_to_the_same_scene_as_the_mitsuba_3_one() {
    let old = import("cornell-box-0.5.xml");
    let new = import("cornell-box.xml");
    assert_eq!(old.scene, new.scene);
    assert_eq!(old.spp, Some(64));
    assert_eq!(old.spp, new.spp);
    assert_warnings(
        "cornell-box-0.5.xml",
        &old.warnings,
        &[
            "cornell-box-0.5.xml:15:5: <sensor type=\"perspective\">: near_clip and far_clip are ignored",
            "cornell-box-0.5.xml:24:9: <sampler type=\"ldsampler\">: caustic samples with independent random numbers",
        ],
    );
}

#[test]
fn mitsuba_0_6_fixtures_import_to_the_same_scene_as_their_mitsuba_3_forms() {
    let pairs: [(&str, &str, &[&str]); 7] = [
        (
            "v06-sensor-thinlens.xml",
            "sensor-thinlens.xml",
            &[
                "v06-sensor-thinlens.xml:2:5: <integrator type=\"bdpt\">: rr_depth is ignored",
                "v06-sensor-thinlens.xml:19:9: <sampler type=\"stratified\">: caustic samples with independent",
            ],
        ),
        ("v06-medium-homogeneous.xml", "medium-homogeneous.xml", &[]),
        (
            "v06-medium-heterogeneous.xml",
            "medium-heterogeneous.xml",
            &[
                "v06-medium-heterogeneous.xml:12:13: <volume type=\"gridvolume\" name=\"density\">: Mitsuba 0.x put a grid's values on the corners",
                "v06-medium-heterogeneous.xml:4:5: <integrator type=\"volpath_simple\">: caustic has no volpath_simple: rendered with volpath",
            ],
        ),
        ("v06-emitter-spot.xml", "emitter-spot.xml", &[]),
        ("v06-bsdf-dielectric.xml", "bsdf-dielectric.xml", &[]),
        ("v06-shape-serialized.xml", "shape-serialized.xml", &[]),
        (
            "v06-shape-obj.xml",
            "shape-obj.xml",
            &["v06-shape-obj.xml:7:9: <float name=\"max_smooth_angle\">: Mitsuba 0.x discarded the mesh's normals"],
        ),
    ];
    for (old, new, warnings) in pairs {
        let (a, b) = (import(old), import(new));
        assert_eq!(canonical(&a.scene), canonical(&b.scene), "{old}");
        assert_eq!(a.spp, b.spp, "{old}");
        assert_warnings(old, &a.warnings, warnings);
    }
}

/// The scene as JSON, with the names the import made up for elements without an id
/// (`bsdf@file.xml:12`) replaced by their order of first use, so that two files that
/// differ only in their names and layout compare equal.
fn canonical(scene: &caustic::scene::SceneFile) -> serde_json::Value {
    let v = serde_json::to_value(scene).unwrap();
    let mut made_up: Vec<String> = Vec::new();
    for shape in v["shapes"].as_array().unwrap() {
        for key in ["material", "interior", "exterior"] {
            if let Some(name) = shape[key].as_str().filter(|n| n.contains('@')) {
                if !made_up.iter().any(|m| m == name) {
                    made_up.push(name.to_string());
                }
            }
        }
    }
    let mut text = v.to_string();
    for (k, name) in made_up.iter().enumerate() {
        text = text.replace(&format!("\"{name}\""), &format!("\"#{k}\""));
    }
    assert!(!text.contains(".xml:"), "a made-up name left: {text}");
    serde_json::from_str(&text).unwrap()
}

/// Imports `body` after the shared camera and stage, in a scene file of `version`.
fn import_with_camera(version: &str, body: &str) -> caustic::scene::error::Result<Import> {
    let dir = tempfile::tempdir().unwrap();
    for name in ["camera.xml", "stage.xml"] {
        std::fs::copy(data(name), dir.path().join(name)).unwrap();
    }
    let text = format!(
        "<scene version=\"{version}\">\n<include filename=\"camera.xml\"/>\n\
         <include filename=\"stage.xml\"/>\n{body}\n</scene>\n"
    );
    std::fs::write(dir.path().join("s.xml"), text).unwrap();
    import_file(&dir.path().join("s.xml"))
}

#[test]
fn every_integrator_and_sampler_imports_as_the_nearest_caustic_setting_with_a_warning() {
    // camera.xml's film is 32 x 24 = 768 pixels.
    let cases: &[(&str, serde_json::Value, &[&str])] = &[
        (
            "<integrator type=\"photonmapper\"><integer name=\"maxDepth\" value=\"6\"/>\
             <integer name=\"globalPhotons\" value=\"250000\"/>\
             <float name=\"causticLookupRadius\" value=\"0.01\"/></integrator>",
            serde_json::json!({"algorithm": "sppm", "max_depth": 6}),
            &["caustic has no photon mapper with final gathering: rendered with sppm"],
        ),
        (
            "<integrator type=\"sppm\"><integer name=\"maxDepth\" value=\"6\"/>\
             <integer name=\"photonCount\" value=\"1536\"/><float name=\"initialRadius\" value=\"0.05\"/>\
             <float name=\"alpha\" value=\"0.5\"/><integer name=\"rrDepth\" value=\"2\"/>\
             <integer name=\"granularity\" value=\"0\"/><integer name=\"maxPasses\" value=\"10\"/></integrator>",
            serde_json::json!({"algorithm": "sppm", "max_depth": 6, "light_paths": 2.0,
                "radius": 0.05, "alpha": 0.5, "rr_depth": 2}),
            &[],
        ),
        (
            "<integrator type=\"ppm\"><integer name=\"maxDepth\" value=\"4\"/></integrator>",
            serde_json::json!({"algorithm": "ppm", "max_depth": 4}),
            &[],
        ),
        (
            "<integrator type=\"ptracer\"><integer name=\"maxDepth\" value=\"4\"/>\
             <boolean name=\"bruteForce\" value=\"false\"/></integrator>",
            serde_json::json!({"algorithm": "lt", "max_depth": 4}),
            &[],
        ),
        (
            "<integrator type=\"direct\"><integer name=\"emitterSamples\" value=\"4\"/></integrator>",
            serde_json::json!({"algorithm": "pt", "max_depth": 2}),
            &["direct (emitters and direct lighting only) becomes pt with max_depth 2"],
        ),
        (
            "<integrator type=\"irrcache\"><integer name=\"resolution\" value=\"14\"/>\
             <integrator type=\"path\"><integer name=\"maxDepth\" value=\"5\"/></integrator></integrator>",
            serde_json::json!({"algorithm": "pt", "max_depth": 5}),
            &["caustic renders the integrator it wraps, <integrator type=\"path\">, without its irradiance cache"],
        ),
        (
            "<integrator type=\"adaptive\"><float name=\"maxError\" value=\"0.05\"/>\
             <integrator type=\"volpath\"><integer name=\"maxDepth\" value=\"7\"/>\
             <boolean name=\"strictNormals\" value=\"true\"/></integrator></integrator>",
            serde_json::json!({"algorithm": "volpath", "max_depth": 7}),
            &[
                "caustic renders the integrator it wraps, <integrator type=\"volpath\">, without its adaptive sample counts",
                "strict_normals is ignored",
            ],
        ),
        (
            "<integrator type=\"pssmlt\"><boolean name=\"bidirectional\" value=\"false\"/>\
             <integer name=\"maxDepth\" value=\"5\"/><float name=\"pLarge\" value=\"0.3\"/></integrator>",
            serde_json::json!({"algorithm": "pt", "max_depth": 5}),
            &["caustic has no Metropolis sampling: rendered with pt"],
        ),
        (
            "<integrator type=\"mlt\"><integer name=\"maxDepth\" value=\"5\"/></integrator>",
            serde_json::json!({"algorithm": "bpt", "max_depth": 5}),
            &["caustic has no Metropolis sampling: rendered with bpt"],
        ),
        (
            "<integrator type=\"vpl\"><integer name=\"maxDepth\" value=\"5\"/>\
             <integer name=\"shadowMapResolution\" value=\"512\"/></integrator>",
            serde_json::json!({"algorithm": "vpl", "max_depth": 5}),
            &["Mitsuba's vpl clamps each virtual light's contribution"],
        ),
        (
            "<integrator type=\"ao\"><integer name=\"shadingSamples\" value=\"4\"/>\
             <float name=\"rayLength\" value=\"2\"/></integrator>",
            serde_json::json!({"algorithm": "pt", "max_depth": 1024}),
            &[
                "\"ao\" is not an integrator caustic has",
                "max_depth -1 (no limit) becomes 1024",
                "the integrator in caustic has no equivalent of <float name=\"ray_length\">; ignored",
            ],
        ),
        (
            "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"0\"/>\
             <boolean name=\"hideEmitters\" value=\"true\"/><integer name=\"rrDepth\" value=\"-2\"/></integrator>",
            serde_json::json!({"algorithm": "pt", "max_depth": 1}),
            &["max_depth 0 (an empty image in Mitsuba) becomes 1", "rr_depth -2 is negative; ignored", "hide_emitters is ignored"],
        ),
        (
            "<integrator type=\"path\"><float name=\"maxDepth\" value=\"deep\"/></integrator>",
            serde_json::json!({"algorithm": "pt", "max_depth": 1024}),
            &["\"max_depth\" must be an <integer>; ignored, the default is used", "max_depth -1 (no limit)"],
        ),
    ];
    for (body, want, warnings) in cases {
        let i = import_with_camera("0.6.0", body).unwrap_or_else(|e| panic!("{body}: {e}"));
        assert_eq!(i.scene.integrator.as_ref(), Some(want), "{body}");
        let got = &i.warnings;
        assert_eq!(got.len(), warnings.len(), "{body}: {got:#?}");
        for (got, want) in got.iter().zip(*warnings) {
            assert!(got.contains(want), "{body}: {got}\nwant: {want}");
        }
        // Every imported setting is one caustic takes.
        let scene = caustic::scene::Scene::compile(&i.scene, None).unwrap();
        caustic::integrator::Settings::for_scene(None, &scene, &Default::default())
            .unwrap_or_else(|e| panic!("{body}: {e}"));
    }
}

#[test]
fn what_cannot_be_upgraded_is_an_error_at_its_element() {
    let cases = [
        (
            "<emitter type=\"point\">\n  <blackbody name=\"intensity\" temperature=\"5000\"/>\n</emitter>",
            "s.xml:5:3: <blackbody name=\"intensity\">",
            "black-body spectra are not supported",
        ),
        (
            "<shape type=\"sphere\">\n  <transform name=\"toWorld\">\n    <animation/>\n  </transform>\n</shape>",
            "s.xml:6:5: <animation>",
            "animated transforms are not supported",
        ),
        (
            "<shape type=\"sphere\">\n  <bsdf type=\"diffuse\">\n    <texture type=\"bitmap\" name=\"diffuseReflectance\">\n      \
             <string name=\"filename\" value=\"a.png\"/>\n      <string name=\"wrapMode\" value=\"one\"/>\n    \
             </texture>\n  </bsdf>\n</shape>",
            "s.xml:8:7: <string name=\"wrap_mode\">",
            "wrap mode \"one\" (a constant outside the image) has no Mitsuba 3 form",
        ),
        (
            "<medium type=\"homogeneous\" id=\"m\">\n  <string name=\"material\" value=\"Ketchup\"/>\n</medium>",
            "s.xml:5:3: <string name=\"material\">",
            "measured material presets are not supported",
        ),
        (
            "<shape type=\"sphere\">\n  <bsdf type=\"diffuse\">\n    <spectrum name=\"reflectance\" value=\"400:0.1, 700:0.5\"/>\n  </bsdf>\n</shape>",
            "s.xml:6:5: <spectrum name=\"reflectance\">",
            "spectra given by wavelength are not supported",
        ),
        (
            "<shape type=\"sphere\">\n  <bsdf type=\"roughdiffuse\"/>\n</shape>",
            "s.xml:5:3: <bsdf type=\"roughdiffuse\">",
            "unknown or unsupported BSDF plugin",
        ),
    ];
    for (body, at, words) in cases {
        let err = match import_with_camera("0.5.0", body) {
            Ok(_) => panic!("imported: {body}"),
            Err(e) => e.to_string(),
        };
        assert!(err.starts_with(at), "want {at}: {err}");
        assert!(err.contains(words), "want {words}: {err}");
    }
}

#[test]
fn a_sensor_without_a_fov_takes_its_focal_length_as_mitsuba_does() {
    let dir = tempfile::tempdir().unwrap();
    let import_sensor = |focal: &str| {
        let text = format!(
            "<scene version=\"0.5.0\">\n<sensor type=\"perspective\">\n{focal}\
             <film type=\"hdrfilm\"><integer name=\"width\" value=\"30\"/>\
             <integer name=\"height\" value=\"20\"/></film></sensor>\n\
             <shape type=\"sphere\"/><emitter type=\"constant\"/></scene>"
        );
        std::fs::write(dir.path().join("s.xml"), text).unwrap();
        import_file(&dir.path().join("s.xml"))
    };
    let fov_x = |focal: &str| {
        let i = import_sensor(focal).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(i.scene.camera.fov_axis, caustic::scene::format::FovAxis::X);
        i.scene.camera.fov as f64
    };
    // Mitsuba 3's parse_fov: a diagonal fov from a 36 x 24 mm film, then its x part.
    let mitsuba = |mm: f64| {
        let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / mm;
        let width = diagonal / (1.0 + 1.0 / (1.5f64 * 1.5)).sqrt();
        2.0 * (width * 0.5).atan().to_degrees()
    };
    let given = fov_x("<string name=\"focalLength\" value=\"35mm\"/>");
    assert!(
        (given - mitsuba(35.0)).abs() < 1e-4,
        "{given} {}",
        mitsuba(35.0)
    );
    let default = fov_x("");
    assert!(
        (default - mitsuba(50.0)).abs() < 1e-4,
        "{default} {}",
        mitsuba(50.0)
    );
    let err = import_sensor("<string name=\"focalLength\" value=\"wide\"/>")
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("s.xml:3:1: <string name=\"focal_length\">"),
        "{err}"
    );
    assert!(
        err.contains("focal_length \"wide\" is not a length"),
        "{err}"
    );
}

#[test]
fn without_an_integrator_a_0x_scene_renders_0xs_default_direct_lighting() {
    for (version, depth, words) in [
        ("0.6.0", 2, "no <integrator>: Mitsuba 0.x's default, direct illumination, becomes pt with max_depth 2"),
        ("3.0.0", 1024, "no <integrator>: Mitsuba's default path tracer with unlimited max_depth becomes pt with max_depth 1024"),
    ] {
        let i = import_with_camera(version, "").unwrap();
        assert_eq!(
            i.scene.integrator,
            Some(serde_json::json!({"algorithm": "pt", "max_depth": depth}))
        );
        assert!(i.warnings.iter().any(|w| w == &format!("s.xml:1:1: {words}")), "{:?}", i.warnings);
    }
}
