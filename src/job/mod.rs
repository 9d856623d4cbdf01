//! Render jobs: specs and states, the job directory, scene storage, the scheduler that
//! runs progressive iterations on the worker pool, and the transport-neutral service
//! that the HTTP and gRPC front ends call.
//!
//! Layers, each importing only those below it: `spec`, `store`, `events`, `scenes` and
//! `runtime` (a job's render state and iteration loop) at the bottom; then `remote`
//! (pools of workers), `context` (what running needs from the server), `transition`
//! (the one writer of a state change), `run` (a job's batches), `scheduler`, and
//! `service` and `watch` at the top.

pub mod context;
pub mod disk;
pub mod events;
pub mod failpoint;
mod keep;
pub mod layer_log;
pub mod limits;
pub mod lock;
pub mod memory;
pub mod remote;
pub mod run;
pub mod runtime;
pub mod scenes;
pub mod scheduler;
pub mod service;
pub mod spec;
pub mod store;
pub mod sweep;
pub mod transition;
pub mod watch;

pub use service::{Service, ServiceConfig};
pub use spec::{HaltSpec, JobSpec, JobState, JobStatus};

use std::path::Path;

/// Errors of the job layer; each transport maps them once (HTTP status, gRPC code).
///
/// What a client reads ([`JobError::client_message`]) never names a server path: the
/// data directory's location is the operator's business. The full detail of storage
/// and internal errors goes to the server log instead.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The request is malformed or names something invalid.
    #[error("{0}")]
    BadRequest(String),
    /// The scene does not validate.
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    #[error("{0} not found")]
    NotFound(String),
    /// The request conflicts with the current state (e.g. cancelling a finished job).
    #[error("{0}")]
    Conflict(String),
    #[error("{0}")]
    TooLarge(String),
    /// The data directory could not be read or written (full or read-only disk, ...).
    /// `detail` names the file and is only logged.
    #[error("{detail}")]
    Storage {
        kind: std::io::ErrorKind,
        detail: String,
    },
    /// A bug or an unexpected state; the message is only logged.
    #[error("{0}")]
    Internal(String),
    /// `error`, about one parameter: `field` names it as the request wrote it
    /// (`params.radius`; `integrator.radius` in an uploaded scene), for clients that
    /// point at it (the REST error body's `field`).
    #[error("{error}")]
    AtField { field: String, error: Box<JobError> },
}

impl JobError {
    pub fn io(path: &Path, e: std::io::Error) -> Self {
        JobError::Storage {
            kind: e.kind(),
            detail: format!("{}: {e}", path.display()),
        }
    }

    /// A stable machine-readable code for clients.
    pub fn code(&self) -> &'static str {
        match self {
            JobError::BadRequest(_) => "bad_request",
            JobError::InvalidScene(_) => "invalid_scene",
            JobError::NotFound(_) => "not_found",
            JobError::Conflict(_) => "conflict",
            JobError::TooLarge(_) => "too_large",
            JobError::Storage {
                kind: std::io::ErrorKind::StorageFull,
                ..
            } => "storage_full",
            JobError::Storage { .. } => "storage",
            JobError::Internal(_) => "internal",
            JobError::AtField { error, .. } => error.code(),
        }
    }

    /// True for errors that are the server's fault, not the request's.
    pub fn is_server_error(&self) -> bool {
        match self {
            JobError::AtField { error, .. } => error.is_server_error(),
            e => matches!(e, JobError::Storage { .. } | JobError::Internal(_)),
        }
    }

    /// `self`, about the parameter `field` when there is one.
    pub fn at_field(self, field: Option<&str>) -> JobError {
        match field {
            Some(field) => JobError::AtField {
                field: field.to_string(),
                error: Box::new(self),
            },
            None => self,
        }
    }

    /// The parameter the error is about, as the request wrote it.
    pub fn field(&self) -> Option<&str> {
        match self {
            JobError::AtField { field, .. } => Some(field),
            _ => None,
        }
    }

    /// What the client is told: the message itself for request errors; for server
    /// errors, what happened in words an operator can act on, without paths.
    pub fn client_message(&self) -> String {
        use std::io::ErrorKind as K;
        match self {
            JobError::Storage { kind, .. } => match kind {
                K::StorageFull | K::QuotaExceeded => {
                    "the server's disk is full: nothing was stored; try again once space is freed"
                }
                K::ReadOnlyFilesystem | K::PermissionDenied => {
                    "the server may not write its data directory (read-only or no permission)"
                }
                _ => "the server could not read or write its data directory",
            }
            .to_string(),
            JobError::Internal(_) => "internal server error (details are in the server log)".into(),
            other => other.to_string(),
        }
    }
}

impl From<crate::film::FilmError> for JobError {
    fn from(e: crate::film::FilmError) -> Self {
        match e {
            crate::film::FilmError::Io { path, source } => JobError::io(&path, source),
            other => JobError::Internal(other.to_string()),
        }
    }
}

impl From<crate::integrator::SettingsError> for JobError {
    fn from(e: crate::integrator::SettingsError) -> Self {
        JobError::BadRequest(e.to_string()).at_field(e.field())
    }
}
