//! The client commands (submit, watch, jobs, sweep) run as a user would: the built
//! binary against an in-process test server.

mod server_common;
use serde_json::{json, Value};
use server_common::*;
use std::borrow::BorrowMut;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

fn caustic(s: &TestServer, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_caustic"));
    c.env_remove("CAUSTIC_SERVER")
        .env_remove("CAUSTIC_TOKEN")
        .args(args)
        .args(["--server", &s.url]);
    c
}

fn run(mut c: impl BorrowMut<Command>) -> Run {
    let Output {
        status,
        stdout,
        stderr,
    } = c.borrow_mut().output().expect("runs");
    Run {
        code: status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&stdout).into(),
        stderr: String::from_utf8_lossy(&stderr).into(),
    }
}

fn ok(mut c: impl BorrowMut<Command>) -> Run {
    let c = c.borrow_mut();
    let r = run(&mut *c);
    assert_eq!(r.code, 0, "{c:?} failed:\n{}\n{}", r.stdout, r.stderr);
    r
}

fn write_scene(dir: &Path, scene: &Value) -> PathBuf {
    let p = dir.join("scene.json");
    std::fs::write(&p, serde_json::to_string_pretty(scene).unwrap()).unwrap();
    p
}

fn json_lines(text: &str) -> Vec<Value> {
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn submit_local_scene_watch_json_then_jobs_and_watch() {
    let s = TestServer::start(None);
    let tmp = tempfile::tempdir().unwrap();
    let scene = write_scene(tmp.path(), &tiny_scene(16));
    let r = ok(caustic(
        &s,
        &[
            "submit",
            scene.to_str().unwrap(),
            "--spp",
            "3",
            "--watch",
            "--json",
        ],
    )
    .args([
        "--name",
        "tiny",
        "--tag",
        "cli",
        "--snapshot-every-iterations",
        "1",
    ]));
    let lines = json_lines(&r.stdout);
    let job = &lines[0];
    let id = job["id"].as_str().unwrap().to_string();
    assert_eq!(job["spec"]["halt"]["spp"], 3);
    assert_eq!(job["urls"]["events"], format!("/v1/jobs/{id}/events"));
    let last = lines.last().unwrap();
    assert_eq!(last["event"], "done", "{}", r.stdout);
    assert_eq!(last["status"]["state"], "completed");
    assert_eq!(last["status"]["iteration"], 3);
    assert!(lines[1..].iter().all(|l| l["job"] == id.as_str()));

    // jobs: JSON and the table, with filters.
    let r = ok(caustic(&s, &["jobs", "--json", "--tag", "cli"]));
    let list: Value = serde_json::from_str(&r.stdout).unwrap();
    let ids: Vec<&str> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, [id.as_str()]);
    let r = ok(caustic(&s, &["jobs", "--state", "completed"]));
    let mut rows = r.stdout.lines();
    let header = rows.next().unwrap();
    assert!(
        header.starts_with("id ") && header.contains("algorithm"),
        "{header}"
    );
    let row = rows.next().unwrap();
    assert!(
        row.starts_with(&id) && row.contains("completed") && row.contains("pt"),
        "{row}"
    );
    assert!(row.trim_end().ends_with("tiny"), "{row}");
    let r = ok(caustic(&s, &["jobs", "--state", "running"]));
    assert_eq!(r.stdout.lines().count(), 1, "{}", r.stdout);

    // watch on a finished job: the summary at once.
    let r = ok(caustic(&s, &["watch", &id]));
    assert!(
        r.stdout
            .starts_with(&format!("{id}: completed, 3 iterations")),
        "{}",
        r.stdout
    );
}

