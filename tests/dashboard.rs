//! The web dashboard in a real headless Chromium, driven over W3C WebDriver
//! (chromedriver, installed by deploy/scripts/install-chromium.sh when missing; without
//! root and without it, the tests say they skipped). Each page is also saved as a
//! screenshot under <target>/dashboard-screenshots/ for a person to look at.

mod server_common;
use serde_json::{json, Value};
use server_common::*;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// chromedriver: $CAUSTIC_CHROMEDRIVER, else /usr/bin/chromedriver, installed by the
/// project's script when absent; None (the test skips) when that needs root and this
/// is not root. As root (CI) a failed install fails the test: a browser test that
/// silently skipped there would prove nothing.
fn chromedriver() -> Option<&'static Path> {
    /// The install script's exit status when it would need root.
    const NEEDS_ROOT: i32 = 3;
    static BIN: OnceLock<Option<PathBuf>> = OnceLock::new();
    BIN.get_or_init(|| {
        if let Ok(p) = std::env::var("CAUSTIC_CHROMEDRIVER") {
            return Some(PathBuf::from(p));
        }
        let root = env!("CARGO_MANIFEST_DIR");
        let out = Command::new(format!("{root}/deploy/scripts/install-chromium.sh"))
            .stderr(Stdio::inherit())
            .output()
            .expect("running deploy/scripts/install-chromium.sh");
        match out.status.code() {
            Some(0) => Some(PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())),
            Some(NEEDS_ROOT) => None,
            _ => panic!("deploy/scripts/install-chromium.sh failed: {}", out.status),
        }
    })
    .as_deref()
}

/// One browser at a time: the machine has few cores and the jobs need them too.
static BROWSER: Mutex<()> = Mutex::new(());

/// Where screenshots go: <target dir>/dashboard-screenshots (the test binary lives in
/// <target dir>/<profile>/deps).
fn screenshot_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let target = exe.ancestors().nth(3).unwrap().to_path_buf();
    let dir = target.join("dashboard-screenshots");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

/// A chromedriver process and one headless Chromium session on it, both ended when
/// dropped.
struct Browser {
    driver: Child,
    session: String,
    /// Where the browser saves downloads.
    downloads: tempfile::TempDir,
    _lock: std::sync::MutexGuard<'static, ()>,
}

