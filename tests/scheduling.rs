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

fn metric(s: &TestServer, name: &str) -> u64 {
    let (_, body) = s.get("/metrics");
    let text = String::from_utf8(body).unwrap();
    text.lines()
        .find_map(|l| l.strip_prefix(name)?.trim().parse().ok())
        .unwrap_or_else(|| panic!("no {name} in /metrics"))
}

fn iteration(s: &TestServer, id: &str) -> u64 {
    s.get_json(&format!("/v1/jobs/{id}")).1["iteration"]
        .as_u64()
        .unwrap()
}

/// Render state is memory (an 8K job holds gigabytes): only `max_active_jobs` jobs
/// hold it; the next job of equal priority waits queued until one ends.
#[test]
fn at_most_max_active_jobs_are_held_in_memory() {
    let s = TestServer::start_with(None, |c| c.max_active_jobs = 2);
    let long = json!({"scene": "cornell-box", "halt": {"spp": 100000}});
    let ids: Vec<String> = (0..3)
        .map(|_| {
            s.post_json("/v1/jobs", &long).1["id"]
                .as_str()
                .unwrap()
                .into()
        })
        .collect();
    let start = Instant::now();
    while iteration(&s, &ids[0]) == 0 || iteration(&s, &ids[1]) == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "two jobs never ran"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    let third = s.get_json(&format!("/v1/jobs/{}", ids[2])).1;
    assert_eq!(third["state"], "queued", "{third}");
    assert_eq!(third["iteration"], 0, "{third}");
    assert_eq!(metric(&s, "caustic_jobs_held"), 2);
    // When one ends, the waiting job takes its place.
    s.post_json(&format!("/v1/jobs/{}/cancel", ids[0]), &json!({}));
    while iteration(&s, &ids[2]) == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the third never ran"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    for id in &ids[1..] {
        let (code, job) = s.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({}));
        assert_eq!((code, &job["state"]), (200, &json!("cancelled")), "{job}");
    }
    // A cancelled job lets go of its memory when its scheduler notices, just after the
    // request returns: wait for that, within a minute of the cancels (on one busy core
    // the steps above can take most of a minute of their own).
    let cancelled = Instant::now();
    while metric(&s, "caustic_jobs_held") != 0 {
        assert!(
            cancelled.elapsed() < Duration::from_secs(60),
            "cancelled jobs still held: {}; jobs: {}",
            metric(&s, "caustic_jobs_held"),
            s.get_json("/v1/jobs").1
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// With memory full, a job of higher priority sets the lowest one aside: that job is
/// checkpointed, waits, resumes, and still ends with the uninterrupted image.
#[test]
fn a_higher_priority_job_sets_one_aside_which_resumes_bit_identically() {
    let s = TestServer::start_with(None, |c| c.max_active_jobs = 1);
    let spp = 48;
    let (_, low) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": spp}, "seed": 21}),
    );
    let low = low["id"].as_str().unwrap().to_string();
    let start = Instant::now();
    while iteration(&s, &low) == 0 {
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    let (_, high) = s.post_json(
        "/v1/jobs",
        &json!({"scene": "cornell-box", "halt": {"spp": 2}, "priority": 10}),
    );
    let high = s.wait_job(high["id"].as_str().unwrap());
    assert_eq!(high["state"], "completed");
    let low_job = s.wait_job(&low);
    assert_eq!(low_job["state"], "completed");
    assert!(
        iteration(&s, &low) == spp && metric(&s, "caustic_jobs_set_aside_total") == 1,
        "the low job was not set aside: it finished before the high one started?"
    );
    let (_, exr) = s.get(&format!("/v1/jobs/{low}/image.exr"));
    let served = caustic::film::decode_exr(&exr).unwrap();
    let text = caustic::job::scenes::BUILTIN
        .iter()
        .find(|(n, _)| *n == "cornell-box")
        .unwrap()
        .1;
    let direct = direct_render(text, None, &json!({}), 21, spp);
    assert!(direct == served.pixels(), "resumed image differs");
}
