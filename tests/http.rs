//! The REST API end to end: uploads, jobs, SSE, images, logs, control, sweeps, auth and
//! every class of bad input.

mod server_common;
use serde_json::{json, Value};
use server_common::*;
use std::io::{BufRead, BufReader};

fn submit(s: &TestServer, spec: Value) -> String {
    let (code, job) = s.post_json("/v1/jobs", &spec);
    assert_eq!(code, 201, "{job}");
    assert_eq!(job["state"], "queued");
    job["id"].as_str().unwrap().to_string()
}

fn upload_tiny(s: &TestServer, size: u32) -> String {
    let (code, info) = s.post_bytes("/v1/scenes", tiny_scene(size).to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    info["id"].as_str().unwrap().to_string()
}

#[test]
fn upload_is_content_addressed_and_listed_with_builtins() {
    let s = TestServer::start(None);
    let a = upload_tiny(&s, 16);
    let b = upload_tiny(&s, 16);
    assert_eq!(a, b);
    let (code, list) = s.get_json("/v1/scenes");
    assert_eq!(code, 200);
    let ids: Vec<&str> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["id"].as_str().unwrap())
        .collect();
    assert!(
        ids.contains(&"cornell-box") && ids.contains(&a.as_str()),
        "{ids:?}"
    );
    let (code, info) = s.get_json(&format!("/v1/scenes/{a}"));
    assert_eq!((code, info["width"].as_u64()), (200, Some(16)));
    assert_eq!(s.delete(&format!("/v1/scenes/{a}")).0, 204);
    assert_eq!(s.get_json(&format!("/v1/scenes/{a}")).0, 404);
    assert_eq!(s.delete("/v1/scenes/cornell-box").0, 409);
}

/// A scene's `integrator` section is every job's default, so it is checked on upload
/// as a job's settings are: `max_depth` 2^32 uploaded with 201, then every job on
/// the scene was a 400.
#[test]
fn upload_checks_the_scene_integrator_as_a_jobs_settings() {
    let s = TestServer::start(None);
    let upload = |integrator: &Value| {
        let mut v = tiny_scene(8);
        v["integrator"] = integrator.clone();
        s.post_bytes("/v1/scenes", v.to_string().as_bytes())
    };
    let cases = [
        (
            json!({"algorithm": "pt", "max_depth": 1u64 << 32}),
            "integrator.max_depth: invalid value: integer `4294967296`",
        ),
        (
            json!({"algorithm": "vcm", "max_dept": 5}),
            "integrator.max_dept: unknown field",
        ),
        (
            json!({"algorithm": "pt", "max_depth": 0}),
            "max_depth must be at least 1",
        ),
        (json!({"algorithm": "pt2"}), "unknown algorithm \"pt2\""),
    ];
    for (integrator, words) in cases {
        let (code, body) = upload(&integrator);
        assert_eq!(code, 422, "{integrator}: {body}");
        assert_eq!(body["error"]["code"], "invalid_scene", "{body}");
        let message = body["error"]["message"].as_str().unwrap_or_default();
        assert!(message.contains(words), "{integrator}: {message}");
    }
    let (code, info) = upload(&json!({"algorithm": "vcm", "max_depth": 6}));
    assert_eq!(code, 201, "{info}");
    submit(&s, json!({"scene": info["id"], "halt": {"spp": 1}}));
}

/// A refused parameter comes back as the error body's `field`, as the request wrote
/// it: a job's parameter of each algorithm family (`params.*`), a scene's default
/// (`integrator.*`); errors about no one parameter have none. The OpenAPI document
/// describes it.
#[test]
fn refused_parameters_are_named_in_the_error_field() {
    let s = TestServer::start(None);
    let cases = [
        ("pt", json!({"max_depth": 0}), "params.max_depth"),
        ("volpath", json!({"max_depth": "deep"}), "params.max_depth"),
        ("vcm", json!({"pb2d_alpha": 0}), "params.pb2d_alpha"),
        ("upbp", json!({"techniques": []}), "params.techniques"),
        (
            "sppm",
            json!({"medium_radius_factor": 0}),
            "params.medium_radius_factor",
        ),
        ("vpm", json!({"max_photon_mib": 0}), "params.max_photon_mib"),
        ("ppb", json!({"max_beam_mib": 0}), "params.max_beam_mib"),
        (
            "vrl",
            json!({"light_paths": {"count": 0}}),
            "params.light_paths.count",
        ),
        ("normals", json!({"max_depth": 3}), "params.max_depth"),
    ];
    for (alg, params, field) in cases {
        let (code, body) = s.post_json(
            "/v1/jobs",
            &json!({"scene": "cornell-box", "algorithm": alg, "params": params,
                    "halt": {"spp": 1}}),
        );
        assert_eq!(code, 400, "{alg}: {body}");
        assert_eq!(body["error"]["code"], "bad_request", "{body}");
        assert_eq!(body["error"]["field"], field, "{alg}: {body}");
    }
    let mut scene = tiny_scene(8);
    scene["integrator"] = json!({"algorithm": "vpl", "clamp_limit": 1.0});
    let (code, body) = s.post_bytes("/v1/scenes", scene.to_string().as_bytes());
    assert_eq!(code, 422, "{body}");
    assert_eq!(body["error"]["code"], "invalid_scene", "{body}");
    assert_eq!(body["error"]["field"], "integrator.clamp_limit", "{body}");
    let (code, body) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "algorithm": "vcmm", "halt": {"spp": 1}}),
    );
    assert_eq!(code, 400, "{body}");
    assert!(body["error"].get("field").is_none(), "{body}");
    let (_, doc) = s.get_json("/v1/openapi.json");
    let detail = &doc["components"]["schemas"]["ErrorDetail"];
    let about = detail["properties"]["field"]["description"].as_str();
    assert!(
        about.is_some_and(|d| d.contains("params.radius")),
        "{detail}"
    );
}

