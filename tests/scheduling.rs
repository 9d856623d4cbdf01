//! Scheduling: short jobs are not starved by long ones, priorities order the queue,
//! and a sweep shares one compiled scene.

mod server_common;
use serde_json::json;
use server_common::*;
use std::time::{Duration, Instant};

#[test]
fn a_long_job_does_not_block_a_short_one_of_equal_priority() {
    let s = TestServer::start(None);
    let (_, long) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 100000}}),
    );
    let long = long["id"].as_str().unwrap().to_string();
    s.wait_state(&long, "running");
    let t = Instant::now();
    let (_, short) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 3}}),
    );
    let short = s.wait_job(short["id"].as_str().unwrap());
    assert_eq!(short["state"], "completed");
    // Three short iterations interleave with the long job's quarter-second batches.
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "short job took {:?}",
        t.elapsed()
    );
    assert_eq!(
        s.get_json(&format!("/v1/jobs/{long}")).1["state"],
        "running"
    );
    s.post_json(&format!("/v1/jobs/{long}/cancel"), &json!({}));
    s.wait_job(&long);
}

#[test]
fn higher_priority_runs_first_and_lower_still_progresses() {
    let s = TestServer::start(None);
    // Keep the pool busy with a running job, then queue two more.
    let (_, blocker) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 100000}}),
    );
    let blocker = blocker["id"].as_str().unwrap().to_string();
    s.wait_state(&blocker, "running");
    let (_, low) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 2}, "priority": -1}),
    );
    let (_, high) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 2}, "priority": 5}),
    );
    let high = s.wait_job(high["id"].as_str().unwrap());
    assert_eq!(high["state"], "completed");
    // Aging: the low-priority job still completes while the blocker keeps running.
    let low = s.wait_job(low["id"].as_str().unwrap());
    assert_eq!(low["state"], "completed");
    assert!(high["finished_at"].as_f64() <= low["finished_at"].as_f64());
    s.post_json(&format!("/v1/jobs/{blocker}/cancel"), &json!({}));
    s.wait_job(&blocker);
}

#[test]
fn a_sweep_compiles_its_scene_once() {
    let s = TestServer::start(None);
    let (code, table) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": "cornell-box", "halt": {"spp": 1}},
                "grid": {"seed": [1, 2, 3, 4, 5, 6, 7, 8, 9, 10], "params.max_depth": [2, 3]}}),
    );
    assert_eq!(code, 201, "{table}");
    assert_eq!(table["rows"].as_array().unwrap().len(), 20);
    for r in table["rows"].as_array().unwrap() {
        s.wait_job(r["job"].as_str().unwrap());
    }
    let text = String::from_utf8(s.get("/metrics").1).unwrap();
    assert!(
        text.contains("caustic_scene_compilations_total 1\n"),
        "{text}"
    );
    assert!(
        text.contains("caustic_jobs{state=\"completed\"} 20"),
        "{text}"
    );
}
