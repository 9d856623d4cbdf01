//! Recovery at start: the job table rebuilt from the job directories on disk.

use crate::job::disk;
use crate::job::scheduler::{Entry, Table};
use crate::job::spec::JobState;
use crate::job::store::{Checkpoint, JobDir};
use std::path::Path;

/// Reads every job.json under `<data-dir>/jobs`. Jobs that were running go back to
/// the queue and resume from their checkpoints; a job's iteration is its checkpoint's
/// (what it resumes from), and a completed job's leftovers (a checkpoint it did not ask
/// to keep, `latest.*`) are removed.
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
            status.state = JobState::Queued;
        }
        if status.state == JobState::Completed {
            disk::tidy_finished(&dir, &status.spec);
        } else {
            let header = Checkpoint::read_header(&dir);
            status.iteration = header.as_ref().map_or(0, |h| h.iteration);
            status.elapsed_s = header.as_ref().map_or(0.0, |h| h.elapsed_s);
        }
        t.jobs.insert(id, Entry::new(status, 0));
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Film;
    use crate::job::spec::{JobSpec, JobStatus};

    fn status(id: &str, state: JobState, iteration: u64) -> JobStatus {
        let spec: JobSpec = serde_json::from_value(serde_json::json!({
            "scene": "cornell-box", "halt": {"spp": 100}
        }))
        .unwrap();
        JobStatus {
            id: id.into(),
            spec,
            settings: serde_json::json!({}),
            state,
            iteration,
            elapsed_s: 9.0,
            samples_per_s: 0.0,
            last_rmse: None,
            eta_s: None,
            dropped: 0,
            width: 2,
            height: 2,
            created_at: 0.0,
            finished_at: None,
            error: None,
        }
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
}