/// A bundle keeps `scene.json` and the files it names: a megabyte of padding was
/// stored, counted in the scene's size and sent to every worker; now it is dropped
/// with a warning, and what a worker fetches by id still renders.
#[test]
fn bundle_files_the_scene_does_not_name_are_not_stored() {
    let s = TestServer::start(None);
    let mut scene = tiny_scene(8);
    scene["shapes"][1] = json!({"type": "obj", "filename": "m/quad.obj", "material": "m"});
    let text = scene.to_string();
    let quad = b"v -2 -1 -2\nv 2 -1 -2\nv 2 -1 2\nv -2 -1 2\nf 4 3 2 1\n";
    let padding = vec![7u8; 1 << 20];
    let bundle = tar_with(&[
        ("scene.json", text.as_bytes()),
        ("m/quad.obj", quad),
        ("padding.bin", &padding),
        ("m/notes.txt", b"not a mesh"),
    ]);
    let (code, info) = s.post_bytes("/v1/scenes", &bundle);
    assert_eq!(code, 201, "{info}");
    let id = info["id"].as_str().unwrap();
    let (files, bytes) = stored_files(&s.dir.path().join("scenes").join(id));
    assert_eq!(files, ["import-warnings.txt", "m/quad.obj", "scene.json"]);
    assert_eq!(info["size_bytes"].as_u64(), Some(bytes));
    assert_eq!(
        info["warnings"],
        json!([
            "not stored: 2 files of the bundle that the scene does not name, 1.0 MiB in all: \
                m/notes.txt (10 B), padding.bin (1.0 MiB)"
        ])
    );
    // What a worker fetches by id: the stored files, and they render.
    let pool = std::sync::Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap(),
    );
    let store = caustic::job::scenes::SceneStore::new(s.dir.path(), 1 << 20, pool).unwrap();
    let tar = store.bundle(id).unwrap().expect("an uploaded scene");
    let mut entries: Vec<String> = tar::Archive::new(tar.as_slice())
        .entries()
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.header().entry_type().is_file())
        .map(|e| e.path().unwrap().to_string_lossy().into_owned())
        .collect();
    entries.sort();
    assert_eq!(entries, ["import-warnings.txt", "m/quad.obj", "scene.json"]);
    let job = submit(&s, json!({"scene": id, "halt": {"spp": 1}}));
    assert_eq!(s.wait_job(&job)["state"], "completed");
}

#[test]
fn job_runs_to_completion_with_events_images_and_log() {
    let s = TestServer::start(None);
    let scene = upload_tiny(&s, 32);
    let id = submit(
        &s,
        json!({"scene": scene, "halt": {"spp": 6}, "snapshot_every": {"iterations": 2}, "seed": 3}),
    );
    // Follow the SSE stream to the end.
    let resp = ureq::get(&format!("{}/v1/jobs/{id}/events", s.url))
        .call()
        .unwrap();
    assert_eq!(resp.header("content-type"), Some("text/event-stream"));
    let mut events = Vec::new();
    for line in BufReader::new(resp.into_reader()).lines() {
        let line = line.unwrap();
        if let Some(e) = line.strip_prefix("event: ") {
            events.push(e.to_string());
        }
    }
    assert_eq!(
        events.last().map(String::as_str),
        Some("done"),
        "{events:?}"
    );
    assert!(
        events.iter().filter(|e| *e == "snapshot").count() >= 3,
        "{events:?}"
    );
    let job = s.wait_job(&id);
    assert_eq!(job["state"], "completed");
    assert_eq!(job["iteration"], 6);
    assert_eq!(job["dropped"], 0);

    let (code, png) = s.get(&format!("/v1/jobs/{id}/preview.png?exposure=1"));
    assert_eq!(code, 200);
    assert_eq!(&png[1..4], b"PNG");
    let (code, exr) = s.get(&format!("/v1/jobs/{id}/image.exr"));
    assert_eq!(code, 200);
    let img = caustic::film::decode_exr(&exr).unwrap();
    assert_eq!(img.size(), (32, 32));
    assert!(img.mean().x > 0.0);

    let (_, snaps) = s.get_json(&format!("/v1/jobs/{id}/snapshots"));
    let its: Vec<u64> = snaps
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["iteration"].as_u64().unwrap())
        .collect();
    assert_eq!(its, vec![2, 4, 6]);
    assert_eq!(s.get(&format!("/v1/jobs/{id}/snapshots/4.png")).0, 200);
    assert_eq!(s.get(&format!("/v1/jobs/{id}/snapshots/5.png")).0, 404);

    let (_, csv) = s.get(&format!("/v1/jobs/{id}/log"));
    let csv = String::from_utf8(csv).unwrap();
    assert!(
        csv.starts_with("iteration,elapsed_s,samples,rmse,rel_mse,dropped"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 4);
    let (code, b) = respond(
        ureq::get(&format!("{}/v1/jobs/{id}/log", s.url))
            .set("accept", "application/json")
            .call(),
    );
    let rows: Value = serde_json::from_slice(&b).unwrap();
    assert_eq!((code, rows.as_array().unwrap().len()), (200, 3));

    // The image equals a direct render of the same settings: the server adds nothing.
    let file = caustic::scene::load::parse_scene(&tiny_scene(32).to_string()).unwrap();
    let scene = caustic::scene::Scene::compile(&file, None).unwrap();
    let settings =
        caustic::integrator::Settings::resolve(Some("pt"), None, &Default::default()).unwrap();
    let out = caustic::integrator::drive::render(
        &scene,
        settings.build().as_ref(),
        3,
        caustic::integrator::drive::Halt {
            iterations: Some(6),
            ..caustic::integrator::drive::Halt::default()
        },
        |_, _| {},
    );
    assert_eq!(out.image().pixels(), img.pixels());
}

