//! A coordinator (`Service` with `nats` set) and `caustic worker` processes on a real
//! NATS server with JetStream, started here (installed by
//! deploy/scripts/install-nats-server.sh when not on the machine).

mod server_common;
use serde_json::{json, Value};
use server_common::*;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The nats-server binary: $CAUSTIC_NATS_SERVER, else the project's installed copy.
fn nats_server_bin() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        if let Ok(p) = std::env::var("CAUSTIC_NATS_SERVER") {
            return PathBuf::from(p);
        }
        let root = env!("CARGO_MANIFEST_DIR");
        let out = Command::new(format!("{root}/deploy/scripts/install-nats-server.sh"))
            .arg(format!("{root}/target/tools/nats"))
            .stderr(Stdio::inherit())
            .output()
            .expect("running deploy/scripts/install-nats-server.sh");
        assert!(out.status.success(), "installing nats-server failed");
        PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
    })
}

/// A child process killed when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

struct Nats {
    proc: Option<Proc>,
    port: u16,
    auth: Option<String>,
    dir: tempfile::TempDir,
}

impl Nats {
    /// JetStream with file storage on a free loopback port; `auth` sets a token.
    fn start(auth: Option<&str>) -> Nats {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let mut nats = Nats {
            proc: None,
            port,
            auth: auth.map(String::from),
            dir: tempfile::tempdir().unwrap(),
        };
        nats.run();
        nats
    }

    fn run(&mut self) {
        let mut cmd = Command::new(nats_server_bin());
        cmd.args([
            "-js",
            "-a",
            "127.0.0.1",
            "-p",
            &self.port.to_string(),
            "-sd",
        ])
        .arg(self.dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null());
        if let Some(t) = &self.auth {
            cmd.args(["--auth", t]);
        }
        self.proc = Some(Proc(cmd.spawn().expect("starting nats-server")));
        let start = Instant::now();
        while TcpStream::connect(("127.0.0.1", self.port)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "nats-server did not start"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Kills the server (SIGKILL) and starts it again on its port and storage.
    fn restart(&mut self) {
        drop(self.proc.take());
        std::thread::sleep(Duration::from_millis(500));
        self.run();
    }

    fn url(&self, token: Option<&str>) -> String {
        match token {
            Some(t) => format!("nats://{t}@127.0.0.1:{}", self.port),
            None => format!("nats://127.0.0.1:{}", self.port),
        }
    }
}

/// A `caustic worker` with one render thread and its own scene cache.
fn worker(url: &str, name: &str, cache: &Path) -> Proc {
    Proc(
        Command::new(env!("CARGO_BIN_EXE_caustic"))
            .args(["worker", "--nats", url, "--threads", "1", "--name", name])
            .arg("--cache-dir")
            .arg(cache.join(name))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting caustic worker"),
    )
}

/// Uploads the foggy test scene and submits a bpt job of `spp` iterations on it.
fn submit(s: &TestServer, size: u32, spp: u64) -> String {
    let (code, info) = s.post_bytes("/v1/scenes", foggy_scene(size).to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    let spec = json!({"scene": info["id"], "algorithm": "bpt", "halt": {"spp": spp},
                      "seed": 5, "snapshot_every": {"iterations": 1000000}});
    let (code, job) = s.post_json("/v1/jobs", &spec);
    assert_eq!(code, 201, "{job}");
    job["id"].as_str().unwrap().to_string()
}

fn final_pixels(s: &TestServer, id: &str) -> Vec<glam::Vec3> {
    let path = s.dir.path().join("jobs").join(id).join("final.exr");
    caustic::film::read_exr(&path).unwrap().pixels().to_vec()
}

fn completed(s: &TestServer, id: &str) -> Value {
    let job = s.wait_job(id);
    assert_eq!(job["state"], "completed", "{job}");
    job
}

/// The same job in this process, for comparison.
fn in_process(size: u32, spp: u64) -> Vec<glam::Vec3> {
    let local = TestServer::start(None);
    let id = submit(&local, size, spp);
    completed(&local, &id);
    final_pixels(&local, &id)
}

#[test]
fn a_pool_of_workers_renders_the_in_process_image_bit_for_bit() {
    let nats = Nats::start(None);
    let coord = TestServer::start_with(None, |c| c.nats = Some(nats.url(None)));
    let cache = tempfile::tempdir().unwrap();
    let _w = [
        worker(&nats.url(None), "w1", cache.path()),
        worker(&nats.url(None), "w2", cache.path()),
    ];
    let id = submit(&coord, 24, 40);
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], 40);
    assert!(final_pixels(&coord, &id) == in_process(24, 40));
    // Both listed, with their threads and the iterations they did (heartbeats come
    // every 2 s).
    std::thread::sleep(Duration::from_millis(2500));
    let workers = listed(&coord);
    let names: Vec<&str> = workers
        .iter()
        .map(|w| w["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["w1", "w2"]);
    assert!(workers
        .iter()
        .all(|w| w["threads"] == 1 && w["current_job"].is_null()));
    let done: u64 = workers
        .iter()
        .map(|w| w["iterations_done"].as_u64().unwrap())
        .sum();
    assert!(done >= 40, "{workers:?}");
    let (code, metrics) = coord.get("/metrics");
    assert_eq!(code, 200);
    let metrics = String::from_utf8(metrics).unwrap();
    assert!(
        metrics.contains("caustic_worker_ranges_total{worker=\"w1\"}"),
        "{metrics}"
    );
    assert!(
        metrics.contains("caustic_worker_threads{worker=\"w2\"} 1"),
        "{metrics}"
    );
    // An in-process server has no pool.
    assert!(listed(&TestServer::start(None)).is_empty());
}

/// Waits until the first ranges of job `id` are in: from then on per-iteration times
/// are known and units last about 2 s.
fn wait_for_ranges(s: &TestServer, id: &str) {
    let start = Instant::now();
    while s.get_json(&format!("/v1/jobs/{id}")).1["iteration"].as_u64() < Some(3) {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no ranges came back"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn listed(s: &TestServer) -> Vec<Value> {
    let (code, v) = s.get_json("/v1/workers");
    assert_eq!(code, 200, "{v}");
    v.as_array().unwrap().clone()
}

fn worker_field(s: &TestServer, name: &str, field: &str) -> u64 {
    listed(s)
        .iter()
        .find(|w| w["name"] == name)
        .and_then(|w| w[field].as_u64())
        .unwrap_or(0)
}

/// A paused job hands out no more ranges (its queued units are withdrawn); a worker
/// that joins late takes work after the resume; the image is still the in-process one.
#[test]
fn pause_stops_the_pool_and_a_late_worker_joins_after_resume() {
    let nats = Nats::start(None);
    let coord = TestServer::start_with(None, |c| c.nats = Some(nats.url(None)));
    let cache = tempfile::tempdir().unwrap();
    let _early = worker(&nats.url(None), "early", cache.path());
    let (size, spp) = (48, 1200);
    let id = submit(&coord, size, spp);
    wait_for_ranges(&coord, &id);
    let (code, job) = coord.post_json(&format!("/v1/jobs/{id}/pause"), &json!({}));
    assert_eq!(code, 200, "{job}");
    assert_eq!(job["state"], "paused");
    // The unit in hand (about 2 s) finishes; then the worker stays idle.
    std::thread::sleep(Duration::from_secs(5));
    let idle = worker_field(&coord, "early", "iterations_done");
    std::thread::sleep(Duration::from_secs(5));
    assert_eq!(worker_field(&coord, "early", "iterations_done"), idle);
    let _late = worker(&nats.url(None), "late", cache.path());
    let (code, job) = coord.post_json(&format!("/v1/jobs/{id}/resume"), &json!({}));
    assert_eq!(code, 200, "{job}");
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], spp);
    std::thread::sleep(Duration::from_millis(2500));
    assert!(
        worker_field(&coord, "late", "ranges_done") > 0,
        "{:?}",
        listed(&coord)
    );
    assert!(final_pixels(&coord, &id) == in_process(size, spp));
}

/// A worker killed (SIGKILL) in the middle of its ranges: they are delivered again
/// after the ack wait, another worker renders them, and the image is still the
/// in-process one bit for bit (a range added twice or lost would change it).
#[test]
fn a_worker_killed_mid_range_loses_nothing_and_counts_nothing_twice() {
    let nats = Nats::start(None);
    let coord = TestServer::start_with(None, |c| c.nats = Some(nats.url(None)));
    let cache = tempfile::tempdir().unwrap();
    let mut first = worker(&nats.url(None), "doomed", cache.path());
    let (size, spp) = (48, 400);
    let id = submit(&coord, size, spp);
    // Once some ranges are in, the victim always holds a unit of about 2 s.
    wait_for_ranges(&coord, &id);
    first.0.kill().unwrap();
    first.0.wait().unwrap();
    let at_kill = coord.get_json(&format!("/v1/jobs/{id}")).1["iteration"]
        .as_u64()
        .unwrap();
    assert!(at_kill < spp, "the job ended before the kill");
    let _second = worker(&nats.url(None), "survivor", cache.path());
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], spp);
    assert!(final_pixels(&coord, &id) == in_process(size, spp));
}

