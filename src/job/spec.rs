//! What a client asks for (JobSpec) and what it gets back (JobStatus).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// When a job stops: whichever limit is reached first. At least one must be set.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct HaltSpec {
    /// Iterations (samples per pixel for pixel-driven algorithms).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp: Option<u64>,
    /// Same as `spp`, for light-pass algorithms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u64>,
    /// Render time budget in seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_s: Option<f64>,
    /// Stop when the RMSE against the reference falls to this value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_rmse: Option<f64>,
}

impl HaltSpec {
    /// The iteration limit, from `spp` or `iterations` (the smaller if both).
    pub fn max_iterations(&self) -> Option<u64> {
        match (self.spp, self.iterations) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }
}

/// A reference image for error logs: an uploaded EXR (by scene-store id) or a previous
/// job's final image.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, ToSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ReferenceSpec {
    /// Id returned by `POST /v1/references`.
    Upload(String),
    /// A completed job whose final image is the reference.
    Job(String),
}

/// How often snapshots (EXR, PNG, log row, checkpoint) are written.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, ToSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum SnapshotEvery {
    Iterations(u64),
    Seconds(f64),
}

impl Default for SnapshotEvery {
    fn default() -> Self {
        SnapshotEvery::Seconds(5.0)
    }
}

/// A render job request.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobSpec {
    /// Scene id (content hash of an upload, or a built-in scene's name).
    pub scene: String,
    /// Algorithm name; default: the scene's, else `pt`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub algorithm: Option<String>,
    /// Algorithm parameters (e.g. `{"max_depth": 8}`).
    #[serde(default)]
    #[schema(value_type = Object)]
    pub params: serde_json::Map<String, serde_json::Value>,
    #[serde(default)]
    pub seed: u64,
    pub halt: HaltSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<ReferenceSpec>,
    #[serde(default)]
    pub snapshot_every: SnapshotEvery,
    /// Higher runs first; equal priorities share the workers fairly.
    #[serde(default)]
    pub priority: i32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default)]
    pub tags: Vec<String>,
    /// Set by the server for jobs expanded from a sweep.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<String>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Hash, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    Queued,
    Running,
    Paused,
    Completed,
    Cancelled,
    Failed,
}

impl JobState {
    pub fn is_terminal(self) -> bool {
        matches!(
            self,
            JobState::Completed | JobState::Cancelled | JobState::Failed
        )
    }

    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Paused => "paused",
            JobState::Completed => "completed",
            JobState::Cancelled => "cancelled",
            JobState::Failed => "failed",
        }
    }

    pub const ALL: [JobState; 6] = [
        JobState::Queued,
        JobState::Running,
        JobState::Paused,
        JobState::Completed,
        JobState::Cancelled,
        JobState::Failed,
    ];
}

/// A job as stored in job.json and returned by the API.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, ToSchema)]
pub struct JobStatus {
    pub id: String,
    pub spec: JobSpec,
    /// The resolved algorithm settings the job runs with.
    #[schema(value_type = Object)]
    pub settings: serde_json::Value,
    pub state: JobState,
    /// Iterations completed (and checkpointed, for a job read back after a restart).
    pub iteration: u64,
    /// Render time so far, in seconds (excludes time queued or paused).
    pub elapsed_s: f64,
    pub samples_per_s: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_rmse: Option<f64>,
    /// Seconds left, when the halting rule allows an estimate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eta_s: Option<f64>,
    /// Non-finite or negative samples dropped so far.
    pub dropped: u64,
    pub width: u32,
    pub height: u32,
    /// Unix time (s) of creation and completion.
    pub created_at: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finished_at: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

pub fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}