#[test]
fn pause_resume_cancel_and_delete() {
    let s = TestServer::start(None);
    let id = submit(&s, json!({"scene": "cornell-box", "halt": {"spp": 100000}}));
    s.wait_state(&id, "running");
    // The answer shows the job after the transition (the call waits for the batch).
    let (code, paused) = s.post_json(&format!("/v1/jobs/{id}/pause"), &json!({}));
    assert_eq!(code, 200);
    assert_eq!(paused["state"], "paused", "{paused}");
    assert_eq!(s.get_json(&format!("/v1/jobs/{id}")).1["state"], "paused");
    assert_eq!(
        s.post_json(&format!("/v1/jobs/{id}/pause"), &json!({})).0,
        409
    );
    let it = s.get_json(&format!("/v1/jobs/{id}")).1["iteration"]
        .as_u64()
        .unwrap();
    assert_eq!(
        s.post_json(&format!("/v1/jobs/{id}/resume"), &json!({})).0,
        200
    );
    assert_eq!(
        s.post_json(&format!("/v1/jobs/{id}/resume"), &json!({})).0,
        409
    );
    s.wait_state(&id, "running");
    let (code, cancelled) = s.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({}));
    assert_eq!(code, 200);
    assert_eq!(cancelled["state"], "cancelled", "{cancelled}");
    let job = s.wait_job(&id);
    assert_eq!(job["state"], "cancelled");
    assert!(job["iteration"].as_u64().unwrap() >= it);
    let (code, err) = s.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({}));
    assert_eq!(code, 409);
    assert_eq!(err["error"]["code"], "conflict");
    assert_eq!(s.delete(&format!("/v1/jobs/{id}")).0, 204);
    assert_eq!(s.get_json(&format!("/v1/jobs/{id}")).0, 404);
    assert!(!s.dir.path().join("jobs").join(&id).exists());
}

#[test]
fn sweep_expands_runs_and_tabulates() {
    let s = TestServer::start(None);
    let scene = upload_tiny(&s, 16);
    let (code, table) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": scene, "halt": {"spp": 1}},
                "grid": {"algorithm": ["pt", "albedo"], "halt.spp": [1, 2]}, "name": "t"}),
    );
    assert_eq!(code, 201, "{table}");
    let sid = table["id"].as_str().unwrap().to_string();
    let rows = table["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for r in rows {
        s.wait_job(r["job"].as_str().unwrap());
    }
    let (_, table) = s.get_json(&format!("/v1/sweeps/{sid}"));
    for r in table["rows"].as_array().unwrap() {
        assert_eq!(r["state"], "completed");
        assert_eq!(r["iterations"], r["point"]["halt.spp"]);
    }
    let (_, jobs) = s.get_json(&format!("/v1/jobs?sweep={sid}&state=completed"));
    assert_eq!(jobs.as_array().unwrap().len(), 4);
    let (code, csv) = s.get(&format!("/v1/sweeps/{sid}?format=csv"));
    let csv = String::from_utf8(csv).unwrap();
    assert_eq!(code, 200);
    assert!(csv.starts_with("job,algorithm,halt.spp,state"), "{csv}");
    assert_eq!(csv.lines().count(), 5);
}

