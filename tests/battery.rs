//! Issue 18: the bad-request battery as a repeatable test. A real server process
//! renders a long job while every class of bad input is thrown at it: malformed,
//! mistyped and out-of-range JSON, wrong content types and methods, odd paths, bodies
//! too large (declared, chunked, lying), idle and slow connections, hostile scene
//! bundles (unsafe paths, links, lying sizes, corrupt and bomb zips, OBJ `mtllib`
//! outside the bundle, EXR headers claiming huge images; `battery/images.rs`: hostile
//! textures; `battery/uploads.rs`: imports
//! whose work multiplies, padded bundles), bad references, job
//! operations in the wrong state, and missing or wrong tokens.
//!
//! For every bad request: the right 4xx status (never 5xx, never a dropped
//! connection, except where a case says so), a JSON body `{"error": {"code",
//! "message"}}`, and no server path in any response body. Afterwards the job that
//! rendered throughout has completed with its iteration count and an image
//! bit-identical to a direct render, the server is alive and its peak RSS is bounded.
//! All failures are collected and listed together at the end.
//!
//! Cost: the idle-connection and lying-Content-Length checks wait for the server's
//! header and body timeouts (3 s here, `--request-timeout`); they run on their own
//! threads from the start, so the whole test takes a few seconds.

mod server_common;

#[path = "battery/images.rs"]
mod images;
#[path = "battery/inputs.rs"]
mod inputs;
#[path = "battery/uploads.rs"]
mod uploads;
#[path = "battery/wire.rs"]
mod wire;

use inputs::*;
use serde_json::{json, Value};
use server_common::tiny_scene;
use std::io::Write;
use std::net::TcpStream;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use wire::{clip, send, Outcome, Req, Resp};

/// The main server's upload limit (`--max-upload-mib`): small, so that bodies beyond
/// it and bombs expanding beyond it cost little time, memory and disk. The second
/// (token) server keeps the production default of 256 MiB.
const UPLOAD_MIB: usize = 16;
const UPLOAD_LIMIT: usize = UPLOAD_MIB << 20;
/// JSON bodies (jobs, sweeps) are limited to 1 MiB (`job::limits::MAX_JSON_BODY`).
const JSON_LIMIT: usize = 1 << 20;
/// The server's header-read and body timeouts (`--request-timeout`; 30 s in
/// production, short here so the test stays short).
const SERVER_TIMEOUT: Duration = Duration::from_secs(3);
/// Allowed lateness on those timeouts (shared, loaded machine).
const SLACK: Duration = Duration::from_secs(5);
/// Peak resident memory the server may reach during the battery.
const RSS_BOUND_MIB: u64 = 600;
/// Address-space cap of the server processes: a reader that trusts a size field
/// (an EXR header claiming 10^10 pixels, an endless `mtllib`) fails its allocation
/// and aborts instead of taking the shared machine's memory with it. Far above what
/// the server needs (its normal peak is tens of MiB resident).
const ADDRESS_SPACE_LIMIT: u64 = 8 << 30;

/// The main server's memory budget per job (`--max-job-mib`): below [`RSS_BOUND_MIB`],
/// so that no job it accepts can take it past the bound.
const JOB_MIB: &str = "512";

/// The long job: renders while the battery runs.
const LONG_SIZE: u32 = 32;
const LONG_SPP: u64 = 20000;
const LONG_SEED: u64 = 5;

// ---- the server process -------------------------------------------------------------

type Proc = server_common::ServerProcess;

/// The last `n` lines the server wrote to stderr, for a report.
fn last_stderr(p: &Proc, n: usize) -> String {
    let l = p.stderr.lock().unwrap();
    let skip = l.len().saturating_sub(n);
    l.iter()
        .skip(skip)
        .map(|line| clip(line, 300))
        .collect::<Vec<_>>()
        .join("\n    ")
}

/// A server process whose address space is capped (see [`ADDRESS_SPACE_LIMIT`]).
fn start(data: &Path, extra: &[&str]) -> Proc {
    use std::os::unix::process::CommandExt;
    Proc::start_with(data, extra, |cmd| {
        // A crash reports its message, not a backtrace that pushes it out of the lines
        // kept.
        cmd.env("RUST_BACKTRACE", "0").env("NO_COLOR", "1");
        // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and
        // exec.
        unsafe {
            cmd.pre_exec(|| {
                let lim = libc::rlimit {
                    rlim_cur: ADDRESS_SPACE_LIMIT,
                    rlim_max: ADDRESS_SPACE_LIMIT,
                };
                libc::setrlimit(libc::RLIMIT_AS, &lim);
                Ok(())
            });
        }
    })
}

/// Whether the process is still running (a zombie or a missing /proc entry is dead).
fn alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(s) => s
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|st| st != "Z" && st != "X"),
        Err(_) => false,
    }
}