impl Browser {
    fn start() -> Option<Browser> {
        let Some(bin) = chromedriver() else {
            eprintln!(
                "skipped: chromium and chromedriver are missing and deploy/scripts/install-chromium.sh could not install them (it needs root)"
            );
            return None;
        };
        let lock = BROWSER.lock().unwrap_or_else(|e| e.into_inner());
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let driver = Command::new(bin)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting chromedriver");
        let base = format!("http://127.0.0.1:{port}");
        let start = Instant::now();
        while ureq::get(&format!("{base}/status")).call().is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "chromedriver did not start"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let mut options = json!({"args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                                           "--window-size=1280,900"]});
        let downloads = tempfile::tempdir().unwrap();
        options["prefs"] = json!({"download.default_directory": downloads.path(),
                                  "download.prompt_for_download": false});
        if Path::new("/usr/bin/chromium").exists() {
            options["binary"] = json!("/usr/bin/chromium");
        }
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome", "goog:chromeOptions": options,
            "goog:loggingPrefs": {"browser": "ALL"}}}});
        let v = call("POST", &format!("{base}/session"), Some(&caps)).expect("a session");
        let session = format!("{base}/session/{}", v["sessionId"].as_str().unwrap());
        Some(Browser {
            driver,
            session,
            downloads,
            _lock: lock,
        })
    }

    fn cmd(&self, method: &str, path: &str, body: Option<&Value>) -> Value {
        call(method, &format!("{}{path}", self.session), body)
            .unwrap_or_else(|e| panic!("{method} {path}: {e}\n{}", self.console()))
    }

    fn goto(&self, url: &str) {
        self.cmd("POST", "/url", Some(&json!({"url": url})));
    }

    /// Runs `script` (a function body; `arguments` holds `args`) in the page.
    fn js(&self, script: &str, args: Value) -> Value {
        self.cmd(
            "POST",
            "/execute/sync",
            Some(&json!({"script": script, "args": args})),
        )
    }

    /// Waits until the expression (a function body returning a value) is truthy, and
    /// returns its value.
    fn wait_for(&self, what: &str, script: &str, timeout: Duration) -> Value {
        let start = Instant::now();
        loop {
            let v = self.js(script, json!([]));
            if !(v.is_null() || v == false || v == "" || v == 0) {
                return v;
            }
            if start.elapsed() > timeout {
                let text = self.js("return document.body.innerText", json!([]));
                panic!(
                    "timed out waiting for {what}; the page shows:\n{}\n{}",
                    text.as_str().unwrap_or(""),
                    self.console()
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn find(&self, css: &str) -> String {
        let v = self.cmd(
            "POST",
            "/element",
            Some(&json!({"using": "css selector", "value": css})),
        );
        v[ELEMENT].as_str().unwrap().to_string()
    }

    fn click(&self, css: &str) {
        let e = self.find(css);
        self.cmd("POST", &format!("/element/{e}/click"), Some(&json!({})));
    }

    /// Clears an input and types `text` into it, as a person would.
    fn type_into(&self, css: &str, text: &str) {
        let e = self.find(css);
        self.cmd("POST", &format!("/element/{e}/clear"), Some(&json!({})));
        self.cmd(
            "POST",
            &format!("/element/{e}/value"),
            Some(&json!({"text": text})),
        );
    }

    /// Picks an option of a <select> by value (and fires `change`).
    fn select(&self, css: &str, value: &str) {
        self.js(
            "const s = document.querySelector(arguments[0]); s.value = arguments[1];
             s.dispatchEvent(new Event('change')); return s.value === arguments[1];",
            json!([css, value]),
        );
    }

    fn screenshot(&self, name: &str) {
        use base64::Engine;
        let v = self.cmd("GET", "/screenshot", None);
        let png = base64::engine::general_purpose::STANDARD
            .decode(v.as_str().unwrap())
            .unwrap();
        std::fs::write(screenshot_dir().join(format!("{name}.png")), png).unwrap();
    }

    /// The browser console (errors of the page's scripts), for failure messages.
    fn console(&self) -> String {
        call(
            "POST",
            &format!("{}/se/log", self.session),
            Some(&json!({"type": "browser"})),
        )
        .map(|v| {
            v.as_array()
                .map(|a| {
                    a.iter()
                        .map(|e| format!("console: {}", e["message"]))
                        .collect::<Vec<_>>()
                        .join("\n")
                })
                .unwrap_or_default()
        })
        .unwrap_or_default()
    }

    /// Waits for a finished download named `name` and returns its bytes.
    fn downloaded(&self, name: &str) -> Vec<u8> {
        let path = self.downloads.path().join(name);
        let start = Instant::now();
        while !path.exists() {
            assert!(start.elapsed() < WAIT, "{name} was not downloaded");
            std::thread::sleep(Duration::from_millis(50));
        }
        std::fs::read(path).unwrap()
    }

    /// The preview canvas's pixels (RGBA bytes).
    fn preview_pixels(&self) -> Vec<u8> {
        let v = self.js(
            "const c = document.getElementById('preview');
             return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data);",
            json!([]),
        );
        serde_json::from_value(v).unwrap()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = call("DELETE", &self.session, None);
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

/// One WebDriver call: the answer's `value`, or the driver's error.
fn call(method: &str, url: &str, body: Option<&Value>) -> Result<Value, String> {
    let req = ureq::request(method, url).timeout(Duration::from_secs(60));
    let r = match body {
        Some(b) => req
            .set("content-type", "application/json")
            .send_string(&b.to_string()),
        None => req.call(),
    };
    let (code, bytes) = match r {
        Ok(r) => respond(Ok(r)),
        Err(ureq::Error::Status(_, r)) => respond(Ok(r)),
        Err(e) => return Err(e.to_string()),
    };
    let v: Value = serde_json::from_slice(&bytes).map_err(|e| e.to_string())?;
    if code >= 400 {
        return Err(format!("{code}: {}", v["value"]));
    }
    Ok(v["value"].clone())
}

/// The built-in Cornell box at 32 x 32, uploaded: noisy enough that two snapshots a
/// second apart differ in their 8-bit pixels.
fn upload_cornell(s: &TestServer) -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.json"
    ))
    .unwrap();
    let mut scene: Value = serde_json::from_str(&text).unwrap();
    scene["film"]["width"] = json!(32);
    scene["film"]["height"] = json!(32);
    let (code, info) = s.post_bytes("/v1/scenes", scene.to_string().as_bytes());
    assert_eq!(code, 201, "{info}");
    info["id"].as_str().unwrap().to_string()
}

const WAIT: Duration = Duration::from_secs(15);

#[test]
fn submit_through_the_form_watch_the_preview_and_cancel() {
    let Some(b) = Browser::start() else { return };
    let s = TestServer::start(None);
    let scene = upload_cornell(&s);
    // An earlier job, the reference of the one submitted below.
    let (code, earlier) = s.post_json(
        "/v1/jobs",
        &json!({"scene": scene, "halt": {"spp": 64}, "name": "earlier", "tags": ["warm-up"]}),
    );
    assert_eq!(code, 201, "{earlier}");
    let earlier = earlier["id"].as_str().unwrap().to_string();
    assert_eq!(s.wait_job(&earlier)["state"], "completed");

    // The list shows the job, with its tag.
    b.goto(&format!("{}/", s.url));
    b.wait_for(
        "the job list",
        "return document.querySelectorAll('#jobs tbody tr').length === 1 &&
                document.querySelector('#jobs tbody').innerText.includes('warm-up')",
        WAIT,
    );
    b.screenshot("list");

    // A bad parameter: the server's message appears next to the field its error names
    // (the body's `field`), whose input is marked invalid.
    b.click("nav a[data-route=submit]");
    b.wait_for(
        "the submit form",
        "return document.getElementById('submit-form')?.dataset.ready",
        WAIT,
    );
    b.select("#scene", &scene);
    b.select("#algorithm", "pt");
    // The registry's line on the algorithm sits above its parameters.
    let about = caustic::integrator::registry::find("pt").unwrap().about;
    let shown = b.wait_for(
        "the algorithm's line",
        "return document.getElementById('algorithm-about')?.textContent",
        WAIT,
    );
    assert_eq!(shown, about);
    b.type_into("#param-max_depth", "deep");
    b.type_into("#halt-spp", "1000000");
    b.type_into("#snapshot-every", "1");
    b.type_into("#name", "from the form");
    b.type_into("#tags", "browser, test");
    b.select("#reference-job", &earlier);
    b.click("#submit");
    let message_at = |path: &str| {
        let script =
            format!("return document.querySelector('[data-error-for=\"{path}\"]').textContent");
        b.wait_for(&format!("the message at {path}"), &script, WAIT)
    };
    let msg = message_at("params.max_depth");
    assert!(msg.as_str().unwrap().contains("max_depth"), "{msg}");
    let form_error = "return document.getElementById('form-error').textContent";
    assert_eq!(b.js(form_error, json!([])), "");
    let invalid = "return document.querySelector(arguments[0]).getAttribute('aria-invalid')";
    assert_eq!(b.js(invalid, json!(["#param-max_depth"])), "true");
    b.screenshot("submit-error");

    // A message that does not spell its field's path ("halt: spp / iterations ...")
    // lands by the `field` too; the earlier mark is cleared.
    b.type_into("#param-max_depth", "8");
    b.type_into("#halt-spp", "0");
    b.click("#submit");
    let msg = message_at("halt.spp");
    assert!(msg.as_str().unwrap().contains("at least 1"), "{msg}");
    assert_eq!(b.js(form_error, json!([])), "");
    assert_eq!(b.js(invalid, json!(["#halt-spp"])), "true");
    assert_eq!(b.js(invalid, json!(["#param-max_depth"])), Value::Null);

    // Fixed, the job is created and its page opens; the preview changes live.
    b.type_into("#halt-spp", "1000000");
    b.click("#submit");
    let hash = b.wait_for(
        "the job page",
        "return location.hash.startsWith('#/job/') && location.hash",
        WAIT,
    );
    let id = hash
        .as_str()
        .unwrap()
        .trim_start_matches("#/job/")
        .to_string();
    let (_, job) = s.get_json(&format!("/v1/jobs/{id}"));
    assert_eq!(job["spec"]["params"]["max_depth"], 8, "{job}");
    assert_eq!(job["spec"]["tags"], json!(["browser", "test"]), "{job}");
    assert_eq!(
        job["spec"]["snapshot_every"],
        json!({"seconds": 1.0}),
        "{job}"
    );
    assert_eq!(job["spec"]["reference"], json!({"job": earlier}), "{job}");
    b.wait_for(
        "a first preview",
        "return Number(document.getElementById('preview').dataset.version || 0) >= 1",
        WAIT,
    );
    let first = b.preview_pixels();
    assert_eq!(first.len(), 32 * 32 * 4);
    let start = Instant::now();
    loop {
        let now = b.preview_pixels();
        if now != first {
            break;
        }
        assert!(
            start.elapsed() < WAIT,
            "the preview never changed\n{}",
            b.console()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    // The log has rows with an RMSE (against the reference), and the plot draws them
    // (points in the RMSE line's colour).
    b.wait_for(
        "a log row with an RMSE",
        "return [...document.querySelectorAll('#log tbody tr')].some((r) => r.children[3].textContent !== '–')",
        WAIT,
    );
    b.wait_for(
        "the plotted RMSE",
        "const c = document.getElementById('plot');
         const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
         let n = 0;
         for (let i = 0; i < d.length; i += 4) if (d[i] === 0xf0 && d[i + 1] === 0xa5 && d[i + 2] === 0x3a) n++;
         return n",
        WAIT,
    );
    b.screenshot("job");

    // Pause and resume.
    b.click("#action-pause");
    b.wait_for(
        "the paused state",
        "return document.querySelector('[data-stat=state]').textContent === 'paused'",
        WAIT,
    );
    assert_eq!(s.get_json(&format!("/v1/jobs/{id}")).1["state"], "paused");
    b.click("#action-resume");
    b.wait_for(
        "the resumed job",
        "return ['queued', 'running'].includes(document.querySelector('[data-stat=state]').textContent)",
        WAIT,
    );

    // Cancel, then cancel again: the server's refusal is shown.
    b.click("#action-cancel");
    b.wait_for(
        "the cancelled state",
        "return document.querySelector('[data-stat=state]').textContent === 'cancelled'",
        WAIT,
    );
    assert_eq!(
        s.get_json(&format!("/v1/jobs/{id}")).1["state"],
        "cancelled"
    );
    b.click("#action-cancel");
    let refusal = b.wait_for(
        "the refusal",
        "return document.getElementById('action-error').textContent",
        WAIT,
    );
    assert!(refusal.as_str().unwrap().contains("409"), "{refusal}");
    b.screenshot("job-cancelled");

    // The exposure slider brightens the preview; the scrubber shows a stored snapshot.
    let mean = |p: &[u8]| p.iter().map(|&v| v as f64).sum::<f64>() / p.len() as f64;
    let version = || {
        b.js(
            "return Number(document.getElementById('preview').dataset.version)",
            json!([]),
        )
        .as_f64()
        .unwrap()
    };
    let slide = |css: &str, v: f64| {
        b.js(
            "const e = document.querySelector(arguments[0]); e.value = arguments[1];
             e.dispatchEvent(new Event('input'));",
            json!([css, v]),
        );
    };
    b.wait_for(
        "the final preview",
        "return document.getElementById('preview-note').textContent.startsWith('latest image')",
        WAIT,
    );
    let dim = mean(&b.preview_pixels());
    let before = version();
    slide("#exposure", 2.0);
    b.wait_for(
        "the exposed preview",
        &format!("return Number(document.getElementById('preview').dataset.version) > {before}"),
        WAIT,
    );
    let bright = mean(&b.preview_pixels());
    assert!(bright > dim * 1.2, "exposure +2: {dim} -> {bright}");
    slide("#scrubber", 0.0);
    let note = b.wait_for(
        "the first snapshot",
        "const t = document.getElementById('preview-note').textContent;
         return t.startsWith('snapshot at iteration') && t",
        WAIT,
    );
    let (_, snaps) = s.get_json(&format!("/v1/jobs/{id}/snapshots"));
    assert_eq!(
        note,
        format!("snapshot at iteration {}", snaps[0]["iteration"]),
        "{snaps}"
    );
    b.screenshot("job-snapshot");

    // Downloads go through fetch with the API's answers.
    b.click("button[data-download=EXR]");
    let exr = b.downloaded(&format!("{id}-image.exr"));
    assert_eq!(&exr[..4], &[0x76, 0x2f, 0x31, 0x01], "an OpenEXR file");
    b.click("button[data-download='log CSV']");
    let csv = String::from_utf8(b.downloaded(&format!("{id}-log.csv"))).unwrap();
    assert!(csv.starts_with("iteration,elapsed_s,"), "{csv}");

    // The list filters by state.
    b.goto(&format!("{}/#/jobs?state=cancelled", s.url));
    b.wait_for(
        "the filtered list",
        &format!(
            "const rows = document.querySelectorAll('#jobs tbody tr');
             return rows.length === 1 && rows[0].dataset.job === '{id}'"
        ),
        WAIT,
    );
}

#[test]
fn sweep_table_and_workers_page() {
    let Some(b) = Browser::start() else { return };
    let s = TestServer::start(None);
    let scene = upload_cornell(&s);
    let (code, table) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": scene, "halt": {"spp": 4}},
                "grid": {"halt.spp": [2, 8], "seed": [1, 2]}, "name": "spp x seed"}),
    );
    assert_eq!(code, 201, "{table}");
    let sweep = table["id"].as_str().unwrap();
    for r in table["rows"].as_array().unwrap() {
        s.wait_job(r["job"].as_str().unwrap());
    }
    b.goto(&format!("{}/#/sweep/{sweep}", s.url));
    b.wait_for(
        "the sweep table with its thumbnails",
        "const imgs = [...document.querySelectorAll('#sweep tbody img.thumb')];
         return imgs.length === 4 && imgs.every((i) => i.complete && i.naturalWidth === 32)",
        WAIT,
    );
    // Sorted by iterations, descending (two clicks).
    b.click("#sweep th[data-key=iterations]");
    b.click("#sweep th[data-key=iterations]");
    let order = b.js(
        "const col = [...document.querySelectorAll('#sweep th')].findIndex((h) => h.dataset.key === 'iterations');
         return [...document.querySelectorAll('#sweep tbody tr')].map((r) => r.children[col].textContent)",
        json!([]),
    );
    let iterations: Vec<String> = serde_json::from_value(order).unwrap();
    assert_eq!(iterations, ["8", "8", "2", "2"]);
    b.screenshot("sweep");

    b.click("nav a[data-route=server]");
    b.wait_for(
        "the metrics",
        "return document.querySelector('#metrics tbody')?.innerText.includes('caustic_jobs')",
        WAIT,
    );
    let workers = b.js(
        "return document.querySelector('#workers tbody').innerText",
        json!([]),
    );
    assert!(
        workers.as_str().unwrap().contains("in-process"),
        "{workers}"
    );
    b.screenshot("workers");
}

