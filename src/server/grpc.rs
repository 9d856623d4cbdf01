//! The gRPC front end (tonic): `caustic.v1.Caustic` from proto/caustic.proto over the
//! transport-neutral [`Service`]. Methods convert messages, call the service on the
//! blocking pool and map errors with the one `to_status`.

use crate::job::events::Event;
use crate::job::scenes::SceneInfo;
use crate::job::service::JobFilter;
use crate::job::spec::{KeepSnapshots, ReferenceSpec, SnapshotEvery};
use crate::job::sweep::{Sweep, SweepSpec};
use crate::job::watch::{Watch, Watched};
use crate::job::{HaltSpec, JobError, JobSpec, JobState, JobStatus, Service};
use std::pin::Pin;
use std::sync::Arc;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::service::interceptor::InterceptedService;
use tonic::service::Interceptor;
use tonic::{Request, Response, Status};

/// Messages, server and client generated from proto/caustic.proto.
pub mod pb {
    tonic::include_proto!("caustic.v1");
}

use pb::caustic_server::{Caustic, CausticServer};

/// The gRPC service with bearer-token auth, ready for `Server::builder().add_service`.
pub type GrpcServer = OversizeExhausted<InterceptedService<CausticServer<Grpc>, BearerAuth>>;

/// Room for protobuf framing around an upload of exactly `max_upload` bytes.
const FRAMING: usize = 64 << 10;

/// The one mapping from domain errors to gRPC status codes.
fn to_status(e: JobError) -> Status {
    if e.is_server_error() {
        tracing::error!(error = %e, "call failed on the server's side");
    }
    let message = e.client_message();
    match e {
        JobError::BadRequest(_) | JobError::InvalidScene(_) => Status::invalid_argument(message),
        JobError::NotFound(_) => Status::not_found(message),
        JobError::Conflict(_) => Status::failed_precondition(message),
        JobError::TooLarge(_) => Status::resource_exhausted(message),
        JobError::Storage {
            kind: std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded,
            ..
        } => Status::resource_exhausted(message),
        JobError::Storage { .. } => Status::unavailable(message),
        JobError::Internal(_) => Status::internal(message),
    }
}

fn bad(msg: impl Into<String>) -> JobError {
    JobError::BadRequest(msg.into())
}

/// The `Caustic` implementation; build it with [`service`] or [`grpc_server`].
#[derive(Clone)]
pub struct Grpc {
    svc: Arc<Service>,
}

/// The service without auth, accepting messages up to the upload limit.
pub fn service(svc: Arc<Service>) -> CausticServer<Grpc> {
    let limit = usize::try_from(svc.config().max_upload).unwrap_or(usize::MAX);
    CausticServer::new(Grpc { svc }).max_decoding_message_size(limit.saturating_add(FRAMING))
}

/// The service behind bearer-token auth (none when `token` is `None`).
pub fn grpc_server(svc: Arc<Service>, token: Option<String>) -> GrpcServer {
    OversizeExhausted(InterceptedService::new(
        service(svc),
        BearerAuth::new(token),
    ))
}

/// Answers a message above the size limit with RESOURCE_EXHAUSTED, the code the proto
/// documents (and the one an upload just above the limit gets from the service):
/// tonic's decoder refuses such messages before any handler runs, with OUT_OF_RANGE,
/// which no method of ours returns.
#[derive(Clone)]
pub struct OversizeExhausted<S>(S);

impl<S: tonic::server::NamedService> tonic::server::NamedService for OversizeExhausted<S> {
    const NAME: &'static str = S::NAME;
}

