//! A test server: the REST app on 127.0.0.1:0 with a temp data directory, and small
//! blocking HTTP helpers.
#![allow(dead_code)]

use caustic::job::{Service, ServiceConfig};
use serde_json::{json, Value};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub struct TestServer {
    pub url: String,
    pub svc: Arc<Service>,
    pub dir: tempfile::TempDir,
    rt: Option<tokio::runtime::Runtime>,
}

impl TestServer {
    pub fn start(token: Option<&str>) -> TestServer {
        Self::start_with(token, |_| {})
    }

    /// A test server with its configuration changed by `configure`.
    pub fn start_with(
        token: Option<&str>,
        configure: impl FnOnce(&mut ServiceConfig),
    ) -> TestServer {
        let dir = tempfile::tempdir().unwrap();
        let mut config = ServiceConfig::for_tests(dir.path());
        configure(&mut config);
        let svc = Service::start(config).unwrap();
        let rt = tokio::runtime::Runtime::new().unwrap();
        let listener = rt
            .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
            .unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        let app = caustic::server::http::app(svc.clone(), token.map(String::from));
        let limits = caustic::server::listen::ConnLimits {
            header_timeout: svc.config().header_timeout,
            drain: Duration::from_secs(1),
        };
        rt.spawn(caustic::server::listen::serve(
            listener,
            app,
            limits,
            std::future::pending(),
        ));
        TestServer {
            url,
            svc,
            dir,
            rt: Some(rt),
        }
    }

    pub fn get(&self, path: &str) -> (u16, Vec<u8>) {
        respond(ureq::get(&format!("{}{path}", self.url)).call())
    }

    pub fn get_json(&self, path: &str) -> (u16, Value) {
        let (code, body) = self.get(path);
        (code, serde_json::from_slice(&body).unwrap_or(Value::Null))
    }

    /// GET with `Accept: application/json`.
    pub fn get_json_accept(&self, path: &str) -> (u16, Value) {
        let (code, body) = respond(
            ureq::get(&format!("{}{path}", self.url))
                .set("accept", "application/json")
                .call(),
        );
        (code, serde_json::from_slice(&body).unwrap_or(Value::Null))
    }

    pub fn post_json(&self, path: &str, body: &Value) -> (u16, Value) {
        let (code, b) = respond(
            ureq::post(&format!("{}{path}", self.url))
                .set("content-type", "application/json")
                .send_string(&body.to_string()),
        );
        (code, serde_json::from_slice(&b).unwrap_or(Value::Null))
    }

    pub fn post_bytes(&self, path: &str, body: &[u8]) -> (u16, Value) {
        let (code, b) = respond(ureq::post(&format!("{}{path}", self.url)).send_bytes(body));
        (code, serde_json::from_slice(&b).unwrap_or(Value::Null))
    }

    pub fn delete(&self, path: &str) -> (u16, Value) {
        let (code, b) = respond(ureq::delete(&format!("{}{path}", self.url)).call());
        (code, serde_json::from_slice(&b).unwrap_or(Value::Null))
    }

