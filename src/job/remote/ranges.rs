//! A job's batches when a pool of workers renders its iterations: keep units queued
//! ahead in groups, collect the answers, and add finished groups to the job's exact
//! sums in index order from its checkpoint on, each range exactly once (its results
//! are decoded and added up in `intake`, off this thread). A chained job has one unit
//! out at a time, carrying its checkpoint (module notes in `remote`).

use super::coordinator::{Arrival, Fetched, NatsExecutor};
use super::intake::{Expected, Filed, Intake};
use super::{carry_name, range_name, Done, Unit};
use crate::integrator::RenderStats;
use crate::job::runtime::{batch_len, Runtime};
use crate::job::scenes::SceneStore;
use crate::job::spec::{unix_now, JobStatus, SnapshotEvery};
use crate::job::store::Checkpoint;
use crate::job::JobError;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long one answer is waited for per batch (the scheduler's cadence).
const WAIT: Duration = Duration::from_millis(250);
/// Shortest render time of one work unit on one worker: long enough that publishing
/// and answering are small beside it, short enough to balance the pool and show
/// progress often. Units of large films are longer ([`unit_time`]).
const UNIT: Duration = Duration::from_secs(2);
/// Raw result bytes the coordinator plans to take in per second from all workers
/// together, until it has measured its own costs: fetching, decoding and adding a
/// 1080p range (199 MB) costs it about 0.3 core-seconds (README "Scaling").
const INTAKE_BYTES_PER_S: f64 = 1e9;
/// How much more the coordinator's intake could take than the units it plans for.
const INTAKE_HEADROOM: f64 = 2.0;
/// Fewest units in a group; a group has about as many units as the pool has workers.
const GROUP_UNITS: usize = 8;
/// Groups a job keeps published ahead of what it has added: all workers stay busy
/// while the oldest group waits for its last range.
const OPEN_GROUPS: usize = 3;
/// A worker counts as serving a job while its last answer is this recent, or two
/// units' time when units are longer.
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
    /// Where the ranges' sums are added up (not for a chained job).
    intake: Option<Arc<Intake>>,
    /// A chained job's checkpoints ahead of the added prefix, by first iteration.
    pending: BTreeMap<u64, (u64, Checkpoint, RenderStats)>,
    /// Answers whose results could not be fetched yet, with the tries so far.
    unfetched: Vec<(Done, u32)>,
    /// Ranges whose results were lost, to publish again.
    lost: Vec<(u64, u64)>,
    /// A worker's seconds per iteration, from the latest answer (0: none yet).
    per_iter: f64,
    /// When each worker last answered.
    serving: HashMap<String, Instant>,
    /// Workers in the pool when the latest group was published.
    pool: usize,
    /// The target render time of the latest group's units.
    unit: Duration,
}

impl Drop for RemoteJob {
    fn drop(&mut self) {
        self.ex.stop_receiving(&self.job, self.generation);
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
        None => match start(scenes.bundle(&status.spec.scene)?, ex, status, rt) {
            Ok(r) => r,
            Err(e) => return Ok(unreachable_for_now(e)),
        },
    };
    if let Err(e) = top_up(&mut r, status, rt) {
        tracing::warn!(job = %status.id, "publishing units: {e}");
    }
    let mut answers: Vec<(Arrival, u32)> = std::mem::take(&mut r.unfetched)
        .into_iter()
        .map(|(done, tries)| {
            let result = Fetched::Missing;
            (Arrival { done, result }, tries)
        })
        .collect();
    answers.extend(ex.take(&status.id, WAIT).into_iter().map(|a| (a, 0)));
    for (arrival, tries) in answers {
        file(&mut r, status, arrival, tries)?;
    }
    let (mut n, mut stats) = (0, RenderStats::default());
    while let Some((end, s)) = add_next(&mut r, status, rt)? {
        n += end - status.iteration;
        status.iteration = end;
        stats += s;
    }
    let serving = SERVING.max(2 * r.unit);
    r.serving.retain(|_, at| at.elapsed() < serving);
    status.workers = Some(r.serving.len() as u32);
    *remote = Some(r);
    Ok((n, stats))
}