impl<S, B, R> tower::Service<axum::http::Request<B>> for OversizeExhausted<S>
where
    S: tower::Service<axum::http::Request<B>, Response = axum::http::Response<R>>,
    S::Future: Send + 'static,
{
    type Response = axum::http::Response<R>;
    type Error = S::Error;
    type Future =
        Pin<Box<dyn std::future::Future<Output = Result<Self::Response, S::Error>> + Send>>;

    fn poll_ready(
        &mut self,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Result<(), Self::Error>> {
        self.0.poll_ready(cx)
    }

    fn call(&mut self, req: axum::http::Request<B>) -> Self::Future {
        let fut = self.0.call(req);
        Box::pin(async move {
            let mut resp = fut.await?;
            let out_of_range = (tonic::Code::OutOfRange as i32).to_string();
            let h = resp.headers_mut();
            if h.get("grpc-status")
                .is_some_and(|v| v.as_bytes() == out_of_range.as_bytes())
            {
                let code = (tonic::Code::ResourceExhausted as i32).to_string();
                h.insert(
                    "grpc-status",
                    code.parse().expect("a number is a header value"),
                );
            }
            Ok(resp)
        })
    }
}

/// Serves [`grpc_server`] on `listener` until the future `shutdown` resolves.
pub async fn serve(
    listener: tokio::net::TcpListener,
    svc: Arc<Service>,
    token: Option<String>,
    shutdown: impl std::future::Future<Output = ()>,
) -> Result<(), tonic::transport::Error> {
    tonic::transport::Server::builder()
        .add_service(grpc_server(svc, token))
        .serve_with_incoming_shutdown(
            tokio_stream::wrappers::TcpListenerStream::new(listener),
            shutdown,
        )
        .await
}

/// Checks `authorization: Bearer <token>` metadata when a token is configured.
#[derive(Clone)]
pub struct BearerAuth {
    token: Option<Arc<str>>,
}

impl BearerAuth {
    pub fn new(token: Option<String>) -> Self {
        BearerAuth {
            token: token.filter(|t| !t.is_empty()).map(Arc::from),
        }
    }
}

impl Interceptor for BearerAuth {
    fn call(&mut self, req: Request<()>) -> Result<Request<()>, Status> {
        let Some(expected) = &self.token else {
            return Ok(req);
        };
        let given = req
            .metadata()
            .get("authorization")
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.split_once(' '))
            .filter(|(scheme, _)| scheme.eq_ignore_ascii_case("bearer"))
            .map(|(_, t)| t.trim());
        match given {
            Some(t) if same_secret(t.as_bytes(), expected.as_bytes()) => Ok(req),
            Some(_) => Err(Status::unauthenticated("wrong bearer token")),
            None => Err(Status::unauthenticated(
                "this server needs a token: send metadata \"authorization: Bearer <token>\"",
            )),
        }
    }
}

/// Compares without an early exit, so timing does not reveal a matching prefix.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

impl Grpc {
    /// Runs a blocking service call on the blocking pool.
    async fn call<T, F>(&self, f: F) -> Result<T, Status>
    where
        T: Send + 'static,
        F: FnOnce(&Service) -> Result<T, JobError> + Send + 'static,
    {
        let svc = self.svc.clone();
        tokio::task::spawn_blocking(move || f(&svc))
            .await
            .map_err(|e| to_status(JobError::Internal(format!("service task: {e}"))))?
            .map_err(to_status)
    }
}

// ---- conversions ----------------------------------------------------------------

fn scene_to_pb(s: SceneInfo) -> pb::Scene {
    pb::Scene {
        id: s.id,
        builtin: s.builtin,
        width: s.width,
        height: s.height,
        shapes: s.shapes as u64,
        lights: s.lights as u64,
        size_bytes: s.size_bytes,
    }
}

fn state_to_pb(s: JobState) -> pb::JobState {
    match s {
        JobState::Queued => pb::JobState::Queued,
        JobState::Running => pb::JobState::Running,
        JobState::Paused => pb::JobState::Paused,
        JobState::Completed => pb::JobState::Completed,
        JobState::Cancelled => pb::JobState::Cancelled,
        JobState::Failed => pb::JobState::Failed,
    }
}

/// `None` for `JOB_STATE_UNSPECIFIED`.
fn state_from_pb(v: i32) -> Result<Option<JobState>, JobError> {
    let s = pb::JobState::try_from(v).map_err(|_| bad(format!("unknown job state {v}")))?;
    Ok(match s {
        pb::JobState::Unspecified => None,
        pb::JobState::Queued => Some(JobState::Queued),
        pb::JobState::Running => Some(JobState::Running),
        pb::JobState::Paused => Some(JobState::Paused),
        pb::JobState::Completed => Some(JobState::Completed),
        pb::JobState::Cancelled => Some(JobState::Cancelled),
        pb::JobState::Failed => Some(JobState::Failed),
    })
}

fn halt_to_pb(h: &HaltSpec) -> pb::Halt {
    pb::Halt {
        spp: h.spp,
        iterations: h.iterations,
        time_s: h.time_s,
        target_rmse: h.target_rmse,
    }
}