/// The natural sweep of the many-light methods: every pair sampler of `vrl` on one
/// scene, each job rendering with the sampler its grid point names.
#[test]
fn a_sweep_over_the_vrl_sampler_renders_every_sampler() {
    let s = TestServer::start(None);
    let (code, info) = s.post_bytes("/v1/scenes", foggy_scene(12).to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    let samplers = [
        "uniform",
        "exponential",
        "uniform_equiangular",
        "joint_simple",
        "joint_advanced",
    ];
    let (code, table) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": info["id"], "algorithm": "vrl", "halt": {"spp": 3},
                         "params": {"light_paths": {"count": 8}}},
                "grid": {"params.sampler": samplers}}),
    );
    assert_eq!(code, 201, "{table}");
    let sid = table["id"].as_str().unwrap().to_string();
    let mut seen = Vec::new();
    for r in table["rows"].as_array().unwrap() {
        let id = r["job"].as_str().unwrap();
        s.wait_job(id);
        let (_, job) = s.get_json(&format!("/v1/jobs/{id}"));
        assert_eq!(job["state"], "completed", "{job}");
        // The resolved settings the integrator was built from, not just the request.
        let used = &job["settings"]["sampler"]["type"];
        assert_eq!(used, &r["point"]["params.sampler"], "{job}");
        let (code, exr) = s.get(&format!("/v1/jobs/{id}/image.exr"));
        assert_eq!(code, 200);
        let img = caustic::film::decode_exr(&exr).unwrap();
        let sum: f32 = img.pixels().iter().map(|p| p.x + p.y + p.z).sum();
        assert!(sum.is_finite() && sum > 0.0, "{id}: image sum {sum}");
        seen.push(used.as_str().unwrap().to_string());
    }
    seen.sort();
    let mut want: Vec<String> = samplers.iter().map(|x| x.to_string()).collect();
    want.sort();
    assert_eq!(seen, want);
    let (_, csv) = s.get(&format!("/v1/sweeps/{sid}?format=csv"));
    let csv = String::from_utf8(csv).unwrap();
    assert!(csv.starts_with("job,params.sampler,state"), "{csv}");
}

/// The natural sweep of `upbp`: technique sets against a beam radius. Every job
/// renders with the set and radius of its grid point (checked in the resolved
/// settings) and gives a finite, lit image.
#[test]
fn a_sweep_over_upbp_technique_sets_and_radii() {
    let s = TestServer::start(None);
    let (code, info) = s.post_bytes("/v1/scenes", foggy_scene(12).to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    let sets = json!([
        ["bpt"],
        ["surf", "pb2d"],
        ["bpt", "surf", "pp3d", "pb2d", "bb1d"]
    ]);
    let (code, table) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": info["id"], "algorithm": "upbp", "halt": {"spp": 2},
                         "params": {"light_paths": 0.5}},
                "grid": {"params.techniques": sets, "params.pb2d_radius_factor": [0.01, 0.05]}}),
    );
    assert_eq!(code, 201, "{table}");
    let rows = table["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 6, "{table}");
    for r in rows {
        let id = r["job"].as_str().unwrap();
        s.wait_job(id);
        let (_, job) = s.get_json(&format!("/v1/jobs/{id}"));
        assert_eq!(job["state"], "completed", "{job}");
        let used = &job["settings"];
        assert_eq!(used["techniques"], r["point"]["params.techniques"], "{job}");
        // f32 settings: equal to the requested value in single precision.
        let asked = r["point"]["params.pb2d_radius_factor"].as_f64().unwrap();
        let got = used["pb2d_radius_factor"].as_f64().unwrap();
        assert_eq!(got as f32, asked as f32, "{job}");
        let (code, exr) = s.get(&format!("/v1/jobs/{id}/image.exr"));
        assert_eq!(code, 200);
        let img = caustic::film::decode_exr(&exr).unwrap();
        let sum: f32 = img.pixels().iter().map(|p| p.x + p.y + p.z).sum();
        assert!(sum.is_finite() && sum > 0.0, "{id}: image sum {sum}");
    }
}

#[test]
fn bearer_token_guards_everything_but_health() {
    let s = TestServer::start(Some("s3cret"));
    let (code, err) = s.get_json("/v1/jobs");
    assert_eq!(code, 401);
    assert_eq!(err["error"]["code"], "unauthorized");
    assert_eq!(s.get("/metrics").0, 401);
    assert_eq!(s.get("/healthz").0, 200);
    let (code, _) = respond(
        ureq::get(&format!("{}/v1/jobs", s.url))
            .set("authorization", "Bearer s3cret")
            .call(),
    );
    assert_eq!(code, 200);
    let (code, _) = respond(
        ureq::get(&format!("{}/v1/jobs", s.url))
            .set("authorization", "Bearer wrong")
            .call(),
    );
    assert_eq!(code, 401);
}

