//! Following a job: its event stream (reconnecting across server restarts) shown as a
//! progress bar, and the summary line of a finished job.

use super::sse::WatchEvent;
use super::{Client, ClientError, Result};
use crate::job::spec::{JobState, JobStatus};
use crate::tev::TevClient;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::Value;
use std::io::Write;
use std::time::Duration;

/// `caustic watch`: follows a job to its end, showing each snapshot (and the final
/// image) in tev when `tev` is given. Returns whether it completed.
pub fn watch(
    client: &Client,
    id: &str,
    json: bool,
    tev: Option<&TevClient>,
    out: &mut impl Write,
) -> Result<bool> {
    let job = client.job(id)?;
    let mut show = |client: &Client, id: &str| {
        if let Some(t) = tev {
            show_in_tev(client, id, t)
        }
    };
    watch_job(client, job.job, json, &mut show, out)
}

/// Fetches the job's latest image and queues it for tev; a job without an image yet,
/// or an unreadable one, is skipped (the next snapshot brings another).
fn show_in_tev(client: &Client, id: &str, tev: &TevClient) {
    let image = client
        .image_exr(id)
        .map_err(|e| e.to_string())
        .and_then(|bytes| crate::film::decode_exr(&bytes).map_err(|e| e.to_string()));
    match image {
        Ok(image) => tev.show(image),
        Err(e) => tracing::debug!("no image of {id} for tev: {e}"),
    }
}

/// What the progress bar measures.
#[derive(Clone, Copy)]
enum Measure {
    Iterations,
    Millis,
    Spinner,
}

struct Watcher {
    bar: ProgressBar,
    measure: Measure,
    state: JobState,
    iteration: u64,
    elapsed_ms: f64,
    rmse: Option<f64>,
    /// Estimated relative error (`JobStatus::noise`).
    noise: Option<f64>,
    sps: f64,
    eta: Option<f64>,
}

impl Watcher {
    fn new(job: &JobStatus, json: bool) -> Watcher {
        let halt = &job.spec.halt;
        let (bar, measure) = if json {
            (ProgressBar::hidden(), Measure::Spinner)
        } else if let Some(n) = halt.max_iterations() {
            let bar = ProgressBar::new(n);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {pos}/{len} it  {msg}").expect("template"),
            );
            (bar, Measure::Iterations)
        } else if let Some(t) = halt.time_s {
            let bar = ProgressBar::new((t * 1e3).round() as u64);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {prefix} it  {msg}").expect("template"),
            );
            (bar, Measure::Millis)
        } else {
            let bar = ProgressBar::new_spinner();
            bar.set_style(
                ProgressStyle::with_template("{spinner} {prefix} it  {msg}").expect("template"),
            );
            (bar, Measure::Spinner)
        };
        if !json {
            bar.enable_steady_tick(Duration::from_millis(200));
        }
        let w = Watcher {
            bar,
            measure,
            state: job.state,
            iteration: job.iteration,
            elapsed_ms: job.elapsed_s * 1e3,
            rmse: job.last_rmse,
            noise: job.noise,
            sps: job.samples_per_s,
            eta: job.eta_s,
        };
        w.refresh();
        w
    }

    fn refresh(&self) {
        match self.measure {
            Measure::Iterations => self.bar.set_position(self.iteration),
            Measure::Millis => self.bar.set_position(self.elapsed_ms as u64),
            Measure::Spinner => {}
        }
        self.bar.set_prefix(self.iteration.to_string());
        let mut msg = String::new();
        if self.state != JobState::Running {
            msg.push_str(self.state.as_str());
            msg.push_str("  ");
        }
        msg.push_str(&format!("{} samples/s", rate(self.sps)));
        if let Some(r) = self.rmse {
            msg.push_str(&format!("  rmse {r:.3e}"));
        }
        if let Some(n) = self.noise {
            msg.push_str(&format!("  noise {:.2} %", 100.0 * n));
        }
        if let Some(e) = self.eta {
            msg.push_str(&format!("  eta {}", duration(e)));
        }
        self.bar.set_message(msg);
    }
}

/// `1.23 M`, `456.7 k`, `12`.
fn rate(x: f64) -> String {
    if x >= 1e6 {
        format!("{:.2} M", x / 1e6)
    } else if x >= 1e3 {
        format!("{:.1} k", x / 1e3)
    } else {
        format!("{x:.0}")
    }
}

