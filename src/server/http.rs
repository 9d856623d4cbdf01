//! REST API under /v1 (axum). `app(service, token)` builds the router, so tests can
//! serve it on an ephemeral port.

use super::auth::Token;
use super::error::ApiError;
use crate::api::{AlgorithmInfo, ErrorBody, ErrorDetail, JobUrls, JobView};
use crate::api::{SweepRow, SweepTable};
use crate::job::layer_log::LayerRow;
use crate::job::remote::WorkerInfo;
use crate::job::scenes::SceneInfo;
use crate::job::service::JobFilter;
use crate::job::store::LogRow;
use crate::job::sweep::SweepSpec;
use crate::job::watch::Watched;
use crate::job::JobState;
use crate::job::{JobError, JobSpec, JobStatus, Service};
use axum::body::Bytes;
use axum::extract::rejection::JsonRejection;
use axum::extract::{DefaultBodyLimit, FromRequest, Path, Query, Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::middleware::{self, Next};
use axum::response::sse::{self, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures::{Stream, StreamExt};
use serde::Deserialize;
use std::convert::Infallible;
use std::sync::Arc;
use utoipa::OpenApi;

type Svc = Arc<Service>;
type ApiResult<T> = Result<T, ApiError>;

/// JSON bodies whose rejections (malformed JSON, wrong types, unknown fields, a body
/// that is not an object) become our JSON errors instead of axum's plain-text ones,
/// and name a number that does not fit as it was written.
pub struct JsonBody<T>(pub T);

impl<S, T> FromRequest<S> for JsonBody<T>
where
    T: serde::de::DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        if !is_json(req.headers()) {
            // axum's own answer (415), whatever it finds.
            return match Json::<Object<T>>::from_request(req, state).await {
                Ok(Json(Object(v))) => Ok(JsonBody(v)),
                Err(r) => Err(json_rejection(r, b"")),
            };
        }
        let bytes = Bytes::from_request(req, state)
            .await
            .map_err(|r| ApiError::new(r.status(), ApiError::code_of(r.status()), r.body_text()))?;
        match Json::<Object<T>>::from_bytes(&bytes) {
            Ok(Json(Object(v))) => Ok(JsonBody(v)),
            Err(r) => Err(json_rejection(r, &bytes)),
        }
    }
}

/// `application/json` or `application/...+json`: a content type axum's `Json` takes
/// too (its test is a little wider; what this one leaves, axum judges).
fn is_json(headers: &HeaderMap) -> bool {
    let Some(essence) = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
    else {
        return false;
    };
    let essence = essence.trim().to_ascii_lowercase();
    essence == "application/json"
        || (essence.starts_with("application/") && essence.ends_with("+json"))
}

/// A value that must arrive as a JSON object: serde would otherwise fill a struct
/// from an array, field by field in order (`[1]` as a job).
struct Object<T>(T);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Object<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        crate::job::spec::de_object(d).map(Object)
    }
}

/// A JSON body's rejection; `body` is the text it was about (for the numbers in it).
fn json_rejection(r: JsonRejection, body: &[u8]) -> ApiError {
    let text = String::from_utf8_lossy(body);
    let message = crate::json_numbers::name_out_of_range(&r.body_text(), &text);
    ApiError::new(r.status(), ApiError::code_of(r.status()), message)
}

/// Runs a blocking service call off the async runtime.
async fn blocking<T: Send + 'static>(
    svc: &Svc,
    f: impl FnOnce(&Service) -> Result<T, JobError> + Send + 'static,
) -> ApiResult<T> {
    let svc = svc.clone();
    tokio::task::spawn_blocking(move || f(&svc))
        .await
        .map_err(|e| ApiError::from(JobError::Internal(e.to_string())))?
        .map_err(ApiError::from)
}

