//! Running one job in batches: starting its runtime (`runtime`) from the checkpoint,
//! a batch of iterations (rendered here, or by a pool of workers through `remote`),
//! its snapshots, and its end. The scheduler calls it; it sits above `runtime` and
//! `remote` and never imports the scheduler or the service.
//!
//! Crash consistency rests on one order of writes. A snapshot writes its EXR and PNG,
//! `latest.*`, a log row, then the checkpoint; completion then writes `final.*` and
//! job.json. Once the checkpoint names iteration i, everything up to i is on disk; a
//! job resumed from a checkpoint that already meets its halt condition completes
//! without rendering, and the log is cut back to the checkpoint, so a kill at any
//! write leaves a job that finishes as if it never happened.

use super::context::{Context, JobSettings};
use super::disk;
use super::failpoint;
use super::layer_log::{append_layer_rows, truncate_layer_log, LayerRow};
use super::remote::ranges::{remote_batch, RemoteJob};
use super::runtime::Runtime;
use super::spec::{
    JobSpec, JobState, JobStatus, ReferenceSpec, SnapshotEvery, NOISE_HALT_MIN_ITERATIONS,
};
use super::store::{append_log, read_log, truncate_log, Checkpoint, LogRow};
use super::transition::{self, To};
use super::JobError;
use crate::film::{self, Image};
use crate::integrator::RenderStats;
use crate::scene::Scene;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// A job held in memory between batches: its runtime, and its ranges out with a pool
/// of workers when the server has one (dropping it withdraws those).
pub struct Live {
    runtime: Runtime,
    remote: Option<RemoteJob>,
}

impl Live {
    /// The exact state to resume from after `status.iteration` iterations.
    pub fn checkpoint(&self, status: &JobStatus) -> Checkpoint {
        self.runtime.checkpoint(status)
    }
}

/// What one step did to a job. `saved` is false when job.json could not be written
/// (the scheduler retries until it can).
pub struct StepResult {
    pub status: JobStatus,
    pub runtime: Option<Box<Live>>,
    pub saved: bool,
}

/// What a step goes on from: the job's runtime, when it is held in memory, or else
/// the settings to build one from.
pub enum Held {
    Live(Box<Live>),
    Settings(Box<JobSettings>),
}

/// Runs the next batch of `status`'s job, building its runtime first if needed.
pub fn step(ctx: &Context, held: Held, mut status: JobStatus) -> StepResult {
    let mut live = match held {
        Held::Live(live) => live,
        Held::Settings(settings) => match start(ctx, *settings, &mut status) {
            Ok(live) => Box::new(live),
            Err(e) => return fail(ctx, status, e),
        },
    };
    // The state event goes out from `scheduler::settle`, which sees the change.
    if status.state == JobState::Queued {
        transition::enter(&mut status, To::Running);
    }
    let result = if status.iteration > 0 && halt_reached(&status) {
        // Resumed from a checkpoint written by the job's last snapshot: what is left
        // is to finish, not to render one more iteration.
        complete(ctx, &mut status, &live.runtime).map(|()| true)
    } else {
        run_batch(ctx, &mut status, &mut live)
    };
    match result {
        Ok(done) => StepResult {
            status,
            runtime: (!done).then_some(live),
            saved: true,
        },
        Err(e) => fail(ctx, status, e),
    }
}

/// Marks the job failed and tries to store that; the error the client sees is the
/// one it can act on (no server paths).
pub fn fail(ctx: &Context, mut status: JobStatus, err: JobError) -> StepResult {
    tracing::warn!(job = %status.id, error = %err, "job failed");
    let dir = ctx.job_dir(&status.id);
    let saved = transition::make(&dir, &mut status, To::Failed(err.client_message())).is_ok();
    StepResult {
        status,
        runtime: None,
        saved,
    }
}

