//! A job's batches when a pool of workers renders its iterations: keep a few work
//! units queued ahead, collect the answers, and add ranges to the job's exact sums in
//! index order from its checkpoint on, each exactly once. A chained job has one unit
//! out at a time, carrying its checkpoint (module notes in `remote`).

use super::coordinator::{Arrival, NatsExecutor};
use super::{carry_name, range_name, Done, Unit};
use crate::film::ExactSums;
use crate::integrator::RenderStats;
use crate::job::runtime::{batch_len, Runtime};
use crate::job::scenes::SceneStore;
use crate::job::spec::{unix_now, JobStatus};
use crate::job::store::Checkpoint;
use crate::job::JobError;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long one answer is waited for per batch (the scheduler's cadence).
const WAIT: Duration = Duration::from_millis(250);
/// Target render time of one work unit on one worker: long enough that publishing,
/// fetching and merging are small beside it, short enough to balance the pool.
const UNIT: Duration = Duration::from_secs(2);
/// Units a job keeps published ahead of what it has added.
const AHEAD: u64 = 8;
/// A worker counts as serving a job while its last answer is this recent.
const SERVING: Duration = Duration::from_secs(10);
/// Failed fetches of one result before its range is rendered again.
const FETCH_TRIES: u32 = 3;

/// The remote side of a job's runtime. Dropping it (the job completes, fails, pauses,
/// is cancelled or set aside) withdraws its units still queued.
pub struct RemoteJob {
    ex: Arc<NatsExecutor>,
    job: String,
    generation: u64,
    /// First iteration not yet published.
    next: u64,
    /// Results ahead of the added prefix, by first iteration.
    pending: BTreeMap<u64, (u64, Answer, RenderStats)>,
    /// Answers whose results could not be fetched yet, with the tries so far.
    unfetched: Vec<(Done, u32)>,
    /// Ranges whose results were lost, to publish again.
    lost: Vec<(u64, u64)>,
    /// A worker's seconds per iteration, from the latest answer (0: none yet).
    per_iter: f64,
    /// When each worker last answered.
    serving: HashMap<String, Instant>,
}

/// A range's result: its exact sums, or a chained job's checkpoint after it.
enum Answer {
    Sums(ExactSums),
    Chain(Checkpoint),
}

impl Drop for RemoteJob {
    fn drop(&mut self) {
        self.ex.withdraw_later(&self.job);
    }
}

/// One batch: top up the queue, take the answers that arrived, add what extends the
/// prefix. Returns the iterations added and their counters. `remote` is the job's
/// remote side, kept with its runtime between batches (started here when None).
pub fn remote_batch(
    scenes: &SceneStore,
    ex: &Arc<NatsExecutor>,
    status: &mut JobStatus,
    rt: &mut Runtime,
    remote: &mut Option<RemoteJob>,
) -> Result<(u64, RenderStats), JobError> {
    let mut r = match remote.take() {
        Some(r) => r,
        None => {
            // Units of an earlier run of this job (before a restart or a pause) go.
            let bundle = scenes.bundle(&status.spec.scene)?;
            let ready = ex
                .withdraw(&status.id)
                .and_then(|()| ex.publish_scene(&status.spec.scene, bundle));
            if let Err(e) = ready {
                return Ok(unreachable_for_now(e));
            }
            RemoteJob {
                ex: ex.clone(),
                job: status.id.clone(),
                generation: (unix_now() * 1e6) as u64,
                next: status.iteration,
                pending: BTreeMap::new(),
                unfetched: Vec::new(),
                lost: Vec::new(),
                per_iter: 0.0,
                serving: HashMap::new(),
            }
        }
    };
    if let Err(e) = top_up(&mut r, status, rt) {
        tracing::warn!(job = %status.id, "publishing units: {e}");
    }
    let mut answers: Vec<(Arrival, u32)> = std::mem::take(&mut r.unfetched)
        .into_iter()
        .map(|(done, tries)| (Arrival { done, body: None }, tries))
        .collect();
    answers.extend(ex.take(&status.id, WAIT).into_iter().map(|a| (a, 0)));
    let expect = Expected {
        chained: rt.chained(),
        size: (rt.scene.width(), rt.scene.height()),
        // Main, moments, layers, and a filter's weights and splats, as whole images.
        images: 2 + 2 * (1 + rt.settings.layers()),
    };
    for (arrival, tries) in answers {
        file(&mut r, status, arrival, tries, &expect)?;
    }
    let (mut n, mut stats) = (0, RenderStats::default());
    while let Some((end, answer, s)) = r.pending.remove(&status.iteration) {
        let started = Instant::now();
        match answer {
            Answer::Sums(sums) => rt
                .sums
                .merge(&sums)
                .map_err(|e| JobError::Internal(e.to_string()))?,
            Answer::Chain(c) => {
                rt.adopt(c)?;
                let range = range_name(&r.job, r.generation, status.iteration, end);
                ex.discard(&carry_name(&range));
            }
        }
        tracing::debug!(job = %status.id, merge_s = started.elapsed().as_secs_f64(), "range added");
        n += end - status.iteration;
        status.iteration = end;
        stats += s;
    }
    r.serving.retain(|_, at| at.elapsed() < SERVING);
    status.workers = Some(r.serving.len() as u32);
    *remote = Some(r);
    Ok((n, stats))
}

/// A batch that waited for NATS to answer again (a restarting server is no reason to
/// fail a job: units and results wait in its file storage).
fn unreachable_for_now(e: super::RemoteError) -> (u64, RenderStats) {
    tracing::warn!("{e}; trying again");
    std::thread::sleep(WAIT);
    (0, RenderStats::default())
}

/// Publishes ranges whose results were lost, then new units until [`AHEAD`] of them
/// wait beyond the added prefix (one, for a chained job), within the halt rule.
fn top_up(r: &mut RemoteJob, status: &JobStatus, rt: &Runtime) -> Result<(), super::RemoteError> {
    let chained = rt.chained();
    while let Some((first, end)) = r.lost.pop() {
        if let Err(e) = publish(r, status, rt, first, end, None) {
            r.lost.push((first, end));
            return Err(e);
        }
    }
    let spec = &status.spec;
    let len = batch_len(spec, r.next, r.per_iter, UNIT);
    let ahead = if chained { 1 } else { AHEAD * len };
    let by_time = spec.halt.time_s.is_some_and(|t| status.elapsed_s >= t);
    let by_count = |next: u64| spec.halt.max_iterations().is_some_and(|m| next >= m);
    while r.next - status.iteration < ahead && !by_time && !by_count(r.next) {
        let end = r.next + batch_len(spec, r.next, r.per_iter, UNIT);
        // Only reached with nothing out, so the job's checkpoint is at `r.next`.
        let carry = chained.then(|| rt.checkpoint(status).encode());
        publish(r, status, rt, r.next, end, carry)?;
        r.next = end;
    }
    Ok(())
}

/// Publishes the unit of iterations `first..end`, storing the checkpoint it carries
/// first if it is given (a lost chained range finds its carry still stored).
fn publish(
    r: &RemoteJob,
    status: &JobStatus,
    rt: &Runtime,
    first: u64,
    end: u64,
    carry: Option<Vec<u8>>,
) -> Result<(), super::RemoteError> {
    let range = range_name(&status.id, r.generation, first, end);
    let carry_object = carry_name(&range);
    if let Some(bytes) = carry {
        r.ex.put(&carry_object, bytes)?;
    }
    r.ex.publish(&Unit {
        job: status.id.clone(),
        generation: r.generation,
        scene: status.spec.scene.clone(),
        settings: rt.settings.clone(),
        seed: status.spec.seed,
        first,
        end,
        carry: rt.chained().then_some(carry_object),
    })
}

/// What a job's results must be: a chained job's checkpoints, or exact sums of the
/// film's size holding at most `images` images.
struct Expected {
    chained: bool,
    size: (u32, u32),
    images: usize,
}

/// Keeps a result that extends or will extend the prefix; drops stale and duplicate
/// ones (a range a dead worker had finished but not acknowledged comes twice).
fn file(
    r: &mut RemoteJob,
    status: &JobStatus,
    arrival: Arrival,
    tries: u32,
    expect: &Expected,
) -> Result<(), JobError> {
    let Arrival { done, body } = arrival;
    let drop_result = |r: &RemoteJob| {
        if let (Some(o), None) = (&done.object, &body) {
            r.ex.discard(o);
        }
    };
    if done.generation != r.generation {
        drop_result(r);
        return Ok(());
    }
    if let Some(e) = &done.error {
        return Err(JobError::BadRequest(format!(
            "worker {} could not render iterations {}..{}: {e}",
            done.worker, done.first, done.end
        )));
    }
    let Some(object) = &done.object else {
        return Ok(());
    };
    r.serving.insert(done.worker.clone(), Instant::now());
    if done.first < status.iteration || r.pending.contains_key(&done.first) {
        drop_result(r);
        return Ok(());
    }
    let bytes = match body {
        Some(b) => b,
        None => match r.ex.fetch(object) {
            Ok(b) => b,
            Err(e) if tries + 1 < FETCH_TRIES => {
                tracing::warn!(job = %status.id, "fetching {object}: {e}; trying again");
                r.unfetched.push((done, tries + 1));
                return Ok(());
            }
            Err(e) => {
                tracing::warn!(job = %status.id, "fetching {object}: {e}; rendering it again");
                r.lost.push((done.first, done.end));
                return Ok(());
            }
        },
    };
    let started = Instant::now();
    let answer = if expect.chained {
        Checkpoint::decode(&bytes).map(Answer::Chain)
    } else {
        ExactSums::decode_expected(&bytes, expect.size, expect.images)
            .ok()
            .map(Answer::Sums)
    };
    let Some(answer) = answer else {
        tracing::warn!(job = %status.id, "{object} is damaged; rendering it again");
        r.lost.push((done.first, done.end));
        return Ok(());
    };
    tracing::debug!(job = %status.id, decode_s = started.elapsed().as_secs_f64(), bytes = bytes.len(), "range decoded");
    r.per_iter = done.seconds / (done.end - done.first).max(1) as f64;
    r.pending.insert(done.first, (done.end, answer, done.stats));
    Ok(())
}
