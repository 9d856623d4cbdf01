//! The REST client behind `caustic submit / watch / jobs / sweep`: uploads local scenes
//! (bundling the meshes and maps they name), submits jobs and sweeps, follows a job's
//! Server-Sent Events with a progress bar, and prints tables.
//!
//! Every command function writes its results to `out` (stdout in the CLI) and progress
//! to stderr, and returns `Ok(true)` when everything it waited for completed.

use crate::api::{JobView, SweepTable};
use crate::job::spec::{JobSpec, JobState, JobStatus, ReferenceSpec, SnapshotEvery};
use crate::job::sweep::SweepSpec;
use indicatif::{ProgressBar, ProgressStyle};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Component, Path, PathBuf};
use std::time::Duration;

/// Where `caustic serve` listens by default.
pub const DEFAULT_SERVER: &str = "http://127.0.0.1:7878";

#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The server answered with an error status; `code` and `message` come from its
    /// `{"error": {"code", "message"}}` body.
    #[error("{status} {code}: {message}")]
    Server {
        status: u16,
        code: String,
        message: String,
    },
    /// No answer: connection refused, DNS, timeout, broken stream.
    #[error("cannot reach the server: {0}")]
    Transport(String),
    /// The server answered something this client does not understand.
    #[error("unexpected response from {url}: {message}")]
    Protocol { url: String, message: String },
    /// A command-line value is malformed.
    #[error("{0}")]
    Input(String),
    /// A local file could not be read.
    #[error("{path}: {message}")]
    File { path: String, message: String },
    /// Writing the results failed (e.g. a closed pipe).
    #[error("writing output: {0}")]
    Output(#[from] std::io::Error),
}

type Result<T, E = ClientError> = std::result::Result<T, E>;

