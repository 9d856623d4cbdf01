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