/// A sweep over the merge radius runs as one job with radius layers: the sweep table
/// names each point's layer, and the job's error plot draws a curve per layer.
#[test]
fn a_radius_sweep_shows_its_layers() {
    let Some(b) = Browser::start() else { return };
    let s = TestServer::start(None);
    let scene = upload_cornell(&s);
    let (code, reference) = s.post_json("/v1/jobs", &json!({"scene": scene, "halt": {"spp": 16}}));
    assert_eq!(code, 201, "{reference}");
    let reference = reference["id"].as_str().unwrap().to_string();
    assert_eq!(s.wait_job(&reference)["state"], "completed");
    let (code, table) = s.post_json(
        "/v1/sweeps",
        &json!({"base": {"scene": scene, "algorithm": "vcm", "halt": {"spp": 4},
                         "reference": {"job": reference}, "snapshot_every": {"iterations": 1}},
                "grid": {"params.radius": [0.02, 0.05]}}),
    );
    assert_eq!(code, 201, "{table}");
    let rows = table["rows"].as_array().unwrap();
    let job = rows[0]["job"].as_str().unwrap().to_string();
    assert!(rows.iter().all(|r| r["job"] == job.as_str()), "{table}");
    assert_eq!(s.wait_job(&job)["state"], "completed");
    b.goto(&format!(
        "{}/#/sweep/{}",
        s.url,
        table["id"].as_str().unwrap()
    ));
    b.wait_for(
        "the layer column",
        "const col = [...document.querySelectorAll('#sweep th')].findIndex((h) => h.dataset.key === 'layer');
         if (col < 0) return false;
         const cells = [...document.querySelectorAll('#sweep tbody tr')].map((r) => r.children[col].textContent);
         return cells.includes('main') && cells.includes('radius0')",
        WAIT,
    );
    b.goto(&format!("{}/#/job/{job}", s.url));
    // Points in the first layer's colour (#7fd47f).
    b.wait_for(
        "the radius layer's curve",
        "const c = document.getElementById('plot');
         const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
         let n = 0;
         for (let i = 0; i < d.length; i += 4) if (d[i] === 0x7f && d[i + 1] === 0xd4 && d[i + 2] === 0x7f) n++;
         return n > 0",
        WAIT,
    );
    b.screenshot("radius-layers");
}