#[test]
fn submit_bundles_the_files_a_scene_names() {
    let s = TestServer::start(None);
    let tmp = tempfile::tempdir().unwrap();
    std::fs::create_dir(tmp.path().join("meshes")).unwrap();
    std::fs::write(
        tmp.path().join("meshes/quad.obj"),
        "v -0.5 0 0\nv 0.5 0 0\nv 0.5 1 0\nv -0.5 1 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let mut scene = tiny_scene(16);
    scene["shapes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"type": "obj", "filename": "meshes/quad.obj", "material": "m"}));
    let path = write_scene(tmp.path(), &scene);
    let r = ok(caustic(
        &s,
        &[
            "submit",
            path.to_str().unwrap(),
            "--spp",
            "2",
            "--watch",
            "--json",
        ],
    ));
    let lines = json_lines(&r.stdout);
    assert_eq!(lines.last().unwrap()["status"]["state"], "completed");
    assert!(r.stderr.contains("(2 files"), "{}", r.stderr);
    let scene_id = lines[0]["spec"]["scene"].as_str().unwrap();
    let stored = s.dir.path().join("scenes").join(scene_id);
    assert!(stored.join("meshes/quad.obj").is_file());
    let (_, info) = s.get_json(&format!("/v1/scenes/{scene_id}"));
    assert_eq!(info["shapes"], 3);

    // A missing mesh is reported before anything is sent.
    std::fs::remove_file(tmp.path().join("meshes/quad.obj")).unwrap();
    let r = run(caustic(
        &s,
        &["submit", path.to_str().unwrap(), "--spp", "1"],
    ));
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("quad.obj"), "{}", r.stderr);
}

/// The shipped smoke scene names its density grid with `file`: it is bundled too.
#[test]
fn submit_bundles_media_grids() {
    let s = TestServer::start(None);
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/media/smoke-room.json");
    let r = ok(caustic(
        &s,
        &[
            "submit",
            scene.to_str().unwrap(),
            "--spp",
            "1",
            "--watch",
            "--json",
        ],
    ));
    let lines = json_lines(&r.stdout);
    assert_eq!(
        lines.last().unwrap()["status"]["state"],
        "completed",
        "{}",
        r.stdout
    );
    assert!(r.stderr.contains("(2 files"), "{}", r.stderr);
    let scene_id = lines[0]["spec"]["scene"].as_str().unwrap();
    assert!(s
        .dir
        .path()
        .join("scenes")
        .join(scene_id)
        .join("smoke.vol")
        .is_file());
}

#[test]
fn sweep_over_algorithms_prints_csv() {
    let s = TestServer::start(None);
    let tmp = tempfile::tempdir().unwrap();
    let scene = write_scene(tmp.path(), &tiny_scene(16));
    let r = ok(caustic(
        &s,
        &[
            "sweep",
            scene.to_str().unwrap(),
            "--grid",
            "algorithm=pt,albedo",
            "--spp",
            "1",
            "--csv",
        ],
    ));
    let lines: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{}", r.stdout);
    assert!(
        lines[0].starts_with("job,algorithm,state,iterations"),
        "{}",
        lines[0]
    );
    assert!(lines[1].contains(",pt,completed,1,"), "{}", lines[1]);
    assert!(lines[2].contains(",albedo,completed,1,"), "{}", lines[2]);

    // The same sweep from a file, as a text table.
    let sweep = json!({
        "base": {"scene": "scene.json", "halt": {"spp": 1}},
        "grid": {"seed": [1, 2]},
        "name": "seeds"
    });
    std::fs::write(tmp.path().join("sweep.json"), sweep.to_string()).unwrap();
    let file = tmp.path().join("sweep.json");
    let r = ok(caustic(&s, &["sweep", "--file", file.to_str().unwrap()]));
    let lines: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{}", r.stdout);
    assert!(
        lines[0].starts_with("job ") && lines[0].contains("seed"),
        "{}",
        lines[0]
    );
    assert!(
        lines[1..].iter().all(|l| l.contains("completed")),
        "{}",
        r.stdout
    );
}

#[test]
fn server_errors_print_the_servers_message() {
    let s = TestServer::start(None);
    let r = run(caustic(
        &s,
        &["submit", "cornell-box", "--algorithm", "vcmm", "--spp", "1"],
    ));
    assert_eq!(r.code, 2, "{}", r.stdout);
    assert!(r.stdout.is_empty(), "{}", r.stdout);
    assert!(
        r.stderr
            .contains("error: 400 bad_request: unknown algorithm \"vcmm\""),
        "{}",
        r.stderr
    );
    let r = run(caustic(&s, &["watch", "no-such-job"]));
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("404 not_found"), "{}", r.stderr);
    let r = run(caustic(&s, &["submit", "missing.json", "--spp", "1"]));
    assert_eq!(r.code, 2);
    assert!(
        r.stderr.contains("missing.json: no such scene file"),
        "{}",
        r.stderr
    );

    // An unreachable server.
    let r = run(Command::new(env!("CARGO_BIN_EXE_caustic")).args([
        "jobs",
        "--server",
        "http://127.0.0.1:1",
    ]));
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("cannot reach the server"), "{}", r.stderr);
}

