//! The gRPC front end (tonic): `caustic.v1.Caustic` from proto/caustic.proto over the
//! transport-neutral [`Service`]. Methods convert messages, call the service on the
//! blocking pool and map errors with the one `to_status`. The conversions, the token
//! check, the oversize-message layer and the WatchJob stream have their own files.

mod auth;
mod convert;
mod oversize;
mod watch;

pub use auth::BearerAuth;
pub use oversize::OversizeExhausted;

use crate::job::service::JobFilter;
use crate::job::{JobError, Service};
use convert::{
    job_to_pb, scene_to_pb, spec_from_pb, state_from_pb, sweep_spec_from_json, sweep_to_pb,
};
use std::pin::Pin;
use std::sync::Arc;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::service::interceptor::InterceptedService;
use tonic::{Request, Response, Status};
use watch::forward;

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
        // The message names the parameter already.
        JobError::AtField { error, .. } => to_status(*error),
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
        tokio::spawn(forward(self.svc.clone(), id, include_snapshots, watch, tx));
        Ok(Response::new(Box::pin(ReceiverStream::new(rx))))
    }
}
