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
    /// Stop when the image's estimated relative error (`noise` in the status: sqrt of
    /// the relative MSE estimated from the job's own iterations, `film::noise`) falls
    /// to this value, e.g. 0.01 for 1 %. Checked at snapshots, from
    /// [`NOISE_HALT_MIN_ITERATIONS`] iterations on; needs no reference.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
}

pub use crate::integrator::drive::NOISE_HALT_MIN_ITERATIONS;

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
    #[serde(deserialize_with = "de_object")]
    pub halt: HaltSpec,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "de_enum_object_or_null"
    )]
    pub reference: Option<ReferenceSpec>,
    #[serde(default, deserialize_with = "de_enum_object")]
    pub snapshot_every: SnapshotEvery,
    /// Higher runs first; equal priorities share the workers fairly.
    #[serde(default)]
    pub priority: i32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default)]
    pub tags: Vec<String>,
    /// Snapshots kept on disk: a number (default 16, thinned to stay spread over the
    /// run on a log scale of iterations, the first and latest always kept) or `"all"`.
    /// The log keeps a row for every snapshot either way.
    #[serde(default, skip_serializing_if = "KeepSnapshots::is_default")]
    #[schema(value_type = Object)]
    pub keep_snapshots: KeepSnapshots,
    /// Keep the checkpoint (exact pixel sums) after the job completes, e.g. to extend
    /// it later; by default a completed job drops it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub keep_checkpoint: bool,
    /// Add a `variance` layer to the EXR snapshots and the final EXR: each pixel's
    /// estimated variance of the mean, per channel (`film::noise`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub variance_layer: bool,
    /// Set by the server for jobs expanded from a sweep; a client may not set it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(read_only)]
    pub sweep: Option<String>,
}

/// How many snapshots a job keeps: `Count(n)` or `All`; JSON `16` or `"all"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeepSnapshots {
    Count(u32),
    All,
}

impl KeepSnapshots {
    pub const DEFAULT: KeepSnapshots = KeepSnapshots::Count(16);

    fn is_default(&self) -> bool {
        *self == Self::DEFAULT
    }
}

impl Default for KeepSnapshots {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum KeepRepr {
    Count(u32),
    Word(AllWord),
}

#[derive(Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum AllWord {
    All,
}

impl Serialize for KeepSnapshots {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match *self {
            KeepSnapshots::Count(n) => KeepRepr::Count(n),
            KeepSnapshots::All => KeepRepr::Word(AllWord::All),
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for KeepSnapshots {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match KeepRepr::deserialize(d)
            .map_err(|_| serde::de::Error::custom("keep_snapshots: expected a count or \"all\""))?
        {
            KeepRepr::Count(n) => Ok(KeepSnapshots::Count(n)),
            KeepRepr::Word(AllWord::All) => Ok(KeepSnapshots::All),
        }
    }
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
    /// Estimated relative error of the image at the last snapshot, from its own
    /// iterations (sqrt of `est_rel_mse` in the log); absent before two iterations and
    /// for `sppm`/`ppm`, whose iterations are not independent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
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
    /// Workers of the pool (`caustic serve --nats`) that returned a range of this
    /// running job in the last 10 s; absent when it renders in-process or is not
    /// running.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub workers: Option<u32>,
}

/// Deserializes `T` only from a JSON object (a map): serde's derived structs also
/// accept a sequence of their fields in order, which would read `"halt": [1]` as
/// `{"spp": 1}`.
pub fn de_object<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Only<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for Only<T> {
        type Value = T;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an object")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
            T::deserialize(serde::de::value::MapAccessDeserializer::new(map))
        }
    }
    d.deserialize_map(Only(std::marker::PhantomData))
}

/// An enum written as a one-key object (`{"iterations": 8}`), through a JSON value: a
/// second key is then "expected one key", a type error, rather than the syntax error
/// serde's streaming enum reader reports for valid JSON.
pub fn de_enum_object<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: serde::Deserializer<'de>,
    T: serde::de::DeserializeOwned,
{
    use serde::de::Error;
    match serde_json::Value::deserialize(d)? {
        serde_json::Value::Object(m) if m.len() == 1 => {
            T::deserialize(serde_json::Value::Object(m)).map_err(D::Error::custom)
        }
        serde_json::Value::Object(m) => Err(D::Error::custom(format!(
            "expected an object with one key, found {} keys",
            m.len()
        ))),
        _ => Err(D::Error::custom("expected an object with one key")),
    }
}

/// [`de_enum_object`] for an optional field: null is none.
pub fn de_enum_object_or_null<'de, D, T>(d: D) -> Result<Option<T>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: serde::de::DeserializeOwned,
{
    use serde::de::{Error, IntoDeserializer};
    match serde_json::Value::deserialize(d)? {
        serde_json::Value::Null => Ok(None),
        v => de_enum_object(v.into_deserializer())
            .map(Some)
            .map_err(|e: serde_json::Error| D::Error::custom(e)),
    }
}

pub fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

#[cfg(test)]
impl JobStatus {
    /// A job of `state` at `iteration` on the built-in Cornell box, for tests.
    pub(crate) fn for_tests(id: &str, state: JobState, iteration: u64) -> JobStatus {
        let spec: JobSpec = serde_json::from_value(serde_json::json!({
            "scene": "cornell-box", "halt": {"spp": 100}
        }))
        .unwrap();
        JobStatus {
            id: id.into(),
            spec,
            settings: serde_json::json!({"algorithm": "pt"}),
            state,
            iteration,
            elapsed_s: 9.0,
            samples_per_s: 0.0,
            last_rmse: None,
            noise: None,
            eta_s: None,
            dropped: 0,
            width: 2,
            height: 2,
            created_at: 0.0,
            finished_at: None,
            error: None,
            workers: None,
        }
    }
}
