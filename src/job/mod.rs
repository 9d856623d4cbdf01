//! Render jobs: specs and states, the job directory, scene storage, the scheduler that
//! runs progressive iterations on the worker pool, and the transport-neutral service
//! that the HTTP and gRPC front ends call.

pub mod events;
pub mod scenes;
pub mod scheduler;
pub mod service;
pub mod spec;
pub mod store;
pub mod sweep;

pub use service::{Service, ServiceConfig};
pub use spec::{HaltSpec, JobSpec, JobState, JobStatus};

use std::path::Path;

/// Errors of the job layer; each transport maps them once (HTTP status, gRPC code).
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
    #[error("{0}")]
    Internal(String),
}

impl JobError {
    pub fn io(path: &Path, e: std::io::Error) -> Self {
        JobError::Internal(format!("{}: {e}", path.display()))
    }

    /// A stable machine-readable code for clients.
    pub fn code(&self) -> &'static str {
        match self {
            JobError::BadRequest(_) => "bad_request",
            JobError::InvalidScene(_) => "invalid_scene",
            JobError::NotFound(_) => "not_found",
            JobError::Conflict(_) => "conflict",
            JobError::TooLarge(_) => "too_large",
            JobError::Internal(_) => "internal",
        }
    }
}

impl From<crate::film::FilmError> for JobError {
    fn from(e: crate::film::FilmError) -> Self {
        JobError::Internal(e.to_string())
    }
}

impl From<crate::integrator::SettingsError> for JobError {
    fn from(e: crate::integrator::SettingsError) -> Self {
        JobError::BadRequest(e.to_string())
    }
}