pub fn app(svc: Svc, token: Option<String>) -> Router {
    let limits = BodyLimits {
        upload: usize::try_from(svc.config().max_upload).unwrap_or(usize::MAX),
        json: crate::job::limits::MAX_JSON_BODY,
    };
    let body_timeout = svc.config().body_timeout;
    // Upload bodies are held in memory whole: a few at a time bound that memory to
    // a few times the upload limit, however many clients send at once.
    let uploads = Router::new()
        .route("/scenes", post(upload_scene))
        .route("/references", post(upload_reference))
        .layer(DefaultBodyLimit::max(limits.upload))
        .layer(tower::limit::GlobalConcurrencyLimitLayer::new(
            UPLOADS_AT_ONCE,
        ))
        .route("/scenes", get(list_scenes));
    let v1 = Router::new()
        .route("/scenes/{id}", get(get_scene).delete(delete_scene))
        .route("/jobs", post(submit).get(list_jobs))
        .route("/jobs/{id}", get(get_job).delete(delete_job))
        .route("/jobs/{id}/cancel", post(cancel))
        .route("/jobs/{id}/pause", post(pause))
        .route("/jobs/{id}/resume", post(resume))
        .route("/jobs/{id}/retry", post(retry))
        .route("/jobs/{id}/preview.png", get(preview))
        .route("/jobs/{id}/image.exr", get(image))
        .route("/jobs/{id}/snapshots", get(snapshots))
        .route("/jobs/{id}/snapshots/{file}", get(snapshot))
        .route("/jobs/{id}/log", get(log))
        .route("/jobs/{id}/layers", get(layer_log))
        .route("/jobs/{id}/events", get(events))
        .route("/sweeps", post(create_sweep))
        .route("/sweeps/{id}", get(get_sweep))
        .route("/workers", get(workers))
        .route("/algorithms", get(algorithms))
        .route("/openapi.json", get(openapi))
        .layer(DefaultBodyLimit::max(limits.json))
        .merge(uploads);
    let protected = Router::new()
        .nest("/v1", v1)
        .route("/metrics", get(metrics))
        .layer(middleware::from_fn_with_state(Token::new(token), auth));
    Router::new()
        .merge(protected)
        .route("/healthz", get(healthz))
        .merge(super::dashboard::routes())
        .fallback(|| async {
            ApiError::new(StatusCode::NOT_FOUND, "not_found", "no such endpoint")
        })
        .layer(tower_http::timeout::RequestBodyTimeoutLayer::new(
            body_timeout,
        ))
        .layer(middleware::from_fn_with_state(limits, refuse_long_bodies))
        .layer(middleware::from_fn(json_errors))
        .with_state(svc)
}

/// Uploads whose bodies are read at the same time; more wait their turn.
const UPLOADS_AT_ONCE: usize = 2;

#[utoipa::path(get, path = "/healthz", description = "Health check; needs no token.", security(()), responses((status = 200, body = Object)))]
async fn healthz() -> Json<serde_json::Value> {
    Json(serde_json::json!({"status": "ok"}))
}

/// Body size limits: uploads (scenes, references) and every other (JSON) body.
#[derive(Clone, Copy)]
struct BodyLimits {
    upload: usize,
    json: usize,
}

impl BodyLimits {
    fn for_path(&self, path: &str) -> usize {
        if matches!(path, "/v1/scenes" | "/v1/references") {
            self.upload
        } else {
            self.json
        }
    }
}

/// Answers 413 at once when the declared Content-Length is above the limit, rather
/// than waiting for a body the server would refuse anyway (and that may never come).
async fn refuse_long_bodies(
    State(limits): State<BodyLimits>,
    req: Request,
    next: Next,
) -> Response {
    let limit = limits.for_path(req.uri().path());
    let declared = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    if declared.is_some_and(|n| n > limit as u64) {
        return ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
            format!(
                "the body declares {} bytes; this endpoint takes at most {limit}",
                declared.unwrap_or(0)
            ),
        )
        .into_response();
    }
    next.run(req).await
}

