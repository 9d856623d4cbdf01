//! What a job has produced: its directory, current image, snapshots and log, read
//! for the front ends.

use super::{bad, Service};
use crate::job::layer_log::{read_layer_log, LayerRow, LAYER_HEADER};
use crate::job::store::{read_log, JobDir, LogRow};
use crate::job::JobError;
use std::path::Path;

impl Service {
    pub fn job_dir(&self, id: &str) -> Result<JobDir, JobError> {
        self.get_job(id)?;
        Ok(JobDir::new(&self.config.data_dir, id))
    }

    /// The job's current image file: `latest.*` while it renders, `final.*` once it
    /// has completed (which replaces `latest.*`).
    pub(super) fn current_image(
        &self,
        id: &str,
        ext: &str,
    ) -> Result<std::path::PathBuf, JobError> {
        let dir = self.job_dir(id)?;
        let latest = dir.latest(ext);
        let fin = dir.final_image(ext);
        Ok(if !latest.exists() && fin.exists() {
            fin
        } else {
            latest
        })
    }

    /// Latest image as PNG, re-encoded when an exposure is asked for.
    pub fn preview_png(&self, id: &str, exposure: Option<f32>) -> Result<Vec<u8>, JobError> {
        match exposure {
            None | Some(0.0) => read_file(&self.current_image(id, "png")?),
            Some(e) if e.is_finite() && e.abs() <= 64.0 => {
                let img = crate::film::read_exr(self.current_image(id, "exr")?)
                    .map_err(|_| JobError::NotFound(format!("job {id} has no image yet")))?;
                Ok(crate::film::encode_png(&img, e)?)
            }
            Some(_) => Err(bad("exposure must be a number of stops in [-64, 64]")),
        }
    }

    pub fn image_exr(&self, id: &str) -> Result<Vec<u8>, JobError> {
        read_file(&self.current_image(id, "exr")?)
    }

    pub fn snapshots(&self, id: &str) -> Result<Vec<u64>, JobError> {
        Ok(self.job_dir(id)?.list_snapshots())
    }

    pub fn snapshot(&self, id: &str, iteration: u64, ext: &str) -> Result<Vec<u8>, JobError> {
        if ext != "exr" && ext != "png" {
            return Err(bad("snapshots are .exr or .png"));
        }
        read_file(&self.job_dir(id)?.snapshot(iteration, ext))
    }

    pub fn log(&self, id: &str) -> Result<Vec<LogRow>, JobError> {
        Ok(read_log(&self.job_dir(id)?))
    }

    pub fn log_csv(&self, id: &str) -> Result<Vec<u8>, JobError> {
        let dir = self.job_dir(id)?;
        Ok(std::fs::read(dir.log_csv())
            .unwrap_or_else(|_| format!("{}\n", crate::job::store::LOG_HEADER).into_bytes()))
    }

    pub fn layer_log(&self, id: &str) -> Result<Vec<LayerRow>, JobError> {
        Ok(read_layer_log(&self.job_dir(id)?))
    }

    /// layers.csv; its header alone for a job that has none (yet, or no `radii`).
    pub fn layer_log_csv(&self, id: &str) -> Result<Vec<u8>, JobError> {
        let dir = self.job_dir(id)?;
        Ok(std::fs::read(dir.layers_csv())
            .unwrap_or_else(|_| format!("{LAYER_HEADER}\n").into_bytes()))
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>, JobError> {
    std::fs::read(path).map_err(|_| {
        JobError::NotFound(format!(
            "{} (not written yet)",
            path.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        ))
    })
}
