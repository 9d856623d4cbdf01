//! Running a range of progressive iterations with a halting rule, for the CLI, the
//! benchmarks and the tests (the server schedules iterations itself).

use crate::film::{ExactSums, Film};
use crate::integrator::{Integrator, RenderStats};
use crate::scene::Scene;
use std::time::{Duration, Instant};

/// When to stop: whichever limit is reached first (at least one iteration runs).
#[derive(Clone, Copy, Debug, Default)]
pub struct Halt {
    pub iterations: Option<u64>,
    pub time: Option<Duration>,
    /// The estimated relative error to stop at (`film::Noise::rel_error`), checked
    /// from [`NOISE_HALT_MIN_ITERATIONS`] iterations on, about 32 times per doubling of
    /// the iteration count (each check is a pass over the film).
    pub noise: Option<f64>,
}

/// Iterations before a noise target may stop a render (a job's `halt.noise` too): the
/// estimate from fewer is itself too noisy to trust (its relative spread is about
/// sqrt(2 / (N - 1)) per pixel).
pub const NOISE_HALT_MIN_ITERATIONS: u64 = 16;

impl Halt {
    /// Whether the noise target is met after `i` iterations; evaluates the noise only
    /// on the iterations it checks.
    fn noise_met(&self, i: u64, sums: &ExactSums) -> bool {
        let Some(target) = self.noise else {
            return false;
        };
        if i < NOISE_HALT_MIN_ITERATIONS || !i.is_multiple_of((i / 32).max(1)) {
            return false;
        }
        sums.noise(&sums.to_film(), i)
            .is_some_and(|n| n.rel_error() <= target)
    }
}

#[derive(Clone, Debug)]
pub struct RenderOutcome {
    pub film: Film,
    pub iterations: u64,
    pub elapsed: Duration,
    pub stats: RenderStats,
    /// The image's noise estimated from its own iterations (`film::noise`), when
    /// there is one.
    pub noise: Option<crate::film::Noise>,
}

/// Runs iterations `first..` until `halt`; `progress(done, elapsed)` is called after each.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u64,
    halt: Halt,
    mut progress: impl FnMut(u64, Duration),
) -> RenderOutcome {
    render_observed(scene, integrator, seed, halt, |p| {
        progress(p.iterations, p.elapsed)
    })
}

/// The state of a render after an iteration, for [`render_observed`]'s observer.
pub struct Progress<'a> {
    pub iterations: u64,
    pub elapsed: Duration,
    sums: &'a ExactSums,
}

impl Progress<'_> {
    /// The mean of the iterations so far: the image the render would write if it
    /// stopped now. Computed on demand (a pass over the film).
    pub fn image(&self) -> crate::film::Image {
        self.sums
            .to_film()
            .to_image(1.0 / self.iterations.max(1) as f64)
    }
}

/// [`render`] with an observer that may look at the image after each iteration.
pub fn render_observed(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u64,
    halt: Halt,
    mut observe: impl FnMut(&Progress),
) -> RenderOutcome {
    let (w, h) = (scene.width(), scene.height());
    // Exact sums, as jobs keep them: the same image, bit for bit, as a server job.
    let (mut scratch, mut sums) = (Film::new(w, h), ExactSums::new(w, h));
    let mut stats = RenderStats::default();
    let start = Instant::now();
    let mut i = 0u64;
    loop {
        stats += iterate_exact(scene, integrator, seed, i, &mut scratch, &mut sums);
        i += 1;
        let elapsed = start.elapsed();
        observe(&Progress {
            iterations: i,
            elapsed,
            sums: &sums,
        });
        let by_count = halt.iterations.is_some_and(|n| i >= n);
        let by_time = halt.time.is_some_and(|t| elapsed >= t);
        // A chained integrator has no noise estimate (`iterate_exact`).
        let by_noise = halt.noise.is_some() && !integrator.chained();
        let unbounded = halt.iterations.is_none() && halt.time.is_none() && !by_noise;
        if by_count || by_time || unbounded || halt.noise_met(i, &sums) {
            break;
        }
    }
    let film = sums.to_film();
    RenderOutcome {
        noise: sums.noise(&film, i),
        film,
        iterations: i,
        elapsed: start.elapsed(),
        stats,
    }
}

impl RenderOutcome {
    /// The mean of all iterations.
    pub fn image(&self) -> crate::film::Image {
        self.film.to_image(1.0 / self.iterations.max(1) as f64)
    }
}

/// Adds iteration `iteration` to a job's exact sums (`film::exact`), which is what
/// makes its image independent of how iterations are grouped into batches, ranges and
/// workers. An independent iteration renders into the cleared `scratch` film, which
/// is then rounded into `sums`; a chained integrator keeps its running totals in
/// `scratch`, which `sums` then holds instead. `scratch` and `sums` have the scene's
/// film size.
pub fn iterate_exact(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u64,
    iteration: u64,
    scratch: &mut Film,
    sums: &mut ExactSums,
) -> RenderStats {
    let stats = iterate_scratch(scene, integrator, seed, iteration, scratch);
    fold_exact(integrator.chained(), scratch, sums);
    stats
}

/// The first half of [`iterate_exact`]: renders iteration `iteration` into
/// `scratch` (cleared first unless the integrator is chained).
pub fn iterate_scratch(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u64,
    iteration: u64,
    scratch: &mut Film,
) -> RenderStats {
    if !integrator.chained() {
        scratch.clear();
    }
    integrator.iterate(scene, seed, iteration, scratch)
}

/// The second half of [`iterate_exact`]: adds what [`iterate_scratch`] rendered to
/// `sums` (or, `chained`, makes `sums` hold it).
pub fn fold_exact(chained: bool, scratch: &Film, sums: &mut ExactSums) {
    // A chained film holds every iteration so far: it has no single iteration's
    // values to take second moments of, so its jobs have no noise estimate.
    let added = if chained {
        *sums = ExactSums::new(scratch.width(), scratch.height());
        sums.add_film(scratch)
    } else {
        sums.add_iteration(scratch)
    };
    added.expect("iterate_exact: scratch film and sums of different sizes");
}