    /// Polls a job until it reaches a terminal state.
    pub fn wait_job(&self, id: &str) -> Value {
        let start = Instant::now();
        loop {
            let (code, job) = self.get_json(&format!("/v1/jobs/{id}"));
            assert_eq!(code, 200, "{job}");
            if ["completed", "cancelled", "failed"].contains(&job["state"].as_str().unwrap()) {
                return job;
            }
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "job {id} did not finish: {job}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    pub fn wait_state(&self, id: &str, state: &str) {
        let start = Instant::now();
        while self.get_json(&format!("/v1/jobs/{id}")).1["state"] != state {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "job {id} never {state}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for TestServer {
    fn drop(&mut self) {
        self.svc.shutdown();
        if let Some(rt) = self.rt.take() {
            rt.shutdown_background();
        }
    }
}

pub fn respond(r: Result<ureq::Response, ureq::Error>) -> (u16, Vec<u8>) {
    let resp = match r {
        Ok(r) => r,
        Err(ureq::Error::Status(_, r)) => r,
        Err(e) => panic!("transport error: {e}"),
    };
    let code = resp.status();
    let mut body = Vec::new();
    std::io::Read::read_to_end(&mut resp.into_reader(), &mut body).unwrap();
    (code, body)
}

/// A small scene: a diffuse sphere on a plane under a point light.
pub fn tiny_scene(size: u32) -> Value {
    json!({
        "format": 1,
        "camera": {"look_at": {"origin": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 45},
        "film": {"width": size, "height": size},
        "materials": {"m": {"type": "diffuse", "reflectance": [0.6, 0.5, 0.4]}},
        "shapes": [
            {"type": "sphere", "radius": 0.8, "material": "m"},
            {"type": "rectangle", "material": "m", "transform": {"translate": [0, -0.8, 0], "rotate": [{"axis": [1, 0, 0], "angle": -90}], "scale": 5}}
        ],
        "lights": [{"type": "point", "position": [1, 3, 2], "intensity": [8, 8, 8]}]
    })
}

/// `tiny_scene` in an unbounded fog that also fills the camera's space: every medium
/// estimator has work on it.
#[allow(dead_code)]
pub fn foggy_scene(size: u32) -> Value {
    let mut v = tiny_scene(size);
    v["media"] = json!({"fog": {"type": "homogeneous", "sigma_a": [0.05, 0.05, 0.05],
                                "sigma_s": [0.2, 0.2, 0.2],
                                "phase": {"type": "henyey_greenstein", "g": 0.5}}});
    v["camera"]["medium"] = json!("fog");
    v
}

/// Sends a raw HTTP/1.1 request (`head` without the final blank line) and as much of
/// `body` as the server takes, then reads the answer: status and JSON body. For
/// requests a well-behaved client library will not send (lying Content-Length,
/// bodies the server refuses before reading them).
pub fn raw_request(url: &str, head: &str, body: &[u8]) -> (u16, Value) {
    use std::io::{Read, Write};
    let addr = url.trim_start_matches("http://");
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let head = format!("{head}\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    s.write_all(head.as_bytes()).unwrap();
    // The server may answer and close before the body is sent: that is allowed.
    let _ = s.write_all(body);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).to_string();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no HTTP answer: {text:?}"));
    let json = text
        .split_once("\r\n\r\n")
        .and_then(|(_, b)| serde_json::from_str(b).ok())
        .unwrap_or(Value::Null);
    (status, json)
}

/// The image of an uninterrupted in-process render of a scene document: what a job
/// on that scene, algorithm, parameters and seed must serve, bit for bit.
pub fn direct_render(
    scene: &str,
    algorithm: Option<&str>,
    params: &Value,
    seed: u64,
    iterations: u64,
) -> Vec<glam::Vec3> {
    direct_outcome(scene, algorithm, params, seed, iterations)
        .image()
        .pixels()
        .to_vec()
}

/// [`direct_render`]'s whole outcome (its noise estimate too).
pub fn direct_outcome(
    scene: &str,
    algorithm: Option<&str>,
    params: &Value,
    seed: u64,
    iterations: u64,
) -> caustic::integrator::drive::RenderOutcome {
    let file = caustic::scene::load::parse_scene(scene).unwrap();
    let compiled = caustic::scene::Scene::compile(&file, None).unwrap();
    let empty = serde_json::Map::new();
    let settings = caustic::integrator::Settings::resolve(
        algorithm,
        compiled.integrator.as_ref(),
        params.as_object().unwrap_or(&empty),
    )
    .unwrap();
    caustic::integrator::drive::render(
        &compiled,
        settings.build().as_ref(),
        seed,
        caustic::integrator::drive::Halt {
            iterations: Some(iterations),
            ..caustic::integrator::drive::Halt::default()
        },
        |_, _| {},
    )
}

/// A `caustic serve` process on 127.0.0.1:0 (REST and gRPC) over `data`, killed when
/// dropped. Its stderr is drained (so it never blocks) and its last lines kept.
pub struct ServerProcess {
    pub child: std::process::Child,
    pub url: String,
    pub grpc: String,
    pub stderr: std::sync::Arc<std::sync::Mutex<std::collections::VecDeque<String>>>,
}

impl ServerProcess {
    pub fn start(data: &std::path::Path, extra: &[&str]) -> ServerProcess {
        Self::start_with(data, extra, |_| {})
    }

    /// As [`ServerProcess::start`], with the command adjusted first (environment,
    /// limits).
    pub fn start_with(
        data: &std::path::Path,
        extra: &[&str],
        configure: impl FnOnce(&mut std::process::Command),
    ) -> ServerProcess {
        use std::io::BufRead;
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_caustic"));
        cmd.args([
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--grpc-addr",
            "127.0.0.1:0",
        ]);
        if !extra.contains(&"--workers") {
            cmd.args(["--workers", "2"]);
        }
        cmd.arg("--data-dir")
            .arg(data)
            .args(extra)
            .env_remove("CAUSTIC_FAILPOINT")
            .env_remove("CAUSTIC_TOKEN")
            .stderr(std::process::Stdio::piped())
            .stdout(std::process::Stdio::null());
        configure(&mut cmd);
        let mut child = cmd.spawn().unwrap();
        let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
        let (url, grpc) = loop {
            let line = lines.next().expect("server printed its address").unwrap();
            if let Some(rest) = line.split("serving REST on ").nth(1) {
                let mut words = rest.split_whitespace();
                let url = words.next().unwrap().to_string();
                break (url, words.last().unwrap().to_string());
            }
        };
        let stderr = std::sync::Arc::new(std::sync::Mutex::new(std::collections::VecDeque::new()));
        let keep = stderr.clone();
        std::thread::spawn(move || {
            for l in lines.map_while(Result::ok) {
                let mut k = keep.lock().unwrap();
                if k.len() == 40 {
                    k.pop_front();
                }
                k.push_back(l);
            }
        });
        ServerProcess {
            child,
            url,
            grpc,
            stderr,
        }
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// `kill -9` and wait for it.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for ServerProcess {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A tar archive of `entries`, their names written raw so that unsafe paths reach the
/// server as given.
pub fn tar_with(entries: &[(&str, &[u8])]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    for (name, data) in entries {
        let mut h = tar::Header::new_gnu();
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        h.set_entry_type(tar::EntryType::Regular);
        // Write the raw name so that unsafe paths reach the server as given.
        let bytes = name.as_bytes();
        h.as_old_mut().name[..bytes.len()].copy_from_slice(bytes);
        h.set_cksum();
        b.append(&h, *data).unwrap();
    }
    b.into_inner().unwrap()
}

/// Every file below `dir`, relative to it, sorted, with the total of their sizes.
#[allow(dead_code)]
pub fn stored_files(dir: &std::path::Path) -> (Vec<String>, u64) {
    fn walk(root: &std::path::Path, dir: &std::path::Path, out: &mut Vec<(String, u64)>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let path = e.path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let name = path
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                out.push((name, e.metadata().unwrap().len()));
            }
        }
    }
    let mut files = Vec::new();
    walk(dir, dir, &mut files);
    files.sort();
    let total = files.iter().map(|(_, n)| n).sum();
    (files.into_iter().map(|(name, _)| name).collect(), total)
}

/// Issue 36's include tree: `scene.xml` and `f1.xml` .. `f30.xml`, each including the
/// next twice (2^30 includes, 31 deep: under the depth limit); the last holds a
/// sphere. A few KB that kept the importer busy for hours.
#[allow(dead_code)]
pub fn include_tree() -> Vec<(String, String)> {
    (0..=30)
        .map(|i| {
            let body = if i < 30 {
                format!(
                    "<include filename=\"f{0}.xml\"/><include filename=\"f{0}.xml\"/>",
                    i + 1
                )
            } else {
                "<shape type=\"sphere\"/>".to_string()
            };
            let name = if i == 0 {
                "scene.xml".into()
            } else {
                format!("f{i}.xml")
            };
            (
                name,
                format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n"),
            )
        })
        .collect()
}
