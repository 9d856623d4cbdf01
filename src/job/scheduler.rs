//! The scheduler: one thread that runs short batches of iterations, job after job, on
//! the rayon worker pool. Iterations are independent units (`crate::integrator`), so a batch of
//! about a quarter second is the longest any job waits for the pool once it is next.
//!
//! Choice of job: highest effective priority, where a job gains one point per batch it
//! waits ([`AGING`] batches are worth one priority level), so higher priorities go
//! first and nothing starves; equal priorities take turns.

use super::context::{Context, JobSettings};
use super::disk::{self, Finished, Retention};
use super::run::{self, Held, Live, StepResult};
use super::spec::{unix_now, JobState, JobStatus};
use super::transition::{self, To};
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Batches a job must wait to gain one priority level.
pub const AGING: i64 = 16;
/// How often job.json writes that failed are tried again.
const RETRY_SAVE: Duration = Duration::from_secs(2);
/// How often the retention policy runs.
const RETENTION_EVERY: Duration = Duration::from_secs(60);

/// A request from a client, applied between batches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    None,
    Pause,
    Cancel,
}

impl Control {
    /// The state the request moves a job to.
    pub fn to(self) -> Option<To> {
        match self {
            Control::None => None,
            Control::Pause => Some(To::Paused),
            Control::Cancel => Some(To::Cancelled),
        }
    }
}

pub struct Entry {
    pub status: JobStatus,
    /// What the job's runtime is built from, each time it starts or resumes;
    /// `status.settings` holds them as JSON, as clients and job.json see them.
    pub settings: JobSettings,
    pub control: Control,
    /// Scheduler tick when the job last ran.
    pub served: u64,
    /// The scheduler holds the job right now (its runtime is out of the table).
    pub active: bool,
    pub runtime: Option<Box<Live>>,
    /// job.json is behind `status` (a write failed); the scheduler retries it.
    pub unsaved: bool,
}

impl Entry {
    pub fn new(status: JobStatus, settings: JobSettings, served: u64) -> Entry {
        Entry {
            status,
            settings,
            control: Control::None,
            served,
            active: false,
            runtime: None,
            unsaved: false,
        }
    }

    /// Whether the job's render state is in memory (in the table, or out of it while
    /// a batch runs or its checkpoint is written).
    pub fn holds_memory(&self) -> bool {
        self.runtime.is_some() || self.active
    }
}

#[derive(Default)]
pub struct Table {
    pub jobs: BTreeMap<String, Entry>,
    pub tick: u64,
}

pub struct Shared {
    pub ctx: Context,
    pub table: Mutex<Table>,
    pub wake: Condvar,
    pub shutdown: std::sync::atomic::AtomicBool,
    /// Jobs whose render state may be held in memory at once; the others wait with
    /// their checkpoints on disk.
    pub max_active: usize,
    pub retention: Retention,
    /// Signalled after every step, for callers waiting on a transition.
    pub stepped: Condvar,
}

/// Effective priority: the job's own, plus one level per [`AGING`] batches waited.
fn urgency(t: &Table, e: &Entry) -> i64 {
    e.status.spec.priority as i64 * AGING + t.tick.saturating_sub(e.served) as i64
}

/// Queued or running, stored, and in no one's hands: not `active`, which a pause or
/// cancel also sets while it writes the job's checkpoint. A job picked then would
/// start again from disk, and the end of that step would overwrite the cancel with
/// `running` (seen as a cancelled job rendering on, tests/scheduling.rs).
fn runnable(e: &Entry) -> bool {
    matches!(e.status.state, JobState::Queued | JobState::Running) && !e.unsaved && !e.active
}

/// Picks the next job to run, if any. Jobs already held in memory run as long as they
/// like; a job that is not may start only while fewer than `max_active` are held.
fn pick(t: &Table, max_active: usize) -> Option<String> {
    let held = t.jobs.values().filter(|e| e.holds_memory()).count();
    t.jobs
        .iter()
        .filter(|(_, e)| runnable(e) && (e.runtime.is_some() || held < max_active))
        // Ties go to the older job (smaller id sorts first; ids are time-ordered).
        .max_by_key(|(id, e)| (urgency(t, e), std::cmp::Reverse((*id).clone())))
        .map(|(id, _)| id.clone())
}