fn file_error(path: &Path, e: impl std::fmt::Display) -> ClientError {
    ClientError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// A connection to one server: base URL plus optional bearer token.
pub struct Client {
    base: String,
    token: Option<String>,
    agent: ureq::Agent,
}

/// Percent-encodes one path segment (job and sweep ids come from the user).
fn segment(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

impl Client {
    /// `server` is a base URL (`http://host:port`); a bare `host:port` gets `http://`.
    pub fn new(server: &str, token: Option<String>) -> Client {
        let server = server.trim().trim_end_matches('/');
        let base = if server.contains("://") {
            server.to_string()
        } else {
            format!("http://{server}")
        };
        let agent = ureq::AgentBuilder::new()
            .timeout_connect(Duration::from_secs(10))
            // Longer than the SSE keep-alive interval (15 s), so idle streams live on.
            .timeout_read(Duration::from_secs(120))
            .user_agent(concat!("caustic/", env!("CARGO_PKG_VERSION")))
            .build();
        Client {
            base,
            token: token.filter(|t| !t.is_empty()),
            agent,
        }
    }

    pub fn base_url(&self) -> &str {
        &self.base
    }

    fn request(&self, method: &str, path: &str) -> ureq::Request {
        let req = self.agent.request(method, &format!("{}{path}", self.base));
        match &self.token {
            Some(t) => req.set("authorization", &format!("Bearer {t}")),
            None => req,
        }
    }

    /// Sends a request, turning error statuses into `ClientError::Server`.
    fn send(
        &self,
        result: std::result::Result<ureq::Response, ureq::Error>,
    ) -> Result<ureq::Response> {
        match result {
            Ok(r) => Ok(r),
            Err(ureq::Error::Status(status, resp)) => Err(server_error(status, resp)),
            Err(ureq::Error::Transport(t)) => Err(ClientError::Transport(t.to_string())),
        }
    }

    fn json<T: DeserializeOwned>(&self, resp: ureq::Response) -> Result<T> {
        let url = resp.get_url().to_string();
        let mut body = Vec::new();
        resp.into_reader()
            .read_to_end(&mut body)
            .map_err(|e| ClientError::Transport(format!("{url}: {e}")))?;
        serde_json::from_slice(&body).map_err(|e| ClientError::Protocol {
            url,
            message: e.to_string(),
        })
    }

    fn get<T: DeserializeOwned>(&self, path: &str, query: &[(&str, &str)]) -> Result<T> {
        let mut req = self.request("GET", path);
        for (k, v) in query {
            req = req.query(k, v);
        }
        let resp = self.send(req.call())?;
        self.json(resp)
    }

    fn post<T: DeserializeOwned>(&self, path: &str, body: &impl Serialize) -> Result<T> {
        let resp = self.send(self.request("POST", path).send_json(body))?;
        self.json(resp)
    }

    /// Uploads a scene document or bundle; returns the scene id.
    pub fn upload_scene(&self, bytes: &[u8], content_type: &str) -> Result<String> {
        let resp = self.send(
            self.request("POST", "/v1/scenes")
                .set("content-type", content_type)
                .send_bytes(bytes),
        )?;
        let info: Value = self.json(resp)?;
        info["id"]
            .as_str()
            .map(String::from)
            .ok_or_else(|| ClientError::Protocol {
                url: format!("{}/v1/scenes", self.base),
                message: "no scene id in the answer".into(),
            })
    }

    pub fn submit(&self, spec: &JobSpec) -> Result<JobView> {
        self.post("/v1/jobs", spec)
    }

    pub fn job(&self, id: &str) -> Result<JobView> {
        self.get(&format!("/v1/jobs/{}", segment(id)), &[])
    }

    pub fn jobs(
        &self,
        state: Option<&str>,
        tag: Option<&str>,
        sweep: Option<&str>,
    ) -> Result<Vec<JobView>> {
        let q: Vec<(&str, &str)> = [("state", state), ("tag", tag), ("sweep", sweep)]
            .into_iter()
            .filter_map(|(k, v)| v.map(|v| (k, v)))
            .collect();
        self.get("/v1/jobs", &q)
    }

    pub fn create_sweep(&self, spec: &SweepSpec) -> Result<SweepTable> {
        self.post("/v1/sweeps", spec)
    }

    pub fn sweep(&self, id: &str) -> Result<SweepTable> {
        self.get(&format!("/v1/sweeps/{}", segment(id)), &[])
    }

    pub fn sweep_csv(&self, id: &str) -> Result<String> {
        let resp = self.send(
            self.request("GET", &format!("/v1/sweeps/{}", segment(id)))
                .query("format", "csv")
                .call(),
        )?;
        resp.into_string()
            .map_err(|e| ClientError::Transport(e.to_string()))
    }

    /// Opens a job's event stream.
    pub fn events(&self, id: &str) -> Result<SseReader<BufReader<Box<dyn Read + Send + Sync>>>> {
        let resp = self.send(
            self.request("GET", &format!("/v1/jobs/{}/events", segment(id)))
                .set("accept", "text/event-stream")
                .call(),
        )?;
        Ok(SseReader::new(BufReader::new(resp.into_reader())))
    }
}

/// The server's `{"error": {"code", "message"}}` body, or the raw text when it is not.
fn server_error(status: u16, resp: ureq::Response) -> ClientError {
    let status_text = resp.status_text().to_string();
    let body = resp.into_string().unwrap_or_default();
    let parsed: Option<(String, String)> =
        serde_json::from_str::<Value>(&body).ok().and_then(|v| {
            let e = v.get("error")?;
            Some((e["code"].as_str()?.into(), e["message"].as_str()?.into()))
        });
    match parsed {
        Some((code, message)) => ClientError::Server {
            status,
            code,
            message,
        },
        None => ClientError::Server {
            status,
            code: status_text.to_lowercase().replace(' ', "_"),
            message: body.trim().to_string(),
        },
    }
}

// ---------------------------------------------------------------------------------
// Server-Sent Events

/// One SSE message: its `event:` name (default `message`) and joined `data:` lines.
#[derive(Debug, Clone, PartialEq)]
pub struct SseMessage {
    pub event: String,
    pub data: String,
}

/// Reads SSE messages line by line; comments (keep-alives) and `id:`/`retry:` fields
/// are skipped.
pub struct SseReader<R> {
    inner: R,
}

impl<R: BufRead> SseReader<R> {
    pub fn new(inner: R) -> Self {
        SseReader { inner }
    }

    /// The next complete message, or `None` at the end of the stream.
    pub fn next_message(&mut self) -> std::io::Result<Option<SseMessage>> {
        let mut event = String::new();
        let mut data: Option<String> = None;
        let mut line = String::new();
        loop {
            line.clear();
            if self.inner.read_line(&mut line)? == 0 {
                // An unterminated message at the end is discarded, as the spec says.
                return Ok(None);
            }
            let l = line.trim_end_matches(['\n', '\r']);
            if l.is_empty() {
                if let Some(data) = data.take() {
                    let event = if event.is_empty() {
                        "message".to_string()
                    } else {
                        std::mem::take(&mut event)
                    };
                    return Ok(Some(SseMessage { event, data }));
                }
                event.clear();
                continue;
            }
            if l.starts_with(':') {
                continue;
            }
            let (field, value) = match l.split_once(':') {
                Some((f, v)) => (f, v.strip_prefix(' ').unwrap_or(v)),
                None => (l, ""),
            };
            match field {
                "event" => event = value.to_string(),
                "data" => match &mut data {
                    Some(d) => {
                        d.push('\n');
                        d.push_str(value);
                    }
                    None => data = Some(value.to_string()),
                },
                _ => {}
            }
        }
    }
}

/// The data of a job event (see `job::events::Event`), as the client reads it.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum WatchEvent {
    Progress {
        iteration: u64,
        elapsed_s: f64,
        samples_per_s: f64,
        #[serde(default)]
        eta_s: Option<f64>,
        #[serde(default)]
        dropped: u64,
    },
    Snapshot {
        iteration: u64,
        #[serde(default)]
        rmse: Option<f64>,
    },
    State {
        state: JobState,
    },
    Done {
        status: Box<JobStatus>,
    },
    /// The server is stopping; the stream ends after this (the job resumes when the
    /// server starts again, and the watcher reconnects).
    Shutdown,
    /// An event this client does not know yet.
    #[serde(other)]
    Other,
}

// ---------------------------------------------------------------------------------
// Job options and scenes

/// The job settings `submit` and `sweep` share; unset fields keep the server's default
/// (or, for a sweep file, the file's value).
#[derive(Clone, Debug, Default)]
pub struct JobOptions {
    pub algorithm: Option<String>,
    pub spp: Option<u64>,
    pub time_s: Option<f64>,
    pub iterations: Option<u64>,
    pub target_rmse: Option<f64>,
    pub reference_job: Option<String>,
    pub seed: Option<u64>,
    /// `KEY=VALUE`; values parse as JSON when they can, else as strings.
    pub params: Vec<String>,
    pub priority: Option<i32>,
    pub snapshot_every_iterations: Option<u64>,
    pub snapshot_every_seconds: Option<f64>,
    pub name: Option<String>,
    pub tags: Vec<String>,
}

/// A command-line value: JSON when it parses (numbers, booleans, arrays), else a string.
fn parse_value(v: &str) -> Value {
    serde_json::from_str(v).unwrap_or_else(|_| Value::String(v.to_string()))
}

/// `key=value` pairs into a parameter map.
pub fn parse_params(params: &[String]) -> Result<serde_json::Map<String, Value>> {
    let mut m = serde_json::Map::new();
    for p in params {
        let Some((k, v)) = p.split_once('=') else {
            return Err(ClientError::Input(format!(
                "--param {p}: expected KEY=VALUE"
            )));
        };
        m.insert(k.trim().to_string(), parse_value(v));
    }
    Ok(m)
}

impl JobOptions {
    /// Overrides the fields of `spec` that were given.
    pub fn apply(&self, spec: &mut JobSpec) -> Result<()> {
        if let Some(a) = &self.algorithm {
            spec.algorithm = Some(a.clone());
        }
        if let Some(n) = self.spp {
            spec.halt.spp = Some(n);
        }
        if let Some(n) = self.iterations {
            spec.halt.iterations = Some(n);
        }
        if let Some(t) = self.time_s {
            spec.halt.time_s = Some(t);
        }
        if let Some(r) = self.target_rmse {
            spec.halt.target_rmse = Some(r);
        }
        if let Some(j) = &self.reference_job {
            spec.reference = Some(ReferenceSpec::Job(j.clone()));
        }
        if let Some(s) = self.seed {
            spec.seed = s;
        }
        spec.params.extend(parse_params(&self.params)?);
        if let Some(p) = self.priority {
            spec.priority = p;
        }
        if let Some(n) = self.snapshot_every_iterations {
            spec.snapshot_every = SnapshotEvery::Iterations(n);
        }
        if let Some(s) = self.snapshot_every_seconds {
            spec.snapshot_every = SnapshotEvery::Seconds(s);
        }
        if let Some(n) = &self.name {
            spec.name = Some(n.clone());
        }
        for t in &self.tags {
            if !spec.tags.contains(t) {
                spec.tags.push(t.clone());
            }
        }
        Ok(())
    }

    /// A job spec for `scene` with these options over the server's defaults.
    pub fn spec(&self, scene: &str) -> Result<JobSpec> {
        let mut spec: JobSpec =
            serde_json::from_value(serde_json::json!({"scene": scene, "halt": {}}))
                .map_err(|e| ClientError::Input(e.to_string()))?;
        self.apply(&mut spec)?;
        Ok(spec)
    }
}

/// Does `scene` name a local file rather than a scene id?
fn looks_like_path(scene: &str) -> bool {
    scene.contains('/')
        || scene.contains('\\')
        || [".json", ".tar", ".zip"]
            .iter()
            .any(|x| scene.to_ascii_lowercase().ends_with(x))
}

/// A scene id for `scene`: a local file (relative to `base_dir` if given) is uploaded
/// first; anything else is taken as the id of a built-in or uploaded scene.
pub fn resolve_scene(client: &Client, scene: &str, base_dir: Option<&Path>) -> Result<String> {
    let path = match base_dir {
        Some(d) => d.join(scene),
        None => PathBuf::from(scene),
    };
    if path.is_file() {
        let (bytes, content_type, files) = scene_upload(&path)?;
        let id = client.upload_scene(&bytes, content_type)?;
        eprintln!(
            "uploaded {} as scene {id} ({} file{}, {:.1} KiB)",
            path.display(),
            files,
            if files == 1 { "" } else { "s" },
            bytes.len() as f64 / 1024.0
        );
        Ok(id)
    } else if looks_like_path(scene) {
        Err(file_error(&path, "no such scene file"))
    } else {
        Ok(scene.to_string())
    }
}

/// The bytes to upload for a local scene file, their content type and how many files
/// they hold. A JSON scene naming other files becomes a tar bundle; archives (tar, zip)
/// are sent as they are.
pub fn scene_upload(path: &Path) -> Result<(Vec<u8>, &'static str, usize)> {
    let bytes = std::fs::read(path).map_err(|e| file_error(path, e))?;
    let first = bytes.iter().find(|b| !b.is_ascii_whitespace()).copied();
    if first != Some(b'{') {
        let ct = if bytes.starts_with(b"PK\x03\x04") {
            "application/zip"
        } else {
            "application/x-tar"
        };
        return Ok((bytes, ct, 1));
    }
    let doc: Value = serde_json::from_slice(&bytes).map_err(|e| file_error(path, e))?;
    let mut names = Vec::new();
    referenced_files(&doc, &mut names);
    if names.is_empty() {
        return Ok((bytes, "application/json", 1));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let files = bundle_files(dir, &names)?;
    let n = files.len() + 1;
    let tar = build_tar(&bytes, dir, &files)?;
    Ok((tar, "application/x-tar", n))
}

/// Keys whose string values name files next to the scene: meshes and environment
/// maps (`filename`), media grids (`file`, `albedo_file`).
const FILE_KEYS: [&str; 3] = ["filename", "file", "albedo_file"];

/// Every file a scene document names (see [`FILE_KEYS`]).
pub fn referenced_files(doc: &Value, out: &mut Vec<String>) {
    match doc {
        Value::Object(m) => {
            for (k, v) in m {
                match v {
                    Value::String(s) if FILE_KEYS.contains(&k.as_str()) => out.push(s.clone()),
                    _ => referenced_files(v, out),
                }
            }
        }
        Value::Array(a) => a.iter().for_each(|v| referenced_files(v, out)),
        _ => {}
    }
}

/// A reference as a clean relative path; absolute paths and `..` are refused, as the
/// server would.
fn relative(name: &str) -> Result<PathBuf> {
    let mut out = PathBuf::new();
    for c in Path::new(name).components() {
        match c {
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            _ => {
                return Err(ClientError::Input(format!(
                    "scene references \"{name}\": file references must be relative paths inside the scene's folder"
                )))
            }
        }
    }
    if out.as_os_str().is_empty() {
        return Err(ClientError::Input(
            "scene references an empty file name".into(),
        ));
    }
    Ok(out)
}

/// The referenced files (relative to the scene folder), plus the data file a raw
/// grid's `.json` header names (relative to the header). OBJ material libraries are
/// left out: caustic reads no OBJ materials.
fn bundle_files(dir: &Path, names: &[String]) -> Result<BTreeSet<PathBuf>> {
    let mut files = BTreeSet::new();
    for name in names {
        let rel = relative(name)?;
        let full = dir.join(&rel);
        if !full.is_file() {
            return Err(file_error(&full, "referenced by the scene but not found"));
        }
        let is_json = rel
            .extension()
            .is_some_and(|x| x.eq_ignore_ascii_case("json"));
        if is_json {
            let text = std::fs::read(&full).map_err(|e| file_error(&full, e))?;
            let header: Value = serde_json::from_slice(&text).map_err(|e| file_error(&full, e))?;
            if let Some(data) = header.get("data").and_then(Value::as_str) {
                let folder = rel.parent().map(Path::to_path_buf).unwrap_or_default();
                let data = relative(&folder.join(data).to_string_lossy())?;
                if !dir.join(&data).is_file() {
                    return Err(file_error(
                        &dir.join(&data),
                        "named by a grid header but not found",
                    ));
                }
                files.insert(data);
            }
        }
        files.insert(rel);
    }
    Ok(files)
}

/// A tar archive of `scene.json` and the files, with fixed metadata so the same scene
/// always gives the same bytes (and so the same content-addressed scene id).
fn build_tar(scene: &[u8], dir: &Path, files: &BTreeSet<PathBuf>) -> Result<Vec<u8>> {
    let mut b = tar::Builder::new(Vec::new());
    let mut add = |name: &Path, data: &[u8]| -> std::io::Result<()> {
        let mut h = tar::Header::new_ustar();
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        h.set_mtime(0);
        h.set_entry_type(tar::EntryType::Regular);
        b.append_data(&mut h, name, data)
    };
    add(Path::new("scene.json"), scene).map_err(|e| ClientError::Input(format!("bundle: {e}")))?;
    for rel in files {
        let full = dir.join(rel);
        let data = std::fs::read(&full).map_err(|e| file_error(&full, e))?;
        add(rel, &data).map_err(|e| file_error(&full, e))?;
    }
    b.into_inner()
        .map_err(|e| ClientError::Input(format!("bundle: {e}")))
}

// ---------------------------------------------------------------------------------
// Commands

pub struct SubmitOptions {
    /// Scene id or local scene file.
    pub scene: String,
    pub job: JobOptions,
    pub watch: bool,
    pub json: bool,
}

/// `caustic submit`: prints the job id (or the job as JSON), then follows it with
/// `watch`. Returns whether the job completed (always true without `watch`).
pub fn submit(client: &Client, o: &SubmitOptions, out: &mut impl Write) -> Result<bool> {
    let scene = resolve_scene(client, &o.scene, None)?;
    let spec = o.job.spec(&scene)?;
    let job = client.submit(&spec)?;
    if o.json {
        if o.watch {
            // One JSON document per line, followed by the event lines.
            writeln!(
                out,
                "{}",
                serde_json::to_string(&job).expect("job serialises")
            )?;
        } else {
            writeln!(
                out,
                "{}",
                serde_json::to_string_pretty(&job).expect("job serialises")
            )?;
        }
    } else {
        writeln!(out, "{}", job.job.id)?;
    }
    out.flush()?;
    if o.watch {
        watch_job(client, job.job, o.json, out)
    } else {
        Ok(true)
    }
}

/// `caustic watch`: follows a job to its end. Returns whether it completed.
pub fn watch(client: &Client, id: &str, json: bool, out: &mut impl Write) -> Result<bool> {
    let job = client.job(id)?;
    watch_job(client, job.job, json, out)
}

/// What the progress bar measures.
#[derive(Clone, Copy)]
enum Measure {
    Iterations,
    Millis,
    Spinner,
}

struct Watcher {
    bar: ProgressBar,
    measure: Measure,
    state: JobState,
    iteration: u64,
    elapsed_ms: f64,
    rmse: Option<f64>,
    sps: f64,
    eta: Option<f64>,
}

impl Watcher {
    fn new(job: &JobStatus, json: bool) -> Watcher {
        let halt = &job.spec.halt;
        let (bar, measure) = if json {
            (ProgressBar::hidden(), Measure::Spinner)
        } else if let Some(n) = halt.max_iterations() {
            let bar = ProgressBar::new(n);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {pos}/{len} it  {msg}").expect("template"),
            );
            (bar, Measure::Iterations)
        } else if let Some(t) = halt.time_s {
            let bar = ProgressBar::new((t * 1e3).round() as u64);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {prefix} it  {msg}").expect("template"),
            );
            (bar, Measure::Millis)
        } else {
            let bar = ProgressBar::new_spinner();
            bar.set_style(
                ProgressStyle::with_template("{spinner} {prefix} it  {msg}").expect("template"),
            );
            (bar, Measure::Spinner)
        };
        if !json {
            bar.enable_steady_tick(Duration::from_millis(200));
        }
        let w = Watcher {
            bar,
            measure,
            state: job.state,
            iteration: job.iteration,
            elapsed_ms: job.elapsed_s * 1e3,
            rmse: job.last_rmse,
            sps: job.samples_per_s,
            eta: job.eta_s,
        };
        w.refresh();
        w
    }

    fn refresh(&self) {
        match self.measure {
            Measure::Iterations => self.bar.set_position(self.iteration),
            Measure::Millis => self.bar.set_position(self.elapsed_ms as u64),
            Measure::Spinner => {}
        }
        self.bar.set_prefix(self.iteration.to_string());
        let mut msg = String::new();
        if self.state != JobState::Running {
            msg.push_str(self.state.as_str());
            msg.push_str("  ");
        }
        msg.push_str(&format!("{} samples/s", rate(self.sps)));
        if let Some(r) = self.rmse {
            msg.push_str(&format!("  rmse {r:.3e}"));
        }
        if let Some(e) = self.eta {
            msg.push_str(&format!("  eta {}", duration(e)));
        }
        self.bar.set_message(msg);
    }
}

