//! The scheduler: one thread that runs short batches of iterations, job after job, on
//! the rayon worker pool. Iterations are independent units (DESIGN.md), so a batch of
//! about a quarter second is the longest any job waits for the pool once it is next.
//!
//! Choice of job: highest effective priority, where a job gains one point per batch it
//! waits ([`AGING`] batches are worth one priority level), so higher priorities go
//! first and nothing starves; equal priorities take turns.

use super::events::{Event, Sender};
use super::scenes::SceneStore;
use super::spec::{unix_now, JobSpec, JobState, JobStatus, ReferenceSpec, SnapshotEvery};
use super::store::{append_log, truncate_log, Checkpoint, JobDir, LogRow};
use super::JobError;
use crate::film::{self, Film, Image};
use crate::integrator::{Integrator, Settings};
use crate::scene::Scene;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Batches a job must wait to gain one priority level.
pub const AGING: i64 = 16;
/// Target wall time of one batch.
const BATCH: Duration = Duration::from_millis(250);

/// A request from a client, applied between batches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    None,
    Pause,
    Cancel,
}

/// Live state of an active job: everything needed to run its next iterations.
pub struct Runtime {
    scene: Arc<Scene>,
    integrator: Box<dyn Integrator>,
    film: Film,
    samples: u64,
    reference: Option<Image>,
    /// Seconds per iteration, smoothed.
    per_iter: f64,
    last_snapshot: (u64, f64),
}

pub struct Entry {
    pub status: JobStatus,
    pub control: Control,
    /// Scheduler tick when the job last ran.
    pub served: u64,
    /// The scheduler holds the job right now (its runtime is out of the table).
    pub active: bool,
    pub runtime: Option<Box<Runtime>>,
}

#[derive(Default)]
pub struct Table {
    pub jobs: BTreeMap<String, Entry>,
    pub tick: u64,
}

/// Counters for /metrics.
#[derive(Default)]
pub struct Metrics {
    pub iterations: AtomicU64,
    pub samples: AtomicU64,
    pub rays: AtomicU64,
    pub dropped: AtomicU64,
    pub render_ns: AtomicU64,
}

pub struct Shared {
    pub table: Mutex<Table>,
    pub wake: Condvar,
    pub events: Sender,
    pub scenes: Arc<SceneStore>,
    pub data_dir: PathBuf,
    pub metrics: Metrics,
    pub shutdown: std::sync::atomic::AtomicBool,
}

impl Shared {
    pub fn emit(&self, e: Event) {
        // No receivers is fine: nobody is watching.
        let _ = self.events.send(e);
    }

    pub fn job_dir(&self, id: &str) -> JobDir {
        JobDir::new(&self.data_dir, id)
    }
}

/// Picks the next job to run, if any.
fn pick(t: &Table) -> Option<String> {
    t.jobs
        .iter()
        .filter(|(_, e)| matches!(e.status.state, JobState::Queued | JobState::Running))
        .max_by_key(|(id, e)| {
            let waited = t.tick.saturating_sub(e.served) as i64;
            // Ties go to the older job (smaller id sorts first; ids are time-ordered).
            (
                e.status.spec.priority as i64 * AGING + waited,
                std::cmp::Reverse((*id).clone()),
            )
        })
        .map(|(id, _)| id.clone())
}

/// The scheduler thread's loop; returns when `shared.shutdown` is set.
pub fn run(shared: Arc<Shared>, pool: rayon::ThreadPool) {
    loop {
        if shared.shutdown.load(Ordering::Relaxed) {
            return;
        }
        let (id, runtime, status) = {
            let mut t = shared.table.lock().expect("job table");
            let Some(id) = pick(&t) else {
                let _ = shared.wake.wait_timeout(t, Duration::from_millis(500));
                continue;
            };
            let e = t.jobs.get_mut(&id).expect("picked job");
            e.active = true;
            (id, e.runtime.take(), e.status.clone())
        };
        let result = pool.install(|| step(&shared, runtime, status));
        finish_step(&shared, &id, result);
    }
}

/// What one step did to a job.
struct StepResult {
    status: JobStatus,
    runtime: Option<Box<Runtime>>,
}