#[test]
fn bad_input_gets_clear_4xx_json_and_running_jobs_are_undisturbed() {
    let s = TestServer::start(None);
    let running = submit(
        &s,
        json!({"scene": "cornell-box", "halt": {"spp": 3}, "seed": 1}),
    );
    let check = |code: u16, body: &Value, want: u16, words: &str| {
        assert_eq!(code, want, "{body}");
        let msg = body["error"]["message"].as_str().unwrap_or_default();
        assert!(msg.contains(words), "expected '{words}' in {body}");
    };
    // Malformed JSON, wrong types, unknown fields.
    let (c, b) = respond(
        ureq::post(&format!("{}/v1/jobs", s.url))
            .set("content-type", "application/json")
            .send_string("{\"scene\": "),
    );
    let b: Value = serde_json::from_slice(&b).unwrap();
    assert_eq!(c, 400, "{b}");
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": "many"}}),
    );
    check(c, &b, 422, "spp");
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 1}, "colour": 1}),
    );
    check(c, &b, 422, "colour");
    // Unknown algorithm and parameter.
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "algorithm": "vcmm", "halt": {"spp": 1}}),
    );
    check(c, &b, 400, "vcmm");
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "params": {"max_dept": 3}, "halt": {"spp": 1}}),
    );
    check(c, &b, 400, "max_dept");
    // No halting rule; target RMSE without a reference.
    let (c, b) = s.post_json("/v1/jobs", &json!({"scene": "cornell-box", "halt": {}}));
    check(c, &b, 400, "halt");
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"target_rmse": 0.1}}),
    );
    check(c, &b, 400, "reference");
    // Unknown ids.
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "0123456789abcdef", "halt": {"spp": 1}}),
    );
    check(c, &b, 404, "scene");
    check(
        s.get_json("/v1/jobs/jnope").0,
        &s.get_json("/v1/jobs/jnope").1,
        404,
        "jnope",
    );
    assert_eq!(s.get_json("/v1/sweeps/s123").0, 404);
    // A scene that does not validate names the field.
    let mut bad = tiny_scene(16);
    bad["shapes"][0]["material"] = json!("glas");
    let (c, b) = s.post_bytes("/v1/scenes", bad.to_string().as_bytes());
    check(c, &b, 422, "shapes[0].material");
    // Huge resolution (the test server caps at 1024).
    let (c, b) = s.post_bytes("/v1/scenes", tiny_scene(2000).to_string().as_bytes());
    assert_eq!(c, 201, "{b}");
    let big = b["id"].as_str().unwrap();
    let (c, b) = s.post_json("/v1/jobs", &json!({"scene": big, "halt": {"spp": 1}}));
    check(c, &b, 400, "limit");
    // Bundles: `..`, absolute paths, symlinks, too large, not an archive.
    let scene = tiny_scene(16).to_string();
    let (c, b) = s.post_bytes(
        "/v1/scenes",
        &tar_with(&[
            ("scene.json", scene.as_bytes()),
            ("../evil.obj", b"v 0 0 0"),
        ]),
    );
    check(c, &b, 400, "../evil.obj");
    let (c, b) = s.post_bytes(
        "/v1/scenes",
        &tar_with(&[("scene.json", scene.as_bytes()), ("/etc/evil", b"x")]),
    );
    check(c, &b, 400, "/etc/evil");
    let (c, b) = s.post_bytes(
        "/v1/scenes",
        &tar_with(&[("scene.json", scene.as_bytes()), ("smoke.VDB", b"x")]),
    );
    // OpenVDB files are read in a child process now (tests/vdb_uploads.rs); one the
    // scene does not name is dropped like any other file, and the warning says so.
    assert_eq!(c, 201, "{b}");
    assert!(b["warnings"].to_string().contains("smoke.VDB"), "{b}");
    let mut tb = tar::Builder::new(Vec::new());
    let mut h = tar::Header::new_gnu();
    h.set_entry_type(tar::EntryType::Symlink);
    h.set_size(0);
    tb.append_link(&mut h, "mesh.obj", "/etc/passwd").unwrap();
    let mut h = tar::Header::new_gnu();
    h.set_size(scene.len() as u64);
    h.set_mode(0o644);
    tb.append_data(&mut h, "scene.json", scene.as_bytes())
        .unwrap();
    let (c, b) = s.post_bytes("/v1/scenes", &tb.into_inner().unwrap());
    check(c, &b, 400, "link");
    // Above the limit: 413 on the declared length, before any of the body is read.
    let huge = format!("POST /v1/scenes HTTP/1.1\r\nContent-Length: {}", 9 << 20);
    let (c, b) = server_common::raw_request(&s.url, &huge, b"");
    check(c, &b, 413, "at most");
    let (c, b) = s.post_bytes("/v1/scenes", b"\x00\x01garbage");
    check(c, &b, 400, "tar");
    // A bundle with a mesh works.
    let mut with_mesh = tiny_scene(16);
    with_mesh["shapes"][1] = json!({"type": "obj", "filename": "m/quad.obj", "material": "m"});
    let text = with_mesh.to_string();
    let obj = b"v -2 -1 -2\nv 2 -1 -2\nv 2 -1 2\nv -2 -1 2\nf 4 3 2 1\n";
    let (c, b) = s.post_bytes(
        "/v1/scenes",
        &tar_with(&[("scene.json", text.as_bytes()), ("m/quad.obj", obj)]),
    );
    assert_eq!(c, 201, "{b}");

    let job = s.wait_job(&running);
    assert_eq!(job["state"], "completed", "{job}");
    assert_eq!(job["iteration"], 3);
}

