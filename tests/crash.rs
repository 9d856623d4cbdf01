//! A server killed at each write of a job's last snapshot (and of its first) restarts
//! and finishes the job as if nothing happened: the same iteration count, one log row
//! per snapshot, the same image bit for bit. The kill is an abort at a failpoint
//! (`CAUSTIC_FAILPOINT`, src/job/failpoint.rs), so it lands exactly where chosen.

mod server_common;
use serde_json::{json, Value};
use server_common::{direct_render, respond, tiny_scene, ServerProcess};
use std::path::Path;
use std::time::{Duration, Instant};

const SPP: u64 = 40;
const EVERY: u64 = 10;
const SEED: u64 = 9;

fn start(data: &Path, failpoint: Option<&str>) -> ServerProcess {
    ServerProcess::start_with(data, &["--workers", "1"], |cmd| {
        if let Some(f) = failpoint {
            cmd.env("CAUSTIC_FAILPOINT", f);
        }
    })
}

fn get(url: &str) -> Value {
    let (code, b) = respond(ureq::get(url).call());
    assert_eq!(code, 200, "{}", String::from_utf8_lossy(&b));
    serde_json::from_slice(&b).unwrap()
}

fn post(url: &str, body: &Value) -> Value {
    let (code, b) = respond(ureq::post(url).send_json(body.clone()));
    assert!(code < 300, "{}", String::from_utf8_lossy(&b));
    serde_json::from_slice(&b).unwrap()
}

fn wait_until(what: &str, secs: u64, mut f: impl FnMut() -> bool) {
    let start = Instant::now();
    while !f() {
        assert!(
            start.elapsed() < Duration::from_secs(secs),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The image of an uninterrupted render of the job.
fn uninterrupted(scene: &Value) -> Vec<glam::Vec3> {
    direct_render(&scene.to_string(), Some("pt"), &json!({}), SEED, SPP)
}

/// Submits the job on a server armed with `failpoint`, waits for the abort, restarts
/// and checks the finished job against `expected`.
fn crash_and_resume(failpoint: &str, scene: &Value, expected: &[glam::Vec3]) {
    let dir = tempfile::tempdir().unwrap();
    let mut p = start(dir.path(), Some(failpoint));
    let info = post(&format!("{}/v1/scenes", p.url), scene);
    let spec = json!({"scene": info["id"], "halt": {"spp": SPP}, "seed": SEED,
                      "snapshot_every": {"iterations": EVERY}});
    let id = post(&format!("{}/v1/jobs", p.url), &spec)["id"]
        .as_str()
        .unwrap()
        .to_string();
    let mut exited = None;
    wait_until(&format!("the abort at {failpoint}"), 60, || {
        exited = p.child.try_wait().unwrap();
        exited.is_some()
    });
    assert!(
        !exited.unwrap().success(),
        "{failpoint}: server exited cleanly"
    );
    drop(p);

    let p = start(dir.path(), None);
    let job_url = format!("{}/v1/jobs/{id}", p.url);
    wait_until(&format!("{failpoint}: completion"), 60, || {
        get(&job_url)["state"] == "completed"
    });
    let job = get(&job_url);
    assert_eq!(job["iteration"], SPP, "{failpoint}: {job}");
    let log = std::fs::read_to_string(dir.path().join("jobs").join(&id).join("log.csv")).unwrap();
    let rows: Vec<u64> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    let want: Vec<u64> = (1..=SPP / EVERY).map(|k| k * EVERY).collect();
    assert_eq!(rows, want, "{failpoint}: log rows");
    let (_, exr) = respond(ureq::get(&format!("{job_url}/image.exr")).call());
    let served = caustic::film::decode_exr(&exr).unwrap();
    assert!(served.pixels() == expected, "{failpoint}: image differs");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path().join("jobs").join(&id))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp") || n.starts_with("latest.") || n == "checkpoint.bin")
        .collect();
    assert!(leftovers.is_empty(), "{failpoint}: left {leftovers:?}");
}

/// Every write of the last snapshot and of completion, in the order they happen.
#[test]
fn a_kill_at_any_write_of_the_last_snapshot_changes_nothing() {
    let scene = tiny_scene(16);
    let expected = uninterrupted(&scene);
    let points = [
        "snapshot-exr",
        "snapshot-png",
        "latest-exr",
        "latest-png",
        "log",
        "checkpoint",
        "final-exr",
        "final-png",
    ];
    for p in points {
        crash_and_resume(&format!("{p}@{SPP}"), &scene, &expected);
    }
    // The job.json that says "completed" is the last write of all.
    crash_and_resume(&format!("status@{SPP}"), &scene, &expected);
}

/// Before the first checkpoint exists: the log row of the first snapshot is written,
/// the checkpoint is not. The replayed iterations must not add a second row.
#[test]
fn a_kill_before_the_first_checkpoint_leaves_one_row_per_snapshot() {
    let scene = tiny_scene(16);
    let expected = uninterrupted(&scene);
    for p in ["log", "checkpoint"] {
        crash_and_resume(&format!("{p}@{EVERY}"), &scene, &expected);
    }
}