#[test]
fn watch_exits_1_when_the_job_did_not_complete() {
    let s = TestServer::start(None);
    let (_, info) = s.post_bytes("/v1/scenes", tiny_scene(16).to_string().as_bytes());
    let (code, job) = s.post_json(
        "/v1/jobs",
        &json!({"scene": info["id"], "halt": {"time_s": 60}}),
    );
    assert_eq!(code, 201, "{job}");
    let id = job["id"].as_str().unwrap();
    assert_eq!(
        s.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({})).0,
        200
    );
    s.wait_job(id);
    let r = run(caustic(&s, &["watch", id]));
    assert_eq!(r.code, 1, "{}{}", r.stdout, r.stderr);
    assert!(r.stdout.contains(": cancelled,"), "{}", r.stdout);
}

#[test]
fn token_is_required_and_sent() {
    let s = TestServer::start(Some("s3cret"));
    let r = run(caustic(&s, &["jobs"]));
    assert_ne!(r.code, 0);
    assert!(r.stderr.contains("401 unauthorized"), "{}", r.stderr);
    let r = run(caustic(&s, &["jobs", "--token", "wrong"]));
    assert_ne!(r.code, 0);
    ok(caustic(&s, &["jobs", "--token", "s3cret"]));
    ok(caustic(&s, &["jobs"]).env("CAUSTIC_TOKEN", "s3cret"));
    let r = ok(caustic(
        &s,
        &[
            "submit",
            "cornell-box",
            "--spp",
            "1",
            "--token",
            "s3cret",
            "--watch",
        ],
    )
    .args(["--param", "max_depth=2"]));
    assert!(
        r.stdout
            .lines()
            .nth(1)
            .unwrap()
            .contains(": completed, 1 iterations"),
        "{}",
        r.stdout
    );
}

// ---------------------------------------------------------------------------------
// Job commands, references, XML halts, event order (issue 36)

/// A long job on the tiny scene, submitted over HTTP.
fn long_job(s: &TestServer) -> String {
    let (_, info) = s.post_bytes("/v1/scenes", tiny_scene(16).to_string().as_bytes());
    let (code, job) = s.post_json(
        "/v1/jobs",
        &json!({"scene": info["id"], "halt": {"time_s": 600}}),
    );
    assert_eq!(code, 201, "{job}");
    job["id"].as_str().unwrap().to_string()
}