/// Makes every error response JSON, as the API promises: axum's own answers (405,
/// some 400 and 413 rejections, body timeouts) are empty or plain text.
async fn json_errors(req: Request, next: Next) -> Response {
    let resp = next.run(req).await;
    let status = resp.status();
    let is_json = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return resp;
    }
    let allow = resp.headers().get(header::ALLOW).cloned();
    let text = axum::body::to_bytes(resp.into_body(), 4096)
        .await
        .map(|b| String::from_utf8_lossy(&b).trim().to_string())
        .unwrap_or_default();
    let message = match (status, &allow) {
        (StatusCode::METHOD_NOT_ALLOWED, Some(a)) => format!(
            "method not allowed here; this endpoint accepts {}",
            a.to_str().unwrap_or("other methods")
        ),
        _ if !text.is_empty() => text,
        _ => status
            .canonical_reason()
            .unwrap_or("request refused")
            .to_string(),
    };
    let mut out = ApiError::new(status, ApiError::code_of(status), message).into_response();
    if let Some(a) = allow {
        out.headers_mut().insert(header::ALLOW, a);
    }
    out
}

/// Bearer-token check (`server::auth`); a no-op when the server runs without a token.
async fn auth(State(token): State<Token>, req: Request, next: Next) -> Response {
    let given = req
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok());
    if token.check(given).is_err() {
        return ApiError::new(
            StatusCode::UNAUTHORIZED,
            "unauthorized",
            "missing or wrong bearer token",
        )
        .into_response();
    }
    next.run(req).await
}

#[utoipa::path(post, path = "/v1/scenes", description = "Upload a scene: one JSON document or Mitsuba 3 XML scene, or a tar/zip bundle with scene.json (or scene.xml) and its assets. Validated; id = content hash. An XML scene is imported; `warnings` lists what the import approximated.", request_body(content = Vec<u8>, content_type = "application/octet-stream"), responses((status = 201, body = SceneInfo), (status = 400, body = ErrorBody), (status = 413, body = ErrorBody), (status = 422, body = ErrorBody)))]
async fn upload_scene(State(svc): State<Svc>, body: Bytes) -> ApiResult<impl IntoResponse> {
    let info = blocking(&svc, move |s| s.upload_scene(&body)).await?;
    Ok((StatusCode::CREATED, Json(info)))
}

#[utoipa::path(get, path = "/v1/scenes", description = "Built-in and uploaded scenes.", responses((status = 200, body = Vec<SceneInfo>)))]
async fn list_scenes(State(svc): State<Svc>) -> ApiResult<impl IntoResponse> {
    Ok(Json(blocking(&svc, |s| Ok(s.list_scenes())).await?))
}

#[utoipa::path(get, path = "/v1/scenes/{id}", description = "One scene.", params(("id" = String, Path)), responses((status = 200, body = SceneInfo), (status = 404, body = ErrorBody)))]
async fn get_scene(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    Ok(Json(blocking(&svc, move |s| s.get_scene(&id)).await?))
}

#[utoipa::path(delete, path = "/v1/scenes/{id}", description = "Delete an uploaded scene (409 while a job uses it).", params(("id" = String, Path)), responses((status = 204), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn delete_scene(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<StatusCode> {
    blocking(&svc, move |s| s.delete_scene(&id)).await?;
    Ok(StatusCode::NO_CONTENT)
}

#[utoipa::path(post, path = "/v1/references", description = "Upload a reference EXR for error logs; returns its id.", request_body(content = Vec<u8>, content_type = "image/x-exr"), responses((status = 201, body = Object), (status = 400, body = ErrorBody)))]
async fn upload_reference(State(svc): State<Svc>, body: Bytes) -> ApiResult<impl IntoResponse> {
    let id = blocking(&svc, move |s| s.upload_reference(&body)).await?;
    Ok((StatusCode::CREATED, Json(serde_json::json!({"id": id}))))
}