fn halt_from_pb(h: pb::Halt) -> HaltSpec {
    HaltSpec {
        spp: h.spp,
        iterations: h.iterations,
        time_s: h.time_s,
        target_rmse: h.target_rmse,
    }
}

fn reference_to_pb(r: &ReferenceSpec) -> pb::ReferenceSource {
    use pb::reference_source::Source;
    let source = match r {
        ReferenceSpec::Upload(id) => Source::Upload(id.clone()),
        ReferenceSpec::Job(id) => Source::Job(id.clone()),
    };
    pb::ReferenceSource {
        source: Some(source),
    }
}

fn reference_from_pb(r: pb::ReferenceSource) -> Result<ReferenceSpec, JobError> {
    use pb::reference_source::Source;
    match r.source {
        Some(Source::Upload(id)) => Ok(ReferenceSpec::Upload(id)),
        Some(Source::Job(id)) => Ok(ReferenceSpec::Job(id)),
        None => Err(bad("reference: set upload or job")),
    }
}

fn snapshot_every_to_pb(s: &SnapshotEvery) -> pb::SnapshotEvery {
    use pb::snapshot_every::Every;
    let every = match *s {
        SnapshotEvery::Iterations(n) => Every::Iterations(n),
        SnapshotEvery::Seconds(t) => Every::Seconds(t),
    };
    pb::SnapshotEvery { every: Some(every) }
}

fn snapshot_every_from_pb(s: pb::SnapshotEvery) -> SnapshotEvery {
    use pb::snapshot_every::Every;
    match s.every {
        Some(Every::Iterations(n)) => SnapshotEvery::Iterations(n),
        Some(Every::Seconds(t)) => SnapshotEvery::Seconds(t),
        None => SnapshotEvery::default(),
    }
}

fn spec_to_pb(s: &JobSpec) -> pb::JobSpec {
    pb::JobSpec {
        scene: s.scene.clone(),
        algorithm: s.algorithm.clone(),
        params_json: if s.params.is_empty() {
            String::new()
        } else {
            serde_json::Value::Object(s.params.clone()).to_string()
        },
        seed: s.seed,
        halt: Some(halt_to_pb(&s.halt)),
        reference: s.reference.as_ref().map(reference_to_pb),
        snapshot_every: Some(snapshot_every_to_pb(&s.snapshot_every)),
        priority: s.priority,
        name: s.name.clone(),
        tags: s.tags.clone(),
        sweep: s.sweep.clone(),
        keep_snapshots: match s.keep_snapshots {
            KeepSnapshots::Count(n) => Some(n),
            KeepSnapshots::All => None,
        },
        keep_all_snapshots: s.keep_snapshots == KeepSnapshots::All,
        keep_checkpoint: s.keep_checkpoint,
    }
}

fn spec_from_pb(s: pb::JobSpec) -> Result<JobSpec, JobError> {
    let params = if s.params_json.trim().is_empty() {
        serde_json::Map::new()
    } else {
        serde_json::from_str(&s.params_json)
            .map_err(|e| bad(format!("params_json must be a JSON object: {e}")))?
    };
    Ok(JobSpec {
        scene: s.scene,
        algorithm: s.algorithm,
        params,
        seed: s.seed,
        halt: s.halt.map(halt_from_pb).unwrap_or_default(),
        reference: s.reference.map(reference_from_pb).transpose()?,
        snapshot_every: s
            .snapshot_every
            .map(snapshot_every_from_pb)
            .unwrap_or_default(),
        priority: s.priority,
        name: s.name,
        tags: s.tags,
        sweep: s.sweep,
        keep_snapshots: match (s.keep_all_snapshots, s.keep_snapshots) {
            (true, _) => KeepSnapshots::All,
            (false, Some(n)) => KeepSnapshots::Count(n),
            (false, None) => KeepSnapshots::DEFAULT,
        },
        keep_checkpoint: s.keep_checkpoint,
    })
}

fn job_to_pb(j: JobStatus) -> pb::Job {
    pb::Job {
        spec: Some(spec_to_pb(&j.spec)),
        settings_json: j.settings.to_string(),
        state: state_to_pb(j.state) as i32,
        iteration: j.iteration,
        elapsed_s: j.elapsed_s,
        samples_per_s: j.samples_per_s,
        last_rmse: j.last_rmse,
        eta_s: j.eta_s,
        dropped: j.dropped,
        width: j.width,
        height: j.height,
        created_at: j.created_at,
        finished_at: j.finished_at,
        error: j.error,
        id: j.id,
    }
}