/// `1.23 M`, `456.7 k`, `12`.
fn rate(x: f64) -> String {
    if x >= 1e6 {
        format!("{:.2} M", x / 1e6)
    } else if x >= 1e3 {
        format!("{:.1} k", x / 1e3)
    } else {
        format!("{x:.0}")
    }
}

/// `4.2 s`, `3m07s`, `2h05m`.
fn duration(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.1} s")
    } else if s < 3600.0 {
        format!("{}m{:02}s", (s / 60.0) as u64, (s % 60.0) as u64)
    } else {
        format!(
            "{}h{:02}m",
            (s / 3600.0) as u64,
            ((s % 3600.0) / 60.0) as u64
        )
    }
}

/// The one-line summary of a finished job.
pub fn summary(job: &JobStatus) -> String {
    let mut s = format!(
        "{}: {}, {} iterations in {:.2} s, {} dropped samples",
        job.id,
        job.state.as_str(),
        job.iteration,
        job.elapsed_s,
        job.dropped
    );
    if let Some(r) = job.last_rmse {
        s.push_str(&format!(", rmse {r:.4e}"));
    }
    if let Some(e) = &job.error {
        s.push_str(&format!(": {e}"));
    }
    s
}

/// How many times in a row the stream may fail to (re)connect before giving up.
const MAX_RECONNECTS: u32 = 30;