fn fail(shared: &Shared, mut status: JobStatus, err: JobError) -> StepResult {
    tracing::warn!(job = %status.id, error = %err, "job failed");
    status.state = JobState::Failed;
    status.error = Some(err.to_string());
    status.finished_at = Some(unix_now());
    let _ = shared.job_dir(&status.id).write_status(&status);
    StepResult {
        status,
        runtime: None,
    }
}

fn step(shared: &Shared, runtime: Option<Box<Runtime>>, mut status: JobStatus) -> StepResult {
    let mut rt = match runtime {
        Some(rt) => rt,
        None => match start(shared, &mut status) {
            Ok(rt) => rt,
            Err(e) => return fail(shared, status, e),
        },
    };
    // The state event goes out from `finish_step`, which sees the change.
    if status.state == JobState::Queued {
        status.state = JobState::Running;
    }
    match run_batch(shared, &mut status, &mut rt) {
        Ok(done) => StepResult {
            status,
            runtime: (!done).then_some(rt),
        },
        Err(e) => fail(shared, status, e),
    }
}

/// Builds the runtime: compiled scene (cached), integrator, and the checkpoint if any.
fn start(shared: &Shared, status: &mut JobStatus) -> Result<Box<Runtime>, JobError> {
    let scene = shared.scenes.compiled(&status.spec.scene)?;
    let settings: Settings = serde_json::from_value(status.settings.clone())
        .map_err(|e| JobError::Internal(format!("stored settings: {e}")))?;
    let dir = shared.job_dir(&status.id);
    let reference = load_reference(shared, &status.spec, &scene)?;
    let integrator = settings.build();
    let (film, samples, elapsed, iteration) = match Checkpoint::read(&dir) {
        Some(c) if c.film.width() == scene.width() && c.film.height() == scene.height() => {
            truncate_log(&dir, c.iteration)?;
            if let Some(state) = &c.state {
                // An unusable state is not fatal: the integrator then starts its
                // statistics afresh and keeps the film consistent.
                if let Err(e) = integrator.load_state(state) {
                    tracing::warn!(job = %status.id, "checkpoint state not restored: {e}");
                }
            }
            (c.film, c.samples, c.elapsed_s, c.iteration)
        }
        _ => (Film::new(scene.width(), scene.height()), 0, 0.0, 0),
    };
    status.iteration = iteration;
    status.elapsed_s = elapsed;
    status.dropped = film.dropped();
    Ok(Box::new(Runtime {
        integrator,
        scene,
        film,
        samples,
        reference,
        per_iter: 0.0,
        last_snapshot: (iteration, elapsed),
    }))
}

pub fn load_reference(
    shared: &Shared,
    spec: &JobSpec,
    scene: &Scene,
) -> Result<Option<Image>, JobError> {
    let path = match &spec.reference {
        None => return Ok(None),
        Some(ReferenceSpec::Upload(rid)) => reference_path(&shared.data_dir, rid)?,
        Some(ReferenceSpec::Job(jid)) => shared.job_dir(jid).final_image("exr"),
    };
    let img = film::read_exr(&path).map_err(|_| {
        JobError::BadRequest(format!("reference {} is not available", path.display()))
    })?;
    if img.size() != (scene.width(), scene.height()) {
        return Err(JobError::BadRequest(format!(
            "reference is {}x{} but the scene renders {}x{}",
            img.width(),
            img.height(),
            scene.width(),
            scene.height()
        )));
    }
    Ok(Some(img))
}

pub fn reference_path(data_dir: &std::path::Path, id: &str) -> Result<PathBuf, JobError> {
    if id.len() != 16 || !id.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(JobError::NotFound(format!("reference {id}")));
    }
    Ok(data_dir.join("references").join(format!("{id}.exr")))
}

