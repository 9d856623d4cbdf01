//! A job's transitions, the state machine of [`JobState`], written in one place:
//! [`make`] moves a status to its next state with the fields that go with that state
//! and stores it (job.json); [`announce`] says a state to watchers (`state`, then
//! `done` for a finished job). A status goes into the job table, and is announced,
//! through `scheduler::settle`.
//!
//! Who moves jobs: `run` (a job completes or fails at the end of its step), the
//! scheduler (a queued job starts; a pause or cancel lands between batches) and the
//! service (requests on an idle job, retries, recovery at start). This module imports
//! only the job's spec, its directory, the events and the context they go out on.

use super::context::Context;
use super::events::Event;
use super::failpoint;
use super::spec::{unix_now, JobState, JobStatus};
use super::store::JobDir;
use super::JobError;

/// The state a job moves to, with what the move needs.
#[derive(Clone, Debug, PartialEq)]
pub enum To {
    /// Waiting to run: a new job, a resumed or retried one, one recovered at start.
    Queued,
    Running,
    Paused,
    Cancelled,
    Completed,
    /// With the reason, in words for the client.
    Failed(String),
}

/// Moves `status` to `to`, and stores it: the one writer of a transition. When
/// job.json cannot be written, `status` has moved all the same; the caller decides
/// what that means (refuse a client's request, or write it again later).
pub fn make(dir: &JobDir, status: &mut JobStatus, to: To) -> Result<(), JobError> {
    enter(status, to);
    store(dir, status)
}

/// Moves `status` to `to` without storing it: a stopped job (paused or finished) has
/// no estimate and no workers, a finished one its time of finishing (and a failed one
/// its reason), and a queued one none of those. For a job starting, whose batch writes
/// job.json, and for recovery, which stores only what must change.
pub fn enter(status: &mut JobStatus, to: To) {
    let state = match to {
        To::Queued => {
            status.error = None;
            status.finished_at = None;
            status.eta_s = None;
            JobState::Queued
        }
        To::Running => JobState::Running,
        To::Paused => JobState::Paused,
        To::Cancelled => JobState::Cancelled,
        To::Completed => JobState::Completed,
        To::Failed(why) => {
            status.error = Some(why);
            JobState::Failed
        }
    };
    if state.is_terminal() {
        status.finished_at = Some(unix_now());
    }
    if !matches!(state, JobState::Queued | JobState::Running) {
        status.eta_s = None;
        status.workers = None;
    }
    status.state = state;
}

/// Writes job.json, logging a failure (the caller decides what it means).
pub fn store(dir: &JobDir, status: &JobStatus) -> Result<(), JobError> {
    failpoint::hit("status", status.iteration);
    let r = dir.write_status(status);
    if let Err(e) = &r {
        tracing::warn!(job = %status.id, error = %e, "job.json not written");
    }
    r
}

/// Tells watchers a job's state, and `done` with its status if it has finished.
/// Called with the job table locked, so that changes are said in the order made.
pub fn announce(ctx: &Context, status: &JobStatus) {
    for e in Event::said(status) {
        ctx.emit(e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A running job with an estimate and workers.
    fn running() -> JobStatus {
        let mut s = JobStatus::for_tests("j", JobState::Running, 7);
        s.eta_s = Some(4.0);
        s.workers = Some(2);
        s
    }

    #[test]
    fn a_stopped_job_has_no_estimate_and_a_finished_one_its_end() {
        let mut s = running();
        enter(&mut s, To::Paused);
        assert_eq!(
            (s.state, s.eta_s, s.workers, s.finished_at),
            (JobState::Paused, None, None, None)
        );
        let mut s = running();
        enter(&mut s, To::Failed("why".into()));
        assert_eq!(
            (s.state, s.eta_s, s.workers),
            (JobState::Failed, None, None)
        );
        assert!(s.finished_at.is_some());
        assert_eq!(s.error.as_deref(), Some("why"));
        // Queued again, it keeps its iteration and forgets how it ended.
        enter(&mut s, To::Queued);
        assert_eq!(
            (s.state, s.error, s.finished_at, s.iteration),
            (JobState::Queued, None, None, 7)
        );
        let mut s = running();
        enter(&mut s, To::Running);
        assert_eq!((s.eta_s, s.workers), (Some(4.0), Some(2)));
    }

    #[test]
    fn a_transition_is_stored() {
        let dir = tempfile::tempdir().unwrap();
        let jd = JobDir::new(dir.path(), "j");
        jd.create().unwrap();
        let mut s = running();
        make(&jd, &mut s, To::Completed).unwrap();
        // job.json keeps times to the digit its writer prints, not every bit of f64.
        let back = jd.read_status().unwrap();
        let (stored, now) = (back.finished_at.unwrap(), s.finished_at.unwrap());
        assert!((stored - now).abs() < 1e-3, "{stored} vs {now}");
        let finished_at = s.finished_at;
        assert_eq!(
            JobStatus {
                finished_at,
                ..back
            },
            s
        );
        assert_eq!(s.state, JobState::Completed);
        // A directory that is gone: the status moved, the error says it was not stored.
        let gone = JobDir::new(dir.path(), "missing");
        let mut s = running();
        assert!(make(&gone, &mut s, To::Cancelled).is_err());
        assert_eq!(s.state, JobState::Cancelled);
    }
}
