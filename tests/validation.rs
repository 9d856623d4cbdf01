//! Bad scenes: every class of bad input gets an error that names the field.

use caustic::scene::{load::parse_scene, Scene, SceneError};
use serde_json::{json, Value};
use std::path::Path;

fn base() -> Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
        "film": {"width": 16, "height": 16},
        "materials": {"white": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
                      "glass": {"type": "dielectric", "int_ior": 1.5}},
        "shapes": [{"type": "sphere", "radius": 1, "material": "white"}],
        "lights": [{"type": "point", "position": [0, 3, 3], "intensity": [1, 1, 1]}]
    })
}

fn error_of(v: &Value) -> SceneError {
    error_in(v, None)
}

fn error_in(v: &Value, dir: Option<&Path>) -> SceneError {
    match parse_scene(&v.to_string()) {
        Err(e) => e,
        Ok(f) => match Scene::compile(&f, dir) {
            Err(e) => e,
            Ok(_) => panic!("scene was accepted: {v}"),
        },
    }
}

fn expect(v: Value, path: &str, words: &str) {
    let e = error_of(&v);
    assert_eq!(e.path, path, "{e}");
    assert!(e.message.contains(words), "{e}");
}

#[test]
fn the_base_scene_is_valid() {
    let f = parse_scene(&base().to_string()).unwrap();
    Scene::compile(&f, None).unwrap();
}

#[test]
fn malformed_json_is_reported_with_its_position() {
    let e = parse_scene("{\"format\": 1, \"camera\": ").unwrap_err();
    assert!(e.message.contains("EOF"), "{e}");
}

#[test]
fn unknown_material_names_the_shape() {
    let mut v = base();
    v["shapes"][0]["material"] = json!("glas");
    let e = error_of(&v);
    assert_eq!(
        e.to_string(),
        "shapes[0].material: unknown material \"glas\""
    );
}

#[test]
fn unknown_field_is_an_error() {
    let mut v = base();
    v["materials"]["white"]["reflectence"] = json!([0.5, 0.5, 0.5]);
    let e = error_of(&v);
    assert!(e.path.starts_with("materials.white"), "{e}");
    assert!(e.message.contains("reflectence"), "{e}");
    let mut v = base();
    v["shapes"][0]["radiu"] = json!(2);
    let e = error_of(&v);
    assert_eq!(e.path, "shapes[0]", "{e}");
    assert!(e.message.contains("radiu"), "{e}");
}

#[test]
fn wrong_type_is_an_error() {
    let mut v = base();
    v["film"]["width"] = json!("wide");
    expect(v, "film.width", "invalid type");
}

#[test]
fn non_finite_numbers_are_refused() {
    // JSON has no NaN; 1e39 would overflow f32 to infinity: it is refused as written
    // (serde_json writes it 1e+39), naming the element.
    let mut v = base();
    v["lights"][0]["position"] = json!([0, 1e39, 0]);
    expect(v, "lights[0].position[1]", "number 1e+39 is out of range");
}

#[test]
fn negative_radiance_is_refused() {
    let mut v = base();
    v["shapes"][0]["emission"] = json!({"radiance": [1, -1, 1]});
    expect(v, "shapes[0].emission.radiance", "negative");
}

#[test]
fn albedo_above_one_is_refused() {
    let mut v = base();
    v["materials"]["white"]["reflectance"] = json!([0.5, 1.2, 0.5]);
    expect(v, "materials.white.reflectance", "exceeds 1");
    let mut v = base();
    v["materials"]["white"] =
        json!({"type": "phong", "kd": [0.6, 0.6, 0.6], "ks": [0.6, 0.6, 0.6], "exponent": 10});
    expect(v, "materials.white", "kd + ks");
}

#[test]
fn non_positive_ior_is_refused() {
    let mut v = base();
    v["materials"]["glass"]["int_ior"] = json!(0.0);
    expect(v, "materials.glass.int_ior", "positive");
}

#[test]
fn out_of_range_camera_and_film_are_refused() {
    let mut v = base();
    v["camera"]["fov"] = json!(180.0);
    expect(v, "camera.fov", "out of range");
    let mut v = base();
    v["film"]["width"] = json!(0);
    expect(v, "film.width", "out of range");
    let mut v = base();
    v["camera"]["look_at"]["up"] = json!([0, 0, 1]);
    expect(v, "camera.look_at.up", "parallel");
}

#[test]
fn unsupported_format_version_is_refused() {
    let mut v = base();
    v["format"] = json!(2);
    expect(v, "format", "unsupported");
}

