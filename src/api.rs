//! The JSON wire types of the REST API under /v1 that are not domain values
//! themselves: what [`crate::server::http`] answers and [`crate::client`] reads.
//! Request bodies are the domain's own ([`crate::job::JobSpec`],
//! [`crate::job::sweep::SweepSpec`]).

use crate::job::JobStatus;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

pub use crate::job::sweep::{SweepRow, SweepTable};

/// A job with the URLs a client follows.
#[derive(Serialize, Deserialize, Debug, Clone, ToSchema)]
pub struct JobView {
    #[serde(flatten)]
    pub job: JobStatus,
    pub urls: JobUrls,
}

#[derive(Serialize, Deserialize, Debug, Clone, ToSchema)]
pub struct JobUrls {
    pub this: String,
    pub preview: String,
    pub image: String,
    pub snapshots: String,
    pub log: String,
    pub events: String,
}

impl JobView {
    pub fn new(job: JobStatus) -> JobView {
        let base = format!("/v1/jobs/{}", job.id);
        JobView {
            urls: JobUrls {
                preview: format!("{base}/preview.png"),
                image: format!("{base}/image.exr"),
                snapshots: format!("{base}/snapshots"),
                log: format!("{base}/log"),
                events: format!("{base}/events"),
                this: base,
            },
            job,
        }
    }
}

/// Error responses: what went wrong, in words a client can act on.
#[derive(Serialize, ToSchema)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[derive(Serialize, ToSchema)]
pub struct ErrorDetail {
    /// bad_request (400), unauthorized (401), not_found (404), method_not_allowed
    /// (405), timeout (408), conflict (409), too_large (413), unsupported_media_type
    /// (415), invalid_body or invalid_scene (422), internal (500), storage (500),
    /// storage_full (507)
    pub code: String,
    pub message: String,
    /// The parameter at fault, when the error is about one, as the request wrote it:
    /// `params.radius` for a job's parameter (`params.light_paths.count` inside one),
    /// `integrator.radius` for a scene's default (in an uploaded scene, or the default a
    /// job inherits from its scene). Absent otherwise; the message names it too.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
}

/// An algorithm a job may name, with its parameters and their defaults
/// (`GET /v1/algorithms`, read by the dashboard's submit form).
#[derive(Serialize, Deserialize, Debug, Clone, ToSchema)]
pub struct AlgorithmInfo {
    pub name: String,
    /// What it computes, in one line.
    pub about: String,
    /// Every parameter the algorithm takes, at its default value.
    #[schema(value_type = Object)]
    pub params: serde_json::Map<String, serde_json::Value>,
}

impl AlgorithmInfo {
    /// Every algorithm of [`crate::integrator::ALGORITHMS`], in its order.
    pub fn all() -> Vec<AlgorithmInfo> {
        crate::integrator::registry::TABLE
            .iter()
            .map(|a| AlgorithmInfo {
                name: a.name.to_string(),
                about: a.about.to_string(),
                params: crate::integrator::Settings::defaults(a.name).unwrap_or_default(),
            })
            .collect()
    }
}
