//! Iterations rendered by a pool of `caustic worker` processes over NATS JetStream
//! (DESIGN.md "Scale-out"): what the coordinator and the workers say to each other.
//!
//! - Work units are contiguous iteration ranges of a job, JSON [`Unit`]s published on
//!   the work-queue stream [`UNITS_STREAM`] (subject `caustic.units.<job>`), pulled one
//!   at a time by the workers through the shared durable consumer [`WORKERS`]. A unit
//!   that is not acknowledged within its ack wait (its worker died) is delivered again;
//!   a worker keeps a long unit alive with in-progress acknowledgements.
//! - Scenes travel by content id: the coordinator puts a stored scene's bundle (a tar
//!   of its directory) into the object store [`SCENES_BUCKET`] under its id; a worker
//!   fetches it once, validates it as an upload, compiles it and keeps it. Built-in
//!   scenes are in every binary and never travel.
//! - A worker renders a range with `driver::iterate_exact`, puts the range's exact
//!   sums into [`RESULTS_BUCKET`], publishes a [`Done`] on the stream [`DONE_STREAM`]
//!   (subject `caustic.done.<job>`) and only then acknowledges the unit. A worker that
//!   dies in between leaves a range rendered twice, which the coordinator counts once.
//! - Units go out in groups of about one per worker. The coordinator decodes each
//!   result and adds it to its group as it arrives, on its NATS runtime's blocking
//!   threads (`intake`), and adds whole groups to the job's sums in index order from
//!   the checkpoint on. Since the sums are exact, the image is the in-process one bit
//!   for bit.
//! - A chained integrator (sppm, ppm: each iteration continues the previous one's
//!   statistics) runs as an ordered chain: one unit at a time carries the job's
//!   checkpoint to a worker, which returns the checkpoint after its range; the
//!   coordinator adopts it whole. The chain may move between workers at any unit.

pub mod claim;
pub mod coordinator;
pub mod intake;
pub mod ranges;
pub mod simulate;
pub mod worker;

use crate::integrator::{RenderStats, Settings};
use async_nats::jetstream::object_store::ObjectStore;
use serde::{Deserialize, Serialize};
use std::time::Duration;

pub const UNITS_STREAM: &str = "CAUSTIC_UNITS";
pub const DONE_STREAM: &str = "CAUSTIC_DONE";
pub const WORKERS: &str = "caustic-workers";
pub const SCENES_BUCKET: &str = "caustic-scenes";
/// Key-value bucket of worker heartbeats, key = worker name.
pub const WORKERS_BUCKET: &str = "caustic-workers";
/// How often a worker reports; a worker silent for [`WORKER_TTL`] drops out of lists.
pub const HEARTBEAT: Duration = Duration::from_secs(2);
pub const WORKER_TTL: Duration = Duration::from_secs(30);
pub const RESULTS_BUCKET: &str = "caustic-results";
/// How long a delivered unit may go without an acknowledgement (of progress or of
/// completion) before it is delivered to another worker: 10 s, or
/// `CAUSTIC_ACK_WAIT_S` seconds when the worker that creates the shared consumer (the
/// first one on a fresh NATS) has it set. Shorter means a dead worker's unit comes
/// back sooner; longer tolerates longer stalls of a live one.
pub fn ack_wait() -> Duration {
    static WAIT: std::sync::OnceLock<Duration> = std::sync::OnceLock::new();
    *WAIT.get_or_init(|| {
        std::env::var("CAUSTIC_ACK_WAIT_S")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s >= 0.5)
            .map_or(Duration::from_secs(10), Duration::from_secs_f64)
    })
}
/// Deliveries of one unit before its job fails: a range that kills every worker that
/// tries it must not go round for ever.
pub const MAX_DELIVERIES: i64 = 5;

/// One range of iterations to render.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Unit {
    pub job: String,
    /// Changes whenever the coordinator restarts the job's stream of units (start,
    /// resume after pause or restart), so results of older units are told apart.
    pub generation: u64,
    pub scene: String,
    pub settings: Settings,
    pub seed: u64,
    pub first: u64,
    pub end: u64,
    /// For a chained integrator (`Integrator::chained`): the object in
    /// [`RESULTS_BUCKET`] holding the job's checkpoint at `first` (integrator state,
    /// film, sums), which the range continues from and whose successor it returns.
    /// Such a job has one unit out at a time, so its iterations run in order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub carry: Option<String>,
}