#[utoipa::path(post, path = "/v1/jobs", description = "Submit a render job.", request_body = JobSpec, responses((status = 201, body = JobView), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody), (status = 422, body = ErrorBody)))]
async fn submit(
    State(svc): State<Svc>,
    JsonBody(spec): JsonBody<JobSpec>,
) -> ApiResult<impl IntoResponse> {
    let job = blocking(&svc, move |s| s.submit(spec)).await?;
    Ok((StatusCode::CREATED, Json(JobView::new(job))))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ListQuery {
    state: Option<crate::job::JobState>,
    tag: Option<String>,
    sweep: Option<String>,
}

#[utoipa::path(get, path = "/v1/jobs", description = "Jobs, optionally filtered by state, tag or sweep.", params(("state" = Option<JobState>, Query), ("tag" = Option<String>, Query), ("sweep" = Option<String>, Query)), responses((status = 200, body = Vec<JobView>)))]
async fn list_jobs(
    State(svc): State<Svc>,
    q: Result<Query<ListQuery>, axum::extract::rejection::QueryRejection>,
) -> ApiResult<impl IntoResponse> {
    let Query(q) = q.map_err(|e| ApiError::bad_request(e.body_text()))?;
    let f = JobFilter {
        state: q.state,
        tag: q.tag,
        sweep: q.sweep,
    };
    let jobs = blocking(&svc, move |s| Ok(s.list_jobs(&f))).await?;
    Ok(Json(jobs.into_iter().map(JobView::new).collect::<Vec<_>>()))
}

#[utoipa::path(get, path = "/v1/jobs/{id}", description = "One job: state, iteration, elapsed, samples/s, last RMSE, ETA, dropped samples.", params(("id" = String, Path)), responses((status = 200, body = JobView), (status = 404, body = ErrorBody)))]
async fn get_job(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    Ok(Json(JobView::new(
        blocking(&svc, move |s| s.get_job(&id)).await?,
    )))
}

#[utoipa::path(post, path = "/v1/jobs/{id}/retry", description = "Queue a failed or cancelled job again; it resumes from its checkpoint (or starts over, to the same image). Returns the queued job.", params(("id" = String, Path)), responses((status = 200, body = JobView), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn retry(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    Ok(Json(JobView::new(
        blocking(&svc, move |s| s.retry(&id)).await?,
    )))
}

#[utoipa::path(delete, path = "/v1/jobs/{id}", description = "Delete a job that is not running, with its directory.", params(("id" = String, Path)), responses((status = 204), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn delete_job(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<StatusCode> {
    blocking(&svc, move |s| s.delete_job(&id)).await?;
    Ok(StatusCode::NO_CONTENT)
}

#[utoipa::path(post, path = "/v1/jobs/{id}/cancel", description = "Cancel a queued, running or paused job.", params(("id" = String, Path)), responses((status = 200, body = JobView), (status = 409, body = ErrorBody)))]
async fn cancel(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    Ok(Json(JobView::new(
        blocking(&svc, move |s| s.cancel(&id)).await?,
    )))
}

#[utoipa::path(post, path = "/v1/jobs/{id}/pause", description = "Pause a queued or running job (after its current batch).", params(("id" = String, Path)), responses((status = 200, body = JobView), (status = 409, body = ErrorBody)))]
async fn pause(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    Ok(Json(JobView::new(
        blocking(&svc, move |s| s.pause(&id)).await?,
    )))
}

#[utoipa::path(post, path = "/v1/jobs/{id}/resume", description = "Queue a paused job again.", params(("id" = String, Path)), responses((status = 200, body = JobView), (status = 409, body = ErrorBody)))]
async fn resume(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    Ok(Json(JobView::new(
        blocking(&svc, move |s| s.resume(&id)).await?,
    )))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PreviewQuery {
    exposure: Option<f32>,
}

fn bytes_response(content_type: &'static str, bytes: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        bytes,
    )
        .into_response()
}

#[utoipa::path(get, path = "/v1/jobs/{id}/preview.png", description = "Latest image as sRGB PNG.", params(("id" = String, Path), ("exposure" = Option<f32>, Query)), responses((status = 200, content_type = "image/png", body = Vec<u8>), (status = 404, body = ErrorBody)))]
async fn preview(
    State(svc): State<Svc>,
    Path(id): Path<String>,
    q: Result<Query<PreviewQuery>, axum::extract::rejection::QueryRejection>,
) -> ApiResult<Response> {
    let Query(q) = q.map_err(|e| ApiError::bad_request(e.body_text()))?;
    let png = blocking(&svc, move |s| s.preview_png(&id, q.exposure)).await?;
    Ok(bytes_response("image/png", png))
}

