//! Sweeps: a grid of jobs created, stored and queued together, and their table.

use super::{bad, Service};
use crate::integrator::Settings;
use crate::job::limits;
use crate::job::spec::{JobState, JobStatus};
use crate::job::sweep::{Sweep, SweepRow, SweepSpec, SweepTable};
use crate::job::JobError;

impl Service {
    /// Expands a sweep into jobs and queues them all, or none: every job is
    /// validated and stored before any is queued.
    pub fn create_sweep(&self, spec: SweepSpec) -> Result<Sweep, JobError> {
        if spec.base.sweep.is_some() {
            return Err(bad("base.sweep is set by the server"));
        }
        if let Some(n) = &spec.name {
            limits::check_text("name", n, limits::MAX_NAME)?;
        }
        let id = format!("s{}", &uuid::Uuid::new_v4().simple().to_string()[..12]);
        let mut prepared = Vec::new();
        for (point, job) in spec.expand(&id)? {
            prepared.push((point, self.prepare(job)?));
        }
        let sweep = Sweep {
            id,
            spec,
            jobs: prepared
                .iter()
                .map(|(point, (status, _))| (point.clone(), status.id.clone()))
                .collect(),
        };
        let path = self
            .config
            .data_dir
            .join("sweeps")
            .join(format!("{}.json", sweep.id));
        crate::film::write_bytes_atomic(&path, &serde_json::to_vec_pretty(&sweep).expect("sweep"))?;
        let mut stored: Vec<(JobStatus, Settings)> = Vec::with_capacity(prepared.len());
        for (_, job) in prepared {
            if let Err(e) = self.store_new(&job.0) {
                for (s, _) in &stored {
                    let _ = std::fs::remove_dir_all(self.job_dir_of(&s.id).root);
                }
                let _ = std::fs::remove_file(&path);
                return Err(e);
            }
            stored.push(job);
        }
        self.enqueue(stored);
        Ok(sweep)
    }

    pub fn get_sweep(&self, id: &str) -> Result<Sweep, JobError> {
        if !id.starts_with('s') || !id[1..].bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(JobError::NotFound(format!("sweep {id}")));
        }
        let path = self
            .config
            .data_dir
            .join("sweeps")
            .join(format!("{id}.json"));
        let bytes = std::fs::read(&path).map_err(|_| JobError::NotFound(format!("sweep {id}")))?;
        serde_json::from_slice(&bytes).map_err(|e| JobError::Internal(e.to_string()))
    }

    /// The sweep's table: each job's state, iterations, time and last RMSE. A job that
    /// is gone (deleted) shows as failed with nothing rendered.
    pub fn sweep_table(&self, sweep: Sweep) -> SweepTable {
        let rows = sweep
            .jobs
            .iter()
            .map(|(point, id)| {
                let st = self.get_job(id);
                SweepRow {
                    job: id.clone(),
                    point: point.clone(),
                    state: st.as_ref().map(|j| j.state).unwrap_or(JobState::Failed),
                    iterations: st.as_ref().map(|j| j.iteration).unwrap_or(0),
                    time_s: st.as_ref().map(|j| j.elapsed_s).unwrap_or(0.0),
                    rmse: st.as_ref().ok().and_then(|j| j.last_rmse),
                }
            })
            .collect();
        SweepTable {
            id: sweep.id,
            name: sweep.spec.name,
            rows,
        }
    }
}