fn sweep_to_pb(s: Sweep) -> pb::Sweep {
    pb::Sweep {
        spec_json: serde_json::to_string(&s.spec).expect("sweep spec serialises"),
        jobs: s
            .jobs
            .into_iter()
            .map(|(point, job_id)| pb::SweepJob {
                point_json: point.into_iter().map(|(k, v)| (k, v.to_string())).collect(),
                job_id,
            })
            .collect(),
        id: s.id,
    }
}

fn sweep_spec_from_json(text: &str) -> Result<SweepSpec, JobError> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| bad(format!("spec_json: {e}")))
}

fn event(e: pb::job_event::Event) -> pb::JobEvent {
    pb::JobEvent { event: Some(e) }
}

fn state_event(s: JobState) -> pb::JobEvent {
    event(pb::job_event::Event::State(pb::StateChange {
        state: state_to_pb(s) as i32,
    }))
}

fn done_event(j: JobStatus) -> pb::JobEvent {
    event(pb::job_event::Event::Done(pb::Done {
        job: Some(job_to_pb(j)),
    }))
}

/// A domain event as a stream message; snapshot PNGs are attached by the caller.
fn event_to_pb(e: Event) -> pb::JobEvent {
    use pb::job_event::Event as E;
    match e {
        Event::Progress {
            iteration,
            elapsed_s,
            samples_per_s,
            eta_s,
            dropped,
            ..
        } => event(E::Progress(pb::Progress {
            iteration,
            elapsed_s,
            samples_per_s,
            eta_s,
            dropped,
        })),
        Event::Snapshot {
            iteration,
            rmse,
            rel_mse,
            ..
        } => event(E::Snapshot(pb::Snapshot {
            iteration,
            rmse,
            rel_mse,
            png: Vec::new(),
        })),
        Event::State { state, .. } => state_event(state),
        Event::Done { status, .. } => done_event(*status),
    }
}

// ---- WatchJob ---------------------------------------------------------------------

type EventSender = mpsc::Sender<Result<pb::JobEvent, Status>>;

/// Forwards a watch ([`crate::job::watch`]) until its last item or the client
/// leaving. The job's state was sent already; state events that repeat the last state
/// sent are dropped: watchers see changes only.
async fn forward(
    svc: Arc<Service>,
    id: String,
    include_snapshots: bool,
    mut watch: Watch,
    tx: EventSender,
) {
    let mut sent = watch.state();
    loop {
        let item = tokio::select! {
            w = watch.next() => w,
            _ = tx.closed() => return,
        };
        let msg = match item {
            None => return,
            Some(Watched::Event(Event::State { state, .. })) if state == sent => continue,
            Some(Watched::Event(Event::State { state, .. })) => {
                sent = state;
                Ok(state_event(state))
            }
            Some(Watched::Event(e @ Event::Snapshot { iteration, .. })) if include_snapshots => {
                let mut msg = event_to_pb(e);
                if let Some(pb::job_event::Event::Snapshot(s)) = &mut msg.event {
                    s.png = snapshot_png(&svc, &id, iteration).await;
                }
                Ok(msg)
            }
            Some(Watched::Event(e)) => Ok(event_to_pb(e)),
            Some(Watched::Stopping) => Err(Status::unavailable(
                "the server is stopping; the job resumes from its checkpoint when it starts again",
            )),
            Some(Watched::Lost(e)) => Err(to_status(e)),
        };
        if tx.send(msg).await.is_err() {
            return;
        }
    }
}

/// The snapshot's PNG, or empty if it cannot be read (e.g. the job was deleted).
async fn snapshot_png(svc: &Arc<Service>, id: &str, iteration: u64) -> Vec<u8> {
    let (svc, id) = (svc.clone(), id.to_string());
    match tokio::task::spawn_blocking(move || svc.snapshot(&id, iteration, "png")).await {
        Ok(Ok(png)) => png,
        Ok(Err(e)) => {
            tracing::warn!(error = %e, iteration, "snapshot for a watcher is gone");
            Vec::new()
        }
        Err(e) => {
            tracing::error!(error = %e, "snapshot read task failed");
            Vec::new()
        }
    }
}