#[utoipa::path(get, path = "/v1/jobs/{id}/image.exr", description = "Latest image as linear float32 EXR.", params(("id" = String, Path)), responses((status = 200, content_type = "image/x-exr", body = Vec<u8>), (status = 404, body = ErrorBody)))]
async fn image(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<Response> {
    let exr = blocking(&svc, move |s| s.image_exr(&id)).await?;
    Ok(bytes_response("image/x-exr", exr))
}

#[utoipa::path(get, path = "/v1/jobs/{id}/snapshots", description = "Snapshot iterations with their URLs.", params(("id" = String, Path)), responses((status = 200, body = Vec<Object>)))]
async fn snapshots(State(svc): State<Svc>, Path(id): Path<String>) -> ApiResult<impl IntoResponse> {
    let base = format!("/v1/jobs/{id}/snapshots");
    let list = blocking(&svc, move |s| s.snapshots(&id)).await?;
    let items: Vec<_> = list
        .into_iter()
        .map(|i| serde_json::json!({"iteration": i, "exr": format!("{base}/{i}.exr"), "png": format!("{base}/{i}.png")}))
        .collect();
    Ok(Json(items))
}

#[utoipa::path(get, path = "/v1/jobs/{id}/snapshots/{file}", description = "One snapshot, `<iteration>.exr` or `<iteration>.png`.", params(("id" = String, Path), ("file" = String, Path)), responses((status = 200, body = Vec<u8>), (status = 404, body = ErrorBody)))]
async fn snapshot(
    State(svc): State<Svc>,
    Path((id, file)): Path<(String, String)>,
) -> ApiResult<Response> {
    let (stem, ext) = file.rsplit_once('.').ok_or_else(|| {
        ApiError::bad_request("snapshot file is <iteration>.exr or <iteration>.png")
    })?;
    let iteration: u64 = stem.parse().map_err(|_| {
        ApiError::bad_request("snapshot file is <iteration>.exr or <iteration>.png")
    })?;
    let ext = ext.to_string();
    let ct = if ext == "png" {
        "image/png"
    } else {
        "image/x-exr"
    };
    let bytes = blocking(&svc, move |s| s.snapshot(&id, iteration, &ext)).await?;
    Ok(bytes_response(ct, bytes))
}

fn wants(headers: &HeaderMap, mime: &str) -> bool {
    headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.contains(mime))
}

#[utoipa::path(get, path = "/v1/jobs/{id}/log", description = "The log: CSV, or JSON rows with `Accept: application/json`.", params(("id" = String, Path)), responses((status = 200, body = Vec<LogRow>), (status = 404, body = ErrorBody)))]
async fn log(
    State(svc): State<Svc>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    if wants(&headers, "application/json") {
        let rows = blocking(&svc, move |s| s.log(&id)).await?;
        return Ok(Json(rows).into_response());
    }
    let csv = blocking(&svc, move |s| s.log_csv(&id)).await?;
    Ok(bytes_response("text/csv", csv))
}

#[utoipa::path(get, path = "/v1/jobs/{id}/layers", description = "layers.csv: each radius layer's error per snapshot (jobs with `radii`), CSV, or JSON rows with `Accept: application/json`.", params(("id" = String, Path)), responses((status = 200, body = Vec<LayerRow>), (status = 404, body = ErrorBody)))]
async fn layer_log(
    State(svc): State<Svc>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    if wants(&headers, "application/json") {
        let rows = blocking(&svc, move |s| s.layer_log(&id)).await?;
        return Ok(Json(rows).into_response());
    }
    let csv = blocking(&svc, move |s| s.layer_log_csv(&id)).await?;
    Ok(bytes_response("text/csv", csv))
}