/// VmHWM (peak resident set) of a process, in KiB.
fn peak_rss_kib(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

// ---- small well-behaved calls for the set-up ----------------------------------

fn call(url: &str, req: Req) -> Resp {
    match send(url, &req, Duration::from_secs(30)) {
        Outcome::Answered(r) => r,
        other => panic!("{}: {}", req.describe(), other.describe()),
    }
}

fn call_json(url: &str, req: Req, want: u16) -> Value {
    let what = req.describe();
    let r = call(url, req);
    assert_eq!(r.status, want, "{what}: {}", r.text());
    r.json().unwrap_or(Value::Null)
}

fn job_state(url: &str, id: &str) -> Value {
    call_json(url, Req::get(format!("/v1/jobs/{id}")), 200)
}

fn wait_for(what: &str, limit: Duration, mut f: impl FnMut() -> bool) -> bool {
    let start = Instant::now();
    while !f() {
        if start.elapsed() > limit {
            eprintln!("timed out waiting for {what}");
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    true
}

// ---- cases ------------------------------------------------------------------

/// One bad request and what the server must answer.
struct Case {
    name: String,
    req: Req,
    /// Acceptable statuses (usually one).
    want: Vec<u16>,
    /// A word the error message must contain (the field it names).
    mentions: Option<String>,
    /// The whole answer must arrive within this time.
    within: Option<Duration>,
    /// Client-supplied strings the answer may echo even though they look like paths.
    echo: Vec<String>,
    /// Malformed HTTP that hyper rejects before any middleware runs: it may answer
    /// with an empty body (its own 400/414/431) or close the connection, but never 5xx.
    protocol: bool,
    /// The client's read timeout.
    timeout: Duration,
}

fn case(name: impl Into<String>, req: Req, want: &[u16]) -> Case {
    Case {
        name: name.into(),
        req,
        want: want.to_vec(),
        mentions: None,
        within: None,
        echo: Vec::new(),
        protocol: false,
        timeout: Duration::from_secs(10),
    }
}

impl Case {
    fn mentions(mut self, w: &str) -> Case {
        self.mentions = Some(w.to_string());
        self
    }

    fn within(mut self, d: Duration) -> Case {
        self.within = Some(d);
        self
    }

    fn echo(mut self, s: impl Into<String>) -> Case {
        self.echo.push(s.into());
        self
    }

    fn protocol(mut self) -> Case {
        self.protocol = true;
        self
    }

    fn timeout(mut self, d: Duration) -> Case {
        self.timeout = d;
        self
    }
}

/// Runs cases against one server and collects every failure.
struct Battery {
    url: String,
    pid: u32,
    /// Strings no response body may contain.
    forbidden: Vec<String>,
    failures: Arc<Mutex<Vec<String>>>,
    run: usize,
    dead: Option<String>,
    label: &'static str,
    /// Largest VmHWM seen after a case (it survives in the figure if the server dies).
    peak_kib: u64,
}

impl Battery {
    fn new(
        p: &Proc,
        data: &Path,
        failures: Arc<Mutex<Vec<String>>>,
        label: &'static str,
    ) -> Battery {
        let mut forbidden = vec![data.display().to_string()];
        if let Ok(c) = data.canonicalize() {
            if c != data {
                forbidden.push(c.display().to_string());
            }
        }
        forbidden.extend(
            ["/tmp", "/work", "/root", "/home", ".upload-"]
                .iter()
                .map(|s| s.to_string()),
        );
        Battery {
            url: p.url.clone(),
            pid: p.pid(),
            forbidden,
            failures,
            run: 0,
            dead: None,
            label,
            peak_kib: 0,
        }
    }

    fn fail(&self, msg: String) {
        self.failures
            .lock()
            .unwrap()
            .push(format!("[{}] {msg}", self.label));
    }

    /// Runs a case; returns the answer when there is one.
    fn run(&mut self, c: Case) -> Option<Resp> {
        if let Some(after) = &self.dead {
            self.fail(format!(
                "{}: not run, the server died during \"{after}\"",
                c.name
            ));
            return None;
        }
        self.run += 1;
        let out = send(&self.url, &c.req, c.timeout);
        let problems = self.check(&c, &out);
        self.log(&c.name, &c.req.describe(), &out, &problems);
        if !problems.is_empty() {
            self.fail(format!(
                "{} ({}): {}; got {}",
                c.name,
                c.req.describe(),
                problems.join("; "),
                out.describe()
            ));
        }
        self.peak_kib = self.peak_kib.max(peak_rss_kib(self.pid).unwrap_or(0));
        if !alive(self.pid) {
            self.dead = Some(c.name.clone());
            self.fail(format!("{}: THE SERVER PROCESS DIED", c.name));
            std::thread::sleep(Duration::from_millis(200)); // its last words reach the pipe
        }
        match out {
            Outcome::Answered(r) => Some(r),
            _ => None,
        }
    }

    /// With `BATTERY_LOG=<file>`, every case and its answer are appended to the file.
    fn log(&self, name: &str, req: &str, out: &Outcome, problems: &[String]) {
        let Some(path) = std::env::var_os("BATTERY_LOG") else {
            return;
        };
        let verdict = if problems.is_empty() { "ok" } else { "FAIL" };
        let line = format!(
            "[{}] {verdict} | {name} | {req} | {}\n",
            self.label,
            out.describe()
        );
        if let Ok(mut f) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
        {
            let _ = f.write_all(line.as_bytes());
        }
    }

    fn run_all(&mut self, cases: Vec<Case>) {
        for c in cases {
            self.run(c);
        }
    }

    fn check(&self, c: &Case, out: &Outcome) -> Vec<String> {
        let mut p = Vec::new();
        let r = match out {
            Outcome::Answered(r) => r,
            Outcome::Closed { .. } if c.protocol => return p,
            Outcome::Closed { .. } => return vec!["dropped connection".into()],
            Outcome::TimedOut { .. } => return vec!["no answer".into()],
            Outcome::Failed(_) => return vec!["could not connect".into()],
        };
        if !c.want.contains(&r.status) {
            p.push(format!("expected {}", alternatives(&c.want)));
        }
        if r.status >= 400 && !(c.protocol && r.body.is_empty()) {
            let ct = r.header("content-type").unwrap_or("");
            if !ct.starts_with("application/json") {
                p.push(format!("error body is not JSON (content-type {ct:?})"));
            }
            match r.json() {
                None => p.push("error body does not parse as JSON".into()),
                Some(v) => {
                    let code = v["error"]["code"].as_str().unwrap_or("");
                    let msg = v["error"]["message"].as_str().unwrap_or("");
                    if code.is_empty() || msg.is_empty() {
                        p.push("body is not {\"error\": {\"code\", \"message\"}}".into());
                    }
                    if let Some(w) = &c.mentions {
                        if !msg.to_lowercase().contains(&w.to_lowercase()) {
                            p.push(format!("message does not mention {w:?}"));
                        }
                    }
                }
            }
        }
        let mut text = r.text();
        for e in &c.echo {
            text = text.replace(e.as_str(), "<echo>");
        }
        let named: Vec<&String> = self
            .forbidden
            .iter()
            .filter(|f| text.contains(f.as_str()))
            .collect();
        if !named.is_empty() {
            p.push(format!("body names a server path (holds {named:?})"));
        }
        if let Some(d) = c.within {
            if r.elapsed > d {
                p.push(format!("answered after {:.2?}, limit {d:?}", r.elapsed));
            }
        }
        p
    }
}

fn alternatives(w: &[u16]) -> String {
    w.iter()
        .map(|s| s.to_string())
        .collect::<Vec<_>>()
        .join(" or ")
}

/// A job body: `{"scene": scene, "halt": {"spp": 1}}` with `patch`'s fields set
/// (a field set to the string "$remove" is removed).
fn spec(scene: &str, patch: Value) -> String {
    let mut v = json!({"scene": scene, "halt": {"spp": 1}});
    for (k, x) in patch.as_object().unwrap() {
        if x == "$remove" {
            v.as_object_mut().unwrap().remove(k);
        } else {
            v[k] = x.clone();
        }
    }
    v.to_string()
}

fn post_job(body: impl AsRef<[u8]>) -> Req {
    Req::post("/v1/jobs").json(body)
}

fn post_sweep(body: impl AsRef<[u8]>) -> Req {
    Req::post("/v1/sweeps").json(body)
}

fn upload(body: impl AsRef<[u8]>) -> Req {
    Req::post("/v1/scenes").bytes(body)
}

/// Class 1: JSON bodies of jobs and sweeps.
fn json_body_cases(s: &str) -> Vec<Case> {
    let mut v =
        vec![
        // Syntax: 400.
        case(
            "job: malformed JSON (a key without a value)",
            post_job(r#"{"scene": }"#),
            &[400],
        ),
        case(
            "job: truncated JSON",
            post_job(format!(r#"{{"scene": "{s}", "halt": {{"spp": 4"#)),
            &[400],
        ),
        case(
            "job: empty body with content-type json",
            post_job(""),
            &[400],
        ),
        case("job: plain words, not JSON", post_job("hello"), &[400]),
        case(
            "job: invalid UTF-8 inside a JSON string",
            post_job([&b"{\"scene\": \"\xff\xfe\", \"halt\": {\"spp\": 1}}"[..]].concat()),
            &[400],
        ),
        case(
            "job: NaN literal for halt.time_s",
            post_job(format!(r#"{{"scene": "{s}", "halt": {{"time_s": NaN}}}}"#)),
            &[400],
        ),
        case(
            "job: trailing garbage after the object",
            post_job(format!(r#"{{"scene": "{s}", "halt": {{"spp": 1}}}} x"#)),
            &[400],
        ),
        case(
            "job: two JSON documents in one body",
            post_job(format!(r#"{{"scene": "{s}", "halt": {{"spp": 1}}}}{{}}"#)),
            &[400],
        ),
        case(
            "job: params nested 100000 arrays deep",
            post_job(format!(
                r#"{{"scene": "{s}", "halt": {{"spp": 1}}, "params": {{"a": {}{}}}}}"#,
                "[".repeat(100_000),
                "]".repeat(100_000)
            )),
            &[400],
        ),
        case(
            "job: halt.time_s 1e999 (beyond f64)",
            post_job(format!(
                r#"{{"scene": "{s}", "halt": {{"time_s": 1e999}}}}"#
            )),
            &[400],
        ),
        // Wrong types, unknown fields, arrays for objects: 422 naming the field.
        case(
            "job: halt.spp a string",
            post_job(spec(s, json!({"halt": {"spp": "many"}}))),
            &[422],
        )
        .mentions("spp"),
        case(
            "job: scene a number",
            post_job(spec(s, json!({"scene": 5}))),
            &[422],
        )
        .mentions("scene"),
        case(
            "job: tags a string",
            post_job(spec(s, json!({"tags": "a"}))),
            &[422],
        )
        .mentions("tags"),
        case(
            "job: tags an object",
            post_job(spec(s, json!({"tags": {"a": 1}}))),
            &[422],
        )
        .mentions("tags"),
        case(
            "job: priority a string",
            post_job(spec(s, json!({"priority": "high"}))),
            &[422],
        )
        .mentions("priority"),
        case(
            "job: keep_snapshots a word other than \"all\"",
            post_job(spec(s, json!({"keep_snapshots": "some"}))),
            &[422],
        )
        .mentions("keep_snapshots"),
        case(
            "job: keep_checkpoint a string",
            post_job(spec(s, json!({"keep_checkpoint": "yes"}))),
            &[422],
        )
        .mentions("keep_checkpoint"),
        case(
            "job: unknown top-level field",
            post_job(spec(s, json!({"colour": 1}))),
            &[422],
        )
        .mentions("colour"),
        case(
            "job: unknown field in halt",
            post_job(spec(s, json!({"halt": {"spp": 1, "sp": 2}}))),
            &[422],
        )
        .mentions("sp"),
        case(
            "job: unknown field in snapshot_every",
            post_job(spec(
                s,
                json!({"snapshot_every": {"iterations": 5, "every": 1}}),
            )),
            &[422],
        ),
        case(
            "job: snapshot_every with both iterations and seconds",
            post_job(spec(
                s,
                json!({"snapshot_every": {"iterations": 5, "seconds": 5}}),
            )),
            &[422],
        ),
        case(
            "job: snapshot_every of an unknown kind",
            post_job(spec(s, json!({"snapshot_every": {"minutes": 1}}))),
            &[422],
        ),
        case(
            "job: reference of an unknown kind",
            post_job(spec(s, json!({"reference": {"file": "x"}}))),
            &[422],
        ),
        case(
            "job: the scene field twice",
            post_job(format!(
                r#"{{"scene": "{s}", "scene": "{s}", "halt": {{"spp": 1}}}}"#
            )),
            &[422],
        )
        .mentions("scene"),
        case(
            "job: halt an array [1]",
            post_job(spec(s, json!({"halt": [1]}))),
            &[422],
        )
        .mentions("halt"),
        case(
            "job: the whole body an array",
            post_job(json!([s, null, {}, 0, {"spp": 1}]).to_string()),
            &[422],
        ),
        case("job: the whole body a number", post_job("5"), &[422]),
        case("job: the whole body null", post_job("null"), &[422]),
        case(
            "job: params an array",
            post_job(spec(s, json!({"params": [1, 2]}))),
            &[422],
        )
        .mentions("params"),
        case(
            "job: params a string",
            post_job(spec(s, json!({"params": "max_depth=3"}))),
            &[422],
        )
        .mentions("params"),
        case(
            "job: params null",
            post_job(spec(s, json!({"params": null}))),
            &[422],
        )
        .mentions("params"),
        case(
            "job: snapshot_every an array [5]",
            post_job(spec(s, json!({"snapshot_every": [5]}))),
            &[422],
        )
        .mentions("snapshot_every"),
        case(
            "job: reference an array",
            post_job(spec(s, json!({"reference": ["job", "x"]}))),
            &[422],
        )
        .mentions("reference"),
        // Numbers that do not fit: 422, never wrapped.
        case(
            "job: seed -1",
            post_job(spec(s, json!({"seed": -1}))),
            &[422],
        )
        .mentions("seed"),
        case(
            "job: seed 2^64",
            post_job(format!(
                r#"{{"scene": "{s}", "halt": {{"spp": 1}}, "seed": 18446744073709551616}}"#
            )),
            &[422],
        )
        .mentions("seed"),
        case(
            "job: seed 1.5",
            post_job(spec(s, json!({"seed": 1.5}))),
            &[422],
        )
        .mentions("seed"),
        case(
            "job: halt.spp 1e30",
            post_job(spec(s, json!({"halt": {"spp": 1e30}}))),
            &[422],
        )
        .mentions("spp"),
        case(
            "job: halt.spp -1",
            post_job(spec(s, json!({"halt": {"spp": -1}}))),
            &[422],
        )
        .mentions("spp"),
        case(
            "job: halt.spp 2.5",
            post_job(spec(s, json!({"halt": {"spp": 2.5}}))),
            &[422],
        )
        .mentions("spp"),
        case(
            "job: priority 4294967297 (2^32 + 1)",
            post_job(spec(s, json!({"priority": 4294967297u64}))),
            &[422],
        )
        .mentions("priority"),
        case(
            "job: priority -2147483649",
            post_job(spec(s, json!({"priority": -2147483649i64}))),
            &[422],
        )
        .mentions("priority"),
        case(
            "job: keep_snapshots -1",
            post_job(spec(s, json!({"keep_snapshots": -1}))),
            &[422],
        )
        .mentions("keep_snapshots"),
        case(
            "job: keep_snapshots 2^32",
            post_job(spec(s, json!({"keep_snapshots": 4294967296u64}))),
            &[422],
        )
        .mentions("keep_snapshots"),
        case(
            "job: snapshot_every.iterations -5",
            post_job(spec(s, json!({"snapshot_every": {"iterations": -5}}))),
            &[422],
        ),
        // Null fields.
        case(
            "job: halt null",
            post_job(spec(s, json!({"halt": null}))),
            &[422],
        )
        .mentions("halt"),
        case(
            "job: scene null",
            post_job(spec(s, json!({"scene": null}))),
            &[422],
        )
        .mentions("scene"),
        case(
            "job: seed null",
            post_job(spec(s, json!({"seed": null}))),
            &[422],
        )
        .mentions("seed"),
        case(
            "job: tags null",
            post_job(spec(s, json!({"tags": null}))),
            &[422],
        )
        .mentions("tags"),
        case(
            "job: tags [null]",
            post_job(spec(s, json!({"tags": [null]}))),
            &[422],
        )
        .mentions("tags"),
        case(
            "job: snapshot_every null",
            post_job(spec(s, json!({"snapshot_every": null}))),
            &[422],
        )
        .mentions("snapshot_every"),
        case(
            "job: priority null",
            post_job(spec(s, json!({"priority": null}))),
            &[422],
        )
        .mentions("priority"),
        case(
            "job: no scene field",
            post_job(spec(s, json!({"scene": "$remove"}))),
            &[422],
        )
        .mentions("scene"),
        case(
            "job: no halt field",
            post_job(spec(s, json!({"halt": "$remove"}))),
            &[422],
        )
        .mentions("halt"),
        case(
            "job: halt.spp null and nothing else",
            post_job(spec(s, json!({"halt": {"spp": null}}))),
            &[400],
        )
        .mentions("halt"),
        // Sizes and contents of text fields.
        case(
            "job: a 20 MiB name (declared length above the 1 MiB JSON limit)",
            post_job(spec(s, json!({"name": "n".repeat(20 << 20)}))),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
        case(
            "job: a 20 MiB name sent chunked (no declared length)",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .chunked(spec(s, json!({"name": "n".repeat(20 << 20)}))),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
        case(
            "job: a 300-byte name",
            post_job(spec(s, json!({"name": "n".repeat(300)}))),
            &[400],
        )
        .mentions("name"),
        case(
            "job: a name with a BEL control character",
            post_job(spec(s, json!({"name": "bad\u{7}name"}))),
            &[400],
        )
        .mentions("name"),
        case(
            "job: a name with a newline",
            post_job(spec(s, json!({"name": "two\nlines"}))),
            &[400],
        )
        .mentions("name"),
        case(
            "job: a name with a NUL",
            post_job(spec(s, json!({"name": "nul\u{0}name"}))),
            &[400],
        )
        .mentions("name"),
        case(
            "job: 33 tags",
            post_job(spec(
                s,
                json!({"tags": (0..33).map(|i| format!("t{i}")).collect::<Vec<_>>()}),
            )),
            &[400],
        )
        .mentions("tags"),
        case(
            "job: a 65-byte tag",
            post_job(spec(s, json!({"tags": ["t".repeat(65)]}))),
            &[400],
        )
        .mentions("tags"),
        case(
            "job: an empty tag",
            post_job(spec(s, json!({"tags": [""]}))),
            &[400],
        )
        .mentions("tags"),
        case(
            "job: a tag with an escape character",
            post_job(spec(s, json!({"tags": ["a\u{1b}[31m"]}))),
            &[400],
        )
        .mentions("tags"),
        case(
            "job: a 65-byte scene id",
            post_job(spec(s, json!({"scene": "a".repeat(65)}))),
            &[400],
        )
        .mentions("scene"),
        case(
            "job: a scene id with a control character",
            post_job(spec(s, json!({"scene": "cornell\u{8}-box"}))),
            &[400],
        )
        .mentions("scene"),
        case(
            "job: a 65-byte algorithm name",
            post_job(spec(s, json!({"algorithm": "p".repeat(65)}))),
            &[400],
        )
        .mentions("algorithm"),
        case(
            "job: 20 KB of params",
            post_job(spec(
                s,
                json!({"params": {"max_depth": 3, "pad": "x".repeat(20_000)}}),
            )),
            &[400],
        )
        .mentions("params"),
        // What the service validates.
        case(
            "job: sweep set by the client",
            post_job(spec(s, json!({"sweep": "s0123456789ab"}))),
            &[400],
        )
        .mentions("sweep"),
        case(
            "job: snapshot_every.seconds 0.001",
            post_job(spec(s, json!({"snapshot_every": {"seconds": 0.001}}))),
            &[400],
        )
        .mentions("snapshot_every"),
        case(
            "job: snapshot_every.seconds 0",
            post_job(spec(s, json!({"snapshot_every": {"seconds": 0}}))),
            &[400],
        )
        .mentions("snapshot_every"),
        case(
            "job: snapshot_every.seconds -1",
            post_job(spec(s, json!({"snapshot_every": {"seconds": -1}}))),
            &[400],
        )
        .mentions("snapshot_every"),
        case(
            "job: snapshot_every.iterations 0",
            post_job(spec(s, json!({"snapshot_every": {"iterations": 0}}))),
            &[400],
        )
        .mentions("snapshot_every"),
        case(
            "job: halt with no limit {}",
            post_job(spec(s, json!({"halt": {}}))),
            &[400],
        )
        .mentions("halt"),
        case(
            "job: halt.spp 0",
            post_job(spec(s, json!({"halt": {"spp": 0}}))),
            &[400],
        )
        .mentions("halt"),
        case(
            "job: halt.iterations 0",
            post_job(spec(s, json!({"halt": {"iterations": 0}}))),
            &[400],
        )
        .mentions("halt"),
        case(
            "job: halt.target_rmse without a reference",
            post_job(spec(s, json!({"halt": {"target_rmse": 0.1}}))),
            &[400],
        )
        .mentions("reference"),
        case(
            "job: halt.target_rmse -1",
            post_job(spec(
                s,
                json!({"halt": {"target_rmse": -1}, "reference": {"upload": "0123456789abcdef"}}),
            )),
            &[400],
        )
        .mentions("target_rmse"),
        case(
            "job: halt.noise -1",
            post_job(spec(s, json!({"halt": {"noise": -1}}))),
            &[400],
        )
        .mentions("halt.noise"),
        case(
            "job: halt.noise for sppm, whose iterations are chained",
            post_job(spec(s, json!({"algorithm": "sppm", "halt": {"noise": 0.01}}))),
            &[400],
        )
        .mentions("halt.noise"),
        case(
            "job: halt.time_s -1",
            post_job(spec(s, json!({"halt": {"time_s": -1}}))),
            &[400],
        )
        .mentions("time_s"),
        case(
            "job: halt.time_s 0",
            post_job(spec(s, json!({"halt": {"time_s": 0}}))),
            &[400],
        )
        .mentions("time_s"),
        case(
            "job: halt.time_s the string \"NaN\"",
            post_job(spec(s, json!({"halt": {"time_s": "NaN"}}))),
            &[422],
        )
        .mentions("time_s"),
        case(
            "job: unknown algorithm vcmm",
            post_job(spec(s, json!({"algorithm": "vcmm"}))),
            &[400],
        )
        .mentions("vcmm"),
        case(
            "job: empty algorithm name",
            post_job(spec(s, json!({"algorithm": ""}))),
            &[400],
        ),
        case(
            "job: unknown parameter max_dept",
            post_job(spec(s, json!({"params": {"max_dept": 3}}))),
            &[400],
        )
        .mentions("max_dept"),
        case(
            "job: a parameter of another algorithm (radius_factor for pt)",
            post_job(spec(s, json!({"params": {"radius_factor": 0.1}}))),
            &[400],
        )
        .mentions("radius_factor"),
        case(
            "job: max_depth a string",
            post_job(spec(s, json!({"params": {"max_depth": "deep"}}))),
            &[400],
        )
        .mentions("max_depth"),
        case(
            "job: max_depth -1",
            post_job(spec(s, json!({"params": {"max_depth": -1}}))),
            &[400],
        )
        .mentions("max_depth"),
        case(
            "job: max_depth 1e30",
            post_job(spec(s, json!({"params": {"max_depth": 1e30}}))),
            &[400],
        )
        .mentions("max_depth"),
        // Unknown ids.
        case(
            "job: unknown scene id (16 hex digits)",
            post_job(spec("0123456789abcdef", json!({}))),
            &[404],
        )
        .mentions("scene"),
        case(
            "job: scene id ../../etc/passwd",
            post_job(spec("../../etc/passwd", json!({}))),
            &[404],
        ),
        case("job: empty scene id", post_job(spec("", json!({}))), &[404]),
        case(
            "job: the uploaded scene's id in upper case",
            post_job(spec(&s.to_uppercase(), json!({}))),
            &[404],
        ),
        case(
            "job: reference upload id that does not exist",
            post_job(spec(
                s,
                json!({"reference": {"upload": "0123456789abcdef"}}),
            )),
            &[404],
        )
        .mentions("reference"),
        case(
            "job: reference upload id ../../etc/passwd",
            post_job(spec(
                s,
                json!({"reference": {"upload": "../../etc/passwd"}}),
            )),
            &[404],
        ),
        case(
            "job: reference job that does not exist",
            post_job(spec(s, json!({"reference": {"job": "jnope"}}))),
            &[404],
        ),
        case(
            "job: reference job id ../jobs",
            post_job(spec(s, json!({"reference": {"job": "../jobs"}}))),
            &[404],
        ),
    ];
    // Sweeps.
    let base = json!({"scene": s, "halt": {"spp": 1}});
    let sweep = |grid: Value| json!({"base": base, "grid": grid}).to_string();
    let grid4: serde_json::Map<String, Value> = ["a", "b", "c", "d"]
        .iter()
        .map(|k| (format!("params.{k}"), json!((0..1000).collect::<Vec<_>>())))
        .collect();
    v.extend([
        case("sweep: grid priority [4294967297]", post_sweep(sweep(json!({"priority": [4294967297u64]}))), &[400]).mentions("priority"),
        case("sweep: grid priority [-2147483649]", post_sweep(sweep(json!({"priority": [-2147483649i64]}))), &[400]).mentions("priority"),
        case("sweep: grid seed [-1]", post_sweep(sweep(json!({"seed": [-1]}))), &[400]).mentions("seed"),
        case("sweep: grid halt.spp [1.5]", post_sweep(sweep(json!({"halt.spp": [1.5]}))), &[400]).mentions("halt.spp"),
        case("sweep: grid halt.spp [\"x\"]", post_sweep(sweep(json!({"halt.spp": ["x"]}))), &[400]).mentions("halt.spp"),
        case("sweep: grid halt.time_s [null]", post_sweep(sweep(json!({"halt.time_s": [null]}))), &[400]).mentions("halt.time_s"),
        case("sweep: grid algorithm [5]", post_sweep(sweep(json!({"algorithm": [5]}))), &[400]).mentions("algorithm"),
        case("sweep: grid algorithm [vcmm]", post_sweep(sweep(json!({"algorithm": ["vcmm"]}))), &[400]).mentions("vcmm"),
        case("sweep: grid unknown key radius", post_sweep(sweep(json!({"radius": [1]}))), &[400]).mentions("radius"),
        case("sweep: grid key params. with no name", post_sweep(sweep(json!({"params.": [1]}))), &[400]),
        case("sweep: empty grid", post_sweep(sweep(json!({}))), &[400]).mentions("grid"),
        case("sweep: a grid key with no values", post_sweep(sweep(json!({"seed": []}))), &[400]).mentions("seed"),
        case("sweep: a grid value that is not an array", post_sweep(sweep(json!({"seed": 1}))), &[422]).mentions("grid"),
        case("sweep: grid of 1001 points", post_sweep(sweep(json!({"seed": (0..1001).collect::<Vec<_>>()}))), &[400]).mentions("1000"),
        case("sweep: grid of 10^12 points", post_sweep(sweep(Value::Object(grid4))), &[400]).mentions("1000"),
        case("sweep: base an array", post_sweep(json!({"base": [s], "grid": {"seed": [1]}}).to_string()), &[422]).mentions("base"),
        case(
            "sweep: base.sweep set by the client",
            post_sweep(json!({"base": {"scene": s, "halt": {"spp": 1}, "sweep": "s0123456789ab"}, "grid": {"seed": [1]}}).to_string()),
            &[400],
        )
        .mentions("sweep"),
        case(
            "sweep: a 300-byte name",
            post_sweep(json!({"base": base, "grid": {"seed": [1]}, "name": "n".repeat(300)}).to_string()),
            &[400],
        )
        .mentions("name"),
        case(
            "sweep: a base without a halting rule",
            post_sweep(json!({"base": {"scene": s, "halt": {}}, "grid": {"seed": [1, 2]}}).to_string()),
            &[400],
        )
        .mentions("halt"),
        case("sweep: unknown field", post_sweep(json!({"base": base, "grid": {"seed": [1]}, "axes": 1}).to_string()), &[422]).mentions("axes"),
        case("sweep: the body an array", post_sweep("[1, 2]"), &[422]),
        case("sweep: malformed JSON", post_sweep(r#"{"base": {"#), &[400]),
    ]);
    v
}

/// Class 2: content types, methods and paths. `l` is the long job, `s` its scene.
fn method_path_cases(l: &str, s: &str) -> Vec<Case> {
    let job = spec(s, json!({}));
    let long_id = "j".repeat(8 << 10);
    vec![
        case(
            "POST /v1/jobs without a content-type",
            Req::post("/v1/jobs").bytes(&job),
            &[415],
        ),
        case(
            "POST /v1/jobs as text/plain",
            Req::post("/v1/jobs")
                .header("content-type", "text/plain")
                .bytes(&job),
            &[415],
        ),
        case(
            "POST /v1/jobs as form-urlencoded",
            Req::post("/v1/jobs")
                .header("content-type", "application/x-www-form-urlencoded")
                .bytes(&job),
            &[415],
        ),
        case(
            "POST /v1/jobs as application/xml",
            Req::post("/v1/jobs")
                .header("content-type", "application/xml")
                .bytes(&job),
            &[415],
        ),
        case(
            "POST /v1/sweeps without a content-type",
            Req::post("/v1/sweeps").bytes(&job),
            &[415],
        ),
        case("DELETE /v1/jobs", Req::new("DELETE", "/v1/jobs"), &[405]),
        case(
            "PUT /v1/jobs",
            Req::new("PUT", "/v1/jobs").json(&job),
            &[405],
        ),
        case(
            "PUT /v1/jobs/{long job}",
            Req::new("PUT", format!("/v1/jobs/{l}")).json(&job),
            &[405],
        ),
        case(
            "PATCH /v1/jobs/{long job}",
            Req::new("PATCH", format!("/v1/jobs/{l}")).json("{}"),
            &[405],
        ),
        case(
            "PUT /v1/scenes",
            Req::new("PUT", "/v1/scenes").bytes("{}"),
            &[405],
        ),
        case(
            "PUT /v1/scenes/{scene}",
            Req::new("PUT", format!("/v1/scenes/{s}")).bytes("{}"),
            &[405],
        ),
        case(
            "PUT /v1/references",
            Req::new("PUT", "/v1/references").bytes("x"),
            &[405],
        ),
        case("GET /v1/references", Req::get("/v1/references"), &[405]),
        case(
            "GET /v1/jobs/{long job}/cancel",
            Req::get(format!("/v1/jobs/{l}/cancel")),
            &[405],
        ),
        case(
            "DELETE /v1/jobs/{long job}/cancel",
            Req::new("DELETE", format!("/v1/jobs/{l}/cancel")),
            &[405],
        ),
        case(
            "POST /v1/jobs/{long job}/image.exr",
            Req::post(format!("/v1/jobs/{l}/image.exr")),
            &[405],
        ),
        case(
            "PUT /v1/sweeps",
            Req::new("PUT", "/v1/sweeps").json("{}"),
            &[405],
        ),
        case("POST /healthz", Req::post("/healthz"), &[405]),
        case(
            "POST /v1/algorithms",
            Req::post("/v1/algorithms").json("{}"),
            &[405],
        ),
        case("PUT /metrics", Req::new("PUT", "/metrics"), &[405]),
        case("OPTIONS /v1/jobs", Req::new("OPTIONS", "/v1/jobs"), &[405]),
        case(
            "custom method FOO /v1/jobs",
            Req::new("FOO", "/v1/jobs"),
            &[405],
        ),
        case("GET /v1/nope", Req::get("/v1/nope"), &[404]),
        case("GET /nope", Req::get("/nope"), &[404]),
        // The dashboard's page and files are public (they hold no data); anything
        // else under /dashboard is a 404, whatever it spells.
        case("GET / (the dashboard, no token)", Req::get("/"), &[200]),
        case("POST /", Req::post("/"), &[405]),
        case(
            "GET /dashboard/style.css",
            Req::get("/dashboard/style.css"),
            &[200],
        ),
        case("GET /dashboard/", Req::get("/dashboard/"), &[404]),
        case(
            "GET /dashboard/nope.js",
            Req::get("/dashboard/nope.js"),
            &[404],
        ),
        case(
            "GET /dashboard/..%2fhttp.rs",
            Req::get("/dashboard/..%2fhttp.rs"),
            &[404],
        ),
        case(
            "GET /dashboard/../Cargo.toml (raw dot segments)",
            Req::get("/dashboard/../Cargo.toml"),
            &[404],
        ),
        case(
            "GET /dashboard/%2e%2e%2f%2e%2e%2fCargo.toml",
            Req::get("/dashboard/%2e%2e%2f%2e%2e%2fCargo.toml"),
            &[404],
        ),
        case(
            "GET /dashboard/app.js%00.html",
            Req::get("/dashboard/app.js%00.html"),
            &[404],
        ),
        case("GET /v1", Req::get("/v1"), &[404]),
        case("GET /v1/", Req::get("/v1/"), &[404]),
        case(
            "GET /v1/jobs/ (trailing slash)",
            Req::get("/v1/jobs/"),
            &[404],
        ),
        case(
            "GET /v1/jobs/{long job}/nope",
            Req::get(format!("/v1/jobs/{l}/nope")),
            &[404],
        ),
        case(
            "GET /v1/jobs/../../etc/passwd (raw dot segments)",
            Req::get("/v1/jobs/../../etc/passwd"),
            &[404],
        ),
        case(
            "GET /v1/jobs/..%2f..%2fetc%2fpasswd",
            Req::get("/v1/jobs/..%2f..%2fetc%2fpasswd"),
            &[404],
        ),
        case("GET /v1/jobs/%2e%2e", Req::get("/v1/jobs/%2e%2e"), &[404]),
        case(
            "GET /v1/jobs/%2e%2e/log",
            Req::get("/v1/jobs/%2e%2e/log"),
            &[404],
        ),
        case(
            "GET /v1/jobs/%2e%2e%2fscenes/image.exr",
            Req::get("/v1/jobs/%2e%2e%2fscenes/image.exr"),
            &[404],
        ),
        case(
            "GET /v1/jobs/%2e%2e/snapshots",
            Req::get("/v1/jobs/%2e%2e/snapshots"),
            &[404],
        ),
        case(
            "GET /v1/scenes/%2e%2e",
            Req::get("/v1/scenes/%2e%2e"),
            &[404],
        ),
        case(
            "GET /v1/scenes/..%2f..%2fetc",
            Req::get("/v1/scenes/..%2f..%2fetc"),
            &[404],
        ),
        case(
            "DELETE /v1/scenes/..%2fjobs",
            Req::new("DELETE", "/v1/scenes/..%2fjobs"),
            &[404],
        ),
        case(
            "DELETE /v1/jobs/..%2fscenes",
            Req::new("DELETE", "/v1/jobs/..%2fscenes"),
            &[404],
        ),
        case(
            "GET /v1/sweeps/..%2f..%2fjobs",
            Req::get("/v1/sweeps/..%2f..%2fjobs"),
            &[404],
        ),
        case("GET /v1/sweeps/s%00", Req::get("/v1/sweeps/s%00"), &[404]),
        case(
            "GET /v1/sweeps/sABCDEF (upper-case hex)",
            Req::get("/v1/sweeps/sABCDEF"),
            &[404],
        ),
        case(
            "GET /v1/jobs/<8 KiB id>",
            Req::get(format!("/v1/jobs/{long_id}")),
            &[404],
        ),
        case(
            "GET /v1/scenes/<8 KiB id>",
            Req::get(format!("/v1/scenes/{long_id}")),
            &[404],
        ),
        case(
            "POST /v1/jobs/<8 KiB id>/cancel",
            Req::post(format!("/v1/jobs/{long_id}/cancel")),
            &[404],
        ),
        case(
            "GET /v1/jobs/j%00x (NUL in the id)",
            Req::get("/v1/jobs/j%00x"),
            &[404],
        ),
        case(
            "DELETE /v1/jobs/%00",
            Req::new("DELETE", "/v1/jobs/%00"),
            &[404],
        ),
        case("GET /v1/scenes/%00", Req::get("/v1/scenes/%00"), &[404]),
        case(
            "GET /v1/jobs/%ff%fe (not UTF-8)",
            Req::get("/v1/jobs/%ff%fe"),
            &[400],
        ),
        case(
            "GET /v1/scenes/%c0%af (overlong UTF-8 slash)",
            Req::get("/v1/scenes/%c0%af"),
            &[400],
        ),
        case(
            "GET /v1/jobs/{long job}/snapshots/%ff.exr",
            Req::get(format!("/v1/jobs/{l}/snapshots/%ff.exr")),
            &[400],
        ),
        case(
            "GET /v1/jobs/jnope/events",
            Req::get("/v1/jobs/jnope/events"),
            &[404],
        ),
        case(
            "GET /v1/jobs?state=bogus",
            Req::get("/v1/jobs?state=bogus"),
            &[400],
        )
        .mentions("bogus"),
        case(
            "GET /v1/jobs?limit=5 (unknown query field)",
            Req::get("/v1/jobs?limit=5"),
            &[400],
        )
        .mentions("limit"),
        case(
            "GET /v1/jobs?state=%ff",
            Req::get("/v1/jobs?state=%ff"),
            &[400],
        ),
        case(
            "GET /v1/jobs?state=running&state=queued",
            Req::get("/v1/jobs?state=running&state=queued"),
            &[400],
        ),
        case(
            "GET /v1/sweeps/s0?format=csv&x=1",
            Req::get("/v1/sweeps/s0?format=csv&x=1"),
            &[400],
        ),
    ]
}

/// Malformed HTTP, which hyper answers (or closes) before the router runs.
fn protocol_cases() -> Vec<Case> {
    vec![
        case(
            "protocol: a raw NUL byte in the request target",
            Req::get(&b"/v1/jobs/a\x00b"[..]),
            &[400],
        )
        .protocol(),
        case(
            "protocol: a raw space in the request target",
            Req::get("/v1/jobs/a b"),
            &[400],
        )
        .protocol(),
        case(
            "protocol: a header name with a space",
            Req::get("/v1/jobs").header("Bad Header", "x"),
            &[400],
        )
        .protocol(),
        case(
            "protocol: a header value with a raw control byte",
            Req::get("/v1/jobs").header("x-a", &b"a\x01b"[..]),
            &[400],
        )
        .protocol(),
        case(
            "protocol: Content-Length not a number",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .declared("abc", "{}"),
            &[400],
        )
        .protocol(),
        case(
            "protocol: two different Content-Length headers",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .header("Content-Length", "2")
                .header("Content-Length", "5")
                .raw_body("{}"),
            &[400],
        )
        .protocol(),
        case(
            "protocol: Content-Length beyond u64",
            Req::post("/v1/scenes").declared("99999999999999999999999", ""),
            &[400, 413],
        )
        .protocol(),
        case(
            "protocol: Content-Length and chunked together",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .header("Content-Length", "3")
                .header("Transfer-Encoding", "chunked")
                .raw_body("2\r\n{}\r\n0\r\n\r\n"),
            &[400, 422],
        )
        .protocol(),
        case(
            "protocol: a chunked body with a bad chunk size",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .header("Transfer-Encoding", "chunked")
                .raw_body("zz\r\n{}\r\n0\r\n\r\n"),
            &[400],
        )
        .protocol(),
        case(
            "protocol: a 512 KiB request target",
            Req::get(format!("/v1/jobs/{}", "a".repeat(512 << 10))),
            &[400, 414, 431],
        )
        .protocol(),
        case(
            "protocol: a 512 KiB header",
            Req::get("/v1/jobs").header("x-big", "b".repeat(512 << 10)),
            &[400, 431],
        )
        .protocol(),
        case(
            "protocol: 200 headers",
            (0..200).fold(Req::get("/v1/jobs"), |r, i| {
                r.header(&format!("x-h{i}"), "1")
            }),
            &[400, 431],
        )
        .protocol(),
        case(
            "protocol: HTTP/2.0 in an HTTP/1 request line",
            Req::new("GET", "/healthz HTTP/2.0\r\nX-Ignore:"),
            &[400, 505],
        )
        .protocol(),
    ]
}

/// Class 3: bodies too large.
fn size_cases(s: &str) -> Vec<Case> {
    let fast = Duration::from_millis(1000);
    let big_job = spec(s, json!({"name": "n".repeat(2 << 20)}));
    vec![
        case(
            "POST /v1/scenes declaring 1 byte more than the upload limit (head only)",
            Req::post("/v1/scenes").declared((UPLOAD_LIMIT + 1).to_string(), ""),
            &[413],
        )
        .within(fast)
        .mentions("at most"),
        case(
            "POST /v1/scenes with Expect: 100-continue, declaring more than the upload limit",
            Req::post("/v1/scenes")
                .header("Expect", "100-continue")
                .declared((UPLOAD_LIMIT + 1).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/scenes declaring 2^63 bytes (head only)",
            Req::post("/v1/scenes").declared((1u64 << 63).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/references declaring more than the upload limit (head only)",
            Req::post("/v1/references").declared((UPLOAD_LIMIT + 1).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/jobs declaring 2 MiB (head only)",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .declared((2 << 20).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/jobs declaring 1 MiB + 1 (head only)",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .declared((JSON_LIMIT + 1).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/sweeps declaring 2 MiB (head only)",
            Req::post("/v1/sweeps")
                .header("content-type", "application/json")
                .declared((2 << 20).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/jobs/jnope/cancel declaring 2 MiB (head only)",
            Req::post("/v1/jobs/jnope/cancel").declared((2 << 20).to_string(), ""),
            &[413],
        )
        .within(fast),
        case(
            "POST /v1/jobs with a 2 MiB body, honest Content-Length",
            post_job(&big_job),
            &[413],
        ),
        case(
            "POST /v1/jobs with a 2 MiB body, chunked",
            Req::post("/v1/jobs")
                .header("content-type", "application/json")
                .chunked(&big_job),
            &[413],
        ),
        case(
            "POST /v1/scenes with a body 1 MiB above the limit, honest Content-Length",
            upload(vec![b' '; UPLOAD_LIMIT + (1 << 20)]),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
        case(
            "POST /v1/scenes with a body 1 MiB above the limit, chunked",
            Req::post("/v1/scenes").chunked(vec![b' '; UPLOAD_LIMIT + (1 << 20)]),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
        case(
            "POST /v1/references with a body 1 MiB above the limit, chunked",
            Req::post("/v1/references").chunked(vec![0u8; UPLOAD_LIMIT + (1 << 20)]),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
    ]
}

/// Class 5: scene uploads (everything but the `mtllib` probes and huge EXR headers).
fn scene_cases() -> Vec<Case> {
    let t = tiny_scene(16);
    let set = |path: &[&str], v: Value| {
        let mut s = t.clone();
        let mut at = &mut s;
        for p in &path[..path.len() - 1] {
            at = if let Ok(i) = p.parse::<usize>() {
                &mut at[i]
            } else {
                &mut at[*p]
            };
        }
        let last = path[path.len() - 1];
        if v == "$remove" {
            at.as_object_mut().unwrap().remove(last);
        } else if let Ok(i) = last.parse::<usize>() {
            at[i] = v;
        } else {
            at[last] = v;
        }
        s.to_string()
    };
    let text = t.to_string();
    let with_obj = scene_with_mesh(t.clone(), "obj", "m/quad.obj");
    let with_ply = scene_with_mesh(t.clone(), "ply", "m/quad.ply");
    let with_env = scene_with_envmap(t.clone(), "env.exr");
    let mut with_vdb = t.clone();
    with_vdb["media"] =
        json!({"smoke": {"type": "grid", "file": "smoke.VDB", "sigma_t": [1, 1, 1]}});
    with_vdb["shapes"] = json!([{"type": "cube", "material": "m", "interior": "smoke"}]);
    let with_vdb = with_vdb.to_string();
    let valid_exr = exr(8, 4);
    let blob = text_blob(256 << 10);

    // A zip whose deflate data for one entry has a flipped bit.
    let good = zip(&[("scene.json", with_obj.as_bytes()), ("m/quad.obj", &blob)]);
    let (at, len) = zip_entry_data(&good, "m/quad.obj");
    let mut flipped = good.clone();
    flipped[at + len / 2] ^= 0x10;
    let mut truncated_zip = good.clone();
    truncated_zip.truncate(good.len() / 2);
    // A bomb: 2 MiB over the limit of zeros deflates to a few KiB.
    let zeros = vec![0u8; UPLOAD_LIMIT + (2 << 20)];
    let bomb = zip(&[("scene.json", text.as_bytes()), ("m/zeros.bin", &zeros)]);
    assert!(
        bomb.len() < UPLOAD_LIMIT / 100,
        "the bomb is small: {}",
        bomb.len()
    );
    // Several entries that together expand beyond the limit.
    let quarter = vec![0u8; UPLOAD_LIMIT / 4 + 1];
    let bombs = zip(&[
        ("scene.json", text.as_bytes()),
        ("a.bin", &quarter),
        ("b.bin", &quarter),
        ("c.bin", &quarter),
        ("d.bin", &quarter),
    ]);
    let tar_scene = file("scene.json", text.as_bytes());
    let mut truncated_tar = tar(&[
        file("scene.json", text.as_bytes()),
        file("m/quad.obj", QUAD_OBJ),
    ]);
    truncated_tar.truncate(512 + text.len() / 2);
    let deep_path = format!("{}x.obj", "d/".repeat(2100));

    vec![
        // Not a scene at all.
        case(
            "scene: garbage bytes",
            upload(b"\x00\x01garbage\xff"),
            &[400],
        ),
        case("scene: empty body", upload(b""), &[400]),
        case("scene: only whitespace", upload(b"  \n\t "), &[400]),
        case("scene: a JSON array", upload(b"[1, 2]"), &[400]),
        case(
            "scene: a PNG",
            upload(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR"),
            &[400],
        ),
        // JSON scenes with errors: 422 naming the field, no server path.
        case(
            "scene: truncated JSON document",
            upload(&text[..text.len() / 2]),
            &[422],
        ),
        case("scene: a lone {", upload(b"{"), &[422]),
        case("scene: {}", upload(b"{}"), &[422]),
        case(
            "scene: missing camera",
            upload(set(&["camera"], json!("$remove"))),
            &[422],
        )
        .mentions("camera"),
        case(
            "scene: missing film",
            upload(set(&["film"], json!("$remove"))),
            &[422],
        )
        .mentions("film"),
        case(
            "scene: negative film width",
            upload(set(&["film", "width"], json!(-32))),
            &[422],
        )
        .mentions("film.width"),
        case(
            "scene: film height 0",
            upload(set(&["film", "height"], json!(0))),
            &[422],
        )
        .mentions("film.height"),
        case(
            "scene: film 100000x100000",
            upload(set(&["film"], json!({"width": 100000, "height": 100000}))),
            &[422],
        )
        .mentions("film"),
        case(
            "scene: film width 2^32",
            upload(set(&["film", "width"], json!(4294967296u64))),
            &[422],
        )
        .mentions("film.width"),
        case(
            "scene: format 2",
            upload(set(&["format"], json!(2))),
            &[422],
        )
        .mentions("format"),
        case(
            "scene: unknown top-level field",
            upload(set(&["colour"], json!(1))),
            &[422],
        )
        .mentions("colour"),
        case(
            "scene: unknown material name",
            upload(set(&["shapes", "0", "material"], json!("glas"))),
            &[422],
        )
        .mentions("shapes[0].material"),
        case(
            "scene: unknown shape type",
            upload(set(&["shapes", "0", "type"], json!("torus"))),
            &[422],
        )
        .mentions("shapes[0]"),
        case(
            "scene: negative sphere radius",
            upload(set(&["shapes", "0", "radius"], json!(-1))),
            &[422],
        )
        .mentions("radius"),
        case(
            "scene: light intensity 1e999",
            upload(text.replace("[8,8,8]", "[1e999,8,8]")),
            &[422],
        ),
        case(
            "scene: shapes an object",
            upload(set(&["shapes"], json!({"a": 1}))),
            &[422],
        )
        .mentions("shapes"),
        case(
            "scene: integrator nested 100000 arrays deep",
            upload(text.replacen(
                '{',
                &format!(
                    "{{\"integrator\": {}{}, ",
                    "[".repeat(100_000),
                    "]".repeat(100_000)
                ),
                1,
            )),
            &[422],
        ),
        case(
            "scene: mesh filename /etc/passwd",
            upload(scene_with_mesh(t.clone(), "obj", "/etc/passwd")),
            &[422],
        )
        .mentions("filename"),
        case(
            "scene: mesh filename ../../../../etc/passwd",
            upload(scene_with_mesh(t.clone(), "obj", "../../../../etc/passwd")),
            &[422],
        )
        .mentions("filename"),
        case(
            "scene: ply filename /dev/zero",
            upload(scene_with_mesh(t.clone(), "ply", "/dev/zero")),
            &[422],
        )
        .mentions("filename"),
        case(
            "scene: envmap filename /dev/zero",
            upload(scene_with_envmap(t.clone(), "/dev/zero")),
            &[422],
        )
        .mentions("filename"),
        case(
            "scene: a JSON document naming a mesh file it does not carry",
            upload(&with_obj),
            &[422],
        )
        .mentions("filename"),
        case(
            "scene: mesh filename empty",
            upload(scene_with_mesh(t.clone(), "obj", "")),
            &[422],
        )
        .mentions("filename"),
        // Tar bundles.
        case(
            "tar: entry ../evil.obj",
            upload(tar(&[
                tar_scene_again(&text),
                file("../evil.obj", b"v 0 0 0"),
            ])),
            &[400],
        )
        .mentions("../evil.obj"),
        case(
            "tar: entry m/../../evil.obj",
            upload(tar(&[
                tar_scene_again(&text),
                file("m/../../evil.obj", b"v 0 0 0"),
            ])),
            &[400],
        )
        .mentions("evil.obj"),
        case(
            "tar: absolute entry /etc/evil",
            upload(tar(&[tar_scene_again(&text), file("/etc/evil", b"x")])),
            &[400],
        )
        .mentions("/etc/evil"),
        case(
            "tar: symbolic link m/quad.obj -> /etc/passwd",
            upload(tar(&[
                TarEntry {
                    name: b"m/quad.obj",
                    kind: tar::EntryType::Symlink,
                    data: b"",
                    claimed_size: None,
                    link: b"/etc/passwd",
                },
                file("scene.json", with_obj.as_bytes()),
            ])),
            &[400],
        )
        .mentions("link"),
        case(
            "tar: hard link m/quad.obj -> /etc/passwd",
            upload(tar(&[
                TarEntry {
                    name: b"m/quad.obj",
                    kind: tar::EntryType::Link,
                    data: b"",
                    claimed_size: None,
                    link: b"/etc/passwd",
                },
                file("scene.json", with_obj.as_bytes()),
            ])),
            &[400],
        )
        .mentions("link"),
        case(
            "tar: character device entry",
            upload(tar(&[
                tar_scene_again(&text),
                TarEntry {
                    name: b"zero",
                    kind: tar::EntryType::Char,
                    data: b"",
                    claimed_size: None,
                    link: b"",
                },
            ])),
            &[400],
        ),
        case(
            "tar: FIFO entry",
            upload(tar(&[
                tar_scene_again(&text),
                TarEntry {
                    name: b"pipe",
                    kind: tar::EntryType::Fifo,
                    data: b"",
                    claimed_size: None,
                    link: b"",
                },
            ])),
            &[400],
        ),
        case(
            "tar: an entry claiming 1 TiB with 10 bytes of data",
            upload(tar(&[
                tar_scene_again(&text),
                TarEntry {
                    name: b"big.bin",
                    kind: tar::EntryType::Regular,
                    data: b"0123456789",
                    claimed_size: Some(1 << 40),
                    link: b"",
                },
            ])),
            &[400, 413],
        ),
        case(
            "tar: scene.json claiming 8 GiB with its real text",
            upload(tar(&[TarEntry {
                name: b"scene.json",
                kind: tar::EntryType::Regular,
                data: text.as_bytes(),
                claimed_size: Some(8 << 30),
                link: b"",
            }])),
            &[400, 413],
        ),
        case(
            "tar: truncated in the middle of scene.json",
            upload(&truncated_tar),
            &[400],
        ),
        case(
            "tar: GNU long name climbing out with ..",
            upload(tar_concat(&[
                tar(&[tar_scene_again(&text)]),
                tar_long_name(
                    &format!("{}/../../../../evil.obj", "a".repeat(120)),
                    b"v 0 0 0",
                ),
            ])),
            &[400],
        )
        .mentions("evil.obj"),
        case(
            "tar: a scene's .vdb grid that is no OpenVDB file",
            upload(tar(&[
                file("scene.json", with_vdb.as_bytes()),
                file("smoke.VDB", b"x"),
            ])),
            &[422],
        )
        .mentions("smoke.VDB"),
        case(
            "tar: no scene.json",
            upload(tar(&[file("m/quad.obj", QUAD_OBJ)])),
            &[400],
        )
        .mentions("scene.json"),
        case(
            "tar: two top-level .json files",
            upload(tar(&[
                file("a.json", text.as_bytes()),
                file("b.json", text.as_bytes()),
            ])),
            &[400],
        )
        .mentions("scene.json"),
        case(
            "tar: scene.json is a directory",
            upload(tar(&[
                TarEntry {
                    name: b"scene.json/",
                    kind: tar::EntryType::Directory,
                    data: b"",
                    claimed_size: None,
                    link: b"",
                },
                file("scene.json/x", b"y"),
            ])),
            &[400, 422],
        ),
        case(
            "tar: a file where the bundle needs a directory (m, then m/quad.obj)",
            upload(tar(&[
                file("scene.json", with_obj.as_bytes()),
                file("m", b"x"),
                file("m/quad.obj", QUAD_OBJ),
            ])),
            &[400, 422],
        ),
        case(
            "tar: an entry name with a 300-byte component",
            upload(tar_concat(&[
                tar(&[tar_scene_again(&text)]),
                tar_long_name(&format!("{}.obj", "a".repeat(300)), b"v 0 0 0"),
            ])),
            &[400],
        ),
        case(
            "tar: an entry 2100 directories deep (path beyond PATH_MAX)",
            upload(tar_concat(&[
                tar(&[tar_scene_again(&text)]),
                tar_long_name(&deep_path, b"v 0 0 0"),
            ])),
            &[400],
        ),
        case(
            "tar: ustar magic over garbage headers",
            upload(
                [
                    vec![0xAAu8; 257],
                    b"ustar\x0000".to_vec(),
                    vec![0x55u8; 1024],
                ]
                .concat(),
            ),
            &[400],
        ),
        case(
            "tar: a JSON scene that is truncated",
            upload(tar(&[file(
                "scene.json",
                &text.as_bytes()[..text.len() / 2],
            )])),
            &[422],
        ),
        case(
            "tar: an OBJ that does not parse (v a b c)",
            upload(tar(&[
                file("scene.json", with_obj.as_bytes()),
                file("m/quad.obj", b"v a b c\nf 1 2 3\n"),
            ])),
            &[422],
        )
        .mentions("shapes[1]"),
        case(
            "tar: an OBJ whose face indexes a missing vertex",
            upload(tar(&[
                file("scene.json", with_obj.as_bytes()),
                file("m/quad.obj", b"v 0 0 0\nf 1 2 99\n"),
            ])),
            &[422],
        )
        .mentions("shapes[1]"),
        case(
            "tar: a PLY that does not parse",
            upload(tar(&[
                file("scene.json", with_ply.as_bytes()),
                file("m/quad.ply", b"ply\nformat ascii 1.0\nelement vertex x\n"),
            ])),
            &[422],
        )
        .mentions("shapes[1]"),
        case(
            "tar: the mesh file is a directory",
            upload(tar(&[
                file("scene.json", with_obj.as_bytes()),
                TarEntry {
                    name: b"m/quad.obj/",
                    kind: tar::EntryType::Directory,
                    data: b"",
                    claimed_size: None,
                    link: b"",
                },
            ])),
            &[422],
        )
        .mentions("shapes[1]"),
        case(
            "tar: envmap EXR truncated to half",
            upload(tar(&[
                file("scene.json", with_env.as_bytes()),
                file("env.exr", &valid_exr[..valid_exr.len() / 2]),
            ])),
            &[422],
        )
        .mentions("lights[0]"),
        case(
            "tar: envmap that is not an EXR",
            upload(tar(&[
                file("scene.json", with_env.as_bytes()),
                file("env.exr", b"not an image"),
            ])),
            &[422],
        )
        .mentions("lights[0]"),
        // Zip bundles.
        case("zip: truncated to half", upload(&truncated_zip), &[400]),
        case(
            "zip: a bit flipped in a deflate entry",
            upload(&flipped),
            &[400],
        )
        .mentions("m/quad.obj"),
        case(
            "zip: a bomb expanding 2 MiB beyond the upload limit",
            upload(&bomb),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
        case(
            "zip: four entries expanding together beyond the upload limit",
            upload(&bombs),
            &[413],
        )
        .timeout(Duration::from_secs(20)),
        case(
            "zip: entry ../m/quad.obj",
            upload(zip(&[
                ("scene.json", with_obj.as_bytes()),
                ("../m/quad.obj", QUAD_OBJ),
            ])),
            &[400],
        )
        .mentions("../m/quad.obj"),
        case(
            "zip: absolute entry /etc/evil",
            upload(zip(&[("scene.json", text.as_bytes()), ("/etc/evil", b"x")])),
            &[400],
        )
        .mentions("/etc/evil"),
        case(
            "zip: symbolic link m/quad.obj -> /etc/passwd",
            upload(zip_symlink(&with_obj, "m/quad.obj", "/etc/passwd")),
            &[400],
        )
        .mentions("link"),
        case(
            "zip: encrypted entries (flag bit 0)",
            upload(zip_set_flags(zip(&[("scene.json", text.as_bytes())]), 1)),
            &[400],
        ),
        case(
            "zip: an unsupported compression method (LZMA)",
            upload(zip_set_method(zip(&[("scene.json", text.as_bytes())]), 14)),
            &[400],
        ),
        case(
            "zip: end record claiming 65535 entries",
            upload(zip_claim_entries(
                zip(&[("scene.json", text.as_bytes())]),
                65535,
            )),
            &[400],
        ),
        case(
            "zip: local header magic then garbage",
            upload([&b"PK\x03\x04"[..], &[0xEEu8; 600]].concat()),
            &[400],
        ),
        case(
            "zip: an entry name with a NUL byte",
            upload(zip(&[
                ("scene.json", text.as_bytes()),
                ("a\0b.obj", QUAD_OBJ),
            ])),
            &[400],
        ),
        case(
            "zip: an entry name with a 300-byte component",
            upload(zip(&[
                ("scene.json", text.as_bytes()),
                (&format!("{}.obj", "a".repeat(300)), QUAD_OBJ),
            ])),
            &[400],
        ),
        case(
            "zip: an entry 2100 directories deep (path beyond PATH_MAX)",
            upload(zip(&[
                ("scene.json", text.as_bytes()),
                (&deep_path, QUAD_OBJ),
            ])),
            &[400],
        ),
        case(
            "zip: a file where the bundle needs a directory (m, then m/quad.obj)",
            upload(zip(&[
                ("scene.json", with_obj.as_bytes()),
                ("m", b"x"),
                ("m/quad.obj", QUAD_OBJ),
            ])),
            &[400, 422],
        ),
        case(
            "zip: an OBJ that does not parse",
            upload(zip(&[
                ("scene.json", with_obj.as_bytes()),
                ("m/quad.obj", b"v a b c\nf 1 2 3\n"),
            ])),
            &[422],
        )
        .mentions("shapes[1]"),
    ]
    .into_iter()
    .chain(std::iter::once(case(
        "tar: scene.json only, as a control (valid upload)",
        upload(tar(&[tar_scene])),
        &[201],
    )))
    .collect()
}

/// Issue 36: the memory-heavy job (`vpl` with 2^24 light paths per iteration on a 256 x
/// 256 film: 1.2 GiB resident when it ran) is refused at once with its figure and the
/// parameter behind it, alone and in a sweep.
fn memory_section(b: &mut Battery) {
    let scene = tiny_scene(256).to_string();
    let Some(r) = b.run(case(
        "scene: 256x256, for the memory cases",
        upload(scene),
        &[201],
    )) else {
        return;
    };
    let Some(s) = r.json().and_then(|v| v["id"].as_str().map(String::from)) else {
        return;
    };
    let heavy = json!({"count": 16777216});
    let quick = Duration::from_secs(10);
    b.run_all(vec![
        case(
            "job: vpl with light_paths.count 2^24 on 256x256 (memory above --max-job-mib)",
            post_job(spec(
                &s,
                json!({"algorithm": "vpl", "params": {"light_paths": heavy}}),
            )),
            &[400],
        )
        .mentions("light_paths.count = 16777216 needs about")
        .within(quick),
        case(
            "sweep: one of its vpl jobs above --max-job-mib",
            post_sweep(
                json!({"base": {"scene": s, "algorithm": "vpl", "halt": {"spp": 1}},
                       "grid": {"params.light_paths": [{"count": 16}, heavy]}})
                .to_string(),
            ),
            &[400],
        )
        .mentions("--max-job-mib")
        .within(quick),
    ]);
}

fn tar_scene_again(text: &str) -> TarEntry<'_> {
    file("scene.json", text.as_bytes())
}

/// Issue 36: scenes of coincident primitives, on which the BVH build was quadratic
/// (32,768 copies of one triangle in a 256 KB OBJ took 40 s, 16,384 copies of one
/// sphere 14.5 s, while the long job renders). Each must be answered quickly: accepted
/// (the build is O(n log n) now) or refused with a 4xx.
fn coincident_primitive_cases() -> Vec<Case> {
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    obj.push_str(&"f 1 2 3\n".repeat(32_768));
    let with_obj = scene_with_mesh(tiny_scene(16), "obj", "copies.obj");
    let bundle = tar(&[
        file("scene.json", with_obj.as_bytes()),
        file("copies.obj", obj.as_bytes()),
    ]);
    let mut spheres = tiny_scene(16);
    let sphere = json!({"type": "sphere", "radius": 0.5, "material": "m"});
    spheres["shapes"] = Value::Array(vec![sphere; 16_384]);
    let quick = |c: Case| {
        c.timeout(Duration::from_secs(60))
            .within(Duration::from_secs(10))
    };
    vec![
        quick(case(
            "tar: an OBJ of 32,768 copies of one triangle (256 KB)",
            upload(bundle),
            &[201, 413, 422],
        )),
        quick(case(
            "scene: 16,384 copies of one sphere",
            upload(spheres.to_string()),
            &[201, 413, 422],
        )),
    ]
}

/// Class 6: references (everything but the huge EXR header).
fn reference_cases() -> Vec<Case> {
    let e = exr(8, 4);
    let post_ref = |b: &[u8]| Req::post("/v1/references").bytes(b);
    vec![
        case("reference: garbage", post_ref(b"\x00garbage"), &[400]).mentions("reference"),
        case("reference: empty", post_ref(b""), &[400]).mentions("reference"),
        case(
            "reference: an EXR truncated to half",
            post_ref(&e[..e.len() / 2]),
            &[400],
        )
        .mentions("reference"),
        case(
            "reference: an EXR cut after its magic number",
            post_ref(&e[..4]),
            &[400],
        )
        .mentions("reference"),
        case(
            "reference: a PNG",
            post_ref(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR"),
            &[400],
        )
        .mentions("reference"),
        case(
            "reference: a JSON scene",
            post_ref(tiny_scene(8).to_string().as_bytes()),
            &[400],
        )
        .mentions("reference"),
    ]
}

/// Class 7: job operations in the wrong state. `q1` cancelled, `q2` queued, `c`
/// completed, `l` running.
fn state_cases(l: &str, q1: &str, q2: &str, c: &str) -> Vec<Case> {
    let p = |path: String| Req::post(path);
    let mut v = vec![
        case(
            "cancel a cancelled job (cancel twice)",
            p(format!("/v1/jobs/{q1}/cancel")),
            &[409],
        ),
        case(
            "pause a cancelled job",
            p(format!("/v1/jobs/{q1}/pause")),
            &[409],
        ),
        case(
            "resume a cancelled job",
            p(format!("/v1/jobs/{q1}/resume")),
            &[409],
        ),
        case(
            "resume a queued job",
            p(format!("/v1/jobs/{q2}/resume")),
            &[409],
        ),
        case(
            "retry a queued job",
            p(format!("/v1/jobs/{q2}/retry")),
            &[409],
        ),
        case(
            "retry a completed job",
            p(format!("/v1/jobs/{c}/retry")),
            &[409],
        ),
        case(
            "cancel a completed job",
            p(format!("/v1/jobs/{c}/cancel")),
            &[409],
        ),
        case(
            "pause a completed job",
            p(format!("/v1/jobs/{c}/pause")),
            &[409],
        ),
        case(
            "resume a completed job",
            p(format!("/v1/jobs/{c}/resume")),
            &[409],
        ),
        case(
            "cancel a job that does not exist",
            p("/v1/jobs/jnope/cancel".into()),
            &[404],
        ),
        case(
            "pause a job that does not exist",
            p("/v1/jobs/jnope/pause".into()),
            &[404],
        ),
        case(
            "resume a job that does not exist",
            p("/v1/jobs/jnope/resume".into()),
            &[404],
        ),
        case(
            "retry a job that does not exist",
            p("/v1/jobs/jnope/retry".into()),
            &[404],
        ),
        case(
            "DELETE a job that does not exist",
            Req::new("DELETE", "/v1/jobs/jnope"),
            &[404],
        ),
        case(
            "DELETE a scene that does not exist",
            Req::new("DELETE", "/v1/scenes/0123456789abcdef"),
            &[404],
        ),
        case(
            "DELETE the built-in scene cornell-box",
            Req::new("DELETE", "/v1/scenes/cornell-box"),
            &[409],
        ),
        case(
            "preview of a job that does not exist",
            Req::get("/v1/jobs/jnope/preview.png"),
            &[404],
        ),
        case(
            "log of a job that does not exist",
            Req::get("/v1/jobs/jnope/log"),
            &[404],
        ),
        case(
            "snapshots of a job that does not exist",
            Req::get("/v1/jobs/jnope/snapshots"),
            &[404],
        ),
        case(
            "image of a queued job (not written yet)",
            Req::get(format!("/v1/jobs/{q2}/image.exr")),
            &[404],
        ),
    ];
    for job in [l, c] {
        let who = if job == l { "running" } else { "completed" };
        for (file, want) in [
            ("abc", 400),
            ("x.exr", 400),
            ("1.tiff", 400),
            ("1.json", 400),
            ("-1.exr", 400),
            ("99999999999999999999.exr", 400),
            ("1.exr.png", 400),
            (".exr", 400),
            ("1.", 400),
            ("1", 400),
            ("..%2f..%2fjob.json", 400),
            ("..%2fjob.json", 400),
            ("7.exr", 404),
        ] {
            v.push(case(
                format!("snapshot file {file:?} of the {who} job"),
                Req::get(format!("/v1/jobs/{job}/snapshots/{file}")),
                &[want],
            ));
        }
        for q in [
            "exposure=nan",
            "exposure=NaN",
            "exposure=1e9",
            "exposure=inf",
            "exposure=-inf",
            "exposure=65",
            "exposure=abc",
            "exposure=",
            "exposure=1&exposure=2",
            "gamma=2",
        ] {
            v.push(case(
                format!("preview.png?{q} of the {who} job"),
                Req::get(format!("/v1/jobs/{job}/preview.png?{q}")),
                &[400],
            ));
        }
    }
    v
}

/// Class 8: a server with `--token secret`.
fn auth_cases(s: &str) -> Vec<Case> {
    let g = |path: &str, auth: Option<&[u8]>| {
        let r = Req::get(path);
        match auth {
            Some(a) => r.header("Authorization", a),
            None => r,
        }
    };
    vec![
        case("auth: no Authorization header", g("/v1/jobs", None), &[401]),
        case(
            "auth: wrong token",
            g("/v1/jobs", Some(b"Bearer wrong")),
            &[401],
        ),
        case(
            "auth: a prefix of the token",
            g("/v1/jobs", Some(b"Bearer secre")),
            &[401],
        ),
        case(
            "auth: the token twice",
            g("/v1/jobs", Some(b"Bearer secretsecret")),
            &[401],
        ),
        case(
            "auth: Bearer with no token",
            g("/v1/jobs", Some(b"Bearer")),
            &[401],
        ),
        case(
            "auth: Bearer and an empty token",
            g("/v1/jobs", Some(b"Bearer  ")),
            &[401],
        ),
        // RFC 7235 sec. 2.1: credentials = auth-scheme [ 1*SP token68 ], so more than
        // one space may stand before the token (gRPC always took it; REST now does).
        case(
            "auth: two spaces before the token",
            g("/v1/jobs", Some(b"Bearer  secret")),
            &[200],
        ),
        case(
            "auth: a space inside the token",
            g("/v1/jobs", Some(b"Bearer sec ret")),
            &[401],
        ),
        case(
            "auth: Basic scheme",
            g("/v1/jobs", Some(b"Basic c2VjcmV0")),
            &[401],
        ),
        case(
            "auth: token only, no scheme",
            g("/v1/jobs", Some(b"secret")),
            &[401],
        ),
        case(
            "auth: non-ASCII bytes in the header",
            g("/v1/jobs", Some(b"Bearer s\xc3\xa9cret")),
            &[401],
        ),
        case(
            "auth: a 10 KB token",
            g(
                "/v1/jobs",
                Some(format!("Bearer {}", "s".repeat(10_000)).as_bytes()),
            ),
            &[401],
        ),
        case(
            "auth: /metrics without a token",
            g("/metrics", None),
            &[401],
        ),
        case(
            "auth: openapi.json without a token",
            g("/v1/openapi.json", None),
            &[401],
        ),
        case(
            "auth: algorithms without a token",
            g("/v1/algorithms", None),
            &[401],
        ),
        case(
            "auth: GET a job without a token",
            g("/v1/jobs/jnope", None),
            &[401],
        ),
        case(
            "auth: POST /v1/jobs without a token",
            post_job(spec(s, json!({}))),
            &[401],
        ),
        case(
            "auth: POST /v1/scenes without a token",
            upload(tiny_scene(8).to_string()),
            &[401],
        ),
        case(
            "auth: DELETE a scene without a token",
            Req::new("DELETE", "/v1/scenes/cornell-box"),
            &[401],
        ),
        case(
            "auth: cancel without a token",
            Req::post("/v1/jobs/jnope/cancel"),
            &[401],
        ),
        case(
            "auth: wrong token on an unknown endpoint",
            g("/v1/nope", Some(b"Bearer wrong")),
            &[401, 404],
        ),
        case(
            "auth: POST /v1/scenes declaring 300 MiB without a token (default 256 MiB limit)",
            Req::post("/v1/scenes").declared((300u64 << 20).to_string(), ""),
            &[401, 413],
        )
        .within(Duration::from_secs(1)),
        // Not bad requests: /healthz needs no token, and the right token works.
        case(
            "auth: /healthz without a token is 200",
            g("/healthz", None),
            &[200],
        ),
        case(
            "auth: /healthz with a wrong token is 200",
            g("/healthz", Some(b"Bearer wrong")),
            &[200],
        ),
        case(
            "auth: the right token is 200",
            g("/v1/jobs", Some(b"Bearer secret")),
            &[200],
        ),
    ]
}

// ---- checks that take their own shape -----------------------------------------

/// Opens a connection, sends `prefix` (maybe nothing) and waits: the server must close
/// it (or answer 408) within its header timeout.
fn slow_client(url: &str, what: &str, prefix: &[u8]) -> Result<String, String> {
    let mut s = TcpStream::connect(wire::addr_of(url)).map_err(|e| format!("{what}: {e}"))?;
    let start = Instant::now();
    if !prefix.is_empty() {
        let _ = s.write_all(prefix);
    }
    let limit = SERVER_TIMEOUT + SLACK;
    match wire::read_answer(&s, start, limit) {
        Outcome::Closed { elapsed, .. } => Ok(format!("{what}: closed after {elapsed:.1?}")),
        Outcome::Answered(r) if r.status == 408 || r.status == 400 => {
            if r.json().is_none() && !r.body.is_empty() {
                return Err(format!(
                    "{what}: answered {} with a body that is not JSON: {}",
                    r.status,
                    r.text()
                ));
            }
            Ok(format!(
                "{what}: answered {} after {:.1?}",
                r.status, r.elapsed
            ))
        }
        other => Err(format!(
            "{what}: expected the server to close the connection within {limit:?}; got {}",
            other.describe()
        )),
    }
}

/// A Content-Length larger than the body sent, then silence: the server must answer
/// 408 or 400 (JSON) or close within its body timeout.
fn lying_body(url: &str, what: &str, req: Req, forbidden: &[String]) -> Result<String, String> {
    let limit = SERVER_TIMEOUT + SLACK;
    match send(url, &req, limit) {
        Outcome::Closed { elapsed, .. } => Ok(format!("{what}: closed after {elapsed:.1?}")),
        Outcome::Answered(r) if r.status == 408 || r.status == 400 => {
            let v = r.json().unwrap_or(Value::Null);
            if v["error"]["message"].as_str().is_none()
                || !r
                    .header("content-type")
                    .unwrap_or("")
                    .starts_with("application/json")
            {
                return Err(format!(
                    "{what}: answered {} without a JSON error body: {}",
                    r.status,
                    r.text()
                ));
            }
            if let Some(f) = forbidden.iter().find(|f| r.text().contains(f.as_str())) {
                return Err(format!(
                    "{what}: the answer names a server path ({f:?}): {}",
                    r.text()
                ));
            }
            Ok(format!(
                "{what}: answered {} after {:.1?}: {}",
                r.status,
                r.elapsed,
                clip(&r.text(), 200)
            ))
        }
        other => Err(format!(
            "{what}: expected 408/400 or a close within {limit:?}; got {}",
            other.describe()
        )),
    }
}

/// `mtllib` naming a FIFO outside the bundle: if the server opens it (absolute or
/// through `..`), its open blocks until this side opens the FIFO for writing, which
/// is how the probe sees it. Returns whether the server opened it.
fn mtllib_probe(b: &mut Battery, name: &str, fifo: &Path, mtllib: &str) -> bool {
    use std::os::unix::fs::OpenOptionsExt;
    let scene = scene_with_mesh(tiny_scene(16), "obj", "m/quad.obj");
    let obj = [format!("mtllib {mtllib}\n").as_bytes(), QUAD_OBJ].concat();
    let body = tar(&[
        file("scene.json", scene.as_bytes()),
        file("m/quad.obj", &obj),
    ]);
    let (tx, rx) = std::sync::mpsc::channel();
    let url = b.url.clone();
    let c = case(name, upload(&body), &[201, 400, 422])
        .echo(mtllib)
        .echo(fifo.display().to_string());
    let req = c.req.clone();
    std::thread::spawn(move || {
        let _ = tx.send(send(&url, &req, Duration::from_secs(20)));
    });
    let mut opened = false;
    let out = loop {
        if let Ok(out) = rx.recv_timeout(Duration::from_millis(5)) {
            break out;
        }
        if let Ok(f) = std::fs::OpenOptions::new()
            .write(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(fifo)
        {
            // A reader has the FIFO open: the server. Closing gives it end-of-file.
            opened = true;
            drop(f);
        }
    };
    let mut problems = b.check(&c, &out);
    if opened {
        problems.push(format!(
            "THE SERVER OPENED {} (named by mtllib {mtllib:?}, outside the bundle)",
            fifo.display()
        ));
    }
    b.log(name, &c.req.describe(), &out, &problems);
    if !problems.is_empty() {
        b.fail(format!(
            "{name}: {}; got {}",
            problems.join("; "),
            out.describe()
        ));
    }
    b.run += 1;
    opened
}

/// Many idle connections at once must not stop the server answering.
fn many_idle_connections(b: &mut Battery, long: &str) {
    for (what, prefix) in [
        ("200 idle connections that send nothing", &b""[..]),
        (
            "200 connections that send half a request head",
            &b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\n"[..],
        ),
    ] {
        let mut conns = Vec::new();
        for _ in 0..200 {
            match TcpStream::connect(wire::addr_of(&b.url)) {
                Ok(mut s) => {
                    let _ = s.write_all(prefix);
                    conns.push(s);
                }
                Err(e) => {
                    b.fail(format!("{what}: connection {} refused: {e}", conns.len()));
                    break;
                }
            }
        }
        for (path, want) in [
            ("/healthz".to_string(), 200),
            (format!("/v1/jobs/{long}"), 200),
            ("/v1/nope".into(), 404),
        ] {
            let c = case(format!("{what}, then GET {path}"), Req::get(&path), &[want])
                .within(Duration::from_secs(3));
            b.run(c);
        }
        drop(conns);
    }
}

// ---- the test ---------------------------------------------------------------

#[test]
fn bad_request_battery() {
    let t0 = Instant::now();
    let data = tempfile::tempdir().unwrap();
    let auth_data = tempfile::tempdir().unwrap();
    let probe_dir = tempfile::tempdir().unwrap();
    let upload_mib = UPLOAD_MIB.to_string();
    let timeout = SERVER_TIMEOUT.as_secs().to_string();
    let p = start(
        data.path(),
        &[
            "--max-upload-mib",
            &upload_mib,
            "--request-timeout",
            &timeout,
            "--max-job-mib",
            JOB_MIB,
        ],
    );
    let auth = start(auth_data.path(), &["--token", "secret"]);
    let failures = Arc::new(Mutex::new(Vec::<String>::new()));
    let mut b = Battery::new(&p, data.path(), failures.clone(), "main");

    // The slow checks wait for the server's 30 s timeouts: on their own threads from
    // the start, while everything else runs.
    let forbidden = b.forbidden.clone();
    let slow: Vec<std::thread::JoinHandle<Result<String, String>>> = {
        let u = p.url.clone();
        let u2 = p.url.clone();
        let u3 = p.url.clone();
        let u4 = p.url.clone();
        let f3 = forbidden.clone();
        let f4 = forbidden.clone();
        vec![
            std::thread::spawn(move || {
                slow_client(&u, "an idle connection that sends nothing", b"")
            }),
            std::thread::spawn(move || {
                slow_client(
                    &u2,
                    "a connection that sends half a request head, then nothing",
                    b"GET /healthz HTTP/1.1\r\nHost: x\r\n",
                )
            }),
            std::thread::spawn(move || {
                lying_body(
                    &u3,
                    "POST /v1/jobs with Content-Length 100, 10 bytes sent, then silence",
                    Req::post("/v1/jobs")
                        .header("content-type", "application/json")
                        .declared("100", "{\"scene\":"),
                    &f3,
                )
            }),
            std::thread::spawn(move || {
                lying_body(
                    &u4,
                    "POST /v1/scenes with Content-Length 100000, 10 bytes sent, then silence",
                    Req::post("/v1/scenes").declared("100000", "{\"format\":"),
                    &f4,
                )
            }),
        ]
    };

    // The long job, and the jobs in other states for class 7.
    let scene = tiny_scene(LONG_SIZE);
    let s = call_json(&p.url, upload(scene.to_string()), 201)["id"]
        .as_str()
        .unwrap()
        .to_string();
    let long = call_json(
        &p.url,
        post_job(json!({"scene": s, "halt": {"spp": LONG_SPP}, "seed": LONG_SEED, "snapshot_every": {"iterations": 500}}).to_string()),
        201,
    )["id"]
        .as_str()
        .unwrap()
        .to_string();
    let running = wait_for("the long job to run", Duration::from_secs(30), || {
        job_state(&p.url, &long)["state"] == "running"
    });
    assert!(
        running,
        "the long job never ran: {}",
        job_state(&p.url, &long)
    );

    // Wrong states of the running job, first, while it surely runs.
    b.run_all(vec![
        case(
            "DELETE the running job",
            Req::new("DELETE", format!("/v1/jobs/{long}")),
            &[409],
        ),
        case(
            "resume the running job",
            Req::post(format!("/v1/jobs/{long}/resume")),
            &[409],
        ),
        case(
            "retry the running job",
            Req::post(format!("/v1/jobs/{long}/retry")),
            &[409],
        ),
        case(
            "a job whose reference is the running job",
            post_job(spec(&s, json!({"reference": {"job": long}}))),
            &[409],
        ),
        case(
            "DELETE the scene the running job uses",
            Req::new("DELETE", format!("/v1/scenes/{s}")),
            &[409],
        ),
    ]);

    let far_below = json!({"priority": -1000, "halt": {"spp": 1_000_000}});
    let q1 = call_json(&p.url, post_job(spec(&s, far_below.clone())), 201)["id"]
        .as_str()
        .unwrap()
        .to_string();
    let q2 = call_json(&p.url, post_job(spec(&s, far_below)), 201)["id"]
        .as_str()
        .unwrap()
        .to_string();
    call_json(&p.url, Req::post(format!("/v1/jobs/{q1}/cancel")), 200);
    let c = call_json(
        &p.url,
        post_job(spec(&s, json!({"priority": 100, "halt": {"spp": 2}}))),
        201,
    )["id"]
        .as_str()
        .unwrap()
        .to_string();
    let reference = call_json(&p.url, Req::post("/v1/references").bytes(exr(2, 1)), 201)["id"]
        .as_str()
        .unwrap()
        .to_string();

    // Classes 1, 2, 3, 5, 6.
    b.run_all(json_body_cases(&s));
    b.run(
        case(
            "job: reference upload of a 2x1 EXR for a 32x32 scene",
            post_job(spec(&s, json!({"reference": {"upload": reference}}))),
            &[400],
        )
        .mentions("2x1"),
    );
    b.run_all(method_path_cases(&long, &s));
    b.run_all(protocol_cases());
    b.run_all(size_cases(&s));
    b.run_all(scene_cases());
    b.run_all(images::image_cases(&tiny_scene(16)));
    b.run_all(coincident_primitive_cases());
    b.run_all(reference_cases());
    uploads::run(&mut b);
    memory_section(&mut b);
    // Scenes that upload but that this server will not render (above --max-resolution
    // 8192, within the scene format's 16384).
    for (w, h) in [(10000u32, 10000u32), (8193, 1)] {
        let mut big = tiny_scene(16);
        big["film"] = json!({"width": w, "height": h});
        let what = format!("scene: film {w}x{h} (above --max-resolution)");
        if let Some(r) = b.run(case(
            format!("{what}: upload is accepted"),
            upload(big.to_string()),
            &[201],
        )) {
            if let Some(id) = r.json().and_then(|v| v["id"].as_str().map(String::from)) {
                b.run(
                    case(
                        format!("{what}: a job on it is refused"),
                        post_job(spec(&id, json!({}))),
                        &[400],
                    )
                    .mentions("limit"),
                );
            }
        }
    }

    // Class 7 (the completed job must have completed).
    let done = wait_for("the small job to complete", Duration::from_secs(30), || {
        job_state(&p.url, &c)["state"] == "completed"
    });
    if !done {
        b.fail(format!(
            "set-up: the small job {c} did not complete: {}",
            job_state(&p.url, &c)
        ));
    }
    b.run_all(state_cases(&long, &q1, &q2, &c));

    // Class 4: many connections at once.
    many_idle_connections(&mut b, &long);

    // Class 5, OBJ `mtllib` outside the bundle (reader fix in progress elsewhere):
    // probes with a FIFO, which show whether the server opens the file at all.
    let fifo = probe_dir.path().join("probe.mtl");
    let cpath = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(cpath.as_ptr(), 0o600) }, 0, "mkfifo");
    let abs = fifo.display().to_string();
    let rel = format!("{}{}", "../".repeat(24), abs.trim_start_matches('/'));
    let opened_abs = mtllib_probe(
        &mut b,
        "tar: OBJ with mtllib <absolute path of a FIFO outside the bundle>",
        &fifo,
        &abs,
    );
    let opened_rel = mtllib_probe(
        &mut b,
        "tar: OBJ with mtllib ../../<...>/FIFO outside the bundle",
        &fifo,
        &rel,
    );
    let with_obj = scene_with_mesh(tiny_scene(16), "obj", "m/quad.obj");
    let obj_with = |lib: &str| [format!("mtllib {lib}\n").as_bytes(), QUAD_OBJ].concat();
    if let Some(r) = b.run(
        case(
            "tar: OBJ with mtllib /etc/passwd",
            upload(tar(&[
                file("scene.json", with_obj.as_bytes()),
                file("m/quad.obj", &obj_with("/etc/passwd")),
            ])),
            &[201, 400, 422],
        )
        .echo("/etc/passwd"),
    ) {
        if r.text().contains("root:") {
            b.fail(
                "tar: OBJ with mtllib /etc/passwd: the answer holds the contents of /etc/passwd"
                    .into(),
            );
        }
    }
    if opened_abs {
        // The server follows absolute mtllib paths: /dev/zero would make it read
        // (and buffer) without end. Recorded above as a failure; not sent.
        b.fail("tar: OBJ with mtllib /dev/zero: not sent, the server follows absolute mtllib paths (see the FIFO probe)".into());
    } else {
        b.run(
            case(
                "tar: OBJ with mtllib /dev/zero",
                upload(tar(&[
                    file("scene.json", with_obj.as_bytes()),
                    file("m/quad.obj", &obj_with("/dev/zero")),
                ])),
                &[201, 400, 422],
            )
            .echo("/dev/zero"),
        );
    }
    if !opened_rel {
        b.run(case(
            "zip: OBJ with mtllib ../../<...>/dev/zero",
            upload(zip(&[
                ("scene.json", with_obj.as_bytes()),
                (
                    "m/quad.obj",
                    &obj_with(&format!("{}dev/zero", "../".repeat(24))),
                ),
            ])),
            &[201, 400, 422],
        ));
    }

    // Class 8: the token server.
    let mut a = Battery::new(&auth, auth_data.path(), failures.clone(), "token");
    a.run_all(auth_cases("cornell-box"));

    // Last, the inputs that can take a trusting reader down (EXR header caps are being
    // added elsewhere): headers claiming 100000 x 100000 pixels (40 GB per channel).
    let huge = exr_claiming(100_000, 100_000);
    b.run(case(
        "tar: envmap EXR whose header claims 100000x100000 pixels",
        upload(tar(&[
            file(
                "scene.json",
                scene_with_envmap(tiny_scene(16), "env.exr").as_bytes(),
            ),
            file("env.exr", &huge),
        ])),
        &[400, 413, 422],
    ));
    b.run(case(
        "reference: an EXR whose header claims 100000x100000 pixels",
        Req::post("/v1/references").bytes(&huge),
        &[400, 413, 422],
    ));
    let battery_time = t0.elapsed();
    let cases_run = b.run + a.run;

    // The long job: completed, every iteration, bit-identical to a direct render.
    let long_note: String;
    if b.dead.is_none() {
        let at = job_state(&p.url, &long);
        long_note = format!(
            "the long job was {} at iteration {} of {LONG_SPP} when the battery ended",
            at["state"], at["iteration"]
        );
        let finished = wait_for("the long job", Duration::from_secs(120), || {
            let st = job_state(&p.url, &long)["state"].clone();
            st == "completed" || st == "failed" || st == "cancelled"
        });
        let job = job_state(&p.url, &long);
        if !finished || job["state"] != "completed" || job["iteration"] != LONG_SPP {
            b.fail(format!(
                "the long job did not complete with {LONG_SPP} iterations: {job}"
            ));
        } else {
            let exr_bytes = call(&p.url, Req::get(format!("/v1/jobs/{long}/image.exr"))).body;
            let served = caustic::film::decode_exr(&exr_bytes).expect("served image decodes");
            let file = caustic::scene::load::parse_scene(&scene.to_string()).unwrap();
            let compiled = caustic::scene::Scene::compile(&file, None).unwrap();
            let settings =
                caustic::integrator::Settings::resolve(None, None, &serde_json::Map::new())
                    .unwrap();
            let direct = caustic::integrator::drive::render(
                &compiled,
                settings.build().as_ref(),
                LONG_SEED,
                caustic::integrator::drive::Halt {
                    iterations: Some(LONG_SPP),
                    ..caustic::integrator::drive::Halt::default()
                },
                |_, _| {},
            );
            if direct.image().pixels() != served.pixels() {
                b.fail("the long job's image differs from a direct render".into());
            }
        }
    } else {
        b.fail("the long job could not be checked: the server died".into());
        long_note = "the long job: not checked, the server died".into();
    }

    // The slow checks.
    let mut slow_notes = Vec::new();
    for h in slow {
        match h.join().expect("slow check thread") {
            Ok(note) => slow_notes.push(note),
            Err(e) => b.fail(e),
        }
    }

    // Alive, and peak memory bounded.
    let peak = peak_rss_kib(p.pid()).or((b.peak_kib > 0).then_some(b.peak_kib));
    for (proc_, label) in [(&p, "main"), (&auth, "token")] {
        if !alive(proc_.pid()) {
            b.fail(format!(
                "the {label} server process is not alive at the end; its last lines:\n    {}",
                last_stderr(proc_, 30)
            ));
        }
    }
    match peak {
        Some(kib) if kib > RSS_BOUND_MIB << 10 => b.fail(format!(
            "peak RSS (VmHWM) of the server is {} MiB, above the bound of {RSS_BOUND_MIB} MiB",
            kib >> 10
        )),
        Some(_) => {}
        None => b.fail("peak RSS: /proc/<pid>/status unreadable (server gone)".into()),
    }

    eprintln!(
        "battery: {cases_run} cases in {battery_time:.1?}; whole test {:.1?}",
        t0.elapsed()
    );
    eprintln!("battery: {long_note}");
    eprintln!(
        "battery: peak RSS (VmHWM) of the main server: {} MiB (bound {RSS_BOUND_MIB} MiB)",
        peak.map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0))
    );
    for n in &slow_notes {
        eprintln!("battery: {n}");
    }
    if b.dead.is_some() {
        eprintln!(
            "battery: the main server's last lines:\n    {}",
            last_stderr(&p, 30)
        );
    }
    let failures = failures.lock().unwrap();
    assert!(
        failures.is_empty(),
        "{} of the battery's checks failed:\n{}",
        failures.len(),
        failures
            .iter()
            .map(|f| format!("  - {}", clip(f, 900)))
            .collect::<Vec<_>>()
            .join("\n")
    );
}