/// A held job to set aside (checkpoint, free its memory) for a waiting job of
/// strictly higher priority, when memory is full: the lowest-priority held job.
fn to_evict(t: &Table, max_active: usize) -> Option<String> {
    if t.jobs.values().filter(|e| e.holds_memory()).count() < max_active {
        return None;
    }
    let held = || t.jobs.iter().filter(|(_, e)| e.runtime.is_some());
    let waiting = t
        .jobs
        .values()
        .filter(|e| runnable(e) && e.runtime.is_none())
        .map(|e| e.status.spec.priority)
        .max()?;
    held()
        .filter(|(_, e)| e.status.spec.priority < waiting)
        .min_by_key(|(id, e)| (e.status.spec.priority, std::cmp::Reverse((*id).clone())))
        .map(|(id, _)| id.clone())
}

/// The scheduler thread's loop; returns when `shared.shutdown` is set.
pub fn run(shared: Arc<Shared>, pool: Arc<rayon::ThreadPool>) {
    let mut housekeeping = Housekeeping::default();
    // After a failed eviction (no room for the checkpoint), wait before the next.
    let mut evictions_from = Instant::now();
    loop {
        if shared.shutdown.load(Ordering::Relaxed) {
            return;
        }
        housekeeping.run(&shared);
        let (id, held, status) = {
            let mut t = shared.table.lock().expect("job table");
            let victim = (Instant::now() >= evictions_from)
                .then(|| to_evict(&t, shared.max_active))
                .flatten();
            if let Some(victim) = victim {
                drop(t);
                if !evict(&shared, &victim) {
                    evictions_from = Instant::now() + RETRY_SAVE;
                }
                continue;
            }
            let Some(id) = pick(&t, shared.max_active) else {
                let _ = shared.wake.wait_timeout(t, Duration::from_millis(500));
                continue;
            };
            let e = t.jobs.get_mut(&id).expect("picked job");
            e.active = true;
            let held = match e.runtime.take() {
                Some(rt) => Held::Live(rt),
                None => Held::Settings(Box::new(e.settings.clone())),
            };
            // A queued job is running from here on, and says so before its batch
            // reports any progress: watchers see `state` before `progress` (job.json
            // says so when the batch writes it).
            if e.status.state == JobState::Queued {
                transition::enter(&mut e.status, To::Running);
                transition::announce(&shared.ctx, &e.status);
            }
            (id, held, e.status.clone())
        };
        let result = pool.install(|| run::step(&shared.ctx, held, status));
        finish_step(&shared, &id, result);
    }
}

/// Writes a held job's checkpoint and drops its render state; it resumes from the
/// checkpoint, bit-identically, when it next runs. If the checkpoint cannot be
/// written the job stays in memory and this returns false.
fn evict(shared: &Shared, id: &str) -> bool {
    let Some((rt, status)) = take_runtime(shared, id) else {
        return true;
    };
    let written = rt.checkpoint(&status).write(&shared.ctx.job_dir(id));
    let mut t = shared.table.lock().expect("job table");
    let Some(e) = t.jobs.get_mut(id) else {
        return true;
    };
    e.active = false;
    match written {
        Ok(()) => {
            tracing::info!(job = id, "set aside for a job of higher priority");
            shared.ctx.metrics.set_aside.fetch_add(1, Ordering::Relaxed);
            true
        }
        Err(err) => {
            tracing::warn!(job = id, error = %err, "could not set the job aside");
            e.runtime = Some(rt);
            false
        }
    }
}

/// Takes a held job's runtime out of the table, marking the job active so that
/// nothing else touches it, for work (a checkpoint write) done without the lock.
/// The caller puts the runtime back or drops it, and clears `active`.
pub fn take_runtime(shared: &Shared, id: &str) -> Option<(Box<Live>, JobStatus)> {
    let mut t = shared.table.lock().expect("job table");
    let e = t.jobs.get_mut(id)?;
    if e.active {
        return None;
    }
    let rt = e.runtime.take()?;
    e.active = true;
    Some((rt, e.status.clone()))
}

/// Periodic work between batches: job.json writes to retry, retention.
#[derive(Default)]
struct Housekeeping {
    last_retry: Option<Instant>,
    last_retention: Option<Instant>,
}

impl Housekeeping {
    fn run(&mut self, shared: &Shared) {
        let due =
            |last: Option<Instant>, every: Duration| last.is_none_or(|l| l.elapsed() >= every);
        if due(self.last_retry, RETRY_SAVE) {
            self.last_retry = Some(Instant::now());
            retry_unsaved(shared);
        }
        if !shared.retention.is_off() && due(self.last_retention, RETENTION_EVERY) {
            self.last_retention = Some(Instant::now());
            apply_retention(shared);
        }
    }
}