// ---- the service ----------------------------------------------------------------

type Reply<T> = Result<Response<T>, Status>;

#[tonic::async_trait]
impl Caustic for Grpc {
    async fn upload_scene(&self, req: Request<pb::UploadSceneRequest>) -> Reply<pb::Scene> {
        let data = req.into_inner().data;
        let info = self.call(move |s| s.upload_scene(&data)).await?;
        Ok(Response::new(scene_to_pb(info)))
    }

    async fn list_scenes(
        &self,
        _: Request<pb::ListScenesRequest>,
    ) -> Reply<pb::ListScenesResponse> {
        let scenes = self.call(|s| Ok(s.list_scenes())).await?;
        Ok(Response::new(pb::ListScenesResponse {
            scenes: scenes.into_iter().map(scene_to_pb).collect(),
        }))
    }

    async fn get_scene(&self, req: Request<pb::GetSceneRequest>) -> Reply<pb::Scene> {
        let id = req.into_inner().id;
        let info = self.call(move |s| s.get_scene(&id)).await?;
        Ok(Response::new(scene_to_pb(info)))
    }

    async fn delete_scene(
        &self,
        req: Request<pb::DeleteSceneRequest>,
    ) -> Reply<pb::DeleteSceneResponse> {
        let id = req.into_inner().id;
        self.call(move |s| s.delete_scene(&id)).await?;
        Ok(Response::new(pb::DeleteSceneResponse {}))
    }

    async fn upload_reference(
        &self,
        req: Request<pb::UploadReferenceRequest>,
    ) -> Reply<pb::Reference> {
        let data = req.into_inner().data;
        let id = self.call(move |s| s.upload_reference(&data)).await?;
        Ok(Response::new(pb::Reference { id }))
    }

    async fn submit_job(&self, req: Request<pb::SubmitJobRequest>) -> Reply<pb::Job> {
        let spec = req
            .into_inner()
            .spec
            .ok_or_else(|| to_status(bad("spec is required")))?;
        let spec = spec_from_pb(spec).map_err(to_status)?;
        let job = self.call(move |s| s.submit(spec)).await?;
        Ok(Response::new(job_to_pb(job)))
    }

    async fn get_job(&self, req: Request<pb::GetJobRequest>) -> Reply<pb::Job> {
        let id = req.into_inner().id;
        let job = self.call(move |s| s.get_job(&id)).await?;
        Ok(Response::new(job_to_pb(job)))
    }

    async fn list_jobs(&self, req: Request<pb::ListJobsRequest>) -> Reply<pb::ListJobsResponse> {
        let r = req.into_inner();
        let filter = JobFilter {
            state: r
                .state
                .map(state_from_pb)
                .transpose()
                .map_err(to_status)?
                .flatten(),
            tag: r.tag,
            sweep: r.sweep,
        };
        let jobs = self.call(move |s| Ok(s.list_jobs(&filter))).await?;
        Ok(Response::new(pb::ListJobsResponse {
            jobs: jobs.into_iter().map(job_to_pb).collect(),
        }))
    }

    async fn cancel_job(&self, req: Request<pb::CancelJobRequest>) -> Reply<pb::Job> {
        let id = req.into_inner().id;
        let job = self.call(move |s| s.cancel(&id)).await?;
        Ok(Response::new(job_to_pb(job)))
    }

    async fn pause_job(&self, req: Request<pb::PauseJobRequest>) -> Reply<pb::Job> {
        let id = req.into_inner().id;
        let job = self.call(move |s| s.pause(&id)).await?;
        Ok(Response::new(job_to_pb(job)))
    }

    async fn resume_job(&self, req: Request<pb::ResumeJobRequest>) -> Reply<pb::Job> {
        let id = req.into_inner().id;
        let job = self.call(move |s| s.resume(&id)).await?;
        Ok(Response::new(job_to_pb(job)))
    }

    async fn retry_job(&self, req: Request<pb::RetryJobRequest>) -> Reply<pb::Job> {
        let id = req.into_inner().id;
        let job = self.call(move |s| s.retry(&id)).await?;
        Ok(Response::new(job_to_pb(job)))
    }

