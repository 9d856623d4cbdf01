//! `kill -9` of a real server process, then a restart on the same data directory:
//! completed jobs keep their files, queued jobs stay queued, and the running job
//! resumes from its last checkpoint and finishes bit-identical to an uninterrupted run
//! (each iteration is added to the f64 sums in the same order, so the sums match
//! exactly, not just within float summation order).

mod server_common;
use serde_json::{json, Value};
use server_common::{direct_outcome, foggy_scene, respond, tiny_scene, ServerProcess};
use std::path::Path;
use std::time::{Duration, Instant};

fn start(data: &Path) -> ServerProcess {
    ServerProcess::start(data, &[])
}

fn get(url: &str) -> Value {
    let (code, b) = respond(ureq::get(url).call());
    assert_eq!(code, 200, "{}", String::from_utf8_lossy(&b));
    serde_json::from_slice(&b).unwrap()
}

fn post(url: &str, body: Value) -> Value {
    let (code, b) = respond(ureq::post(url).send_json(body));
    assert!(code < 300, "{}", String::from_utf8_lossy(&b));
    serde_json::from_slice(&b).unwrap()
}

fn wait_until(what: &str, mut f: impl FnMut() -> bool) {
    let start = Instant::now();
    while !f() {
        assert!(
            start.elapsed() < Duration::from_secs(180),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn kill_9_then_restart_resumes_bit_identically() {
    kill_9_then_restart(tiny_scene(64), "pt", json!({}), 1500);
}

/// SPPM's iterations depend on per-pixel statistics, which the checkpoint carries.
#[test]
fn kill_9_then_restart_resumes_sppm_bit_identically() {
    kill_9_then_restart(
        tiny_scene(64),
        "sppm",
        json!({"light_paths": 0.25, "radius_factor": 0.02}),
        1500,
    );
}

/// vbl's beam radius shrinks with the iteration index, which a resumed job must
/// continue from, not restart.
#[test]
fn kill_9_then_restart_resumes_vbl_bit_identically() {
    kill_9_then_restart(
        foggy_scene(24),
        "vbl",
        json!({"light_paths": {"count": 16}, "sampler": "joint_advanced"}),
        400,
    );
}

/// upbp's five radii shrink with the iteration index, and its beams come from the
/// light store: a resumed job must continue all of them.
#[test]
fn kill_9_then_restart_resumes_upbp_bit_identically() {
    kill_9_then_restart(
        foggy_scene(24),
        "upbp",
        json!({"light_paths": 0.5, "beam_paths": 0.5, "bb1d_radius_factor": 0.02}),
        400,
    );
}

/// `selection: adaptive`: the resumed job renders the pilots before its checkpoint
/// again, so it makes the same per-pixel choices.
#[test]
fn kill_9_then_restart_resumes_adaptive_upbp_bit_identically() {
    kill_9_then_restart(
        foggy_scene(24),
        "upbp",
        json!({"light_paths": 0.5, "selection": "adaptive"}),
        400,
    );
}

fn kill_9_then_restart(scene: Value, alg: &str, params: Value, spp: u64) {
    let dir = tempfile::tempdir().unwrap();
    let mut p = start(dir.path());
    let (code, info) =
        respond(ureq::post(&format!("{}/v1/scenes", p.url)).send_string(&scene.to_string()));
    assert_eq!(code, 201);
    let scene_id = serde_json::from_slice::<Value>(&info).unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();

    let quick = post(
        &format!("{}/v1/jobs", p.url),
        json!({"scene": scene_id, "halt": {"spp": 2}}),
    );
    let quick = quick["id"].as_str().unwrap().to_string();
    wait_until("quick job", || {
        get(&format!("{}/v1/jobs/{quick}", p.url))["state"] == "completed"
    });

    let long = post(
        &format!("{}/v1/jobs", p.url),
        json!({"scene": scene_id, "algorithm": alg, "params": params, "halt": {"spp": spp}, "seed": 77, "snapshot_every": {"iterations": 50}}),
    );
    let long = long["id"].as_str().unwrap().to_string();
    let waiting = post(
        &format!("{}/v1/jobs", p.url),
        json!({"scene": scene_id, "halt": {"spp": 1}, "priority": -1000}),
    );
    let waiting = waiting["id"].as_str().unwrap().to_string();

    let log = dir.path().join("jobs").join(&long).join("log.csv");
    wait_until("two snapshots", || {
        std::fs::read_to_string(&log)
            .map(|t| t.lines().count() >= 3)
            .unwrap_or(false)
    });
    let before = get(&format!("{}/v1/jobs/{long}", p.url));
    assert_eq!(before["state"], "running");
    p.kill(); // SIGKILL: no chance to flush anything

    let p = start(dir.path());
    // Completed jobs and their files survived; the queued job is still queued.
    assert_eq!(
        get(&format!("{}/v1/jobs/{quick}", p.url))["state"],
        "completed"
    );
    for f in ["final.exr", "final.png", "log.csv", "job.json"] {
        assert!(dir.path().join("jobs").join(&quick).join(f).exists(), "{f}");
    }
    // A completed job keeps one copy of its image and no checkpoint.
    for f in ["latest.exr", "latest.png", "checkpoint.bin"] {
        assert!(
            !dir.path().join("jobs").join(&quick).join(f).exists(),
            "{f}"
        );
    }
    assert_eq!(
        get(&format!("{}/v1/jobs/{waiting}", p.url))["state"],
        "queued"
    );
    // The running job resumes from its checkpoint, not from zero.
    let mut resumed_at = u64::MAX;
    wait_until("resume", || {
        let j = get(&format!("{}/v1/jobs/{long}", p.url));
        resumed_at = j["iteration"].as_u64().unwrap();
        j["state"] == "running" || j["state"] == "completed"
    });
    assert!(resumed_at >= 50, "restarted from {resumed_at}");
    wait_until("long job", || {
        get(&format!("{}/v1/jobs/{long}", p.url))["state"] == "completed"
    });
    let job = get(&format!("{}/v1/jobs/{long}", p.url));
    assert_eq!(job["iteration"], spp);
    // The log has one row per snapshot, none duplicated by the replay.
    let text = std::fs::read_to_string(&log).unwrap();
    let its: Vec<u64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(its, (1..=spp / 50).map(|k| k * 50).collect::<Vec<_>>());

    let (_, exr) = respond(ureq::get(&format!("{}/v1/jobs/{long}/image.exr", p.url)).call());
    let served = caustic::film::decode_exr(&exr).unwrap();
    let direct = direct_outcome(&scene.to_string(), Some(alg), &params, 77, spp);
    assert_eq!(
        direct.image().pixels(),
        served.pixels(),
        "{alg}: resumed image differs"
    );
    // The noise estimate's second moments came through the checkpoint too.
    let noise = direct.noise.map(|n| n.rel_error());
    assert_eq!(job["noise"].as_f64(), noise, "{alg}: resumed noise differs");
    assert_eq!(noise.is_none(), alg == "sppm", "{alg}");
}

/// One server per data directory: a second `caustic serve` on it exits at once with
/// a message naming the first (pid and address) and leaves the running job alone;
/// after the first is killed with -9, a new one starts (the kernel's lock died with
/// its holder) and resumes the job.
#[test]
fn a_second_server_on_one_data_directory_exits_naming_the_first() {
    let dir = tempfile::tempdir().unwrap();
    let mut first = start(dir.path());
    let job = post(
        &format!("{}/v1/jobs", first.url),
        json!({"scene": "cornell-box", "halt": {"spp": 1_000_000}, "seed": 2}),
    );
    let id = job["id"].as_str().unwrap().to_string();
    let job_url = format!("{}/v1/jobs/{id}", first.url);
    wait_until("the job to run", || get(&job_url)["state"] == "running");

    let mut second = std::process::Command::new(env!("CARGO_BIN_EXE_caustic"))
        .args([
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--grpc-addr",
            "127.0.0.1:0",
        ])
        .arg("--data-dir")
        .arg(dir.path())
        .env("RUST_BACKTRACE", "0")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start_wait = Instant::now();
    let status = loop {
        if let Some(s) = second.try_wait().unwrap() {
            break s;
        }
        if start_wait.elapsed() > Duration::from_secs(30) {
            let _ = second.kill();
            panic!("a second server on the same data directory kept running");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut second.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(!status.success(), "{stderr}");
    assert!(stderr.contains("is in use"), "{stderr}");
    assert!(stderr.contains(&format!("pid {}", first.pid())), "{stderr}");
    assert!(stderr.contains(&first.url), "{stderr}");
    assert!(!stderr.contains("serving REST"), "{stderr}");
    assert_eq!(get(&job_url)["state"], "running");

    first.kill();
    let again = start(dir.path());
    let job_url = format!("{}/v1/jobs/{id}", again.url);
    wait_until("the job to resume", || get(&job_url)["state"] == "running");
}