#[test]
fn mesh_index_out_of_range_is_refused() {
    let mut v = base();
    v["shapes"][0] = json!({"type": "mesh", "material": "white",
        "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "indices": [[0, 1, 3]]});
    expect(v, "shapes[0].indices[0]", "out of range");
}

#[test]
fn unknown_medium_is_refused() {
    let mut v = base();
    v["shapes"][0]["interior"] = json!("fog");
    expect(v, "shapes[0].interior", "unknown medium");
}

#[test]
fn file_references_may_not_escape_the_scene_folder() {
    for name in ["/etc/passwd", "../outside.obj", "meshes/../../x.obj"] {
        let mut v = base();
        v["shapes"][0] = json!({"type": "obj", "filename": name, "material": "white"});
        expect(v, "shapes[0].filename", "relative path inside");
    }
}

#[test]
fn symlinks_leading_out_of_the_folder_are_refused() {
    let outside = tempfile::tempdir().unwrap();
    std::fs::write(outside.path().join("secret.obj"), "v 0 0 0\n").unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(
        outside.path().join("secret.obj"),
        dir.path().join("link.obj"),
    )
    .unwrap();
    let mut v = base();
    v["shapes"][0] = json!({"type": "obj", "filename": "link.obj", "material": "white"});
    let e = error_in(&v, Some(dir.path()));
    assert_eq!(e.path, "shapes[0].filename");
    assert!(e.message.contains("outside"), "{e}");
}

#[test]
fn missing_files_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut v = base();
    v["shapes"][0] = json!({"type": "ply", "filename": "nope.ply", "material": "white"});
    let e = error_in(&v, Some(dir.path()));
    assert_eq!(e.path, "shapes[0].filename");
    assert!(e.message.contains("nope.ply"), "{e}");
}

#[test]
fn non_similarity_transform_on_a_sphere_is_refused() {
    let mut v = base();
    v["shapes"][0]["transform"] = json!({"scale": [1, 2, 1]});
    expect(v, "shapes[0].transform", "uniformly");
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let mut v = base();
    v["shapes"][0] = json!({"type": "mesh", "material": "white",
        "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]],
        "indices": [[0, 1, 2], [0, 1, 3], [1, 1, 2]]});
    let scene = Scene::compile(&parse_scene(&v.to_string()).unwrap(), None).unwrap();
    assert_eq!(scene.stats.triangles, 1);
    assert_eq!(scene.stats.degenerate_dropped, 2);
}

#[test]
fn obj_and_ply_files_load_relative_to_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("m")).unwrap();
    std::fs::write(
        dir.path().join("m/quad.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("m/tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let mut v = base();
    v["shapes"] = json!([
        {"type": "obj", "filename": "m/quad.obj", "material": "white"},
        {"type": "ply", "filename": "m/tri.ply", "material": "white"}
    ]);
    let scene = Scene::compile(&parse_scene(&v.to_string()).unwrap(), Some(dir.path())).unwrap();
    assert_eq!(scene.stats.triangles, 3);
}

#[test]
fn unknown_fields_on_field_less_types_are_refused() {
    let mut v = base();
    v["shapes"][0] = json!({"type": "cube", "radius": 2, "material": "white"});
    let e = error_of(&v);
    assert!(e.message.contains("radius"), "{e}");
    let mut v = base();
    v["materials"]["white"] = json!({"type": "null", "reflectance": [1, 1, 1]});
    let e = error_of(&v);
    assert!(e.message.contains("reflectance"), "{e}");
}

#[test]
fn camera_type_must_agree_with_the_aperture() {
    let mut v = base();
    v["camera"]["aperture_radius"] = json!(0.1);
    expect(v, "camera.aperture_radius", "pinhole");
    let mut v = base();
    v["camera"]["type"] = json!("thinlens");
    expect(v, "camera.aperture_radius", "positive");
}

#[test]
fn scene_integrator_must_name_its_algorithm() {
    let mut v = base();
    v["integrator"] = json!({"max_depth": 8});
    expect(v, "integrator", "algorithm");
}

#[test]
fn unknown_media_references_are_refused() {
    let mut v = base();
    v["media"] = json!({"fog": {"type": "homogeneous", "sigma_a": [0.1, 0.1, 0.1], "sigma_s": [0.5, 0.5, 0.5]}});
    v["shapes"][0]["exterior"] = json!("fgo");
    expect(v.clone(), "shapes[0].exterior", "unknown medium");
    v["shapes"][0]["exterior"] = json!("fog");
    v["camera"]["medium"] = json!("smoke");
    expect(v, "camera.medium", "unknown medium");
}

#[test]
fn null_boundaries_cannot_emit() {
    let mut v = base();
    v["materials"]["b"] = json!({"type": "null"});
    v["shapes"][0]["material"] = json!("b");
    v["shapes"][0]["emission"] = json!({"radiance": [1, 1, 1]});
    expect(v, "shapes[0].emission", "cannot emit");
}
