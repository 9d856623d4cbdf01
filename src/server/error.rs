//! The one mapping from domain errors to HTTP responses: a status code and a JSON body
//! `{"error": {"code": "...", "message": "..."}}` that tells the client what to fix.

use crate::job::JobError;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;

#[derive(Debug)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub message: String,
}

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        ApiError {
            status,
            code,
            message: message.into(),
        }
    }

    pub fn bad_request(message: impl Into<String>) -> Self {
        ApiError::new(StatusCode::BAD_REQUEST, "bad_request", message)
    }
}

impl From<JobError> for ApiError {
    fn from(e: JobError) -> Self {
        let status = match &e {
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
        };
        if e.is_server_error() {
            tracing::error!(error = %e, "request failed on the server's side");
        }
        ApiError::new(status, e.code(), e.client_message())
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = serde_json::json!({"error": {"code": self.code, "message": self.message}});
        (self.status, Json(body)).into_response()
    }
}
