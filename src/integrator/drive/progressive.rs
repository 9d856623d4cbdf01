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
}

#[derive(Clone, Debug)]
pub struct RenderOutcome {
    pub film: Film,
    pub iterations: u64,
    pub elapsed: Duration,
    pub stats: RenderStats,
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
        let unbounded = halt.iterations.is_none() && halt.time.is_none();
        if by_count || by_time || unbounded {
            break;
        }
    }
    RenderOutcome {
        film: sums.to_film(),
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
    let chained = integrator.chained();
    if !chained {
        scratch.clear();
    }
    let stats = integrator.iterate(scene, seed, iteration, scratch);
    if chained {
        *sums = ExactSums::new(scratch.width(), scratch.height());
    }
    sums.add_film(scratch)
        .expect("iterate_exact: scratch film and sums of different sizes");
    stats
}