/// Waits until the job has rendered at least one batch.
fn wait_rendered(s: &TestServer, id: &str) {
    let start = std::time::Instant::now();
    while s.get_json(&format!("/v1/jobs/{id}")).1["iteration"] == 0 {
        assert!(start.elapsed().as_secs() < 60, "job {id} never rendered");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

#[test]
fn job_commands_pause_resume_cancel_retry_and_delete() {
    let s = TestServer::start(None);
    let id = long_job(&s);
    wait_rendered(&s, &id);
    let r = ok(caustic(&s, &["pause", &id]));
    assert_eq!(r.stdout, format!("{id}: paused\n"));
    let r = ok(caustic(&s, &["resume", &id]));
    assert!(r.stdout.starts_with(&format!("{id}: ")), "{}", r.stdout);
    wait_rendered(&s, &id);
    let r = ok(caustic(&s, &["cancel", &id]));
    assert_eq!(r.stdout, format!("{id}: cancelled\n"));
    // A cancelled job has no ETA, whatever it had while it ran.
    let (_, job) = s.get_json(&format!("/v1/jobs/{id}"));
    assert!(job.get("eta_s").is_none(), "{job}");
    let r = run(caustic(&s, &["cancel", &id]));
    assert_eq!(r.code, 2);
    assert!(
        r.stderr
            .contains(&format!("409 conflict: job {id} is cancelled")),
        "{}",
        r.stderr
    );
    let r = ok(caustic(&s, &["retry", &id, "--json"]));
    let job: Value = serde_json::from_str(&r.stdout).unwrap();
    assert_eq!(job["state"], "queued", "{job}");
    assert!(job["iteration"].as_u64().unwrap() > 0, "resumes: {job}");
    ok(caustic(&s, &["cancel", &id]));
    let r = run(caustic(&s, &["delete", "no-such-job"]));
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("404 not_found"), "{}", r.stderr);
    let r = ok(caustic(&s, &["delete", &id]));
    assert_eq!(r.stdout, format!("{id}: deleted\n"));
    assert_eq!(s.get_json(&format!("/v1/jobs/{id}")).0, 404);
}

/// An EXR of the tiny scene's size.
fn reference_exr(dir: &Path) -> PathBuf {
    let path = dir.join("ref.exr");
    let mut img = caustic::film::Image::new(16, 16);
    img.pixels_mut().fill(glam::Vec3::splat(0.25));
    caustic::film::write_exr(&path, &img).unwrap();
    path
}

#[test]
fn reference_upload_and_submit_with_a_reference() {
    let s = TestServer::start(None);
    let tmp = tempfile::tempdir().unwrap();
    let exr = reference_exr(tmp.path());
    let r = ok(caustic(&s, &["reference", "upload", exr.to_str().unwrap()]));
    let rid = r.stdout.trim().to_string();
    assert!(
        rid.len() == 16 && rid.bytes().all(|b| b.is_ascii_hexdigit()),
        "{}",
        r.stdout
    );
    let scene = write_scene(tmp.path(), &tiny_scene(16));
    let scene = scene.to_str().unwrap();
    let submit = |reference: &str| {
        let r = ok(
            caustic(&s, &["submit", scene, "--spp", "2", "--watch", "--json"])
                .args(["--reference", reference]),
        );
        json_lines(&r.stdout)
    };
    // By the id it printed, then by the file itself: both log an error.
    for reference in [rid.as_str(), exr.to_str().unwrap()] {
        let lines = submit(reference);
        assert_eq!(lines[0]["spec"]["reference"], json!({"upload": rid}));
        let done = &lines.last().unwrap()["status"];
        assert_eq!(done["state"], "completed", "{done}");
        assert!(done["last_rmse"].as_f64().unwrap() > 0.0, "{done}");
    }
    // A completed job, as job:ID.
    let job = submit(&rid)[0]["id"].as_str().unwrap().to_string();
    let lines = submit(&format!("job:{job}"));
    assert_eq!(lines[0]["spec"]["reference"], json!({"job": job}));

    // A PNG where an EXR is expected says that it is a PNG: here, and on the server.
    let png = tmp.path().join("ref.png.exr");
    caustic::film::write_png(&png, &caustic::film::Image::new(16, 16), 0.0).unwrap();
    let r = run(caustic(&s, &["reference", "upload", png.to_str().unwrap()]));
    assert_eq!(r.code, 2);
    assert!(
        r.stderr.contains("a PNG image, not an OpenEXR file"),
        "{}",
        r.stderr
    );
    let (code, err) = s.post_bytes("/v1/references", &std::fs::read(&png).unwrap());
    assert_eq!(code, 400, "{err}");
    let message = err["error"]["message"].as_str().unwrap();
    assert!(
        message.contains("a PNG image, not an OpenEXR file"),
        "{message}"
    );
}

/// The Mitsuba Cornell box at 16 x 16 with `sample_count` 3.
fn small_xml(dir: &Path) -> PathBuf {
    let xml = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba/cornell-box.xml"),
    )
    .unwrap()
    .replace(r#"name="spp" value="64""#, r#"name="spp" value="3""#)
    .replace(r#"name="res" value="256""#, r#"name="res" value="16""#);
    let path = dir.join("small.xml");
    std::fs::write(&path, xml).unwrap();
    path
}

#[test]
fn submit_of_xml_halts_at_its_sample_count_and_a_missing_halt_names_the_flags() {
    let s = TestServer::start(None);
    let tmp = tempfile::tempdir().unwrap();
    let xml = small_xml(tmp.path());
    let r = ok(caustic(
        &s,
        &["submit", xml.to_str().unwrap(), "--watch", "--json"],
    ));
    let lines = json_lines(&r.stdout);
    assert_eq!(lines[0]["spec"]["halt"], json!({"spp": 3}));
    assert_eq!(lines.last().unwrap()["status"]["iteration"], 3);
    // A flag wins over the scene's count.
    let r = ok(caustic(&s, &["submit", xml.to_str().unwrap(), "--json"]).args(["--time", "1"]));
    let job: Value = serde_json::from_str(&r.stdout).unwrap();
    assert_eq!(job["spec"]["halt"], json!({"time_s": 1.0}));
    // A sweep too.
    let r =
        ok(caustic(&s, &["sweep", xml.to_str().unwrap(), "--json"]).args(["--grid", "seed=1,2"]));
    let table: Value = serde_json::from_str(&r.stdout).unwrap();
    let iterations: Vec<&Value> = table["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| &r["iterations"])
        .collect();
    assert_eq!(iterations, [3, 3], "{table}");

    let r = run(caustic(&s, &["submit", "cornell-box"]));
    assert_eq!(r.code, 2);
    assert!(
        r.stderr.contains("--spp N") && r.stderr.contains("--time SECONDS"),
        "{}",
        r.stderr
    );
    assert!(!r.stderr.contains("time_s"), "{}", r.stderr);
}

#[test]
fn numbers_out_of_range_are_named_as_written() {
    let s = TestServer::start(None);
    let r = run(caustic(&s, &["submit", "cornell-box", "--time", "1e999"]));
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("1e999 is out of range"), "{}", r.stderr);
    for (param, written) in [("max_depth=1e400", "1e400"), ("max_depth=[1e39]", "1e39")] {
        let r = run(caustic(&s, &["submit", "cornell-box", "--spp", "1"]).args(["--param", param]));
        assert_eq!(r.code, 2, "{}", r.stderr);
        assert!(
            r.stderr
                .contains(&format!("number {written} is out of range")),
            "{param}: {}",
            r.stderr
        );
        assert!(!r.stderr.contains("inf"), "{}", r.stderr);
    }
}

/// Lines of a child's output as they come, with a timeout per line.
struct Lines(std::sync::mpsc::Receiver<String>);

impl Lines {
    fn of(out: impl std::io::Read + Send + 'static) -> Lines {
        use std::io::BufRead;
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for l in std::io::BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(l).is_err() {
                    return;
                }
            }
        });
        Lines(rx)
    }

    fn next(&self) -> Option<Value> {
        let l = self
            .0
            .recv_timeout(std::time::Duration::from_secs(60))
            .ok()?;
        Some(serde_json::from_str(&l).unwrap_or_else(|e| panic!("{e}: {l}")))
    }
}

