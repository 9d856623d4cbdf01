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
