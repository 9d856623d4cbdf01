//! What a job leaves on disk: a bounded number of snapshots unless asked for all, one
//! copy of its final image, no checkpoint unless asked; and the server's retention
//! policy removes finished jobs, never others.

mod server_common;
use serde_json::{json, Value};
use server_common::*;
use std::path::Path;

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn snapshot_iterations(dir: &Path) -> Vec<u64> {
    let mut v: Vec<u64> = files(&dir.join("snapshots"))
        .iter()
        .filter_map(|n| n.strip_suffix(".exr")?.parse().ok())
        .collect();
    v.sort_unstable();
    v
}

fn run(s: &TestServer, scene: &str, extra: Value) -> String {
    let mut spec =
        json!({"scene": scene, "halt": {"spp": 40}, "snapshot_every": {"iterations": 1}});
    for (k, v) in extra.as_object().unwrap() {
        spec[k] = v.clone();
    }
    let (code, job) = s.post_json("/v1/jobs", &spec);
    assert_eq!(code, 201, "{job}");
    let id = job["id"].as_str().unwrap().to_string();
    assert_eq!(s.wait_job(&id)["state"], "completed");
    id
}

#[test]
fn snapshots_are_thinned_and_finished_jobs_keep_one_image() {
    let s = TestServer::start(None);
    let (_, info) = s.post_bytes("/v1/scenes", tiny_scene(16).to_string().as_bytes());
    let scene = info["id"].as_str().unwrap().to_string();
    let jobs = s.dir.path().join("jobs");

    let default = run(&s, &scene, json!({}));
    let dir = jobs.join(&default);
    let kept = snapshot_iterations(&dir);
    assert_eq!(kept.len(), 16, "{kept:?}");
    assert_eq!(
        (kept[0], kept[15]),
        (1, 40),
        "first and last stay: {kept:?}"
    );
    // Spread on a log scale: the early part of the run keeps more than a uniform
    // choice would (iterations 1..10 are a quarter of the run).
    assert!(kept.iter().filter(|&&i| i <= 10).count() >= 6, "{kept:?}");
    // PNGs follow their EXRs.
    let pngs = files(&dir.join("snapshots"))
        .iter()
        .filter(|n| n.ends_with(".png"))
        .count();
    assert_eq!(pngs, 16);
    // The log keeps every snapshot's row.
    let (_, log) = s.get_json_accept(&format!("/v1/jobs/{default}/log"));
    assert_eq!(log.as_array().unwrap().len(), 40);
    assert_eq!(
        files(&dir)
            .into_iter()
            .filter(|f| f != "snapshots")
            .collect::<Vec<_>>(),
        ["final.exr", "final.png", "job.json", "log.csv"]
    );
    // The image endpoints serve the final image.
    assert_eq!(s.get(&format!("/v1/jobs/{default}/image.exr")).0, 200);
    assert_eq!(s.get(&format!("/v1/jobs/{default}/preview.png")).0, 200);
    assert_eq!(
        s.get(&format!("/v1/jobs/{default}/preview.png?exposure=1"))
            .0,
        200
    );

    let all = run(
        &s,
        &scene,
        json!({"keep_snapshots": "all", "keep_checkpoint": true}),
    );
    assert_eq!(
        snapshot_iterations(&jobs.join(&all)),
        (1..=40).collect::<Vec<_>>()
    );
    assert!(jobs.join(&all).join("checkpoint.bin").exists());

    let none = run(&s, &scene, json!({"keep_snapshots": 0}));
    assert!(snapshot_iterations(&jobs.join(&none)).is_empty());
    let (code, body) = s.post_json(
        "/v1/jobs",
        &json!({"scene": scene, "halt": {"spp": 1}, "keep_snapshots": "some"}),
    );
    assert_eq!(code, 422, "{body}");
}

#[test]
fn retention_removes_finished_jobs_only() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().to_path_buf();
    // First a server without retention: a completed job, a paused one and a queued one.
    let config = caustic::job::ServiceConfig::for_tests(&data);
    let svc = caustic::job::Service::start(config.clone()).unwrap();
    let spec = |v: Value| serde_json::from_value::<caustic::job::JobSpec>(v).unwrap();
    let done = svc
        .submit(spec(json!({"scene": "cornell-box", "halt": {"spp": 1}})))
        .unwrap()
        .id;
    let paused = svc
        .submit(spec(
            json!({"scene": "cornell-box", "halt": {"spp": 100000}, "priority": -5}),
        ))
        .unwrap()
        .id;
    svc.pause(&paused).unwrap();
    let start = std::time::Instant::now();
    while svc.get_job(&done).unwrap().state != caustic::job::JobState::Completed {
        assert!(start.elapsed().as_secs() < 60);
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    svc.shutdown();
    drop(svc);
    std::thread::sleep(std::time::Duration::from_millis(20));

    // Then one that keeps finished jobs for a millisecond.
    let mut config = config;
    config.retention.max_age_s = Some(1e-3);
    let svc = caustic::job::Service::start(config).unwrap();
    let start = std::time::Instant::now();
    while svc.get_job(&done).is_ok() {
        assert!(start.elapsed().as_secs() < 10, "the finished job was kept");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(!data.join("jobs").join(&done).exists());
    assert_eq!(
        svc.get_job(&paused).unwrap().state,
        caustic::job::JobState::Paused
    );
    assert!(data.join("jobs").join(&paused).join("job.json").exists());
    svc.shutdown();
}
