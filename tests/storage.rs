//! A data directory that fills up or turns read-only under a running server: jobs
//! fail with a message an operator can act on (no server paths), the state the API
//! reported is the state a restart reads, submissions that cannot be stored leave
//! nothing behind, and a failed job with its checkpoint is retried to the same image.
//!
//! Each test mounts its own small tmpfs, which needs root (as CI runs); elsewhere the
//! tests say so and do nothing.

use caustic::job::{JobError, JobSpec, JobState, Service, ServiceConfig};
use caustic::server::error::ApiError;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod server_common;

/// A tmpfs mounted on a fresh temporary folder, unmounted on drop.
struct Tmpfs {
    dir: tempfile::TempDir,
}

impl Tmpfs {
    fn mount(options: &str) -> Option<Tmpfs> {
        let dir = tempfile::tempdir().unwrap();
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(dir.path())
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            eprintln!("skipped: mounting a tmpfs needs root");
            return None;
        }
        Some(Tmpfs { dir })
    }

    fn path(&self) -> &Path {
        self.dir.path()
    }

    /// Remounts `ro` or `rw`; a file open for writing makes `ro` busy for a moment
    /// (the server writes snapshots), so it is tried until it takes.
    fn remount(&self, mode: &str) {
        for _ in 0..500 {
            let ok = Command::new("mount")
                .args(["-o", &format!("remount,{mode}")])
                .arg(self.path())
                .stderr(std::process::Stdio::null())
                .status()
                .unwrap()
                .success();
            if ok {
                return;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        panic!("remount {mode} did not take");
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(self.path()).status();
    }
}

fn start(data: &Path) -> Arc<Service> {
    Service::start(ServiceConfig::for_tests(data)).unwrap()
}

fn spec(scene: &str, spp: u64) -> JobSpec {
    serde_json::from_value(json!({
        "scene": scene, "halt": {"spp": spp}, "seed": 3,
        "snapshot_every": {"iterations": 10}
    }))
    .unwrap()
}

fn wait(what: &str, mut f: impl FnMut() -> bool) {
    let start = Instant::now();
    while !f() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "timed out: {what}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// No message a client reads may name where the server keeps its data.
fn assert_no_path(message: &str, data: &Path) {
    let data = data.to_string_lossy();
    assert!(
        !message.contains(data.as_ref()) && !message.contains("/tmp"),
        "a server path in {message:?}"
    );
}

fn on_disk_state(data: &Path, id: &str) -> String {
    let text = std::fs::read_to_string(data.join("jobs").join(id).join("job.json")).unwrap();
    serde_json::from_str::<serde_json::Value>(&text).unwrap()["state"]
        .as_str()
        .unwrap()
        .to_string()
}

#[test]
fn a_read_only_disk_fails_the_job_consistently_and_retry_finishes_it() {
    let Some(fs) = Tmpfs::mount("size=64m") else {
        return;
    };
    let data: PathBuf = fs.path().to_path_buf();
    let svc = start(&data);
    let scene = svc
        .upload_scene(server_common::tiny_scene(32).to_string().as_bytes())
        .unwrap()
        .id;
    let spp = 3000;
    let id = svc.submit(spec(&scene, spp)).unwrap().id;
    wait("a first checkpoint", || {
        data.join("jobs").join(&id).join("checkpoint.bin").exists()
    });
    fs.remount("ro");
    wait("the job to fail", || {
        svc.get_job(&id).unwrap().state == JobState::Failed
    });
    let failed = svc.get_job(&id).unwrap();
    let message = failed.error.clone().unwrap();
    assert!(message.contains("may not write"), "{message}");
    assert_no_path(&message, &data);
    // What the API says could not be stored yet: job.json still says running.
    assert_eq!(on_disk_state(&data, &id), "running");
    // A submission meanwhile is refused with a server error that names no path.
    let err = svc.submit(spec(&scene, 10)).unwrap_err();
    assert!(matches!(err, JobError::Storage { .. }), "{err:?}");
    let api = ApiError::from(err);
    assert_eq!(api.status.as_u16(), 500);
    assert_no_path(&api.message, &data);

    fs.remount("rw");
    // The failed state reaches the disk once it can, so a restart agrees with the API.
    wait("job.json to say failed", || {
        on_disk_state(&data, &id) == "failed"
    });
    svc.shutdown();
    drop(svc);
    let svc = start(&data);
    assert_eq!(svc.get_job(&id).unwrap().state, JobState::Failed);
    let retried = svc.retry(&id).unwrap();
    assert_eq!(retried.state, JobState::Queued);
    assert!(
        retried.iteration >= 10,
        "resumes from its checkpoint: {retried:?}"
    );
    wait("the retried job", || {
        svc.get_job(&id).unwrap().state == JobState::Completed
    });
    assert_eq!(svc.get_job(&id).unwrap().iteration, spp);
    let image = svc.image_exr(&id).unwrap();
    let served = caustic::film::decode_exr(&image).unwrap();
    assert!(
        served.pixels()
            == server_common::direct_render(
                &server_common::tiny_scene(32).to_string(),
                Some("pt"),
                &json!({}),
                3,
                spp
            ),
        "retried image differs"
    );
    // Retrying what completed makes no sense.
    assert!(matches!(svc.retry(&id), Err(JobError::Conflict(_))));
    svc.shutdown();
}

#[test]
fn a_full_disk_is_507_and_a_submission_that_cannot_be_stored_leaves_nothing() {
    // Inodes are the scarce resource here: the job's folders can be made, its
    // job.json cannot, which is the partial failure that used to leave a folder.
    let Some(fs) = Tmpfs::mount("size=64m,nr_inodes=64") else {
        return;
    };
    let data: PathBuf = fs.path().to_path_buf();
    let svc = start(&data);
    let before: Vec<_> = std::fs::read_dir(data.join("jobs")).unwrap().collect();
    assert!(before.is_empty());
    // Use up the inodes but two (the job's folder and its snapshots folder).
    let fill = data.join("fill");
    std::fs::create_dir(&fill).unwrap();
    let free = |p: &Path| {
        let c = std::ffi::CString::new(p.to_string_lossy().as_bytes()).unwrap();
        let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
        // SAFETY: a valid C string and a zeroed statvfs to fill.
        assert_eq!(unsafe { libc::statvfs(c.as_ptr(), &mut st) }, 0);
        st.f_ffree
    };
    let mut n = 0;
    while free(&data) > 2 {
        std::fs::write(fill.join(n.to_string()), b"").unwrap();
        n += 1;
    }
    let err = svc.submit(spec("cornell-box", 10)).unwrap_err();
    let api = ApiError::from(err);
    assert_eq!(api.status.as_u16(), 507, "{}", api.message);
    assert!(api.message.contains("disk is full"), "{}", api.message);
    assert_no_path(&api.message, &data);
    let after: Vec<_> = std::fs::read_dir(data.join("jobs")).unwrap().collect();
    assert!(after.is_empty(), "a failed submission left {after:?}");
    assert!(svc.list_jobs(&Default::default()).is_empty());
    std::fs::remove_dir_all(&fill).unwrap();
    svc.submit(spec("cornell-box", 1)).unwrap();
    svc.shutdown();
}