/// Tries again to write the job.json of every job whose last write failed, so that
/// what a restart reads agrees with what the API said.
pub fn retry_unsaved(shared: &Shared) {
    let pending: Vec<JobStatus> = {
        let t = shared.table.lock().expect("job table");
        t.jobs
            .values()
            .filter(|e| e.unsaved)
            .map(|e| e.status.clone())
            .collect()
    };
    for status in pending {
        if shared
            .ctx
            .job_dir(&status.id)
            .write_status(&status)
            .is_err()
        {
            continue;
        }
        let mut t = shared.table.lock().expect("job table");
        if let Some(e) = t.jobs.get_mut(&status.id) {
            // Only if nothing changed meanwhile; otherwise the next round writes it.
            if e.status == status {
                e.unsaved = false;
            }
        }
    }
}

/// Deletes finished jobs the retention policy no longer keeps.
fn apply_retention(shared: &Shared) {
    let finished: Vec<(String, f64)> = {
        let t = shared.table.lock().expect("job table");
        t.jobs
            .iter()
            .filter(|(_, e)| e.status.state.is_terminal() && !e.active)
            .map(|(id, e)| {
                (
                    id.clone(),
                    e.status.finished_at.unwrap_or(e.status.created_at),
                )
            })
            .collect()
    };
    let finished: Vec<Finished> = finished
        .into_iter()
        .map(|(id, finished_at)| Finished {
            bytes: disk::dir_size(&shared.ctx.job_dir(&id).root),
            id,
            finished_at,
        })
        .collect();
    let total = disk::dir_size(&shared.ctx.data_dir.join("jobs"));
    for id in shared.retention.expired(finished, total, unix_now()) {
        let mut t = shared.table.lock().expect("job table");
        let still_finished = t
            .jobs
            .get(&id)
            .is_some_and(|e| e.status.state.is_terminal() && !e.active);
        if !still_finished {
            continue;
        }
        // The folder leaves jobs/ while the table is locked: once the job is gone
        // from the API its files are too, and deleting them waits for no request.
        let root = shared.ctx.job_dir(&id).root;
        let moved = disk::move_job_to_trash(&shared.ctx.data_dir, &id);
        t.jobs.remove(&id);
        drop(t);
        tracing::info!(job = %id, "removed by the retention policy");
        match moved {
            Ok(trash) => drop(std::fs::remove_dir_all(trash)),
            Err(_) => drop(std::fs::remove_dir_all(root)),
        }
    }
}

/// Puts the job back in the table and applies requests that arrived meanwhile.
fn finish_step(shared: &Shared, id: &str, mut r: StepResult) {
    let mut t = shared.table.lock().expect("job table");
    t.tick += 1;
    let tick = t.tick;
    let Some(e) = t.jobs.get_mut(id) else {
        return; // deleted while running
    };
    e.served = tick;
    e.active = false;
    let control = std::mem::replace(&mut e.control, Control::None);
    if let Some(to) = control.to().filter(|_| !r.status.state.is_terminal()) {
        let dir = shared.ctx.job_dir(id);
        if let Some(rt) = &r.runtime {
            // Keep the exact state so a resume (even after a restart) loses nothing.
            if let Err(err) = rt.checkpoint(&r.status).write(&dir) {
                tracing::warn!(job = id, error = %err, "checkpoint not written");
            }
        }
        r.runtime = None;
        r.saved = transition::make(&dir, &mut r.status, to).is_ok();
    }
    e.runtime = r.runtime;
    // Under the lock: a client's next transition is said after this one.
    settle(&shared.ctx, e, r.status, r.saved);
    drop(t);
    shared.stepped.notify_all();
}

/// Makes `status` job `e`'s, and says the transition if its state changed or it has
/// finished (`transition::announce`). `saved` says whether job.json holds `status`;
/// if not, the scheduler writes it again until it does. A job that stops (paused or
/// finished) drops its render state. Called with the job table locked, so that
/// changes are said in the order made.
pub(super) fn settle(ctx: &Context, e: &mut Entry, status: JobStatus, saved: bool) {
    let changed = status.state != e.status.state;
    e.status = status;
    e.unsaved = !saved;
    if !matches!(e.status.state, JobState::Queued | JobState::Running) {
        e.runtime = None;
    }
    if changed || e.status.state.is_terminal() {
        transition::announce(ctx, &e.status);
    }
}

/// Writes the checkpoint of every job held in memory, so that a stop loses no
/// rendered iteration; called when the scheduler has stopped.
pub fn checkpoint_all(shared: &Shared) {
    let t = shared.table.lock().expect("job table");
    for (id, e) in &t.jobs {
        if let Some(rt) = &e.runtime {
            if let Err(err) = rt.checkpoint(&e.status).write(&shared.ctx.job_dir(id)) {
                tracing::warn!(job = %id, error = %err, "checkpoint at shutdown not written");
            }
        }
    }
}