/// Runs one batch, writes snapshots that fall due, and reports whether the job is done.
fn run_batch(shared: &Shared, status: &mut JobStatus, rt: &mut Runtime) -> Result<bool, JobError> {
    let spec = status.spec.clone();
    let max_it = spec.halt.max_iterations();
    let mut n = if rt.per_iter > 0.0 {
        (BATCH.as_secs_f64() / rt.per_iter).floor().max(1.0) as u64
    } else {
        1
    };
    if let Some(m) = max_it {
        n = n.min(m.saturating_sub(status.iteration)).max(1);
    }
    if let SnapshotEvery::Iterations(k) = spec.snapshot_every {
        // End the batch on the next snapshot iteration so snapshots land exactly.
        let next = (status.iteration / k.max(1) + 1) * k.max(1);
        n = n.min(next - status.iteration);
    }
    let start = Instant::now();
    let mut stats = crate::integrator::RenderStats::default();
    for _ in 0..n {
        stats += rt
            .integrator
            .iterate(&rt.scene, spec.seed, status.iteration, &mut rt.film);
        status.iteration += 1;
    }
    let secs = start.elapsed().as_secs_f64();
    rt.per_iter = if rt.per_iter > 0.0 {
        0.7 * rt.per_iter + 0.3 * secs / n as f64
    } else {
        secs / n as f64
    };
    rt.samples += stats.samples;
    status.elapsed_s += secs;
    status.samples_per_s = stats.samples as f64 / secs.max(1e-9);
    let new_drops = rt.film.dropped() - status.dropped;
    status.dropped = rt.film.dropped();
    let m = &shared.metrics;
    m.iterations.fetch_add(n, Ordering::Relaxed);
    m.samples.fetch_add(stats.samples, Ordering::Relaxed);
    m.rays
        .fetch_add(stats.rays + stats.shadow_rays, Ordering::Relaxed);
    m.dropped.fetch_add(new_drops, Ordering::Relaxed);
    m.render_ns
        .fetch_add((secs * 1e9) as u64, Ordering::Relaxed);
    status.eta_s = eta(status, rt.per_iter);
    let figures = batch_figures(&stats, n, secs, rt.film.sums().len());
    shared.emit(Event::Progress {
        job: status.id.clone(),
        iteration: status.iteration,
        elapsed_s: status.elapsed_s,
        samples_per_s: status.samples_per_s,
        eta_s: status.eta_s,
        dropped: status.dropped,
    });
    let by_count = max_it.is_some_and(|m| status.iteration >= m);
    let by_time = spec.halt.time_s.is_some_and(|t| status.elapsed_s >= t);
    let due = match spec.snapshot_every {
        SnapshotEvery::Iterations(k) => status.iteration.is_multiple_of(k.max(1)),
        SnapshotEvery::Seconds(s) => status.elapsed_s - rt.last_snapshot.1 >= s,
    };
    let mut done = by_count || by_time;
    if due || done {
        snapshot(shared, status, rt, &figures)?;
        done |= spec
            .halt
            .target_rmse
            .zip(status.last_rmse)
            .is_some_and(|(target, r)| r <= target);
    }
    let dir = shared.job_dir(&status.id);
    if done {
        let img = rt.film.to_image(1.0 / status.iteration as f64);
        let layers = rt.film.layer_images();
        let named: Vec<(&str, &Image)> = layers.iter().map(|(n, i)| (n.as_str(), i)).collect();
        film::write_exr_layers(dir.final_image("exr"), &img, &named)?;
        film::write_png(dir.final_image("png"), &img, 0.0)?;
        status.state = JobState::Completed;
        status.finished_at = Some(unix_now());
        status.eta_s = Some(0.0);
    }
    dir.write_status(status)?;
    Ok(done)
}

/// The per-batch figures of a log row: rays per second, and per-iteration means over
/// the `n` iterations of the batch (the merge radius is the latest iteration's).
fn batch_figures(
    stats: &crate::integrator::RenderStats,
    n: u64,
    secs: f64,
    pixels: usize,
) -> LogRow {
    let per_iteration = |v: u64| v as f64 / n.max(1) as f64;
    let per_pixel = |v: u64| per_iteration(v) / pixels.max(1) as f64;
    LogRow {
        rays_per_s: (stats.rays + stats.shadow_rays) as f64 / secs.max(1e-9),
        merge_radius: stats.merge_radius as f64,
        light_vertices: per_iteration(stats.light_vertices),
        connections_per_pixel: per_pixel(stats.connections),
        merges_per_pixel: per_pixel(stats.merges),
        ..Default::default()
    }
}

