//! Issue 36: a job whose estimated peak memory exceeds the server's budget
//! (`--max-job-mib`) is refused when submitted, with the figure, the budget and the
//! parameter behind it; so is a sweep with such a job, which then creates none. A job
//! stored before the budget was lowered fails when it would start, saying why.

mod server_common;

use caustic::job::{JobSpec, Service, ServiceConfig};
use serde_json::{json, Value};
use server_common::{tiny_scene, TestServer};

/// The job from the issue: `vpl` with 2^24 light paths per iteration on a 256 x 256
/// film (1.6 GB resident when it ran).
fn heavy_job(scene: &str) -> Value {
    json!({"scene": scene, "algorithm": "vpl",
           "params": {"light_paths": {"count": 16777216}}, "halt": {"spp": 1}})
}

fn upload(s: &TestServer, scene: Value) -> String {
    let (code, info) = s.post_bytes("/v1/scenes", scene.to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    info["id"].as_str().unwrap().to_string()
}

/// The figure in "... needs about 1.9 GiB (...)", in GiB.
fn gib_needed(msg: &str) -> f64 {
    let (_, rest) = msg.split_once("needs about ").expect(msg);
    let mut words = rest.split_whitespace();
    let v: f64 = words.next().unwrap().parse().expect(msg);
    match words.next().unwrap() {
        "GiB" => v,
        "MiB" => v / 1024.0,
        other => panic!("unit {other} in {msg}"),
    }
}

#[test]
fn the_memory_heavy_job_is_refused_with_its_figure() {
    // The test server's budget is 1024 MiB (ServiceConfig::for_tests).
    let s = TestServer::start(None);
    let scene = upload(&s, tiny_scene(256));
    let (code, body) = s.post_json("/v1/jobs", &heavy_job(&scene));
    assert_eq!(code, 400, "{body}");
    assert_eq!(body["error"]["code"], "bad_request", "{body}");
    let msg = body["error"]["message"].as_str().unwrap();
    for part in [
        "vpl: light_paths.count = 16777216",
        "light vertices",
        "1024 MiB",
        "--max-job-mib",
    ] {
        assert!(msg.contains(part), "{part:?} not in {msg}");
    }
    assert!(gib_needed(msg) > 1.0, "{msg}");
    assert_eq!(s.get_json("/v1/jobs").1, json!([]), "nothing was stored");

    // The same job with the default number of paths is well inside the budget.
    let mut light = heavy_job(&scene);
    light["params"] = json!({});
    let (code, job) = s.post_json("/v1/jobs", &light);
    assert_eq!(code, 201, "{job}");
    let done = s.wait_job(job["id"].as_str().unwrap());
    assert_eq!(done["state"], "completed", "{done}");
}

#[test]
fn a_sweep_with_a_job_over_the_budget_creates_none() {
    let s = TestServer::start(None);
    let scene = upload(&s, tiny_scene(256));
    let (code, body) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": scene, "algorithm": "vpl", "halt": {"spp": 1}},
                "grid": {"params.light_paths": [{"count": 1024}, {"count": 16777216}]}}),
    );
    assert_eq!(code, 400, "{body}");
    let msg = body["error"]["message"].as_str().unwrap();
    assert!(msg.contains("light_paths.count = 16777216"), "{msg}");
    assert_eq!(
        s.get_json("/v1/jobs").1,
        json!([]),
        "no job of the sweep was stored"
    );
}

#[test]
fn a_stored_job_above_a_lowered_budget_fails_when_it_would_start() {
    let dir = tempfile::tempdir().unwrap();
    let config = ServiceConfig::for_tests(dir.path());
    let svc = Service::start(config.clone()).unwrap();
    let scene = svc
        .upload_scene(tiny_scene(32).to_string().as_bytes())
        .unwrap()
        .id;
    let spec: JobSpec = serde_json::from_value(json!({"scene": scene, "algorithm": "vpl",
        "params": {"light_paths": {"count": 65536}}, "halt": {"spp": 100000}}))
    .unwrap();
    let id = svc.submit(spec).unwrap().id;
    svc.pause(&id).unwrap();
    svc.shutdown();
    drop(svc);

    // The same data directory under a budget of 1 MiB: the paused job is kept as it
    // was, and fails with the reason when resumed.
    let svc = Service::start(ServiceConfig {
        max_job: 1 << 20,
        ..config
    })
    .unwrap();
    assert_eq!(svc.get_job(&id).unwrap().state.as_str(), "paused");
    svc.resume(&id).unwrap();
    let start = std::time::Instant::now();
    let job = loop {
        let job = svc.get_job(&id).unwrap();
        if job.state.is_terminal() {
            break job;
        }
        assert!(start.elapsed().as_secs() < 60, "job never ended: {job:?}");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert_eq!(job.state.as_str(), "failed", "{job:?}");
    let why = job.error.unwrap_or_default();
    assert!(
        why.contains("light_paths.count = 65536") && why.contains("1 MiB per job"),
        "{why}"
    );
    svc.shutdown();
}
