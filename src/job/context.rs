//! What running a job needs from the server around it: where to report, which scenes
//! and which directory to use, and the counters to add to. The scheduler's table holds
//! the jobs' runtimes; keeping this apart lets `run` work without the table.

use super::events::{Event, Sender};
use super::remote::coordinator::NatsExecutor;
use super::scenes::SceneStore;
use super::store::JobDir;
use crate::integrator::Settings;
use std::path::PathBuf;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;

/// A job's settings, parsed once: at submit, or from job.json when the server starts.
/// The error says, in words for the client, why stored settings do not parse in this
/// build; such a job fails whenever it would start.
pub type JobSettings = Result<Settings, String>;

/// Counters for /metrics.
#[derive(Default)]
pub struct Metrics {
    pub iterations: AtomicU64,
    pub samples: AtomicU64,
    pub rays: AtomicU64,
    pub dropped: AtomicU64,
    pub render_ns: AtomicU64,
    /// Jobs set aside (checkpointed, memory freed) for a job of higher priority.
    pub set_aside: AtomicU64,
}

pub struct Context {
    pub events: Sender,
    pub scenes: Arc<SceneStore>,
    pub data_dir: PathBuf,
    pub metrics: Metrics,
    /// Where iterations run when not in this process: a pool of workers over NATS.
    pub remote: Option<Arc<NatsExecutor>>,
    /// Largest estimated peak memory of one job, bytes (`job::memory`).
    pub max_job: u64,
}

impl Context {
    pub fn emit(&self, e: Event) {
        // No receivers is fine: nobody is watching.
        let _ = self.events.send(e);
    }

    pub fn job_dir(&self, id: &str) -> JobDir {
        JobDir::new(&self.data_dir, id)
    }
}