fn watch_job(client: &Client, job: JobStatus, json: bool, out: &mut impl Write) -> Result<bool> {
    let id = job.id.clone();
    let mut w = Watcher::new(&job, json);
    let mut failures = 0;
    let final_status = 'outer: loop {
        let mut stream = match client.events(&id) {
            Ok(s) => s,
            Err(ClientError::Transport(e)) if failures < MAX_RECONNECTS => {
                failures += 1;
                w.bar.set_message(format!("reconnecting: {e}"));
                std::thread::sleep(Duration::from_secs(1));
                continue;
            }
            Err(e) => {
                w.bar.finish_and_clear();
                return Err(e);
            }
        };
        failures = 0;
        // Until the stream ends or breaks; without `done`, the server may be restarting.
        while let Ok(Some(msg)) = stream.next_message() {
            let data: Value = match serde_json::from_str(&msg.data) {
                Ok(v) => v,
                Err(_) => continue,
            };
            if json {
                writeln!(out, "{data}")?;
                out.flush()?;
            }
            match serde_json::from_value::<WatchEvent>(data) {
                Ok(WatchEvent::Progress {
                    iteration,
                    elapsed_s,
                    samples_per_s,
                    eta_s,
                    dropped: _,
                }) => {
                    w.state = JobState::Running;
                    w.iteration = iteration;
                    w.elapsed_ms = elapsed_s * 1e3;
                    w.sps = samples_per_s;
                    w.eta = eta_s;
                    w.refresh();
                }
                Ok(WatchEvent::Snapshot { iteration, rmse }) => {
                    w.iteration = w.iteration.max(iteration);
                    w.rmse = rmse.or(w.rmse);
                    w.refresh();
                }
                Ok(WatchEvent::State { state }) => {
                    w.state = state;
                    w.refresh();
                }
                Ok(WatchEvent::Done { status }) => break 'outer *status,
                Ok(WatchEvent::Shutdown) => {
                    w.bar.set_message("the server is stopping; reconnecting")
                }
                Ok(WatchEvent::Other) | Err(_) => {}
            }
        }
        // Ask where the job stands; finished jobs need no new stream.
        match client.job(&id) {
            Ok(j) if j.job.state.is_terminal() => {
                if json {
                    let done = serde_json::json!({"event": "done", "job": id, "status": j.job});
                    writeln!(out, "{done}")?;
                }
                break j.job;
            }
            Ok(_) => {}
            Err(ClientError::Transport(_)) if failures < MAX_RECONNECTS => failures += 1,
            Err(e) => {
                w.bar.finish_and_clear();
                return Err(e);
            }
        }
        std::thread::sleep(Duration::from_secs(1));
    };
    w.bar.finish_and_clear();
    if !json {
        writeln!(out, "{}", summary(&final_status))?;
    }
    out.flush()?;
    Ok(final_status.state == JobState::Completed)
}