/// Server-Sent Events for one job: its current state first, then progress, snapshot and
/// state events, and a final `done`.
#[utoipa::path(get, path = "/v1/jobs/{id}/events", description = "Server-Sent Events: state first, then progress, snapshot and state events, ending with done.", params(("id" = String, Path)), responses((status = 200, content_type = "text/event-stream", body = String)))]
async fn events(
    State(svc): State<Svc>,
    Path(id): Path<String>,
) -> ApiResult<Sse<impl Stream<Item = Result<sse::Event, Infallible>>>> {
    // One stream for both transports: crate::job::watch.
    let jid = id.clone();
    let watch = blocking(&svc, move |s| s.watch(&jid)).await?;
    let stream = watch.into_stream().filter_map(move |w| {
        let e = match w {
            Watched::Event(e) => Some(
                sse::Event::default()
                    .event(e.name())
                    .json_data(&e)
                    .expect("event serialises"),
            ),
            // When the server stops, the stream ends with a `shutdown` event, so that
            // the connection closes and the server can exit.
            Watched::Stopping => Some(shutdown_event(&id)),
            Watched::Lost(e) => {
                tracing::warn!(job = %id, error = %e, "event stream ends: the job is gone");
                None
            }
        };
        futures::future::ready(e.map(Ok))
    });
    Ok(Sse::new(stream).keep_alive(KeepAlive::default()))
}

fn shutdown_event(job: &str) -> sse::Event {
    sse::Event::default().event("shutdown").data(
        serde_json::json!({
            "event": "shutdown",
            "job": job,
            "message": "the server is stopping; the job resumes from its checkpoint when it starts again",
        })
        .to_string(),
    )
}

#[utoipa::path(post, path = "/v1/sweeps", description = "Expand a base job and a parameter grid into jobs tagged with the sweep.", request_body = SweepSpec, responses((status = 201, body = SweepTable), (status = 400, body = ErrorBody)))]
async fn create_sweep(
    State(svc): State<Svc>,
    JsonBody(spec): JsonBody<SweepSpec>,
) -> ApiResult<impl IntoResponse> {
    let table = blocking(&svc, move |s| Ok(s.sweep_table(s.create_sweep(spec)?))).await?;
    Ok((StatusCode::CREATED, Json(table)))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepQuery {
    format: Option<String>,
}

#[utoipa::path(get, path = "/v1/sweeps/{id}", description = "The sweep table (JSON, or CSV with ?format=csv or Accept: text/csv).", params(("id" = String, Path), ("format" = Option<String>, Query)), responses((status = 200, body = SweepTable), (status = 404, body = ErrorBody)))]
async fn get_sweep(
    State(svc): State<Svc>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<SweepQuery>, axum::extract::rejection::QueryRejection>,
) -> ApiResult<Response> {
    let Query(q) = q.map_err(|e| ApiError::bad_request(e.body_text()))?;
    let table = blocking(&svc, move |s| Ok(s.sweep_table(s.get_sweep(&id)?))).await?;
    if q.format.as_deref() == Some("csv") || wants(&headers, "text/csv") {
        return Ok(bytes_response("text/csv", table.csv().into_bytes()));
    }
    Ok(Json(table).into_response())
}

#[utoipa::path(get, path = "/v1/workers", description = "The workers of a pool (`caustic serve --nats`): name, threads, latest heartbeat, ranges and iterations rendered, the job of the range in hand. Empty when the server renders in-process.", responses((status = 200, body = Vec<WorkerInfo>)))]
async fn workers(State(svc): State<Svc>) -> ApiResult<impl IntoResponse> {
    Ok(Json(blocking(&svc, |s| s.workers()).await?))
}

#[utoipa::path(get, path = "/v1/algorithms", description = "The algorithms a job may name, in the registry's order, each with a line on what it computes and every parameter it takes at its default value.", responses((status = 200, body = Vec<AlgorithmInfo>)))]
async fn algorithms() -> Json<Vec<AlgorithmInfo>> {
    Json(AlgorithmInfo::all())
}

#[utoipa::path(get, path = "/metrics", description = "Prometheus metrics.", responses((status = 200, content_type = "text/plain", body = String)))]
async fn metrics(State(svc): State<Svc>) -> ApiResult<Response> {
    let text = blocking(&svc, |s| Ok(s.metrics())).await?;
    Ok(([(header::CONTENT_TYPE, "text/plain; version=0.0.4")], text).into_response())
}

/// The OpenAPI document, generated from the handlers' annotations and the types, and
/// completed by [`CommonAnswers`].
#[derive(OpenApi)]
#[openapi(
    info(
        title = "caustic",
        description = "Progressive physically based rendering server. Every error is JSON, `{\"error\": {\"code\", \"message\", \"field\"}}`, and names no server path; `field`, present when one parameter is at fault, names it as the request wrote it (`params.radius`, or `integrator.radius` for a scene's default), so that a client can point at it. Any path answers a method it does not take with 405 (JSON, with an `Allow` header); unknown paths are 404."
    ),
    modifiers(&CommonAnswers),
    paths(
        healthz,
        openapi,
        retry,
        upload_scene,
        list_scenes,
        get_scene,
        delete_scene,
        upload_reference,
        submit,
        list_jobs,
        get_job,
        delete_job,
        cancel,
        pause,
        resume,
        preview,
        image,
        snapshots,
        snapshot,
        log,
        layer_log,
        events,
        create_sweep,
        get_sweep,
        workers,
        algorithms,
        metrics
    ),
    components(schemas(
        AlgorithmInfo,
        WorkerInfo,
        JobSpec,
        JobStatus,
        JobView,
        JobUrls,
        SceneInfo,
        LogRow,
        LayerRow,
        SweepSpec,
        SweepTable,
        SweepRow,
        ErrorBody,
        ErrorDetail,
        JobState
    ))
)]
pub struct ApiDoc;

