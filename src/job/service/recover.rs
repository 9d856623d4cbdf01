//! Recovery at start: the job table rebuilt from the job directories on disk.

use crate::integrator::Settings;
use crate::job::context::JobSettings;
use crate::job::disk;
use crate::job::scheduler::{Entry, Table};
use crate::job::spec::{JobState, JobStatus};
use crate::job::store::{Checkpoint, JobDir};
use crate::job::transition::{self, To};
use serde::Deserialize;
use std::path::Path;

/// Reads every job.json under `<data-dir>/jobs`. Jobs that were running go back to
/// the queue and resume from their checkpoints; a job's iteration is its checkpoint's
/// (what it resumes from), and a completed job's leftovers (a checkpoint it did not ask
/// to keep, `latest.*`) are removed. Settings are parsed here, once per job: see
/// [`fail_unreadable`] for those that no longer parse.
pub(super) fn recover(data_dir: &Path) -> Table {
    let mut t = Table::default();
    let entries = std::fs::read_dir(data_dir.join("jobs"))
        .into_iter()
        .flatten()
        .flatten();
    for e in entries {
        let Some(id) = e.file_name().into_string().ok() else {
            continue;
        };
        let dir = JobDir::new(data_dir, &id);
        let mut status = match dir.read_status() {
            Ok(s) => s,
            Err(err) => {
                tracing::warn!(job = %id, error = %err, "skipping unreadable job");
                continue;
            }
        };
        if status.state == JobState::Running {
            transition::enter(&mut status, To::Queued);
        }
        // Nothing runs yet: an estimate comes with the next batch.
        status.eta_s = None;
        status.workers = None;
        if status.state == JobState::Completed {
            disk::tidy_finished(&dir, &status.spec);
        } else {
            let header = Checkpoint::read_header(&dir);
            status.iteration = header.as_ref().map_or(0, |h| h.iteration);
            status.elapsed_s = header.as_ref().map_or(0.0, |h| h.elapsed_s);
        }
        let settings = parse_settings(&status.settings);
        let unsaved = match &settings {
            Ok(_) => false,
            Err(why) => fail_unreadable(&dir, &mut status, why),
        };
        let mut entry = Entry::new(status, settings, 0);
        entry.unsaved = unsaved;
        t.jobs.insert(id, entry);
    }
    t
}

/// The stored settings as the scheduler holds them. serde's message names the field
/// at fault and no server path (the value is parsed, not the file).
fn parse_settings(stored: &serde_json::Value) -> JobSettings {
    Settings::deserialize(stored).map_err(|e| {
        format!(
            "the job's stored settings do not parse in this version of caustic ({e}); \
             submit the job again"
        )
    })
}

/// A job whose settings no longer parse (a field that a newer build removed or
/// renamed) cannot run, but its directory, its checkpoint and its settings as written
/// stay: another build may still run it (`retry`). One that would still run is marked
/// failed, saying why, and that is stored as any failure is, so that the API and
/// job.json agree; a finished one keeps its state, since it needs no settings any
/// more. Returns whether job.json is left behind the status (a write failed).
fn fail_unreadable(dir: &JobDir, status: &mut JobStatus, why: &str) -> bool {
    tracing::warn!(job = %status.id, error = why, "stored settings do not parse");
    if status.state.is_terminal() {
        return false;
    }
    transition::make(dir, status, To::Failed(why.to_string())).is_err()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Film;

    fn status(id: &str, state: JobState, iteration: u64) -> JobStatus {
        JobStatus::for_tests(id, state, iteration)
    }

    /// job.json is written every batch, the checkpoint every snapshot: after a kill
    /// the status is ahead, but the job resumes from the checkpoint, and says so.
    #[test]
    fn recovered_jobs_show_the_iteration_they_resume_from() {
        let dir = tempfile::tempdir().unwrap();
        let ahead = JobDir::new(dir.path(), "j1");
        ahead.create().unwrap();
        ahead
            .write_status(&status("j1", JobState::Running, 37))
            .unwrap();
        Checkpoint {
            iteration: 30,
            elapsed_s: 3.0,
            samples: 120,
            film: Film::new(2, 2),
            state: None,
            exact: None,
        }
        .write(&ahead)
        .unwrap();
        let fresh = JobDir::new(dir.path(), "j2");
        fresh.create().unwrap();
        fresh
            .write_status(&status("j2", JobState::Running, 5))
            .unwrap();
        let t = recover(dir.path());
        let j1 = &t.jobs["j1"].status;
        assert_eq!(
            (j1.state, j1.iteration, j1.elapsed_s),
            (JobState::Queued, 30, 3.0)
        );
        let j2 = &t.jobs["j2"].status;
        assert_eq!((j2.state, j2.iteration), (JobState::Queued, 0));
    }

    /// A field the settings no longer have (here `legacy_knob`) fails the job that
    /// would run, with a message naming it, and keeps its directory and its settings
    /// as written; a finished job keeps its state, and the other jobs load as before.
    #[test]
    fn jobs_whose_settings_no_longer_parse_fail_and_the_rest_load() {
        use crate::job::service::{JobFilter, Service, ServiceConfig};
        let dir = tempfile::tempdir().unwrap();
        let stale = serde_json::json!({"algorithm": "pt", "max_depth": 4, "legacy_knob": 3});
        let write = |id: &str, state: JobState, settings: &serde_json::Value| {
            let jd = JobDir::new(dir.path(), id);
            jd.create().unwrap();
            let mut s = status(id, state, 0);
            s.settings = settings.clone();
            jd.write_status(&s).unwrap();
        };
        write("j1", JobState::Running, &stale);
        write(
            "j2",
            JobState::Paused,
            &serde_json::json!({"algorithm": "pt"}),
        );
        let mut done = status("j3", JobState::Completed, 100);
        done.settings = stale.clone();
        JobDir::new(dir.path(), "j3").create().unwrap();
        JobDir::new(dir.path(), "j3").write_status(&done).unwrap();

        let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
        let jobs = svc.list_jobs(&JobFilter::default());
        let ids: Vec<&str> = jobs.iter().map(|j| j.id.as_str()).collect();
        assert_eq!(ids, ["j1", "j2", "j3"]);
        let j1 = &jobs[0];
        assert_eq!(j1.state, JobState::Failed);
        let why = j1.error.clone().unwrap();
        assert!(why.contains("legacy_knob"), "{why}");
        assert!(!why.contains(&*dir.path().to_string_lossy()), "{why}");
        assert_eq!(
            j1.settings, stale,
            "the settings are kept as they were written"
        );
        let on_disk = JobDir::new(dir.path(), "j1").read_status().unwrap();
        assert_eq!(
            (on_disk.state, &on_disk.settings),
            (JobState::Failed, &stale)
        );
        assert_eq!((jobs[1].state, &jobs[1].error), (JobState::Paused, &None));
        assert_eq!(
            (jobs[2].state, &jobs[2].error),
            (JobState::Completed, &None)
        );

        // A retry would run into the same settings: it is refused, saying why, and
        // the job stays as it was (issue 36).
        match svc.retry("j1") {
            Err(crate::job::JobError::Conflict(m)) => assert!(m.contains("legacy_knob"), "{m}"),
            other => panic!("retry was not refused: {other:?}"),
        }
        let again = svc.get_job("j1").unwrap();
        assert_eq!((again.state, again.error), (JobState::Failed, Some(why)));
        svc.shutdown();
    }
}