/// A job's remote side from its checkpoint on: units of an earlier run of the job
/// (before a restart or a pause) go, and its scene (`bundle`, None if built in) is
/// made available to workers.
fn start(
    bundle: Option<Vec<u8>>,
    ex: &Arc<NatsExecutor>,
    status: &JobStatus,
    rt: &Runtime,
) -> Result<RemoteJob, super::RemoteError> {
    ex.withdraw(&status.id)?;
    ex.publish_scene(&status.spec.scene, bundle)?;
    let generation = (unix_now() * 1e6) as u64;
    let intake = (!rt.chained()).then(|| {
        let intake = Arc::new(Intake::new(generation, expected(rt)));
        ex.receive(&status.id, intake.clone());
        intake
    });
    Ok(RemoteJob {
        ex: ex.clone(),
        job: status.id.clone(),
        generation,
        next: status.iteration,
        intake,
        pending: BTreeMap::new(),
        unfetched: Vec::new(),
        lost: Vec::new(),
        per_iter: 0.0,
        serving: HashMap::new(),
        pool: GROUP_UNITS,
        unit: UNIT,
    })
}

/// What the job's range results must be: sums of its film's size holding its main
/// image, moments and layers, and a filter's weights and splats, as whole images.
fn expected(rt: &Runtime) -> Expected {
    Expected {
        size: (rt.scene.width(), rt.scene.height()),
        images: 2 + 2 * (1 + rt.settings.layers()),
    }
}

/// Adds the finished group or chained range that starts at the job's iteration, if
/// there is one: its end and counters.
fn add_next(
    r: &mut RemoteJob,
    status: &JobStatus,
    rt: &mut Runtime,
) -> Result<Option<(u64, RenderStats)>, JobError> {
    let started = Instant::now();
    let added = match &r.intake {
        Some(intake) => match intake.take(status.iteration) {
            Some(group) => {
                rt.sums
                    .merge(&group.sums)
                    .map_err(|e| JobError::Internal(e.to_string()))?;
                Some((group.end, group.stats))
            }
            None => None,
        },
        None => match r.pending.remove(&status.iteration) {
            Some((end, c, stats)) => {
                rt.adopt(c)?;
                let range = range_name(&r.job, r.generation, status.iteration, end);
                r.ex.discard(&carry_name(&range));
                Some((end, stats))
            }
            None => None,
        },
    };
    if added.is_some() {
        tracing::debug!(job = %status.id, merge_s = started.elapsed().as_secs_f64(), "group added");
    }
    Ok(added)
}

/// A batch that waited for NATS to answer again (a restarting server is no reason to
/// fail a job: units and results wait in its file storage).
fn unreachable_for_now(e: super::RemoteError) -> (u64, RenderStats) {
    tracing::warn!("{e}; trying again");
    std::thread::sleep(WAIT);
    (0, RenderStats::default())
}

/// Publishes ranges whose results were lost, then new units: for a chained job one
/// at a time, else groups of units until [`OPEN_GROUPS`] wait, within the halt rule.
fn top_up(r: &mut RemoteJob, status: &JobStatus, rt: &Runtime) -> Result<(), super::RemoteError> {
    while let Some((first, end)) = r.lost.pop() {
        if let Err(e) = publish(r, status, rt, first, end, None) {
            r.lost.push((first, end));
            return Err(e);
        }
    }
    let spec = &status.spec;
    let by_time = spec.halt.time_s.is_some_and(|t| status.elapsed_s >= t);
    let by_count = |next: u64| spec.halt.max_iterations().is_some_and(|m| next >= m);
    if by_time {
        return Ok(());
    }
    let Some(intake) = r.intake.clone() else {
        if r.next == status.iteration && !by_count(r.next) {
            let end = r.next + batch_len(spec, r.next, r.per_iter, UNIT);
            // Only reached with nothing out, so the job's checkpoint is at `r.next`.
            let carry = Some(rt.checkpoint(status).encode());
            publish(r, status, rt, r.next, end, carry)?;
            r.next = end;
        }
        return Ok(());
    };
    while intake.open_groups() < OPEN_GROUPS && !by_count(r.next) {
        if let Ok(n) = r.ex.worker_count() {
            r.pool = n.max(1);
        }
        r.unit = unit_time(r.pool, rt, &r.ex);
        let units = group(r, status);
        let (first, end) = (units[0].0, units[units.len() - 1].1);
        intake.open(first, end);
        r.next = end;
        for (k, &(a, b)) in units.iter().enumerate() {
            if let Err(e) = publish(r, status, rt, a, b, None) {
                r.lost.extend_from_slice(&units[k..]);
                return Err(e);
            }
        }
    }
    Ok(())
}