/// `4.2 s`, `3m07s`, `2h05m`.
fn duration(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.1} s")
    } else if s < 3600.0 {
        format!("{}m{:02}s", (s / 60.0) as u64, (s % 60.0) as u64)
    } else {
        format!(
            "{}h{:02}m",
            (s / 3600.0) as u64,
            ((s % 3600.0) / 60.0) as u64
        )
    }
}

/// The one-line summary of a finished job.
pub fn summary(job: &JobStatus) -> String {
    let mut s = format!(
        "{}: {}, {} iterations in {:.2} s, {} dropped samples",
        job.id,
        job.state.as_str(),
        job.iteration,
        job.elapsed_s,
        job.dropped
    );
    if let Some(r) = job.last_rmse {
        s.push_str(&format!(", rmse {r:.4e}"));
    }
    if let Some(n) = job.noise {
        s.push_str(&format!(", estimated relative error {:.3} %", 100.0 * n));
    }
    if let Some(e) = &job.error {
        s.push_str(&format!(": {e}"));
    }
    s
}

/// How many times in a row the stream may fail to (re)connect before giving up.
const MAX_RECONNECTS: u32 = 30;

/// Follows `job`; `snapshot(client, id)` is called on each snapshot and once at the end.
pub(super) fn watch_job(
    client: &Client,
    job: JobStatus,
    json: bool,
    snapshot: &mut dyn FnMut(&Client, &str),
    out: &mut impl Write,
) -> Result<bool> {
    let id = job.id.clone();
    let mut w = Watcher::new(&job, json);
    // The last state the stream said (printed with --json).
    let mut said = None;
    let mut failures = 0;
    let final_status = 'outer: loop {
        let mut stream = match client.events(&id) {
            Ok(s) => s,
            Err(ClientError::Transport(e)) if failures < MAX_RECONNECTS => {
                failures += 1;
                w.bar.set_message(format!("reconnecting: {e}"));
                std::thread::sleep(Duration::from_secs(1));
                continue;
            }
            Err(e) => {
                w.bar.finish_and_clear();
                return Err(e);
            }
        };
        failures = 0;
        // Until the stream ends or breaks; without `done`, the server may be restarting.
        while let Ok(Some(msg)) = stream.next_message() {
            let data: Value = match serde_json::from_str(&msg.data) {
                Ok(v) => v,
                Err(_) => continue,
            };
            if json {
                writeln!(out, "{data}")?;
                out.flush()?;
            }
            match serde_json::from_value::<WatchEvent>(data) {
                Ok(WatchEvent::Progress {
                    iteration,
                    elapsed_s,
                    samples_per_s,
                    eta_s,
                    dropped: _,
                }) => {
                    w.state = JobState::Running;
                    w.iteration = iteration;
                    w.elapsed_ms = elapsed_s * 1e3;
                    w.sps = samples_per_s;
                    w.eta = eta_s;
                    w.refresh();
                }
                Ok(WatchEvent::Snapshot {
                    iteration,
                    rmse,
                    est_rel_mse,
                }) => {
                    w.iteration = w.iteration.max(iteration);
                    w.rmse = rmse.or(w.rmse);
                    w.noise = est_rel_mse.map(f64::sqrt).or(w.noise);
                    w.refresh();
                    snapshot(client, &id);
                }
                Ok(WatchEvent::State { state }) => {
                    said = Some(state);
                    w.state = state;
                    w.refresh();
                }
                Ok(WatchEvent::Done { status }) => break 'outer *status,
                Ok(WatchEvent::Shutdown) => {
                    w.bar.set_message("the server is stopping; reconnecting")
                }
                Ok(WatchEvent::Other) | Err(_) => {}
            }
        }
        // Ask where the job stands; finished jobs need no new stream.
        match client.job(&id) {
            Ok(j) if j.job.state.is_terminal() => {
                if json {
                    // The stream's own order: the final state (if not said yet), then done.
                    let state = j.job.state;
                    if said != Some(state) {
                        let e = serde_json::json!({"event": "state", "job": id, "state": state});
                        writeln!(out, "{e}")?;
                    }
                    let done = serde_json::json!({"event": "done", "job": id, "status": j.job});
                    writeln!(out, "{done}")?;
                }
                break j.job;
            }
            Ok(_) => {}
            Err(ClientError::Transport(_)) if failures < MAX_RECONNECTS => failures += 1,
            Err(e) => {
                w.bar.finish_and_clear();
                return Err(e);
            }
        }
        std::thread::sleep(Duration::from_secs(1));
    };
    snapshot(client, &id);
    w.bar.finish_and_clear();
    if !json {
        writeln!(out, "{}", summary(&final_status))?;
    }
    out.flush()?;
    Ok(final_status.state == JobState::Completed)
}
