//! Equal-time convergence: run one algorithm for a wall-clock budget, measuring the
//! error against a reference at geometrically spaced times. Only the iterations are
//! timed; building the image and comparing it with the reference is not.

use super::cpu::Stopwatch;
use super::BenchError;
use crate::film::{self, ExactSums, Film, Image};
use crate::integrator::drive::{fold_exact, iterate_scratch};
use crate::integrator::{Integrator, RenderStats};
use crate::scene::Scene;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

/// The error after `iteration` iterations, with the work done so far.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub iteration: u64,
    /// Wall-clock seconds spent in iterations (error measurement excluded).
    pub elapsed_s: f64,
    /// Process CPU seconds (user + system, all threads) spent in iterations.
    pub cpu_s: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    /// The same two estimated from the run's own iterations, without the reference
    /// (`film::noise`), where there is an estimate.
    pub est_rmse: Option<f64>,
    pub est_rel_mse: Option<f64>,
    pub dropped: u64,
    /// Counters summed over all iterations so far (merge radius and vertex bytes:
    /// the latest iteration's).
    pub stats: RenderStats,
}

impl Point {
    /// Closest-hit plus shadow rays per wall-clock second.
    pub fn rays_per_s(&self) -> f64 {
        (self.stats.rays + self.stats.shadow_rays) as f64 / self.elapsed_s.max(1e-9)
    }
}

/// One algorithm's equal-time run.
#[derive(Clone, Debug)]
pub struct ConvergenceRun {
    /// A label for tables, file names and the plot legend.
    pub label: String,
    /// The error at the scheduled times; the last point is the final image.
    pub points: Vec<Point>,
    /// The accumulated film (sums over all iterations).
    pub film: Film,
}

impl ConvergenceRun {
    /// The final point (every run has at least one).
    pub fn last(&self) -> &Point {
        self.points.last().expect("a run has at least one point")
    }

    /// The mean of all iterations.
    pub fn image(&self) -> Image {
        self.film
            .to_image(1.0 / self.last().iteration.max(1) as f64)
    }
}

/// `n` measuring times spread evenly on a log scale over three decades, ending at
/// `budget` seconds: even spacing on the log-log plot.
pub fn geometric_times(budget: f64, n: usize) -> Vec<f64> {
    let n = n.max(1);
    if n == 1 {
        return vec![budget];
    }
    let first = budget * 1e-3;
    (0..n)
        .map(|k| first * (budget / first).powf(k as f64 / (n - 1) as f64))
        .collect()
}

/// How long to run and how often to measure.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub seed: u64,
    /// Iteration time to spend (error measurement excluded).
    pub budget: Duration,
    /// Number of geometrically spaced measuring times (see [`geometric_times`]).
    pub points: usize,
}

/// Runs iterations of `integrator` until `plan.budget` of iteration time is used (at
/// least one iteration), measuring the error against `reference` after the first
/// iteration, whenever one of the scheduled times has passed, and at the end.
/// `progress(iterations, elapsed)` is called after every iteration.
pub fn converge(
    label: &str,
    scene: &Scene,
    integrator: &dyn Integrator,
    reference: &Image,
    plan: Plan,
    mut progress: impl FnMut(u64, Duration),
) -> Result<ConvergenceRun, BenchError> {
    let (seed, budget) = (plan.seed, plan.budget);
    if reference.size() != (scene.width(), scene.height()) {
        return Err(BenchError::Invalid(format!(
            "the reference is {}x{} but the scene renders {}x{}",
            reference.width(),
            reference.height(),
            scene.width(),
            scene.height()
        )));
    }
    let schedule = geometric_times(budget.as_secs_f64(), plan.points);
    let mut next = 0; // index of the next scheduled time
                      // Exact sums as jobs keep them, with their second moments for the noise estimate;
                      // adding an iteration to them is not timed.
    let (w, h) = (scene.width(), scene.height());
    let (mut scratch, mut sums) = (Film::new(w, h), ExactSums::new(w, h));
    let mut stats = RenderStats::default();
    let (mut wall, mut cpu) = (Duration::ZERO, Duration::ZERO);
    let mut out = Vec::new();
    let mut i = 0u64;
    loop {
        let sw = Stopwatch::start();
        stats += iterate_scratch(scene, integrator, seed, i, &mut scratch);
        let (w, c) = sw.elapsed();
        fold_exact(integrator.chained(), &scratch, &mut sums);
        wall += w;
        cpu += c;
        i += 1;
        progress(i, wall);
        let done = wall >= budget;
        let due = next < schedule.len() && wall.as_secs_f64() >= schedule[next];
        if i == 1 || due || done {
            while next < schedule.len() && wall.as_secs_f64() >= schedule[next] {
                next += 1;
            }
            let film = sums.to_film();
            let m = film::compare(&film.to_image(1.0 / i as f64), reference)?;
            let noise = sums.noise(&film, i);
            out.push(Point {
                iteration: i,
                elapsed_s: wall.as_secs_f64(),
                cpu_s: cpu.as_secs_f64(),
                rmse: m.rmse,
                rel_mse: m.rel_mse,
                est_rmse: noise.as_ref().map(|n| n.rmse()),
                est_rel_mse: noise.as_ref().map(|n| n.rel_mse()),
                dropped: film.dropped(),
                stats,
            });
        }
        if done {
            break;
        }
    }
    Ok(ConvergenceRun {
        label: label.to_string(),
        points: out,
        film: sums.to_film(),
    })
}

/// The columns of bench.csv.
pub const CSV_HEADER: &str = "algorithm,iteration,elapsed_s,cpu_s,rmse,rel_mse,rays_per_s,samples,rays,shadow_rays,light_vertices,connections,merges,merge_radius,vertex_bytes,dropped,est_rmse,est_rel_mse";

/// bench.csv: one row per measured point of every run, written atomically.
pub fn write_csv(path: &Path, runs: &[ConvergenceRun]) -> Result<(), BenchError> {
    let mut text = String::from(CSV_HEADER);
    text.push('\n');
    let opt = |v: Option<f64>| v.map(|x| format!("{x:.6e}")).unwrap_or_default();
    for run in runs {
        for p in &run.points {
            let s = &p.stats;
            let _ = writeln!(
                text,
                "{},{},{:.6},{:.6},{:.6e},{:.6e},{:.0},{},{},{},{},{},{},{:.6e},{},{},{},{}",
                run.label,
                p.iteration,
                p.elapsed_s,
                p.cpu_s,
                p.rmse,
                p.rel_mse,
                p.rays_per_s(),
                s.samples,
                s.rays,
                s.shadow_rays,
                s.light_vertices,
                s.connections,
                s.merges,
                s.merge_radius,
                s.vertex_bytes,
                p.dropped,
                opt(p.est_rmse),
                opt(p.est_rel_mse)
            );
        }
    }
    film::write_bytes_atomic(path, text.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_is_geometric_and_ends_at_the_budget() {
        let t = geometric_times(60.0, 21);
        assert_eq!(t.len(), 21);
        assert!((t[0] - 0.06).abs() < 1e-12);
        assert!((t[20] - 60.0).abs() < 1e-9);
        let ratios: Vec<f64> = t.windows(2).map(|w| w[1] / w[0]).collect();
        assert!(ratios.iter().all(|r| (r - ratios[0]).abs() < 1e-9));
        assert_eq!(geometric_times(5.0, 1), vec![5.0]);
    }
}