#[test]
fn a_token_is_asked_for_kept_in_the_session_and_sent_as_a_header() {
    let Some(b) = Browser::start() else { return };
    let s = TestServer::start(Some("s3cret"));
    b.goto(&format!("{}/", s.url));
    b.wait_for(
        "the token prompt",
        "return !document.getElementById('token-form').hidden",
        WAIT,
    );
    b.screenshot("token");
    b.type_into("#token-input", "s3cret");
    b.click("#token-form button");
    b.wait_for(
        "the job list",
        "return document.getElementById('token-form').hidden &&
                document.querySelector('#view p.muted')?.textContent === 'No jobs match.'",
        WAIT,
    );
    assert_eq!(
        b.js("return sessionStorage.getItem('caustic-token')", json!([])),
        "s3cret"
    );
    // A job page's preview and events (fetch streaming) work behind the token.
    let (code, job) = respond(
        ureq::post(&format!("{}/v1/jobs", s.url))
            .set("authorization", "Bearer s3cret")
            .set("content-type", "application/json")
            .send_string(&json!({"scene": "cornell-box", "halt": {"spp": 2}}).to_string()),
    );
    assert_eq!(code, 201);
    let job: Value = serde_json::from_slice(&job).unwrap();
    let id = job["id"].as_str().unwrap();
    b.goto(&format!("{}/#/job/{id}", s.url));
    b.wait_for(
        "the completed job's preview",
        "return document.querySelector('[data-stat=state]')?.textContent === 'completed' &&
                Number(document.getElementById('preview').dataset.version || 0) >= 1",
        WAIT,
    );
}