pub struct JobsOptions {
    pub state: Option<String>,
    pub tag: Option<String>,
    pub sweep: Option<String>,
    pub json: bool,
}

/// `caustic jobs`: a table of jobs, or their JSON.
pub fn jobs(client: &Client, o: &JobsOptions, out: &mut impl Write) -> Result<bool> {
    let jobs = client.jobs(o.state.as_deref(), o.tag.as_deref(), o.sweep.as_deref())?;
    if o.json {
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&jobs).expect("jobs serialise")
        )?;
        return Ok(true);
    }
    let headers = [
        "id",
        "state",
        "algorithm",
        "iteration",
        "elapsed_s",
        "rmse",
        "name",
    ];
    let rows: Vec<Vec<String>> = jobs
        .iter()
        .map(|v| {
            let j = &v.job;
            let alg = j.settings["algorithm"]
                .as_str()
                .map(String::from)
                .or_else(|| j.spec.algorithm.clone())
                .unwrap_or_else(|| "-".into());
            vec![
                j.id.clone(),
                j.state.as_str().into(),
                alg,
                j.iteration.to_string(),
                format!("{:.2}", j.elapsed_s),
                j.last_rmse
                    .map(|r| format!("{r:.4e}"))
                    .unwrap_or("-".into()),
                j.spec.name.clone().unwrap_or_default(),
            ]
        })
        .collect();
    let right = [false, false, false, true, true, true, false];
    out.write_all(table(&headers, &rows, &right).as_bytes())?;
    Ok(true)
}