/// The events (as `watch --json` lines) up to the first `progress`, after which the
/// job is cancelled, and the events up to the end.
fn around_first_progress(
    s: &TestServer,
    id: &str,
    next: impl Fn() -> Option<Value>,
) -> (Vec<Value>, Vec<Value>) {
    let first = next().expect("the first event");
    let (_, resumed) = s.post_json(&format!("/v1/jobs/{id}/resume"), &json!({}));
    assert_eq!(resumed["state"], "queued", "{resumed}");
    let mut before = vec![first];
    while before.last().unwrap()["event"] != "progress" {
        before.push(next().unwrap_or_else(|| panic!("no progress after {before:?}")));
    }
    s.post_json(&format!("/v1/jobs/{id}/cancel"), &json!({}));
    let mut after = Vec::new();
    while let Some(e) = next() {
        after.push(e);
    }
    (before, after)
}

fn states(events: &[Value]) -> Vec<&str> {
    events
        .iter()
        .filter(|e| e["event"] == "state")
        .map(|e| e["state"].as_str().unwrap())
        .collect()
}

/// The order the README gives: `state` first, `running` before any `progress`, and a
/// finished job's stream is its state, then `done`; the same through SSE and
/// `watch --json`.
#[test]
fn events_come_in_the_documented_order() {
    let s = TestServer::start(None);
    for via_cli in [false, true] {
        let id = long_job(&s);
        s.post_json(&format!("/v1/jobs/{id}/pause"), &json!({}));
        s.wait_state(&id, "paused");
        let (before, after) = if via_cli {
            let mut child = caustic(&s, &["watch", &id, "--json"])
                .stdout(std::process::Stdio::piped())
                .spawn()
                .unwrap();
            let lines = Lines::of(child.stdout.take().unwrap());
            let got = around_first_progress(&s, &id, || lines.next());
            assert_eq!(child.wait().unwrap().code(), Some(1));
            got
        } else {
            let resp = ureq::get(&format!("{}/v1/jobs/{id}/events", s.url))
                .call()
                .unwrap();
            let reader = std::sync::Mutex::new(caustic::client::SseReader::new(
                std::io::BufReader::new(resp.into_reader()),
            ));
            let next = || {
                let m = reader.lock().unwrap().next_message().unwrap()?;
                Some(serde_json::from_str::<Value>(&m.data).unwrap())
            };
            around_first_progress(&s, &id, next)
        };
        assert_eq!(
            states(&before),
            ["paused", "queued", "running"],
            "via cli {via_cli}: {before:?}"
        );
        assert_eq!(before[0]["event"], "state");
        let ends: Vec<&Value> = after.iter().rev().take(2).rev().collect();
        assert_eq!(ends[0]["state"], "cancelled", "{after:?}");
        assert_eq!(ends[1]["event"], "done", "{after:?}");
        assert!(
            after
                .iter()
                .all(|e| e["event"] != "state" || e["state"] == "cancelled"),
            "{after:?}"
        );

        // The job has finished: its stream is its state, then done.
        let finished: Vec<Value> = if via_cli {
            json_lines(&run(caustic(&s, &["watch", &id, "--json"])).stdout)
        } else {
            let (_, body) = s.get(&format!("/v1/jobs/{id}/events"));
            let mut r = caustic::client::SseReader::new(body.as_slice());
            std::iter::from_fn(|| r.next_message().unwrap())
                .map(|m| serde_json::from_str(&m.data).unwrap())
                .collect()
        };
        let kinds: Vec<&str> = finished
            .iter()
            .map(|e| e["event"].as_str().unwrap())
            .collect();
        assert_eq!(kinds, ["state", "done"], "via cli {via_cli}: {finished:?}");
        assert_eq!(finished[0]["state"], "cancelled");
    }
}

/// `caustic serve --token` prints a startup hint that sends the token.
#[test]
fn the_startup_hint_sends_the_token() {
    for (extra, auth) in [(&["--token", "s3cret"][..], true), (&[][..], false)] {
        let tmp = tempfile::tempdir().unwrap();
        let server = ServerProcess::start(tmp.path(), extra);
        let start = std::time::Instant::now();
        let hint = loop {
            let lines = server.stderr.lock().unwrap().clone();
            if let Some(l) = lines.iter().find(|l| l.starts_with("try: curl")) {
                break l.clone();
            }
            assert!(start.elapsed().as_secs() < 30, "no hint: {lines:?}");
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        assert_eq!(
            hint.contains("-H \"Authorization: Bearer $CAUSTIC_TOKEN\""),
            auth,
            "{hint}"
        );
        assert!(
            !hint.contains("s3cret"),
            "the token itself is not printed: {hint}"
        );
        drop(server);
    }
}