#[test]
fn static_files_have_their_types_etags_and_a_strict_policy() {
    let s = TestServer::start(Some("s3cret"));
    let get = |path: &str, etag: Option<&str>| {
        let mut req = ureq::get(&format!("{}{path}", s.url));
        if let Some(e) = etag {
            req = req.set("if-none-match", e);
        }
        match req.call() {
            Ok(r) | Err(ureq::Error::Status(_, r)) => r,
            Err(e) => panic!("{path}: {e}"),
        }
    };
    for (path, ct) in [
        ("/", "text/html; charset=utf-8"),
        ("/dashboard/style.css", "text/css; charset=utf-8"),
        ("/dashboard/app.js", "text/javascript; charset=utf-8"),
        ("/dashboard/sse.js", "text/javascript; charset=utf-8"),
    ] {
        // No token needed: the files hold no data.
        let r = get(path, None);
        assert_eq!(r.status(), 200, "{path}");
        assert_eq!(r.header("content-type"), Some(ct), "{path}");
        assert_eq!(r.header("cache-control"), Some("no-cache"), "{path}");
        let csp = r.header("content-security-policy").unwrap().to_string();
        assert!(csp.starts_with("default-src 'self'"), "{csp}");
        assert!(!csp.contains("unsafe"), "{csp}");
        let etag = r.header("etag").unwrap().to_string();
        assert_eq!(get(path, Some(&etag)).status(), 304, "{path}");
        assert_eq!(get(path, Some("\"other\"")).status(), 200, "{path}");
    }
    // Every module the page imports is served.
    let (_, app) = s.get("/dashboard/app.js");
    for module in String::from_utf8(app).unwrap().split("from \"./").skip(1) {
        let file = module.split('"').next().unwrap();
        assert_eq!(
            get(&format!("/dashboard/{file}"), None).status(),
            200,
            "{file}"
        );
    }
    let r = get("/dashboard/secret.txt", None);
    assert_eq!(r.status(), 404);
    assert!(r.into_string().unwrap().contains("not_found"));
    // The API itself still needs the token.
    assert_eq!(get("/v1/jobs", None).status(), 401);
}