/// The units of the next group from `r.next`: about one per worker in the pool, each
/// of the target time `r.unit`, ending early at the halt count or at a snapshot (so
/// that the job reaches the iterations its snapshots are due at).
fn group(r: &RemoteJob, status: &JobStatus) -> Vec<(u64, u64)> {
    let spec = &status.spec;
    let target = r.unit;
    // Until a first answer tells how long an iteration takes, units are single
    // iterations: few of them.
    let count = match r.per_iter > 0.0 {
        true => r.pool.max(GROUP_UNITS),
        false => GROUP_UNITS,
    };
    let mut units = Vec::new();
    let mut next = r.next;
    while units.len() < count {
        let end = next + batch_len(spec, next, r.per_iter, target);
        units.push((next, end));
        next = end;
        let at_count = spec.halt.max_iterations().is_some_and(|m| next >= m);
        let at_snapshot = matches!(spec.snapshot_every, SnapshotEvery::Iterations(k) if next.is_multiple_of(k.max(1)));
        if at_count || at_snapshot {
            break;
        }
    }
    units
}

/// A unit's target render time with `workers` in the pool: at least [`UNIT`], and
/// long enough that the results of all of them together leave the coordinator's
/// intake [`INTAKE_HEADROOM`] times what it needs, by its measured costs per range
/// or, before it has them, by the results' size (at [`INTAKE_BYTES_PER_S`], a 1080p
/// film's units on 100 workers last 20 s).
fn unit_time(workers: usize, rt: &Runtime, ex: &NatsExecutor) -> Duration {
    let e = expected(rt);
    let bytes = 48.0 * e.size.0 as f64 * e.size.1 as f64 * (2 + rt.settings.layers()) as f64;
    let secs = match ex.intake_capacity() {
        Some(ranges_per_s) => INTAKE_HEADROOM * workers as f64 / ranges_per_s,
        None => workers as f64 * bytes / INTAKE_BYTES_PER_S,
    };
    UNIT.max(Duration::from_secs_f64(secs))
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

/// Takes an answer: records its worker and timing, re-queues a range whose result
/// was lost or damaged, keeps a chained job's checkpoint; a failed range fails the
/// job. Stale and duplicate answers (a range a dead worker had finished but not
/// acknowledged comes twice) are dropped.
fn file(
    r: &mut RemoteJob,
    status: &JobStatus,
    arrival: Arrival,
    tries: u32,
) -> Result<(), JobError> {
    let Arrival { done, result } = arrival;
    let discard = |r: &RemoteJob, result: &Fetched| {
        if let (Some(o), Fetched::Missing) = (&done.object, result) {
            r.ex.discard(o);
        }
    };
    if done.generation != r.generation {
        discard(r, &result);
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
    let stale = done.first < status.iteration || r.pending.contains_key(&done.first);
    if r.intake.is_none() && stale {
        discard(r, &result);
        return Ok(());
    }
    let bytes = match result {
        Fetched::Filed(filed) => {
            filed_as(r, &done, filed);
            return Ok(());
        }
        Fetched::Bytes(b) => b,
        Fetched::Missing => match r.ex.fetch(object) {
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
    let filed = match &r.intake {
        // Fetched here, or before the job's intake was there: decoded here too.
        Some(intake) => intake.fold(&done, &bytes),
        None => match Checkpoint::decode(&bytes) {
            Some(c) => {
                r.pending.insert(done.first, (done.end, c, done.stats));
                Filed::Added
            }
            None => Filed::Damaged,
        },
    };
    filed_as(r, &done, filed);
    Ok(())
}

/// Acts on what the intake made of a range's result.
fn filed_as(r: &mut RemoteJob, done: &Done, filed: Filed) {
    match filed {
        Filed::Added => r.per_iter = done.seconds / (done.end - done.first).max(1) as f64,
        Filed::Dropped => {}
        Filed::Damaged => {
            tracing::warn!(job = %done.job, "the result of {}..{} is damaged; rendering it again", done.first, done.end);
            r.lost.push((done.first, done.end));
        }
    }
}