/// A worker's answer for a unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Done {
    pub job: String,
    pub generation: u64,
    pub first: u64,
    pub end: u64,
    pub worker: String,
    /// Name of the range's exact sums in [`RESULTS_BUCKET`]; None with `error`.
    pub object: Option<String>,
    /// Why the range could not be rendered (the job fails with it).
    pub error: Option<String>,
    pub stats: RenderStats,
    pub seconds: f64,
}

impl Unit {
    pub fn subject(&self) -> String {
        format!("caustic.units.{}", self.job)
    }

    /// The name of this range's result object.
    pub fn object_name(&self) -> String {
        range_name(&self.job, self.generation, self.first, self.end)
    }
}

/// The name of a range's result object.
pub fn range_name(job: &str, generation: u64, first: u64, end: u64) -> String {
    format!("{job}.{generation}.{first}-{end}")
}

/// Where the checkpoint a chained range continues from is stored.
pub fn carry_name(range: &str) -> String {
    format!("{range}.from")
}

/// What a worker reports about itself (`GET /v1/workers`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct WorkerInfo {
    pub name: String,
    pub threads: usize,
    /// Unix seconds of the latest heartbeat.
    pub last_heartbeat: f64,
    pub ranges_done: u64,
    pub iterations_done: u64,
    /// The job of the range it renders now.
    pub current_job: Option<String>,
}

/// Errors of the NATS executor and worker, in words for the operator.
#[derive(Debug, thiserror::Error)]
pub enum RemoteError {
    #[error("NATS at {url}: {msg}")]
    Connect { url: String, msg: String },
    #[error("NATS: {0}")]
    Nats(String),
    #[error(
        "another coordinator runs this pool ({holder}); stop it, or give this one another \
         NATS server (a stopped coordinator's claim lapses {ttl_s} s after it stops)"
    )]
    Claimed { holder: String, ttl_s: u64 },
    #[error(
        "NATS at {url} is nats-server {version}; caustic needs {min} or later (Debian 12's \
         package is 2.9): install a current one with deploy/scripts/install-nats-server.sh or \
         from nats.io",
        min = MIN_SERVER_TEXT
    )]
    TooOld { url: String, version: String },
    #[error("NATS at {url} runs without JetStream; start nats-server with -js")]
    NoJetStream { url: String },
}

impl RemoteError {
    pub fn nats(e: impl std::fmt::Display) -> RemoteError {
        RemoteError::Nats(e.to_string())
    }
}

/// Connects to `url` (credentials as `nats://user:password@host` or
/// `nats://token@host`) and returns the JetStream context.
pub async fn connect(
    url: &str,
    name: &str,
) -> Result<(async_nats::Client, async_nats::jetstream::Context), RemoteError> {
    // No retries on the first connection: a wrong address or credential is an error
    // now, not a silent wait (a supervisor restarts the process); later drops of the
    // connection are retried for ever.
    let client = async_nats::ConnectOptions::new()
        .name(name)
        .max_reconnects(None)
        .connection_timeout(Duration::from_secs(5))
        .connect(url)
        .await
        .map_err(|e| RemoteError::Connect {
            url: redact(url),
            msg: e.to_string(),
        })?;
    check_server(&client.server_info(), url)?;
    let js = async_nats::jetstream::new(client.clone());
    Ok((client, js))
}

/// The oldest nats-server whose JetStream answers our client reads: 2.9 answers
/// stream requests in a form it cannot parse (tested: 2.9.10 fails at the first
/// stream request, 2.10.25 and 2.15.1 run every pool test).
const MIN_SERVER: (u64, u64) = (2, 10);
const MIN_SERVER_TEXT: &str = "2.10";

/// Refuses, at connect and in words, a server too old or without JetStream, rather
/// than failing later on a reply that does not parse.
fn check_server(info: &async_nats::ServerInfo, url: &str) -> Result<(), RemoteError> {
    if let Some(v) = major_minor(&info.version) {
        if v < MIN_SERVER {
            return Err(RemoteError::TooOld {
                url: redact(url),
                version: info.version.clone(),
            });
        }
    } else {
        tracing::warn!(version = %info.version, "cannot read the NATS server's version");
    }
    if !info.jetstream {
        return Err(RemoteError::NoJetStream { url: redact(url) });
    }
    Ok(())
}

