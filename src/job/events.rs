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