#[test]
fn metrics_and_openapi_are_served() {
    let s = TestServer::start(None);
    let id = submit(&s, json!({"scene": "cornell-box", "halt": {"spp": 1}}));
    s.wait_job(&id);
    let (code, text) = s.get("/metrics");
    let text = String::from_utf8(text).unwrap();
    assert_eq!(code, 200);
    assert!(
        text.contains("caustic_jobs{state=\"completed\"} 1"),
        "{text}"
    );
    assert!(text.contains("caustic_iterations_total 1"), "{text}");
    assert!(
        text.contains("caustic_scene_compilations_total 1"),
        "{text}"
    );
    let (code, doc) = s.get_json("/v1/openapi.json");
    assert_eq!(code, 200);
    assert!(doc["openapi"].as_str().unwrap().starts_with("3."));
    // Every route the server answers is documented, with its method.
    let routes = [
        ("post", "/v1/scenes"),
        ("get", "/v1/scenes"),
        ("get", "/v1/scenes/{id}"),
        ("delete", "/v1/scenes/{id}"),
        ("post", "/v1/references"),
        ("post", "/v1/jobs"),
        ("get", "/v1/jobs"),
        ("get", "/v1/jobs/{id}"),
        ("delete", "/v1/jobs/{id}"),
        ("post", "/v1/jobs/{id}/cancel"),
        ("post", "/v1/jobs/{id}/pause"),
        ("post", "/v1/jobs/{id}/resume"),
        ("get", "/v1/jobs/{id}/preview.png"),
        ("get", "/v1/jobs/{id}/image.exr"),
        ("get", "/v1/jobs/{id}/snapshots"),
        ("get", "/v1/jobs/{id}/snapshots/{file}"),
        ("get", "/v1/jobs/{id}/log"),
        ("get", "/v1/jobs/{id}/layers"),
        ("get", "/v1/jobs/{id}/events"),
        ("post", "/v1/sweeps"),
        ("get", "/v1/sweeps/{id}"),
        ("get", "/metrics"),
        ("post", "/v1/jobs/{id}/retry"),
        ("get", "/v1/openapi.json"),
        ("get", "/v1/workers"),
        ("get", "/v1/algorithms"),
        ("get", "/healthz"),
    ];
    for (method, path) in routes {
        let op = &doc["paths"][path][method];
        assert!(op.is_object(), "{method} {path} undocumented");
        // Behind a token everything but /healthz answers 401; everything may fail.
        let needs_token = path != "/healthz";
        assert_eq!(
            op["responses"]["401"].is_object(),
            needs_token,
            "{method} {path}"
        );
        assert!(op["responses"]["500"].is_object(), "{method} {path}");
        if method == "post" {
            for code in ["413", "415", "507"] {
                assert!(op["responses"][code].is_object(), "{method} {path} {code}");
            }
        }
    }
    assert_eq!(
        doc["components"]["securitySchemes"]["bearer"]["scheme"],
        "bearer"
    );
    assert!(doc["components"]["schemas"]["JobSpec"]["properties"]["halt"].is_object());
}

#[test]
fn algorithms_are_listed_with_their_defaults() {
    let s = TestServer::start(None);
    let (code, list) = s.get_json("/v1/algorithms");
    assert_eq!(code, 200, "{list}");
    let names: Vec<&str> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, caustic::integrator::ALGORITHMS);
    // Each says in a line what it computes, as the registry does.
    for (a, row) in list
        .as_array()
        .unwrap()
        .iter()
        .zip(caustic::integrator::registry::TABLE)
    {
        let about = a["about"].as_str().unwrap();
        assert!(!about.is_empty() && about == row.about, "{a}");
    }
    for name in caustic::integrator::ALGORITHMS {
        // Every algorithm's defaults resolve (the list would show none otherwise).
        caustic::integrator::Settings::defaults(name).unwrap();
    }
    let pt = &list[0]["params"];
    assert_eq!(pt["max_depth"], 64, "{pt}");
    assert!(list[2]["params"]["techniques"].is_array(), "{list}");
    // The defaults are what a job without parameters runs with (on a scene that
    // sets none).
    let scene = upload_tiny(&s, 8);
    let id = submit(
        &s,
        json!({"scene": scene, "algorithm": "pt", "halt": {"spp": 1}}),
    );
    let (_, job) = s.get_json(&format!("/v1/jobs/{id}"));
    for (k, v) in pt.as_object().unwrap() {
        assert_eq!(&job["settings"][k], v, "{k}: {job}");
    }
}

#[test]
fn zip_bundles_upload_and_unsafe_zip_entries_are_refused() {
    use std::io::Write;
    let s = TestServer::start(None);
    let zip_with = |entries: &[(&str, &[u8])]| {
        let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        for (name, data) in entries {
            w.start_file(*name, zip::write::SimpleFileOptions::default())
                .unwrap();
            w.write_all(data).unwrap();
        }
        w.finish().unwrap().into_inner()
    };
    let mut scene = tiny_scene(16);
    scene["shapes"][1] = json!({"type": "obj", "filename": "m/quad.obj", "material": "m"});
    let text = scene.to_string();
    let obj: &[u8] = b"v -2 -1 -2\nv 2 -1 -2\nv 2 -1 2\nv -2 -1 2\nf 4 3 2 1\n";
    let (c, b) = s.post_bytes(
        "/v1/scenes",
        &zip_with(&[("scene.json", text.as_bytes()), ("m/quad.obj", obj)]),
    );
    assert_eq!(c, 201, "{b}");
    assert_eq!(b["shapes"], 2);
    let (c, b) = s.post_bytes(
        "/v1/scenes",
        &zip_with(&[("scene.json", text.as_bytes()), ("../m/quad.obj", obj)]),
    );
    assert_eq!(c, 400, "{b}");
    assert!(
        b["error"]["message"]
            .as_str()
            .unwrap()
            .contains("../m/quad.obj"),
        "{b}"
    );
}

