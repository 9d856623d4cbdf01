//! Job events, fanned out to every watcher (SSE, gRPC WatchJob) by a broadcast channel.

use super::spec::{JobState, JobStatus};
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// After every batch of iterations.
    Progress {
        job: String,
        iteration: u64,
        elapsed_s: f64,
        samples_per_s: f64,
        eta_s: Option<f64>,
        dropped: u64,
    },
    /// A snapshot was written (EXR + PNG + log row).
    Snapshot {
        job: String,
        iteration: u64,
        rmse: Option<f64>,
        rel_mse: Option<f64>,
        /// Estimated from the job's own iterations (`film::noise`).
        est_rmse: Option<f64>,
        est_rel_mse: Option<f64>,
    },
    State {
        job: String,
        state: JobState,
    },
    /// The job reached a terminal state; the last event for it.
    Done {
        job: String,
        status: Box<JobStatus>,
    },
}

impl Event {
    pub fn job(&self) -> &str {
        match self {
            Event::Progress { job, .. }
            | Event::Snapshot { job, .. }
            | Event::State { job, .. }
            | Event::Done { job, .. } => job,
        }
    }

    /// What says a job's state: `state`, then `done` with its status if it has
    /// finished. Both a transition ([`crate::job::transition::announce`]) and a new
    /// watcher's first look at a job ([`crate::job::watch`]) say it so.
    pub fn said(status: &JobStatus) -> Vec<Event> {
        let state = Event::State {
            job: status.id.clone(),
            state: status.state,
        };
        if status.state.is_terminal() {
            let done = Event::Done {
                job: status.id.clone(),
                status: Box::new(status.clone()),
            };
            vec![state, done]
        } else {
            vec![state]
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Event::Progress { .. } => "progress",
            Event::Snapshot { .. } => "snapshot",
            Event::State { .. } => "state",
            Event::Done { .. } => "done",
        }
    }
}

pub type Sender = tokio::sync::broadcast::Sender<Event>;