/// Text columns separated by two spaces; `right` marks right-aligned columns.
fn table(headers: &[&str], rows: &[Vec<String>], right: &[bool]) -> String {
    let mut widths: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let mut s = String::new();
        for (i, c) in cells.iter().enumerate() {
            if i > 0 {
                s.push_str("  ");
            }
            let pad = widths[i].saturating_sub(c.chars().count());
            if right.get(i).copied().unwrap_or(false) {
                s.push_str(&" ".repeat(pad));
                s.push_str(c);
            } else {
                s.push_str(c);
                if i + 1 < cells.len() {
                    s.push_str(&" ".repeat(pad));
                }
            }
        }
        s.truncate(s.trim_end().len());
        s.push('\n');
        s
    };
    let mut out = line(headers.to_vec());
    for r in rows {
        out.push_str(&line(r.iter().map(String::as_str).collect()));
    }
    out
}

/// Short grid keys for the halting rule.
fn grid_key(k: &str) -> String {
    match k {
        "spp" => "halt.spp".into(),
        "iterations" => "halt.iterations".into(),
        "time" | "time_s" => "halt.time_s".into(),
        "target_rmse" => "halt.target_rmse".into(),
        k => k.into(),
    }
}

/// `KEY=V1,V2,...` (or `KEY=[JSON array]`) into a sweep grid. Values parse as JSON
/// when they can (numbers), else as strings; a key given twice gets both lists.
pub fn parse_grid(items: &[String]) -> Result<BTreeMap<String, Vec<Value>>> {
    let mut grid: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    for item in items {
        let bad = || ClientError::Input(format!("--grid {item}: expected KEY=V1,V2,..."));
        let (k, v) = item.split_once('=').ok_or_else(bad)?;
        let k = k.trim();
        if k.is_empty() {
            return Err(bad());
        }
        let values = match serde_json::from_str::<Value>(v.trim()) {
            Ok(Value::Array(a)) => a,
            _ => v
                .split(',')
                .map(|s| {
                    let s = s.trim();
                    if s.is_empty() {
                        Err(ClientError::Input(format!("--grid {item}: empty value")))
                    } else {
                        Ok(parse_value(s))
                    }
                })
                .collect::<Result<Vec<_>>>()?,
        };
        grid.entry(grid_key(k)).or_default().extend(values);
    }
    Ok(grid)
}

