//! The one mapping from domain errors to HTTP responses: a status code and a JSON body
//! `{"error": {"code": "...", "message": "...", "field": "..."}}` that tells the client
//! what to fix (`field`, when one parameter is at fault, names it: `params.radius`).

use crate::api::{ErrorBody, ErrorDetail};
use crate::job::JobError;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;

#[derive(Debug)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub message: String,
    /// The parameter at fault, as the request wrote it.
    pub field: Option<String>,
}

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        ApiError {
            status,
            code,
            message: message.into(),
            field: None,
        }
    }

    pub fn bad_request(message: impl Into<String>) -> Self {
        ApiError::new(StatusCode::BAD_REQUEST, "bad_request", message)
    }

    /// The code of an error that only has a status (axum's rejections and answers):
    /// each status its own, so that a client can tell a 422 from a 400 by the code.
    pub fn code_of(status: StatusCode) -> &'static str {
        match status {
            StatusCode::UNAUTHORIZED => "unauthorized",
            StatusCode::NOT_FOUND => "not_found",
            StatusCode::METHOD_NOT_ALLOWED => "method_not_allowed",
            StatusCode::REQUEST_TIMEOUT => "timeout",
            StatusCode::CONFLICT => "conflict",
            StatusCode::PAYLOAD_TOO_LARGE => "too_large",
            StatusCode::UNSUPPORTED_MEDIA_TYPE => "unsupported_media_type",
            StatusCode::UNPROCESSABLE_ENTITY => INVALID_BODY,
            s if s.is_server_error() => "internal",
            _ => "bad_request",
        }
    }
}

/// The code of a 422 for a body that is JSON of the wrong shape (a wrong type, an
/// unknown field, a number that does not fit); a scene that does not validate is
/// `invalid_scene`.
pub const INVALID_BODY: &str = "invalid_body";

fn status_of(e: &JobError) -> StatusCode {
    match e {
        JobError::BadRequest(_) => StatusCode::BAD_REQUEST,
        JobError::InvalidScene(_) => StatusCode::UNPROCESSABLE_ENTITY,
        JobError::NotFound(_) => StatusCode::NOT_FOUND,
        JobError::Conflict(_) => StatusCode::CONFLICT,
        JobError::TooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
        JobError::Storage {
            kind: std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded,
            ..
        } => StatusCode::INSUFFICIENT_STORAGE,
        JobError::Storage { .. } | JobError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        JobError::AtField { error, .. } => status_of(error),
    }
}

impl From<JobError> for ApiError {
    fn from(e: JobError) -> Self {
        if e.is_server_error() {
            tracing::error!(error = %e, "request failed on the server's side");
        }
        ApiError {
            field: e.field().map(str::to_string),
            ..ApiError::new(status_of(&e), e.code(), e.client_message())
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = ErrorBody {
            error: ErrorDetail {
                code: self.code.to_string(),
                message: self.message,
                field: self.field,
            },
        };
        (self.status, Json(body)).into_response()
    }
}