/// What every operation can answer besides its own responses: 401 behind a token,
/// 500 on a server fault, and for requests with a body 413, 415 and 507.
struct CommonAnswers;

impl utoipa::Modify for CommonAnswers {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
        use utoipa::openapi::{ContentBuilder, Ref, ResponseBuilder};
        let components = doc.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "bearer",
            SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
        );
        let error = |what: &str| {
            ResponseBuilder::new()
                .description(what)
                .content(
                    "application/json",
                    ContentBuilder::new()
                        .schema(Some(Ref::from_schema_name("ErrorBody")))
                        .build(),
                )
                .build()
        };
        let bearer =
            utoipa::openapi::security::SecurityRequirement::new("bearer", Vec::<String>::new());
        for (path, item) in doc.paths.paths.iter_mut() {
            let open = path == "/healthz";
            let ops = [
                (&mut item.get, false),
                (&mut item.delete, false),
                (&mut item.post, true),
            ];
            for (op, has_body) in ops {
                let Some(op) = op.as_mut() else { continue };
                let r = &mut op.responses.responses;
                if !open {
                    op.security = Some(vec![bearer.clone()]);
                    r.entry("401".into()).or_insert_with(|| {
                        error("missing or wrong bearer token (servers started with --token)").into()
                    });
                }
                r.entry("500".into()).or_insert_with(|| {
                    error("a server fault; the message says what an operator can do").into()
                });
                if has_body {
                    r.entry("413".into()).or_insert_with(|| {
                        error("the body is above the limit (declared length refused at once)")
                            .into()
                    });
                    r.entry("415".into()).or_insert_with(|| {
                        error("a JSON endpoint was sent another content type").into()
                    });
                    r.entry("507".into()).or_insert_with(|| {
                        error("the server's disk is full; nothing was stored").into()
                    });
                }
            }
        }
    }
}

#[utoipa::path(get, path = "/v1/openapi.json", description = "This document.", responses((status = 200, content_type = "application/json", body = Object)))]
async fn openapi() -> Response {
    let doc = ApiDoc::openapi()
        .to_pretty_json()
        .expect("openapi serialises");
    ([(header::CONTENT_TYPE, "application/json")], doc).into_response()
}