fn eta(status: &JobStatus, per_iter: f64) -> Option<f64> {
    let by_count = status
        .spec
        .halt
        .max_iterations()
        .map(|m| m.saturating_sub(status.iteration) as f64 * per_iter);
    let by_time = status
        .spec
        .halt
        .time_s
        .map(|t| (t - status.elapsed_s).max(0.0));
    match (by_count, by_time) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// Snapshot EXR + PNG, latest.*, a log row with the error against the reference (and
/// the batch's `figures`), and the checkpoint, in that order: once the checkpoint
/// names iteration i, everything up to i is on disk.
fn snapshot(
    shared: &Shared,
    status: &mut JobStatus,
    rt: &mut Runtime,
    figures: &LogRow,
) -> Result<(), JobError> {
    let dir = shared.job_dir(&status.id);
    let it = status.iteration;
    let img = rt.film.to_image(1.0 / it.max(1) as f64);
    film::write_exr(dir.snapshot(it, "exr"), &img)?;
    film::write_png(dir.snapshot(it, "png"), &img, 0.0)?;
    film::write_exr(dir.latest("exr"), &img)?;
    film::write_png(dir.latest("png"), &img, 0.0)?;
    let metrics = rt
        .reference
        .as_ref()
        .map(|r| film::compare(&img, r))
        .transpose()?;
    status.last_rmse = metrics.map(|m| m.rmse);
    append_log(
        &dir,
        &LogRow {
            iteration: it,
            elapsed_s: status.elapsed_s,
            samples: rt.samples,
            rmse: metrics.map(|m| m.rmse),
            rel_mse: metrics.map(|m| m.rel_mse),
            dropped: status.dropped,
            ..figures.clone()
        },
    )?;
    Checkpoint {
        iteration: it,
        elapsed_s: status.elapsed_s,
        samples: rt.samples,
        film: rt.film.clone(),
        state: rt.integrator.save_state(),
    }
    .write(&dir)?;
    rt.last_snapshot = (it, status.elapsed_s);
    shared.emit(Event::Snapshot {
        job: status.id.clone(),
        iteration: it,
        rmse: metrics.map(|m| m.rmse),
        rel_mse: metrics.map(|m| m.rel_mse),
    });
    Ok(())
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
    if !r.status.state.is_terminal() && control != Control::None {
        let dir = shared.job_dir(id);
        if let Some(rt) = &r.runtime {
            // Keep the exact state so a resume (even after a restart) loses nothing.
            let _ = Checkpoint {
                iteration: r.status.iteration,
                elapsed_s: r.status.elapsed_s,
                samples: rt.samples,
                film: rt.film.clone(),
                state: rt.integrator.save_state(),
            }
            .write(&dir);
        }
        r.status.state = if control == Control::Pause {
            JobState::Paused
        } else {
            r.status.finished_at = Some(unix_now());
            JobState::Cancelled
        };
        r.runtime = None;
        let _ = dir.write_status(&r.status);
    }
    let state = r.status.state;
    let changed = state != e.status.state;
    e.status = r.status;
    e.runtime = r.runtime;
    let status = e.status.clone();
    drop(t);
    if changed || state.is_terminal() {
        shared.emit(Event::State {
            job: id.to_string(),
            state,
        });
    }
    if state.is_terminal() {
        shared.emit(Event::Done {
            job: id.to_string(),
            status: Box::new(status),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::RenderStats;

    #[test]
    fn batch_figures_are_per_iteration_means() {
        let stats = RenderStats {
            rays: 600,
            shadow_rays: 400,
            light_vertices: 3000,
            connections: 800,
            merges: 200,
            merge_radius: 0.5,
            ..Default::default()
        };
        // 4 iterations on a 10-pixel film in 2 seconds.
        let f = batch_figures(&stats, 4, 2.0, 10);
        assert_eq!(f.rays_per_s, 500.0);
        assert_eq!(f.light_vertices, 750.0);
        assert_eq!(f.connections_per_pixel, 20.0);
        assert_eq!(f.merges_per_pixel, 5.0);
        assert_eq!(f.merge_radius, 0.5);
    }
}
