//! A sweep over `params.radius` runs as one job with radius layers (`radii`), and
//! each layer's error against the reference is logged per snapshot in layers.csv
//! (`GET /v1/jobs/{id}/layers`). The layered sweep's table must give every point the
//! RMSE a separate job with that radius gives (the same image up to float rounding,
//! tests/radii.rs), and `radius_layers: false` must give separate jobs.

mod server_common;
use serde_json::{json, Value};
use server_common::*;

const RADII: [f64; 3] = [0.05, 0.1, 0.2];
const ITERATIONS: u64 = 3;

/// The tiny scene, uploaded, and a reference for it (a short `pt` render).
fn scene_and_reference(s: &TestServer) -> (Value, Value) {
    upload_with_reference(s, tiny_scene(16))
}

/// `scene` uploaded, and a reference for it (a short `pt` render).
fn upload_with_reference(s: &TestServer, scene: Value) -> (Value, Value) {
    let (code, info) = s.post_bytes("/v1/scenes", scene.to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    let pixels = direct_render(&scene.to_string(), Some("pt"), &json!({}), 1, 16);
    let size = scene["film"]["width"].as_u64().unwrap() as u32;
    let img = caustic::film::Image::from_pixels(size, size, pixels);
    let exr = caustic::film::encode_exr(&img).unwrap();
    let (code, reference) = s.post_bytes("/v1/references", &exr);
    assert_eq!(code, 201, "{reference}");
    (info["id"].clone(), reference["id"].clone())
}

/// Runs a `vcm` sweep over `RADII` (with `extra` fields) to the end; its table.
fn radius_sweep(s: &TestServer, setup: &(Value, Value), extra: Value) -> Value {
    let base = json!({"algorithm": "vcm"});
    sweep_over(s, setup, (base, "params.radius"), extra)
}

/// Runs a sweep of `base` (fields added to the test's) over `key` taking `RADII`,
/// with `extra` fields in the sweep spec, to the end; its table.
fn sweep_over(
    s: &TestServer,
    (scene, reference): &(Value, Value),
    (base, key): (Value, &str),
    extra: Value,
) -> Value {
    let mut spec = json!({
        "base": {"scene": scene, "seed": 5,
                 "halt": {"iterations": ITERATIONS}, "reference": {"upload": reference},
                 "snapshot_every": {"iterations": 1}},
        "grid": {key: RADII},
    });
    for (k, v) in base.as_object().unwrap() {
        spec["base"][k] = v.clone();
    }
    for (k, v) in extra.as_object().unwrap() {
        spec[k] = v.clone();
    }
    let (code, table) = s.post_json("/v1/sweeps", &spec);
    assert_eq!(code, 201, "{table}");
    for r in table["rows"].as_array().unwrap() {
        let job = s.wait_job(r["job"].as_str().unwrap());
        assert_eq!(job["state"], "completed", "{job}");
    }
    s.get_json(&format!("/v1/sweeps/{}", table["id"].as_str().unwrap()))
        .1
}

fn rows(table: &Value) -> &Vec<Value> {
    table["rows"].as_array().unwrap()
}

#[test]
fn a_radius_sweep_is_one_job_whose_layers_match_separate_jobs() {
    let s = TestServer::start(None);
    let setup = scene_and_reference(&s);
    let layered = radius_sweep(&s, &setup, json!({}));
    let separate = radius_sweep(&s, &setup, json!({"radius_layers": false}));

    let (shared, own) = (rows(&layered), rows(&separate));
    assert_eq!((shared.len(), own.len()), (3, 3));
    let job = shared[0]["job"].as_str().unwrap();
    assert!(shared.iter().all(|r| r["job"] == job), "{layered}");
    let layers: Vec<&Value> = shared.iter().map(|r| &r["layer"]).collect();
    assert_eq!(layers, [&Value::Null, &json!("radius0"), &json!("radius1")]);
    let jobs: std::collections::HashSet<&str> =
        own.iter().map(|r| r["job"].as_str().unwrap()).collect();
    assert_eq!(jobs.len(), 3, "{separate}");
    assert!(own.iter().all(|r| r.get("layer").is_none()), "{separate}");

    // The shared job renders the first radius as its image and the others as layers.
    let (_, status) = s.get_json(&format!("/v1/jobs/{job}"));
    assert_eq!(status["settings"]["radius"].as_f64().unwrap() as f32, 0.05);
    let radii: Vec<f32> = status["settings"]["radii"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    assert_eq!(radii, [0.1, 0.2]);

    // Point by point, the same error as a separate job with that radius and seed
    // (images equal to 1e-7 of the peak, so the RMSE to well under 1e-4).
    for (a, b) in shared.iter().zip(own) {
        assert_eq!(a["point"], b["point"]);
        assert_eq!(
            (a["iterations"].as_u64(), b["iterations"].as_u64()),
            (Some(3), Some(3))
        );
        let (x, y) = (a["rmse"].as_f64().unwrap(), b["rmse"].as_f64().unwrap());
        assert!(y > 0.0);
        assert!(
            (x - y).abs() <= 1e-4 * y,
            "{}: layered {x} against separate {y}",
            a["point"]
        );
    }
    // Different radii give different images: the check above is not vacuous.
    let r: Vec<f64> = own.iter().map(|r| r["rmse"].as_f64().unwrap()).collect();
    assert!(r[0] != r[1] && r[1] != r[2], "{r:?}");

    // layers.csv: one row per radius layer and snapshot, as CSV and as JSON.
    let (code, csv) = s.get(&format!("/v1/jobs/{job}/layers"));
    assert_eq!(code, 200);
    let csv = String::from_utf8(csv).unwrap();
    assert!(
        csv.starts_with("iteration,layer,radius,medium_radius,rmse,rel_mse\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 1 + 2 * ITERATIONS as usize, "{csv}");
    let (code, json_rows) = s.get_json_accept(&format!("/v1/jobs/{job}/layers"));
    assert_eq!(code, 200);
    let json_rows = json_rows.as_array().unwrap();
    let last = &json_rows[json_rows.len() - 2..];
    assert_eq!(last[0]["layer"], "radius0");
    assert_eq!(last[0]["iteration"], ITERATIONS);
    assert_eq!(last[1]["radius"].as_f64().unwrap() as f32, 0.2);
    assert_eq!(last[1]["rmse"], shared[2]["rmse"]);
    // A job without radius layers has an empty layers.csv (its header).
    let other = own[0]["job"].as_str().unwrap();
    let (_, csv) = s.get(&format!("/v1/jobs/{other}/layers"));
    assert_eq!(String::from_utf8(csv).unwrap().lines().count(), 1);

    // The table's CSV names the layer of each point.
    let sid = layered["id"].as_str().unwrap();
    let (_, csv) = s.get(&format!("/v1/sweeps/{sid}?format=csv"));
    let csv = String::from_utf8(csv).unwrap();
    assert!(
        csv.lines().next().unwrap().ends_with(",rmse,layer"),
        "{csv}"
    );
    assert!(csv.lines().nth(2).unwrap().ends_with(",radius0"), "{csv}");
}

/// Creates the sweep `spec`; its distinct jobs.
fn jobs_of(s: &TestServer, spec: Value) -> std::collections::BTreeSet<String> {
    let (code, table) = s.post_json("/v1/sweeps", &spec);
    assert_eq!(code, 201, "{table}");
    let ids = rows(&table)
        .iter()
        .map(|r| r["job"].as_str().unwrap().to_string());
    ids.collect()
}

#[test]
fn radius_sweeps_that_cannot_share_a_job_run_separately() {
    let s = TestServer::start(None);
    let setup = scene_and_reference(&s);
    // A time halt: a job with layers would run fewer iterations than each separate job.
    let timed = jobs_of(
        &s,
        json!({"base": {"scene": setup.0, "algorithm": "vcm", "halt": {"time_s": 0.2}},
               "grid": {"params.radius": RADII}}),
    );
    assert_eq!(timed.len(), 3, "{timed:?}");
    // An algorithm without radius layers (sppm): separate jobs.
    let sppm = jobs_of(
        &s,
        json!({"base": {"scene": setup.0, "algorithm": "sppm", "halt": {"iterations": 1}},
               "grid": {"params.radius": RADII}}),
    );
    assert_eq!(sppm.len(), 3, "{sppm:?}");
    for id in sppm.iter().chain(&timed) {
        assert_eq!(s.wait_job(id)["state"], "completed");
    }
}

/// A sweep over a volume radius (`upbp`'s beam x beam 1D radius, the job's `radius`
/// fixed) with `selection: all`: one job whose layers repeat the radius and list the
/// beam radii, each point with the error of a separate job. With the default
/// `selection: auto`, adaptive for each separate job but not for one with layers, the
/// points stay separate jobs.
#[test]
fn a_beam_radius_sweep_is_one_upbp_job() {
    let s = TestServer::start(None);
    let setup = upload_with_reference(&s, foggy_scene(12));
    let params = json!({"radius": 0.05, "light_paths": 0.5});
    let key = "params.bb1d_radius";
    let auto = sweep_over(
        &s,
        &setup,
        (json!({"algorithm": "upbp", "params": params}), key),
        json!({}),
    );
    let jobs: std::collections::BTreeSet<_> = rows(&auto)
        .iter()
        .map(|r| r["job"].as_str().unwrap())
        .collect();
    assert_eq!(jobs.len(), rows(&auto).len(), "{auto}");
    let mut params = params;
    params["selection"] = json!("all");
    let base = json!({"algorithm": "upbp", "params": params});
    let layered = sweep_over(&s, &setup, (base.clone(), key), json!({}));
    let separate = sweep_over(&s, &setup, (base, key), json!({"radius_layers": false}));
    let (shared, own) = (rows(&layered), rows(&separate));
    let job = shared[0]["job"].as_str().unwrap();
    assert!(shared.iter().all(|r| r["job"] == job), "{layered}");
    let (_, status) = s.get_json(&format!("/v1/jobs/{job}"));
    let radii = &status["settings"]["radii"];
    assert_eq!(radii.as_array().map(Vec::len), Some(2), "{status}");
    for (a, b) in shared.iter().zip(own) {
        let (x, y) = (a["rmse"].as_f64().unwrap(), b["rmse"].as_f64().unwrap());
        assert!((x - y).abs() <= 1e-4 * y, "{}: {x} against {y}", a["point"]);
    }
    let r: Vec<f64> = own.iter().map(|r| r["rmse"].as_f64().unwrap()).collect();
    assert!(r[0] != r[1] && r[1] != r[2], "{r:?}");
}
