//! Benchmarks: equal-time convergence runs of several algorithms against a reference
//! image (error-vs-time points, CSV, log-log plot), and CPU-time measurement for the
//! speed benchmark. The render core stays untouched: this module only drives
//! integrators iteration by iteration and times them.

pub mod converge;
pub mod cpu;
pub mod mem;
pub mod plot;

pub use converge::{converge, geometric_times, write_csv, ConvergenceRun, Plan, Point, CSV_HEADER};
pub use cpu::{process_cpu_time, Stopwatch};
pub use mem::{peak_rss_bytes, peak_rss_mib, reset_peak_rss};
pub use plot::plot_rmse_vs_time;

/// Errors of the benchmark layer.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Film(#[from] crate::film::FilmError),
    #[error("plot {path}: {message}")]
    Plot { path: String, message: String },
    #[error("{0}")]
    Invalid(String),
}