/// Whether a job at its current iteration, time and error has met its halt rule.
pub(super) fn halt_reached(status: &JobStatus) -> bool {
    let h = &status.spec.halt;
    let by_count = h.max_iterations().is_some_and(|m| status.iteration >= m);
    let by_time = h.time_s.is_some_and(|t| status.elapsed_s >= t);
    let by_error = h
        .target_rmse
        .zip(status.last_rmse)
        .is_some_and(|(target, r)| r <= target);
    let by_noise = status.iteration >= NOISE_HALT_MIN_ITERATIONS
        && h.noise
            .zip(status.noise)
            .is_some_and(|(target, n)| n <= target);
    by_count || by_time || by_error || by_noise
}

/// Builds the runtime: compiled scene (cached), integrator, and the checkpoint if
/// any, which the job's log and snapshots are cut back to.
fn start(ctx: &Context, settings: JobSettings, status: &mut JobStatus) -> Result<Live, JobError> {
    let settings = settings.map_err(JobError::BadRequest)?;
    let scene = ctx.scenes.compiled(&status.spec.scene)?;
    let dir = ctx.job_dir(&status.id);
    let reference = load_reference(ctx, &status.spec, &scene)?;
    // A job stored before the budget was lowered fails here, saying why.
    super::memory::check(&settings, &scene, &status.spec, ctx.max_job)?;
    let checkpoint = Checkpoint::read(&dir)
        .filter(|c| c.film.width() == scene.width() && c.film.height() == scene.height());
    let at = checkpoint.as_ref().map_or(0, |c| c.iteration);
    // Rows and snapshots past the checkpoint came from iterations that run again.
    truncate_log(&dir, at)?;
    truncate_layer_log(&dir, at)?;
    disk::drop_snapshots_after(&dir, at);
    let runtime = Runtime::resume(&status.id, settings, scene, reference, checkpoint)?;
    status.iteration = at;
    status.elapsed_s = runtime.last_snapshot.1;
    status.dropped = runtime.sums.dropped();
    let last = read_log(&dir).pop().filter(|r| r.iteration == at);
    status.last_rmse = last.as_ref().and_then(|r| r.rmse);
    status.noise = last.and_then(|r| r.est_rel_mse).map(f64::sqrt);
    Ok(Live {
        runtime,
        remote: None,
    })
}