pub struct SweepOptions {
    /// Scene id or local scene file; with `file`, overrides the file's base scene.
    pub scene: Option<String>,
    pub grid: Vec<String>,
    /// A SweepSpec JSON file; the other options override its values.
    pub file: Option<PathBuf>,
    pub job: JobOptions,
    /// The sweep's name.
    pub name: Option<String>,
    pub no_wait: bool,
    pub csv: bool,
    pub json: bool,
}

fn sweep_spec(client: &Client, o: &SweepOptions) -> Result<SweepSpec> {
    let mut spec = match &o.file {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| file_error(path, e))?;
            let mut spec: SweepSpec =
                serde_json::from_str(&text).map_err(|e| file_error(path, e))?;
            if o.scene.is_none() {
                // A scene file named by the sweep file is relative to the sweep file.
                let dir = path.parent().unwrap_or(Path::new("."));
                spec.base.scene = resolve_scene(client, &spec.base.scene, Some(dir))?;
            }
            spec
        }
        None => SweepSpec {
            base: JobOptions::default().spec("")?,
            grid: BTreeMap::new(),
            name: None,
        },
    };
    if let Some(scene) = &o.scene {
        spec.base.scene = resolve_scene(client, scene, None)?;
    }
    o.job.apply(&mut spec.base)?;
    for (k, v) in parse_grid(&o.grid)? {
        spec.grid.insert(k, v);
    }
    if o.name.is_some() {
        spec.name = o.name.clone();
    }
    Ok(spec)
}

/// `caustic sweep`: creates a sweep, waits for its jobs with one progress bar and
/// prints its table (or CSV, or JSON). Returns whether every job completed.
pub fn sweep(client: &Client, o: &SweepOptions, out: &mut impl Write) -> Result<bool> {
    let spec = sweep_spec(client, o)?;
    let mut table = client.create_sweep(&spec)?;
    let id = table.id.clone();
    if o.no_wait {
        if o.json {
            writeln!(
                out,
                "{}",
                serde_json::to_string_pretty(&table).expect("table")
            )?;
        } else {
            writeln!(out, "{id}")?;
        }
        return Ok(true);
    }
    eprintln!("sweep {id}: {} jobs", table.rows.len());
    let bar = ProgressBar::new(table.rows.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} jobs  {msg} [{elapsed}]")
            .expect("template"),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    loop {
        let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
        for r in &table.rows {
            *counts.entry(r.state.as_str()).or_default() += 1;
        }
        let done = table.rows.iter().filter(|r| r.state.is_terminal()).count();
        bar.set_position(done as u64);
        bar.set_message(
            counts
                .iter()
                .map(|(s, n)| format!("{n} {s}"))
                .collect::<Vec<_>>()
                .join(", "),
        );
        if done == table.rows.len() {
            break;
        }
        std::thread::sleep(Duration::from_millis(500));
        table = match client.sweep(&id) {
            Ok(t) => t,
            Err(e) => {
                bar.finish_and_clear();
                return Err(e);
            }
        };
    }
    bar.finish_and_clear();
    let ok = table.rows.iter().all(|r| r.state == JobState::Completed);
    if o.csv {
        out.write_all(client.sweep_csv(&id)?.as_bytes())?;
    } else if o.json {
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&table).expect("table")
        )?;
    } else {
        out.write_all(sweep_text(&table).as_bytes())?;
    }
    Ok(ok)
}

