//! A job's runtime: what running its iterations needs in memory (compiled scene,
//! integrator, exact sums, the film iterations render into), resumed from a
//! checkpoint, and the loop that renders a range of iterations.
//!
//! Below both batch runners: `run` (batches in this process, snapshots, completion)
//! and `remote` (ranges on a pool of workers, and the worker's own loop) build on it.
//! It imports neither of them, nor the server's `context`: only the render core, the
//! job's spec and its checkpoint format.

use super::spec::{JobSpec, JobStatus, SnapshotEvery};
use super::store::Checkpoint;
use super::JobError;
use crate::film::{ExactSums, Film, Image};
use crate::integrator::drive::iterate_exact;
use crate::integrator::{Integrator, RenderStats, Settings};
use crate::scene::Scene;
use std::ops::Range;
use std::sync::Arc;
use std::time::Duration;

/// Target wall time of one batch rendered in this process.
const BATCH: Duration = Duration::from_millis(250);

/// Live state of an active job: everything needed to run its next iterations.
pub struct Runtime {
    pub(super) scene: Arc<Scene>,
    /// What `integrator` was built from, for work units sent to other processes.
    pub(super) settings: Settings,
    integrator: Box<dyn Integrator>,
    /// The job's exact sums (`film::exact`): what its images and checkpoints hold.
    pub(super) sums: ExactSums,
    /// The film iterations render into (`driver::iterate_exact`).
    pub(super) scratch: Film,
    pub(super) samples: u64,
    pub(super) reference: Option<Image>,
    /// Seconds per iteration, smoothed.
    pub(super) per_iter: f64,
    /// Iteration and elapsed seconds of the latest snapshot.
    pub(super) last_snapshot: (u64, f64),
}

impl Runtime {
    /// A job's runtime, from its checkpoint if it has one (of the scene's size):
    /// the job goes on after `c.iteration` iterations as if it had never stopped.
    pub(super) fn resume(
        job: &str,
        settings: Settings,
        scene: Arc<Scene>,
        reference: Option<Image>,
        checkpoint: Option<Checkpoint>,
    ) -> Result<Runtime, JobError> {
        let integrator = settings.build();
        let (w, h) = (scene.width(), scene.height());
        let at = checkpoint.as_ref().map_or(0, |c| c.iteration);
        let (sums, scratch, samples, elapsed) = match checkpoint {
            Some(c) => {
                if let Some(state) = &c.state {
                    // An unusable state is not fatal: the integrator then starts its
                    // statistics afresh and keeps the film consistent.
                    if let Err(e) = integrator.load_state(state) {
                        tracing::warn!(job = %job, "checkpoint state not restored: {e}");
                    }
                }
                let sums = match c.exact.filter(|e| e.size() == (w, h)) {
                    Some(e) => e,
                    // Written before exact sums: resumes from the f64 sums, rounded once.
                    None => {
                        let mut e = ExactSums::new(w, h);
                        e.add_film(&c.film)
                            .map_err(|e| JobError::Internal(e.to_string()))?;
                        e
                    }
                };
                (sums, c.film, c.samples, c.elapsed_s)
            }
            None => (ExactSums::new(w, h), Film::new(w, h), 0, 0.0),
        };
        Ok(Runtime {
            integrator,
            settings,
            scene,
            sums,
            scratch,
            samples,
            reference,
            per_iter: 0.0,
            last_snapshot: (at, elapsed),
        })
    }

    /// The exact state to resume from after `status.iteration` iterations.
    pub fn checkpoint(&self, status: &JobStatus) -> Checkpoint {
        // A chained integrator's own film is what it resumes on.
        let film = if self.integrator.chained() {
            self.scratch.clone()
        } else {
            self.sums.to_film()
        };
        Checkpoint {
            iteration: status.iteration,
            elapsed_s: status.elapsed_s,
            samples: self.samples,
            film,
            state: self.integrator.save_state(),
            exact: Some(self.sums.clone()),
        }
    }

    /// Whether the job's iterations continue each other (`Integrator::chained`).
    pub(super) fn chained(&self) -> bool {
        self.integrator.chained()
    }

    /// Continues from checkpoint `c` of a chained job, rendered elsewhere up to
    /// `c.iteration`: its state, film and sums replace the job's.
    pub(super) fn adopt(&mut self, c: Checkpoint) -> Result<(), JobError> {
        let (w, h) = (self.scene.width(), self.scene.height());
        let exact = c.exact.filter(|e| e.size() == (w, h));
        let (Some(exact), true) = (exact, c.film.width() == w && c.film.height() == h) else {
            return Err(JobError::Internal(
                "a worker's checkpoint has the wrong size".into(),
            ));
        };
        if let Some(state) = &c.state {
            self.integrator
                .load_state(state)
                .map_err(|e| JobError::Internal(format!("a worker's checkpoint: {e}")))?;
        }
        self.scratch = c.film;
        self.sums = exact;
        Ok(())
    }

    /// About [`BATCH`] of iterations, rendered here; returns how many and their
    /// counters.
    pub(super) fn local_batch(&mut self, status: &mut JobStatus) -> (u64, RenderStats) {
        let n = batch_len(&status.spec, status.iteration, self.per_iter, BATCH);
        let first = status.iteration;
        let stats = render_iterations(
            &self.scene,
            self.integrator.as_ref(),
            status.spec.seed,
            first..first + n,
            &mut self.scratch,
            &mut self.sums,
        );
        status.iteration += n;
        (n, stats)
    }
}

/// Renders iterations `range` in order into `scratch`, adding each to `sums`: what a
/// batch in this process and a worker's range both run.
pub fn render_iterations(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u64,
    range: Range<u64>,
    scratch: &mut Film,
    sums: &mut ExactSums,
) -> RenderStats {
    let mut stats = RenderStats::default();
    for i in range {
        stats += iterate_exact(scene, integrator, seed, i, scratch, sums);
    }
    stats
}

/// How many iterations the next batch (or work unit) from `iteration` runs: about
/// `target` of work at `per_iter` seconds each (1 while that is unknown), never past
/// the iteration limit, and ending on the next snapshot iteration so snapshots land
/// exactly.
pub(super) fn batch_len(spec: &JobSpec, iteration: u64, per_iter: f64, target: Duration) -> u64 {
    let mut n = if per_iter > 0.0 {
        (target.as_secs_f64() / per_iter).floor().max(1.0) as u64
    } else {
        1
    };
    if let Some(m) = spec.halt.max_iterations() {
        n = n.min(m.saturating_sub(iteration)).max(1);
    }
    if let SnapshotEvery::Iterations(k) = spec.snapshot_every {
        let next = (iteration / k.max(1) + 1) * k.max(1);
        n = n.min(next - iteration);
    }
    n
}