/// The NATS server killed and restarted mid-job (JetStream file storage): units and
/// answers wait in it, every process reconnects, and the job completes with the
/// in-process image.
#[test]
fn a_nats_server_restarted_mid_job_loses_nothing() {
    let mut nats = Nats::start(None);
    let coord = TestServer::start_with(None, |c| c.nats = Some(nats.url(None)));
    let cache = tempfile::tempdir().unwrap();
    let _w = [
        worker(&nats.url(None), "w1", cache.path()),
        worker(&nats.url(None), "w2", cache.path()),
    ];
    let (size, spp) = (48, 600);
    let id = submit(&coord, size, spp);
    wait_for_ranges(&coord, &id);
    nats.restart();
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], spp);
    assert!(final_pixels(&coord, &id) == in_process(size, spp));
}

#[test]
fn a_worker_with_a_wrong_or_missing_credential_is_refused() {
    let nats = Nats::start(Some("s3cret"));
    for url in [nats.url(Some("wrong")), nats.url(None)] {
        let out = Command::new(env!("CARGO_BIN_EXE_caustic"))
            .args(["worker", "--nats", &url, "--threads", "1"])
            .arg("--cache-dir")
            .arg(tempfile::tempdir().unwrap().path())
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr).to_lowercase();
        assert!(err.contains("authorization"), "{err}");
        assert!(!err.contains("wrong@"), "the credential is printed: {err}");
    }
}