#[test]
fn target_rmse_halts_a_job_against_a_reference() {
    let s = TestServer::start(None);
    let scene = upload_tiny(&s, 24);
    let reference = submit(&s, json!({"scene": scene, "halt": {"spp": 64}, "seed": 1}));
    assert_eq!(s.wait_job(&reference)["state"], "completed");
    // One iteration gives an RMSE near 0.011 here; 0.004 takes several, and the cap is
    // far above that.
    let id = submit(
        &s,
        json!({"scene": scene, "halt": {"spp": 100000, "target_rmse": 0.004},
               "reference": {"job": reference}, "snapshot_every": {"iterations": 1}, "seed": 2}),
    );
    let job = s.wait_job(&id);
    assert_eq!(job["state"], "completed", "{job}");
    let rmse = job["last_rmse"].as_f64().unwrap();
    assert!(rmse <= 0.004, "{job}");
    assert!(job["iteration"].as_u64().unwrap() < 100000);
    // The log carries the error at every snapshot, falling overall.
    let (code, b) = respond(
        ureq::get(&format!("{}/v1/jobs/{id}/log", s.url))
            .set("accept", "application/json")
            .call(),
    );
    let rows: Value = serde_json::from_slice(&b).unwrap();
    assert_eq!(code, 200);
    let first = rows[0]["rmse"].as_f64().unwrap();
    assert!(
        rows.as_array().unwrap().len() > 1 && first > 0.004,
        "{rows}"
    );
    // A reference of the wrong size is refused up front.
    let other = upload_tiny(&s, 16);
    let (c, b) = s.post_json(
        "/v1/jobs",
        &json!({"scene": other, "halt": {"spp": 1}, "reference": {"job": reference}}),
    );
    assert_eq!(c, 400, "{b}");
}

/// `halt.noise` stops a job by its own estimated error, with no reference; the log
/// carries the estimate at every snapshot, the status its square root, and the EXRs
/// a variance layer on request.
#[test]
fn a_noise_target_halts_a_job_without_a_reference() {
    let s = TestServer::start(None);
    let scene = upload_tiny(&s, 24);
    let id = submit(
        &s,
        json!({"scene": scene, "halt": {"spp": 100000, "noise": 0.02}, "seed": 3,
               "snapshot_every": {"iterations": 4}, "variance_layer": true}),
    );
    let job = s.wait_job(&id);
    assert_eq!(job["state"], "completed", "{job}");
    let noise = job["noise"].as_f64().unwrap();
    let it = job["iteration"].as_u64().unwrap();
    assert!(noise <= 0.02 && (16..100000).contains(&it), "{job}");
    let (code, b) = respond(
        ureq::get(&format!("{}/v1/jobs/{id}/log", s.url))
            .set("accept", "application/json")
            .call(),
    );
    assert_eq!(code, 200);
    let rows: Value = serde_json::from_slice(&b).unwrap();
    let rows = rows.as_array().unwrap();
    let last = rows.last().unwrap();
    assert_eq!(last["iteration"].as_u64(), Some(it));
    let est = last["est_rel_mse"].as_f64().unwrap();
    // The log holds seven significant digits.
    assert!(
        (est.sqrt() - noise).abs() <= 1e-6 * noise,
        "{last} vs {job}"
    );
    // No reference, so no measured error; the estimate falls as iterations add up.
    assert!(last["rmse"].is_null() && last["est_rmse"].as_f64().unwrap() > 0.0);
    let first = rows[0]["est_rel_mse"].as_f64().unwrap();
    assert!(first > est, "{rows:?}");
    let (code, exr) = s.get(&format!("/v1/jobs/{id}/image.exr"));
    assert_eq!(code, 200);
    let variance = caustic::film::decode_exr_layer(&exr, "variance").unwrap();
    let mean_var = variance.mean().element_sum() as f64 / 3.0;
    let est_rmse = last["est_rmse"].as_f64().unwrap();
    assert!(
        (mean_var / est_rmse.powi(2) - 1.0).abs() < 1e-4,
        "{mean_var} vs {est_rmse}"
    );
}

// ---------------------------------------------------------------------------------
// Messages as a user meets them (issue 36)

/// Every non-integer number under `v`.
fn fractions(v: &Value, out: &mut Vec<f64>) {
    match v {
        Value::Number(n) if !(n.is_u64() || n.is_i64()) => out.push(n.as_f64().unwrap()),
        Value::Array(a) => a.iter().for_each(|v| fractions(v, out)),
        Value::Object(m) => m.values().for_each(|v| fractions(v, out)),
        _ => {}
    }
}

