//! The Prometheus text exposition of the job table and the render counters.

use super::Service;
use crate::job::remote::WorkerInfo;
use crate::job::spec::JobState;
use std::sync::atomic::Ordering;

impl Service {
    /// Prometheus text exposition.
    pub fn metrics(&self) -> String {
        let t = self.shared.table.lock().expect("job table");
        let mut by_state = std::collections::BTreeMap::new();
        for e in t.jobs.values() {
            *by_state.entry(e.status.state.as_str()).or_insert(0u64) += 1;
        }
        let held = t.jobs.values().filter(|e| e.holds_memory()).count() as u64;
        let unsaved = t.jobs.values().filter(|e| e.unsaved).count() as u64;
        drop(t);
        let m = &self.shared.ctx.metrics;
        let mut out = String::new();
        out.push_str("# HELP caustic_jobs Jobs by state.\n# TYPE caustic_jobs gauge\n");
        for st in JobState::ALL {
            let n = by_state.get(st.as_str()).copied().unwrap_or(0);
            out.push_str(&format!("caustic_jobs{{state=\"{}\"}} {n}\n", st.as_str()));
        }
        let queue = by_state.get("queued").copied().unwrap_or(0);
        let counters = [
            (
                "caustic_queue_length",
                "gauge",
                "Jobs waiting to run.",
                queue,
            ),
            (
                "caustic_iterations_total",
                "counter",
                "Iterations rendered.",
                m.iterations.load(Ordering::Relaxed),
            ),
            (
                "caustic_samples_total",
                "counter",
                "Camera samples or light paths.",
                m.samples.load(Ordering::Relaxed),
            ),
            (
                "caustic_rays_total",
                "counter",
                "Rays traced.",
                m.rays.load(Ordering::Relaxed),
            ),
            (
                "caustic_dropped_samples_total",
                "counter",
                "Non-finite or negative samples dropped.",
                m.dropped.load(Ordering::Relaxed),
            ),
            (
                "caustic_scene_compilations_total",
                "counter",
                "Scenes compiled (BVH builds).",
                self.shared.ctx.scenes.compilations(),
            ),
            (
                "caustic_jobs_held",
                "gauge",
                "Jobs whose render state is in memory.",
                held,
            ),
            (
                "caustic_jobs_set_aside_total",
                "counter",
                "Jobs checkpointed and set aside for a job of higher priority.",
                m.set_aside.load(Ordering::Relaxed),
            ),
            (
                "caustic_jobs_unsaved",
                "gauge",
                "Jobs whose job.json could not be written yet (retried).",
                unsaved,
            ),
        ];
        for (name, kind, help, v) in counters {
            out.push_str(&format!(
                "# HELP {name} {help}\n# TYPE {name} {kind}\n{name} {v}\n"
            ));
        }
        let secs = m.render_ns.load(Ordering::Relaxed) as f64 / 1e9;
        out.push_str(&format!(
            "# HELP caustic_render_seconds_total Time spent rendering.\n# TYPE caustic_render_seconds_total counter\ncaustic_render_seconds_total {secs:.3}\n"
        ));
        self.worker_metrics(&mut out);
        out
    }

    /// Per-worker figures of a pool (nothing in-process).
    fn worker_metrics(&self, out: &mut String) {
        let Ok(workers) = self.workers() else {
            return;
        };
        let series: [Series; 4] = [
            (
                "caustic_worker_threads",
                "gauge",
                "Render threads of a pool worker.",
                |w| w.threads.to_string(),
            ),
            (
                "caustic_worker_ranges_total",
                "counter",
                "Iteration ranges a pool worker rendered.",
                |w| w.ranges_done.to_string(),
            ),
            (
                "caustic_worker_iterations_total",
                "counter",
                "Iterations a pool worker rendered.",
                |w| w.iterations_done.to_string(),
            ),
            (
                "caustic_worker_last_heartbeat_seconds",
                "gauge",
                "Unix time of a pool worker's latest heartbeat.",
                |w| format!("{:.3}", w.last_heartbeat),
            ),
        ];
        for (name, kind, help, value) in series {
            out.push_str(&format!("# HELP {name} {help}\n# TYPE {name} {kind}\n"));
            for w in &workers {
                let label = w.name.replace('\\', "\\\\").replace('"', "\\\"");
                out.push_str(&format!("{name}{{worker=\"{label}\"}} {}\n", value(w)));
            }
        }
    }
}

/// A per-worker metric: name, type, help, and its value for one worker.
type Series = (
    &'static str,
    &'static str,
    &'static str,
    fn(&WorkerInfo) -> String,
);
