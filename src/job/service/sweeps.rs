//! Sweeps: a grid of jobs created, stored and queued together, and their table.

use super::{bad, Service};
use crate::integrator::bidir::radius_layer_name;
use crate::integrator::Settings;
use crate::job::limits;
use crate::job::spec::JobSpec;
use crate::job::spec::{JobState, JobStatus};
use crate::job::sweep::{layered_spec, Point, Sweep, SweepRow, SweepSpec, SweepTable};
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
        let expanded = spec.expand(&id)?;
        // Per point, the index of its job in `prepared` and its radius layer.
        let mut renders: Vec<(usize, Option<String>)> = vec![(0, None); expanded.len()];
        let mut prepared = Vec::new();
        for group in spec.radius_groups(&expanded) {
            if let Some(job) = self.prepare_layered(&spec, &expanded, &group) {
                for (k, &i) in group.iter().enumerate() {
                    let layer = (k > 0).then(|| radius_layer_name(k - 1));
                    renders[i] = (prepared.len(), layer);
                }
                prepared.push(job);
                continue;
            }
            for &i in &group {
                renders[i] = (prepared.len(), None);
                prepared.push(self.prepare(expanded[i].1.clone())?);
            }
        }
        let job_of = |i: usize| prepared[renders[i].0].0.id.clone();
        let jobs = expanded
            .iter()
            .enumerate()
            .map(|(i, (point, _))| (point.clone(), job_of(i)))
            .collect();
        let layers = renders.into_iter().map(|(_, l)| l).collect::<Vec<_>>();
        let sweep = Sweep {
            id,
            spec,
            jobs,
            layers: match layers.iter().any(Option::is_some) {
                true => layers,
                false => Vec::new(),
            },
        };
        let path = self
            .config
            .data_dir
            .join("sweeps")
            .join(format!("{}.json", sweep.id));
        crate::film::write_bytes_atomic(&path, &serde_json::to_vec_pretty(&sweep).expect("sweep"))?;
        let mut stored: Vec<(JobStatus, Settings)> = Vec::with_capacity(prepared.len());
        for job in prepared {
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

    /// The one job of a group of points that differ only in their radius, if the
    /// group has several points and such a job prepares (the algorithm has radius
    /// layers, and the job fits the memory budget) and renders what the separate jobs
    /// would (not `upbp` whose `selection: auto` the layers turn from adaptive to
    /// `all`); None: separate jobs.
    fn prepare_layered(
        &self,
        spec: &SweepSpec,
        expanded: &[(Point, JobSpec)],
        group: &[usize],
    ) -> Option<(JobStatus, Settings)> {
        let swept = spec.swept_radius().filter(|_| group.len() > 1)?;
        let specs: Vec<&JobSpec> = group.iter().map(|&i| &expanded[i].1).collect();
        let job = self.prepare(layered_spec(&specs, swept)).ok()?;
        let layers = job.1.radius_layers().len();
        (layers + 1 == group.len() && !job.1.layers_differ_from_separate_jobs()).then_some(job)
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

    /// The sweep's table: each job's state, iterations, time and last RMSE (a radius
    /// layer's from the job's layers.csv). A job that is gone (deleted) shows as failed
    /// with nothing rendered.
    pub fn sweep_table(&self, sweep: Sweep) -> SweepTable {
        let rows = sweep
            .jobs
            .iter()
            .enumerate()
            .map(|(i, (point, id))| {
                let st = self.get_job(id);
                let layer = sweep.layer(i).map(String::from);
                let rmse = match &layer {
                    None => st.as_ref().ok().and_then(|j| j.last_rmse),
                    Some(l) => self.layer_rmse(id, l),
                };
                SweepRow {
                    job: id.clone(),
                    point: point.clone(),
                    state: st.as_ref().map(|j| j.state).unwrap_or(JobState::Failed),
                    iterations: st.as_ref().map(|j| j.iteration).unwrap_or(0),
                    time_s: st.as_ref().map(|j| j.elapsed_s).unwrap_or(0.0),
                    rmse,
                    layer,
                }
            })
            .collect();
        SweepTable {
            id: sweep.id,
            name: sweep.spec.name,
            rows,
        }
    }

    /// Layer `layer`'s latest RMSE in job `id`'s layers.csv.
    fn layer_rmse(&self, id: &str, layer: &str) -> Option<f64> {
        let rows = self.layer_log(id).ok()?;
        rows.iter().rev().find(|r| r.layer == layer)?.rmse
    }
}