/// `(major, minor)` of a version such as `2.10.25` or `v2.11.0-beta`.
fn major_minor(version: &str) -> Option<(u64, u64)> {
    let mut parts = version.trim_start_matches('v').split(['.', '-']);
    Some((parts.next()?.parse().ok()?, parts.next()?.parse().ok()?))
}

/// `url` without its credentials, for messages.
pub fn redact(url: &str) -> String {
    match (url.find("://"), url.rfind('@')) {
        (Some(s), Some(at)) if at > s => format!("{}***{}", &url[..s + 3], &url[at..]),
        _ => url.to_string(),
    }
}

/// What both sides use: the units stream and the two object stores.
pub struct Handles {
    pub units: async_nats::jetstream::stream::Stream,
    pub scenes: ObjectStore,
    pub results: ObjectStore,
}

/// The streams and buckets, created if missing (both sides call this; creation is
/// idempotent).
pub async fn setup(js: &async_nats::jetstream::Context) -> Result<Handles, RemoteError> {
    let units = work_queue(js, UNITS_STREAM, "caustic.units.>").await?;
    work_queue(js, DONE_STREAM, "caustic.done.>").await?;
    if js.get_key_value(WORKERS_BUCKET).await.is_err() {
        js.create_key_value(async_nats::jetstream::kv::Config {
            bucket: WORKERS_BUCKET.into(),
            max_age: WORKER_TTL,
            ..Default::default()
        })
        .await
        .map_err(RemoteError::nats)?;
    }
    Ok(Handles {
        units,
        scenes: object_store(js, SCENES_BUCKET).await?,
        results: object_store(js, RESULTS_BUCKET).await?,
    })
}

async fn object_store(
    js: &async_nats::jetstream::Context,
    bucket: &str,
) -> Result<ObjectStore, RemoteError> {
    if let Ok(store) = js.get_object_store(bucket).await {
        return Ok(store);
    }
    js.create_object_store(async_nats::jetstream::object_store::Config {
        bucket: bucket.into(),
        storage: async_nats::jetstream::stream::StorageType::File,
        ..Default::default()
    })
    .await
    .map_err(RemoteError::nats)
}

/// The whole of object `name`.
pub async fn read_object(store: &ObjectStore, name: &str) -> Result<Vec<u8>, RemoteError> {
    use tokio::io::AsyncReadExt;
    let mut object = store.get(name).await.map_err(RemoteError::nats)?;
    let mut bytes = Vec::new();
    object
        .read_to_end(&mut bytes)
        .await
        .map_err(RemoteError::nats)?;
    Ok(bytes)
}

/// A work-queue stream on file storage (a message goes once it is acknowledged, and
/// survives a restart of the NATS server until then).
async fn work_queue(
    js: &async_nats::jetstream::Context,
    name: &str,
    subjects: &str,
) -> Result<async_nats::jetstream::stream::Stream, RemoteError> {
    use async_nats::jetstream::stream::{Config, RetentionPolicy, StorageType};
    js.get_or_create_stream(Config {
        name: name.into(),
        subjects: vec![subjects.into()],
        retention: RetentionPolicy::WorkQueue,
        storage: StorageType::File,
        ..Default::default()
    })
    .await
    .map_err(RemoteError::nats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn server_versions_compare_as_numbers() {
        assert_eq!(major_minor("2.9.10"), Some((2, 9)));
        assert_eq!(major_minor("v2.11.0-beta.1"), Some((2, 11)));
        assert_eq!(major_minor("garbage"), None);
        assert!(major_minor("2.9.10").unwrap() < MIN_SERVER);
        assert!(major_minor("2.10.0").unwrap() >= MIN_SERVER);
        assert!(major_minor("3.0.0").unwrap() >= MIN_SERVER);
    }

    #[test]
    fn credentials_never_reach_messages() {
        assert_eq!(redact("nats://s3cret@host:4222"), "nats://***@host:4222");
        assert_eq!(redact("nats://u:p@h"), "nats://***@h");
        assert_eq!(redact("nats://host:4222"), "nats://host:4222");
    }
}
