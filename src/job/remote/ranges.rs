//! A job's batches when a pool of workers renders its iterations: keep a few work
//! units queued ahead, collect the answers, and add ranges to the job's exact sums in
//! index order from its checkpoint on, each exactly once.

use super::coordinator::NatsExecutor;
use super::{Done, Unit};
use crate::film::ExactSums;
use crate::integrator::RenderStats;
use crate::job::context::Context;
use crate::job::run::{batch_len, Runtime};
use crate::job::spec::{unix_now, JobStatus};
use crate::job::JobError;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

/// How long one answer is waited for per batch (the scheduler's cadence).
const WAIT: Duration = Duration::from_millis(250);
/// Target render time of one work unit on one worker: long enough that publishing,
/// fetching and merging are small beside it, short enough to balance the pool.
const UNIT: Duration = Duration::from_secs(2);
/// Units a job keeps published ahead of what it has added.
const AHEAD: u64 = 8;

/// The remote side of a job's runtime. Dropping it (the job completes, fails, pauses,
/// is cancelled or set aside) withdraws its units still queued.
pub struct RemoteJob {
    ex: Arc<NatsExecutor>,
    job: String,
    generation: u64,
    /// First iteration not yet published.
    next: u64,
    /// Answers ahead of the added prefix, by first iteration.
    pending: BTreeMap<u64, (u64, ExactSums, RenderStats)>,
    /// Answers whose sums could not be fetched yet.
    unfetched: Vec<Done>,
    /// A worker's seconds per iteration, from the latest answer (0: none yet).
    per_iter: f64,
}

impl Drop for RemoteJob {
    fn drop(&mut self) {
        self.ex.withdraw_later(&self.job);
    }
}

/// One batch: top up the queue, take the answers that arrived, add what extends the
/// prefix. Returns the iterations added and their counters.
pub fn remote_batch(
    ctx: &Context,
    ex: &Arc<NatsExecutor>,
    status: &mut JobStatus,
    rt: &mut Runtime,
) -> Result<(u64, RenderStats), JobError> {
    if rt.remote.is_none() {
        // Units of an earlier run of this job (before a restart or a pause) go.
        let bundle = ctx.scenes.bundle(&status.spec.scene)?;
        let ready = ex
            .withdraw(&status.id)
            .and_then(|()| ex.publish_scene(&status.spec.scene, bundle));
        if let Err(e) = ready {
            return Ok(unreachable_for_now(e));
        }
        rt.remote = Some(RemoteJob {
            ex: ex.clone(),
            job: status.id.clone(),
            generation: (unix_now() * 1e6) as u64,
            next: status.iteration,
            pending: BTreeMap::new(),
            unfetched: Vec::new(),
            per_iter: 0.0,
        });
    }
    let settings = rt.settings.clone();
    let r = rt.remote.as_mut().expect("remote job");
    if let Err(e) = top_up(r, status, &settings) {
        tracing::warn!(job = %status.id, "publishing units: {e}");
    }
    let mut answers = std::mem::take(&mut r.unfetched);
    answers.extend(ex.take(&status.id, WAIT));
    for done in answers {
        file(r, status, done)?;
    }
    let (mut n, mut stats) = (0, RenderStats::default());
    while let Some((end, sums, s)) = r.pending.remove(&status.iteration) {
        let started = std::time::Instant::now();
        rt.sums
            .merge(&sums)
            .map_err(|e| JobError::Internal(e.to_string()))?;
        tracing::debug!(job = %status.id, merge_s = started.elapsed().as_secs_f64(), "range added");
        n += end - status.iteration;
        status.iteration = end;
        stats += s;
    }
    Ok((n, stats))
}

/// A batch that waited for NATS to answer again (a restarting server is no reason to
/// fail a job: units and results wait in its file storage).
fn unreachable_for_now(e: super::RemoteError) -> (u64, RenderStats) {
    tracing::warn!("{e}; trying again");
    std::thread::sleep(WAIT);
    (0, RenderStats::default())
}

/// Publishes units until [`AHEAD`] of them wait beyond the added prefix, within the
/// job's halt rule.
fn top_up(
    r: &mut RemoteJob,
    status: &JobStatus,
    settings: &crate::integrator::Settings,
) -> Result<(), super::RemoteError> {
    let spec = &status.spec;
    let len = batch_len(spec, r.next, r.per_iter, UNIT);
    let by_time = spec.halt.time_s.is_some_and(|t| status.elapsed_s >= t);
    let by_count = |next: u64| spec.halt.max_iterations().is_some_and(|m| next >= m);
    while r.next - status.iteration < AHEAD * len && !by_time && !by_count(r.next) {
        let end = r.next + batch_len(spec, r.next, r.per_iter, UNIT);
        r.ex.publish(&Unit {
            job: status.id.clone(),
            generation: r.generation,
            scene: spec.scene.clone(),
            settings: settings.clone(),
            seed: spec.seed,
            first: r.next,
            end,
        })?;
        r.next = end;
    }
    Ok(())
}

/// Keeps an answer that extends or will extend the prefix; drops stale and duplicate
/// ones (a range a dead worker had finished but not acknowledged comes twice).
fn file(r: &mut RemoteJob, status: &JobStatus, done: Done) -> Result<(), JobError> {
    if done.generation != r.generation {
        if let Some(o) = &done.object {
            r.ex.discard(o);
        }
        return Ok(());
    }
    if let Some(e) = done.error {
        return Err(JobError::BadRequest(format!(
            "worker {} could not render iterations {}..{}: {e}",
            done.worker, done.first, done.end
        )));
    }
    let Some(object) = done.object else {
        return Ok(());
    };
    if done.first < status.iteration || r.pending.contains_key(&done.first) {
        r.ex.discard(&object);
        return Ok(());
    }
    let started = std::time::Instant::now();
    let sums = match r.ex.fetch(&object) {
        Ok(s) => s,
        Err(e) => {
            tracing::warn!(job = %status.id, "fetching {object}: {e}; trying again");
            r.unfetched.push(Done {
                object: Some(object),
                ..done
            });
            return Ok(());
        }
    };
    // The per-range cost of the coordinator, for the scaling model (README).
    tracing::debug!(job = %status.id, %object, fetch_s = started.elapsed().as_secs_f64(), "range fetched");
    r.per_iter = done.seconds / (done.end - done.first).max(1) as f64;
    r.pending.insert(done.first, (done.end, sums, done.stats));
    Ok(())
}