/// The sweep table as text: the job, one column per grid key, then the results.
pub fn sweep_text(t: &SweepTable) -> String {
    let keys: Vec<&String> = t
        .rows
        .first()
        .map(|r| r.point.keys().collect())
        .unwrap_or_default();
    let mut headers: Vec<&str> = vec!["job"];
    headers.extend(keys.iter().map(|k| k.as_str()));
    headers.extend(["state", "iterations", "time_s", "rmse"]);
    let rows: Vec<Vec<String>> = t
        .rows
        .iter()
        .map(|r| {
            let mut row = vec![r.job.clone()];
            for k in &keys {
                row.push(match r.point.get(*k) {
                    Some(Value::String(s)) => s.clone(),
                    Some(v) => v.to_string(),
                    None => "-".into(),
                });
            }
            row.push(r.state.as_str().into());
            row.push(r.iterations.to_string());
            row.push(format!("{:.2}", r.time_s));
            row.push(r.rmse.map(|x| format!("{x:.4e}")).unwrap_or("-".into()));
            row
        })
        .collect();
    let mut right = vec![false; 1 + keys.len()];
    right.extend([false, true, true, true]);
    table(&headers, &rows, &right)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sse_messages_are_parsed_and_keepalives_skipped() {
        let text = ": keep-alive\n\nevent: progress\ndata: {\"a\":1}\n\nevent:done\ndata:x\ndata: y\r\n\r\ndata: z\n\nevent: cut\ndata: 1";
        let mut r = SseReader::new(text.as_bytes());
        let m = |e: &str, d: &str| SseMessage {
            event: e.into(),
            data: d.into(),
        };
        assert_eq!(r.next_message().unwrap(), Some(m("progress", "{\"a\":1}")));
        assert_eq!(r.next_message().unwrap(), Some(m("done", "x\ny")));
        assert_eq!(r.next_message().unwrap(), Some(m("message", "z")));
        assert_eq!(r.next_message().unwrap(), None);
    }

    #[test]
    fn grid_values_are_json_when_possible() {
        let g = parse_grid(&[
            "algorithm=pt,albedo".into(),
            "spp=1,2.5".into(),
            "params.x=[[1,2],[3]]".into(),
        ])
        .unwrap();
        assert_eq!(
            g["algorithm"],
            vec![Value::from("pt"), Value::from("albedo")]
        );
        assert_eq!(g["halt.spp"], vec![Value::from(1), Value::from(2.5)]);
        assert_eq!(g["params.x"].len(), 2);
        assert!(parse_grid(&["spp".into()]).is_err());
        assert!(parse_grid(&["spp=1,,2".into()]).is_err());
    }

    #[test]
    fn options_override_a_spec() {
        let o = JobOptions {
            spp: Some(4),
            params: vec!["max_depth=3".into(), "mode=fast".into()],
            snapshot_every_iterations: Some(2),
            reference_job: Some("j1".into()),
            tags: vec!["t".into()],
            ..Default::default()
        };
        let s = o.spec("cornell-box").unwrap();
        assert_eq!(s.halt.spp, Some(4));
        assert_eq!(s.params["max_depth"], 3);
        assert_eq!(s.params["mode"], "fast");
        assert_eq!(s.snapshot_every, SnapshotEvery::Iterations(2));
        assert_eq!(s.reference, Some(ReferenceSpec::Job("j1".into())));
        assert_eq!(s.tags, vec!["t".to_string()]);
        assert!(JobOptions {
            params: vec!["oops".into()],
            ..Default::default()
        }
        .spec("x")
        .is_err());
    }

    #[test]
    fn scenes_with_files_become_deterministic_tar_bundles() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        std::fs::write(dir.join("meshes/a.obj"), "mtllib a.mtl\nv 0 0 0\n").unwrap();
        std::fs::write(dir.join("meshes/a.mtl"), "newmtl x\n").unwrap();
        let scene = serde_json::json!({"shapes": [{"type": "obj", "filename": "./meshes/a.obj"}]});
        std::fs::write(dir.join("s.json"), scene.to_string()).unwrap();
        let (a, ct, n) = scene_upload(&dir.join("s.json")).unwrap();
        let (b, _, _) = scene_upload(&dir.join("s.json")).unwrap();
        assert_eq!((ct, n), ("application/x-tar", 2));
        assert_eq!(a, b);
        assert_eq!(&a[257..262], b"ustar");
        let names = |bytes: &[u8]| -> Vec<String> {
            tar::Archive::new(bytes)
                .entries()
                .unwrap()
                .map(|e| e.unwrap().path().unwrap().display().to_string())
                .collect()
        };
        // OBJ material libraries stay home: the server reads no OBJ materials.
        assert_eq!(names(&a), ["scene.json", "meshes/a.obj"]);

        // Media grids: a .vol, and a raw grid's header with the data file it names.
        std::fs::create_dir_all(dir.join("grids/raw")).unwrap();
        std::fs::write(dir.join("grids/smoke.vol"), b"VOL").unwrap();
        std::fs::write(dir.join("grids/raw/d.bin"), [0u8; 4]).unwrap();
        std::fs::write(
            dir.join("grids/albedo.json"),
            r#"{"dims": [1, 1, 1], "data": "raw/d.bin"}"#,
        )
        .unwrap();
        let media = serde_json::json!({"media": {"smoke": {"type": "grid", "file": "grids/smoke.vol",
                                        "albedo_file": "grids/albedo.json"}}});
        std::fs::write(dir.join("m.json"), media.to_string()).unwrap();
        let (tar, _, n) = scene_upload(&dir.join("m.json")).unwrap();
        assert_eq!(n, 4);
        assert_eq!(
            names(&tar),
            [
                "scene.json",
                "grids/albedo.json",
                "grids/raw/d.bin",
                "grids/smoke.vol"
            ]
        );

        let bad = serde_json::json!({"lights": [{"type": "envmap", "filename": "../x.exr"}]});
        std::fs::write(dir.join("bad.json"), bad.to_string()).unwrap();
        assert!(scene_upload(&dir.join("bad.json")).is_err());
        let missing = serde_json::json!({"lights": [{"type": "envmap", "filename": "x.exr"}]});
        std::fs::write(dir.join("missing.json"), missing.to_string()).unwrap();
        assert!(scene_upload(&dir.join("missing.json")).is_err());
        let plain = serde_json::json!({"shapes": []});
        std::fs::write(dir.join("plain.json"), plain.to_string()).unwrap();
        assert_eq!(
            scene_upload(&dir.join("plain.json")).unwrap().1,
            "application/json"
        );
    }

    #[test]
    fn tables_align() {
        let t = table(
            &["a", "num"],
            &[
                vec!["xyz".into(), "1".into()],
                vec!["b".into(), "100".into()],
            ],
            &[false, true],
        );
        assert_eq!(t, "a    num\nxyz    1\nb    100\n");
        assert_eq!(segment("a/b c"), "a%2Fb%20c");
    }
}