    async fn delete_job(&self, req: Request<pb::DeleteJobRequest>) -> Reply<pb::DeleteJobResponse> {
        let id = req.into_inner().id;
        self.call(move |s| s.delete_job(&id)).await?;
        Ok(Response::new(pb::DeleteJobResponse {}))
    }

    async fn create_sweep(&self, req: Request<pb::CreateSweepRequest>) -> Reply<pb::Sweep> {
        let spec = sweep_spec_from_json(&req.into_inner().spec_json).map_err(to_status)?;
        let sweep = self.call(move |s| s.create_sweep(spec)).await?;
        Ok(Response::new(sweep_to_pb(sweep)))
    }

    async fn get_sweep(&self, req: Request<pb::GetSweepRequest>) -> Reply<pb::Sweep> {
        let id = req.into_inner().id;
        let sweep = self.call(move |s| s.get_sweep(&id)).await?;
        Ok(Response::new(sweep_to_pb(sweep)))
    }

    type WatchJobStream =
        Pin<Box<dyn tokio_stream::Stream<Item = Result<pb::JobEvent, Status>> + Send + 'static>>;

    async fn watch_job(&self, req: Request<pb::WatchJobRequest>) -> Reply<Self::WatchJobStream> {
        let pb::WatchJobRequest {
            id,
            include_snapshots,
        } = req.into_inner();
        let job_id = id.clone();
        let watch = self.call(move |s| s.watch(&job_id)).await?;
        let (tx, rx) = mpsc::channel(16);
        // The state first, for a finished job too (its `done` follows). The channel is
        // new and has room: this send cannot fail or wait.
        let _ = tx.try_send(Ok(state_event(watch.state())));
        tokio::spawn(forward(self.svc.clone(), id, include_snapshots, watch, tx));
        Ok(Response::new(Box::pin(ReceiverStream::new(rx))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn job_spec_round_trips_through_protobuf() {
        let spec: JobSpec = serde_json::from_value(serde_json::json!({
            "scene": "cornell-box",
            "algorithm": "pt",
            "params": {"max_depth": 8, "rr": true, "name": "x", "list": [1, 2.5]},
            "seed": 7,
            "halt": {"spp": 16, "time_s": 2.5},
            "reference": {"job": "j1"},
            "snapshot_every": {"iterations": 4},
            "priority": -3,
            "name": "test",
            "tags": ["a", "b"],
            "sweep": "s1"
        }))
        .unwrap();
        assert_eq!(spec_from_pb(spec_to_pb(&spec)).unwrap(), spec);
        let minimal: JobSpec =
            serde_json::from_value(serde_json::json!({"scene": "x", "halt": {"iterations": 1}}))
                .unwrap();
        assert_eq!(spec_from_pb(spec_to_pb(&minimal)).unwrap(), minimal);
    }

    #[test]
    fn states_round_trip_and_unspecified_is_no_filter() {
        for s in JobState::ALL {
            assert_eq!(state_from_pb(state_to_pb(s) as i32).unwrap(), Some(s));
        }
        assert_eq!(state_from_pb(0).unwrap(), None);
        assert!(state_from_pb(99).is_err());
    }

    #[test]
    fn params_must_be_a_json_object() {
        let mut p = spec_to_pb(
            &serde_json::from_value(serde_json::json!({"scene": "x", "halt": {"spp": 1}})).unwrap(),
        );
        p.params_json = "[1]".into();
        assert!(matches!(spec_from_pb(p), Err(JobError::BadRequest(_))));
    }

    #[test]
    fn bearer_tokens_are_checked() {
        let req = |auth: Option<&str>| {
            let mut r = Request::new(());
            if let Some(a) = auth {
                r.metadata_mut().insert("authorization", a.parse().unwrap());
            }
            r
        };
        let mut open = BearerAuth::new(None);
        assert!(open.call(req(None)).is_ok());
        let mut auth = BearerAuth::new(Some("s3cret".into()));
        assert!(auth.call(req(Some("Bearer s3cret"))).is_ok());
        assert!(auth.call(req(Some("bearer s3cret"))).is_ok());
        for bad in [
            None,
            Some("Bearer nope"),
            Some("s3cret"),
            Some("Basic s3cret"),
        ] {
            assert_eq!(
                auth.call(req(bad)).unwrap_err().code(),
                tonic::Code::Unauthenticated
            );
        }
    }
}