pub fn load_reference(
    ctx: &Context,
    spec: &JobSpec,
    scene: &Scene,
) -> Result<Option<Image>, JobError> {
    let (path, what) = match &spec.reference {
        None => return Ok(None),
        Some(ReferenceSpec::Upload(rid)) => {
            let path = reference_path(&ctx.data_dir, rid)?;
            if !path.exists() {
                return Err(JobError::NotFound(format!("reference upload {rid}")));
            }
            (path, format!("reference upload {rid}"))
        }
        Some(ReferenceSpec::Job(jid)) => (
            ctx.job_dir(jid).final_image("exr"),
            format!("the final image of reference job {jid}"),
        ),
    };
    let img = film::read_exr(&path).map_err(|e| {
        tracing::warn!(error = %e, "reference not readable");
        JobError::BadRequest(format!("{what} is not available"))
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
fn run_batch(ctx: &Context, status: &mut JobStatus, live: &mut Live) -> Result<bool, JobError> {
    let spec = status.spec.clone();
    let start = Instant::now();
    let rt = &mut live.runtime;
    let (n, stats) = match &ctx.remote {
        Some(ex) => remote_batch(&ctx.scenes, ex, status, rt, &mut live.remote)?,
        None => rt.local_batch(status),
    };
    let secs = start.elapsed().as_secs_f64();
    if n > 0 {
        rt.per_iter = if rt.per_iter > 0.0 {
            0.7 * rt.per_iter + 0.3 * secs / n as f64
        } else {
            secs / n as f64
        };
    }
    rt.samples += stats.samples;
    status.elapsed_s += secs;
    status.samples_per_s = stats.samples as f64 / secs.max(1e-9);
    let new_drops = rt.sums.dropped() - status.dropped;
    status.dropped = rt.sums.dropped();
    count(ctx, &stats, n, secs, new_drops);
    status.eta_s = eta(status, rt.per_iter);
    let figures = batch_figures(&stats, n, secs, rt.scratch.sums().len());
    ctx.emit(super::events::Event::Progress {
        job: status.id.clone(),
        iteration: status.iteration,
        elapsed_s: status.elapsed_s,
        samples_per_s: status.samples_per_s,
        eta_s: status.eta_s,
        dropped: status.dropped,
    });
    // A pool's batch may add nothing (no range came back yet): nothing to snapshot.
    let due = n > 0
        && match spec.snapshot_every {
            SnapshotEvery::Iterations(k) => status.iteration.is_multiple_of(k.max(1)),
            SnapshotEvery::Seconds(s) => status.elapsed_s - rt.last_snapshot.1 >= s,
        };
    let mut done = halt_reached(status);
    if due || done {
        snapshot(ctx, status, rt, &figures)?;
        done = halt_reached(status);
    }
    if done {
        complete(ctx, status, rt)?;
    } else {
        transition::store(&ctx.job_dir(&status.id), status)?;
    }
    Ok(done)
}

/// Adds a batch to the server's counters.
fn count(ctx: &Context, stats: &RenderStats, n: u64, secs: f64, new_drops: u64) {
    let m = &ctx.metrics;
    m.iterations.fetch_add(n, Ordering::Relaxed);
    m.samples.fetch_add(stats.samples, Ordering::Relaxed);
    m.rays
        .fetch_add(stats.rays + stats.shadow_rays, Ordering::Relaxed);
    m.dropped.fetch_add(new_drops, Ordering::Relaxed);
    m.render_ns
        .fetch_add((secs * 1e9) as u64, Ordering::Relaxed);
}

/// layers.csv's rows of a snapshot at iteration `it`: each radius layer of `film`
/// against the reference, if the job has one.
fn layer_rows(rt: &Runtime, film: &film::Film, it: u64) -> Result<Vec<LayerRow>, JobError> {
    let radii = rt.settings.radius_layers();
    if radii.is_empty() {
        return Ok(Vec::new());
    }
    let images = match rt.reference {
        Some(_) => film.layer_images(),
        None => Vec::new(),
    };
    let mut rows = Vec::with_capacity(radii.len());
    for (layer, radius, medium) in radii {
        let image = images.iter().find(|(n, _)| *n == layer).map(|(_, i)| i);
        let metrics = match (image, &rt.reference) {
            (Some(i), Some(r)) => Some(film::compare(i, r)?),
            _ => None,
        };
        rows.push(LayerRow {
            iteration: it,
            layer,
            radius: radius as f64,
            medium_radius: medium.map(f64::from),
            rmse: metrics.map(|m| m.rmse),
            rel_mse: metrics.map(|m| m.rel_mse),
        });
    }
    Ok(rows)
}

/// Writes the final images and the completed status, then drops what a finished job
/// no longer needs (the checkpoint unless kept, `latest.*`, which `final.*` replaces).
fn complete(ctx: &Context, status: &mut JobStatus, rt: &Runtime) -> Result<(), JobError> {
    let dir = ctx.job_dir(&status.id);
    let film = rt.sums.to_film();
    let img = film.to_image(1.0 / status.iteration.max(1) as f64);
    let layers = exr_layers(&status.spec, rt, &film, status.iteration);
    let named: Vec<(&str, &Image)> = layers.iter().map(|(n, i)| (n.as_str(), i)).collect();
    failpoint::hit("final-exr", status.iteration);
    film::write_exr_layers(dir.final_image("exr"), &img, &named)?;
    failpoint::hit("final-png", status.iteration);
    film::write_png(dir.final_image("png"), &img, 0.0)?;
    transition::make(&dir, status, To::Completed)?;
    disk::tidy_finished(&dir, &status.spec);
    Ok(())
}

/// The per-batch figures of a log row: rays per second, and per-iteration means over
/// the `n` iterations of the batch (the merge radius is the latest iteration's).
fn batch_figures(stats: &RenderStats, n: u64, secs: f64, pixels: usize) -> LogRow {
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

/// The EXR layers of an image after `it` iterations: the film's own (techniques,
/// radii), and the estimated variance if the job asked for it and there is one.
fn exr_layers(spec: &JobSpec, rt: &Runtime, film: &film::Film, it: u64) -> Vec<(String, Image)> {
    let mut layers = film.layer_images();
    if spec.variance_layer {
        if let Some(noise) = rt.sums.noise(film, it) {
            layers.push(("variance".into(), noise.variance_image()));
        }
    }
    layers
}

/// Seconds left: the least of what the iteration limit, the time budget and the noise
/// target each leave. Noise falls as 1 / sqrt(iterations), so reaching `target` from
/// `noise` takes (noise / target)^2 times the iterations so far.
fn eta(status: &JobStatus, per_iter: f64) -> Option<f64> {
    let halt = &status.spec.halt;
    let by_count = halt
        .max_iterations()
        .map(|m| m.saturating_sub(status.iteration) as f64 * per_iter);
    let by_time = halt.time_s.map(|t| (t - status.elapsed_s).max(0.0));
    let by_noise = halt.noise.zip(status.noise).map(|(target, n)| {
        let needed =
            (status.iteration as f64 * (n / target).powi(2)).max(NOISE_HALT_MIN_ITERATIONS as f64);
        (needed - status.iteration as f64).max(0.0) * per_iter
    });
    [by_count, by_time, by_noise]
        .into_iter()
        .flatten()
        .reduce(f64::min)
}

/// Snapshot EXR + PNG, latest.*, a log row with the error against the reference (and
/// the batch's `figures`), and the checkpoint, in that order (see the module notes).
fn snapshot(
    ctx: &Context,
    status: &mut JobStatus,
    rt: &mut Runtime,
    figures: &LogRow,
) -> Result<(), JobError> {
    let dir = ctx.job_dir(&status.id);
    let it = status.iteration;
    let film = rt.sums.to_film();
    let img = film.to_image(1.0 / it.max(1) as f64);
    let noise = rt.sums.noise(&film, it);
    let variance = noise
        .as_ref()
        .filter(|_| status.spec.variance_layer)
        .map(|n| n.variance_image());
    let variance: Vec<(&str, &Image)> = variance.iter().map(|i| ("variance", i)).collect();
    failpoint::hit("snapshot-exr", it);
    film::write_exr_layers(dir.snapshot(it, "exr"), &img, &variance)?;
    failpoint::hit("snapshot-png", it);
    film::write_png(dir.snapshot(it, "png"), &img, 0.0)?;
    failpoint::hit("latest-exr", it);
    film::write_exr_layers(dir.latest("exr"), &img, &variance)?;
    failpoint::hit("latest-png", it);
    film::write_png(dir.latest("png"), &img, 0.0)?;
    let metrics = rt
        .reference
        .as_ref()
        .map(|r| film::compare(&img, r))
        .transpose()?;
    status.last_rmse = metrics.map(|m| m.rmse);
    let (est_rmse, est_rel_mse) = (
        noise.as_ref().map(|n| n.rmse()),
        noise.as_ref().map(|n| n.rel_mse()),
    );
    status.noise = est_rel_mse.map(f64::sqrt);
    failpoint::hit("log", it);
    append_log(
        &dir,
        &LogRow {
            iteration: it,
            elapsed_s: status.elapsed_s,
            samples: rt.samples,
            rmse: metrics.map(|m| m.rmse),
            rel_mse: metrics.map(|m| m.rel_mse),
            dropped: status.dropped,
            est_rmse,
            est_rel_mse,
            ..figures.clone()
        },
    )?;
    append_layer_rows(&dir, &layer_rows(rt, &film, it)?)?;
    failpoint::hit("checkpoint", it);
    rt.checkpoint(status).write(&dir)?;
    rt.last_snapshot = (it, status.elapsed_s);
    disk::thin_snapshots(&dir, &status.spec);
    ctx.emit(super::events::Event::Snapshot {
        job: status.id.clone(),
        iteration: it,
        rmse: metrics.map(|m| m.rmse),
        rel_mse: metrics.map(|m| m.rel_mse),
        est_rmse,
        est_rel_mse,
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
