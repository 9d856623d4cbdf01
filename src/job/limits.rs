//! Limits on what a client may store in a job: text fields are shown in every job
//! list and rewritten with job.json after every batch, so a 20 MiB name must be an
//! error, not a slow server.

use super::spec::{JobSpec, SnapshotEvery};
use super::JobError;

/// Longest job or sweep name, in bytes.
pub const MAX_NAME: usize = 256;
/// Most tags on a job, and the longest tag in bytes.
pub const MAX_TAGS: usize = 32;
pub const MAX_TAG: usize = 64;
/// Longest id a client may send (scene, algorithm, reference).
pub const MAX_ID: usize = 64;
/// Largest `params` object, as JSON text.
pub const MAX_PARAMS: usize = 16 << 10;
/// Shortest time between snapshots: each writes two images, a log row and a
/// checkpoint.
pub const MIN_SNAPSHOT_SECONDS: f64 = 1.0;
/// Largest JSON request body (jobs, sweeps); scene uploads have their own limit.
pub const MAX_JSON_BODY: usize = 1 << 20;

fn bad(m: impl Into<String>) -> JobError {
    JobError::BadRequest(m.into())
}

/// A short text: at most `max` bytes, no control characters.
pub fn check_text(field: &str, v: &str, max: usize) -> Result<(), JobError> {
    if v.len() > max {
        return Err(bad(format!(
            "{field} is {} bytes long; the limit is {max}",
            v.len()
        )));
    }
    if v.chars().any(char::is_control) {
        return Err(bad(format!("{field} may not hold control characters")));
    }
    Ok(())
}

/// The size and shape limits of a job spec (what the values mean is checked later).
pub fn check_spec(spec: &JobSpec) -> Result<(), JobError> {
    check_text("scene", &spec.scene, MAX_ID)?;
    if let Some(a) = &spec.algorithm {
        check_text("algorithm", a, MAX_ID)?;
    }
    if let Some(n) = &spec.name {
        check_text("name", n, MAX_NAME)?;
    }
    if spec.tags.len() > MAX_TAGS {
        return Err(bad(format!(
            "tags: {} given; the limit is {MAX_TAGS}",
            spec.tags.len()
        )));
    }
    for t in &spec.tags {
        if t.is_empty() {
            return Err(bad("tags may not be empty"));
        }
        check_text("tags", t, MAX_TAG)?;
    }
    let params = serde_json::to_string(&spec.params).expect("params serialise");
    if params.len() > MAX_PARAMS {
        return Err(bad(format!(
            "params is {} bytes of JSON; the limit is {MAX_PARAMS}",
            params.len()
        )));
    }
    if let Some(r) = &spec.reference {
        let (super::spec::ReferenceSpec::Upload(id) | super::spec::ReferenceSpec::Job(id)) = r;
        check_text("reference", id, MAX_ID)?;
    }
    check_halt(spec)?;
    match spec.snapshot_every {
        SnapshotEvery::Iterations(0) => Err(bad("snapshot_every.iterations must be at least 1")),
        SnapshotEvery::Seconds(s) if !(s.is_finite() && s >= MIN_SNAPSHOT_SECONDS) => Err(bad(
            format!("snapshot_every.seconds must be at least {MIN_SNAPSHOT_SECONDS}"),
        )),
        _ => Ok(()),
    }
}

fn check_halt(spec: &JobSpec) -> Result<(), JobError> {
    let h = &spec.halt;
    let by_error = h.target_rmse.is_some() || h.noise.is_some();
    if h.max_iterations().is_none() && h.time_s.is_none() && !by_error {
        return Err(bad(
            "halt: give at least one of spp, iterations, time_s, target_rmse, noise",
        ));
    }
    if h.max_iterations() == Some(0) {
        let field = if h.spp.is_some() {
            "halt.spp"
        } else {
            "halt.iterations"
        };
        return Err(bad("halt: spp / iterations must be at least 1").at_field(Some(field)));
    }
    if h.time_s.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
        return Err(bad("halt.time_s must be a positive number").at_field(Some("halt.time_s")));
    }
    if h.target_rmse.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
        let field = Some("halt.target_rmse");
        return Err(bad("halt.target_rmse must be a positive number").at_field(field));
    }
    if h.noise.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
        let field = Some("halt.noise");
        return Err(
            bad("halt.noise must be a positive number (e.g. 0.01 for 1 %)").at_field(field),
        );
    }
    if h.target_rmse.is_some() && spec.reference.is_none() {
        return Err(bad("halt.target_rmse needs a reference").at_field(Some("halt.target_rmse")));
    }
    Ok(())
}