/// Each setting is an f32: its JSON is the f32's shortest decimal (0.7, not
/// 0.699999988079071), in the algorithm list and in a job's settings alike.
#[test]
fn settings_are_written_as_their_shortest_decimals() {
    let s = TestServer::start(None);
    let (_, list) = s.get_json("/v1/algorithms");
    let scene = upload_tiny(&s, 8);
    let id = submit(
        &s,
        json!({"scene": scene, "algorithm": "sppm", "halt": {"spp": 1}, "params": {"alpha": 0.7}}),
    );
    let (_, job) = s.get_json(&format!("/v1/jobs/{id}"));
    assert_eq!(job["settings"]["alpha"], json!(0.7), "{job}");
    let mut numbers = Vec::new();
    fractions(&list, &mut numbers);
    fractions(&job["settings"], &mut numbers);
    assert!(numbers.len() > 20, "{numbers:?}");
    for x in numbers {
        let shortest: f64 = (x as f32).to_string().parse().unwrap();
        assert_eq!(x, shortest, "{x} is not the shortest decimal of its f32");
    }
}

/// A 422 (JSON of the wrong shape) has its own code, not a 400's.
#[test]
fn unprocessable_bodies_have_their_own_code() {
    let s = TestServer::start(None);
    for body in [
        json!({"scene": "cornell-box", "halt": {"spp": 1}, "bogus": 1}),
        json!({"scene": "cornell-box", "halt": {"spp": -1}}),
        json!({"scene": 5, "halt": {"spp": 1}}),
    ] {
        let (code, err) = s.post_json("/v1/jobs", &body);
        assert_eq!(code, 422, "{body}: {err}");
        assert_eq!(err["error"]["code"], "invalid_body", "{body}: {err}");
    }
    let (code, err) = s.post_json("/v1/sweeps", &json!({"base": 1, "grid": {}}));
    assert_eq!(
        (code, &err["error"]["code"]),
        (422, &json!("invalid_body")),
        "{err}"
    );
    // A malformed body stays a 400.
    let (code, err) = raw_request(
        &s.url,
        "POST /v1/jobs HTTP/1.1\r\ncontent-type: application/json\r\ncontent-length: 2",
        b"{x",
    );
    assert_eq!(
        (code, &err["error"]["code"]),
        (400, &json!("bad_request")),
        "{err}"
    );
}

/// Numbers too large for their fields are named as written, never as `inf`.
#[test]
fn numbers_out_of_range_are_named_as_written() {
    let s = TestServer::start(None);
    let post = |path: &str, body: &str| {
        let (code, err) = respond(
            ureq::post(&format!("{}{path}", s.url))
                .set("content-type", "application/json")
                .send_string(body),
        );
        let err: Value = serde_json::from_slice(&err).unwrap();
        (code, err["error"]["message"].as_str().unwrap().to_string())
    };
    let cases = [
        (
            r#"{"scene": "cornell-box", "halt": {"time_s": 1e999}}"#,
            "halt.time_s: number 1e999 is out of range",
        ),
        (
            r#"{"scene": "cornell-box", "halt": {"spp": 1}, "params": {"max_depth": 1e400}}"#,
            "params.max_depth: number 1e400 is out of range",
        ),
        (
            r#"{"scene": "cornell-box", "algorithm": "sppm", "halt": {"spp": 1}, "params": {"alpha": 1e39}}"#,
            "params.alpha: number 1e39 is out of range",
        ),
    ];
    for (body, says) in cases {
        let (code, message) = post("/v1/jobs", body);
        assert!(code == 400 || code == 422, "{body}: {code} {message}");
        assert!(message.contains(says), "{body}: {message}");
    }
    // In a scene: beyond f64, and beyond the f32 of its field.
    for (fov, says) in [
        ("1e400", "number 1e400 is out of range"),
        ("2.5e39", "number 2.5e39 is out of range"),
    ] {
        let scene = tiny_scene(8)
            .to_string()
            .replace("\"fov\":45", &format!("\"fov\":{fov}"));
        assert!(scene.contains(fov), "{scene}");
        let (code, err) = s.post_bytes("/v1/scenes", scene.as_bytes());
        let message = err["error"]["message"].as_str().unwrap();
        assert_eq!(code, 422, "{message}");
        assert!(
            message.contains(&format!("camera.fov: {says}")),
            "{message}"
        );
        assert!(!message.contains("inf"), "{message}");
    }
}

/// A job that stopped before its end keeps no estimate of the time left.
#[test]
fn stopped_jobs_have_no_eta() {
    let s = TestServer::start(None);
    let scene = upload_tiny(&s, 16);
    let id = submit(&s, json!({"scene": scene, "halt": {"time_s": 600}}));
    let start = std::time::Instant::now();
    while s.get_json(&format!("/v1/jobs/{id}")).1["eta_s"].is_null() {
        assert!(start.elapsed().as_secs() < 60, "no eta while running");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let (_, paused) = s.post_json(&format!("/v1/jobs/{id}/pause"), &json!({}));
    assert_eq!(paused["state"], "paused");
    assert!(paused.get("eta_s").is_none(), "{paused}");
    s.post_json(&format!("/v1/jobs/{id}/resume"), &json!({}));
    s.wait_state(&id, "running");
    let (_, cancelled) = s.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({}));
    assert_eq!(cancelled["state"], "cancelled");
    assert!(cancelled.get("eta_s").is_none(), "{cancelled}");
    let (_, list) = s.get_json("/v1/jobs?state=cancelled");
    assert!(list[0].get("eta_s").is_none(), "{list}");
    let done = submit(&s, json!({"scene": scene, "halt": {"spp": 1}}));
    assert!(s.wait_job(&done).get("eta_s").is_none());
}
