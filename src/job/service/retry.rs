//! Retrying a finished job: queued again only when it can run, so that a retry never
//! queues a job that would just fail again for the same reason.

use super::Service;
use crate::job::run;
use crate::job::scheduler::Entry;
use crate::job::spec::{JobState, ReferenceSpec};
use crate::job::store::Checkpoint;
use crate::job::transition::To;
use crate::job::JobError;

impl Service {
    /// Queues a failed or cancelled job again: it resumes from its checkpoint (or
    /// starts over without one, to the same image). A job that cannot run (its
    /// settings do not parse in this build, its scene or reference is gone) is refused
    /// with the reason, and stays as it is.
    pub fn retry(&self, id: &str) -> Result<super::JobStatus, JobError> {
        let t = self.shared.table.lock().expect("job table");
        let e = t
            .jobs
            .get(id)
            .ok_or_else(|| JobError::NotFound(format!("job {id}")))?;
        if !matches!(e.status.state, JobState::Failed | JobState::Cancelled) {
            return Err(JobError::Conflict(format!(
                "job {id} is {}: only failed or cancelled jobs are retried",
                e.status.state.as_str()
            )));
        }
        if let Some(why) = self.cannot_run(e) {
            return Err(JobError::Conflict(format!(
                "job {id} cannot be retried: {why}"
            )));
        }
        let mut status = e.status.clone();
        let dir = self.job_dir_of(id);
        status.iteration = Checkpoint::read_header(&dir).map_or(0, |h| h.iteration);
        self.commit(t, status, To::Queued)
    }

    /// Why the job would fail again at once if it were queued, if it would. Checks
    /// what is cheap to check under the table's lock: files exist, settings parsed.
    fn cannot_run(&self, e: &Entry) -> Option<String> {
        if let Err(why) = &e.settings {
            return Some(why.clone());
        }
        let spec = &e.status.spec;
        if !self.shared.ctx.scenes.exists(&spec.scene) {
            return Some(format!(
                "its scene {} was deleted (uploading the same scene again gives it the \
                 same id; then retry)",
                spec.scene
            ));
        }
        let reference = match &spec.reference {
            None => return None,
            Some(ReferenceSpec::Upload(rid)) => run::reference_path(&self.config.data_dir, rid)
                .ok()
                .filter(|p| p.is_file())
                .is_none()
                .then(|| format!("its reference upload {rid} is gone")),
            Some(ReferenceSpec::Job(jid)) => (!self.job_dir_of(jid).final_image("exr").is_file())
                .then(|| format!("its reference job {jid} is gone or has no final image")),
        };
        reference.map(|r| format!("{r}; submit the job again with another reference"))
    }
}

#[cfg(test)]
mod tests {
    use crate::job::spec::JobState;
    use crate::job::{JobError, Service, ServiceConfig};
    use std::path::Path;

    const SCENE: &str = r#"{"format": 1, "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0],
        "up": [0, 1, 0]}, "fov": 40}, "film": {"width": 8, "height": 8},
        "materials": {"m": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
        "shapes": [{"type": "sphere", "radius": 1, "material": "m"}],
        "lights": [{"type": "point", "position": [0, 2, 3], "intensity": [5, 5, 5]}]}"#;

    /// A cancelled job on an uploaded scene.
    fn cancelled_job(svc: &Service) -> String {
        let scene = svc.upload_scene(SCENE.as_bytes()).unwrap().id;
        let spec = serde_json::from_value(serde_json::json!({
            "scene": scene, "halt": {"iterations": 1_000_000}
        }))
        .unwrap();
        let id = svc.submit(spec).unwrap().id;
        svc.cancel(&id).unwrap();
        id
    }

    fn refused(svc: &Service, id: &str, says: &str) {
        match svc.retry(id) {
            Err(JobError::Conflict(m)) => assert!(m.contains(says), "{m}"),
            other => panic!("retry of {id} was not refused: {other:?}"),
        }
        assert_eq!(svc.get_job(id).unwrap().state, JobState::Cancelled);
    }

    #[test]
    fn a_job_whose_scene_is_gone_is_not_queued_again() {
        let dir = tempfile::tempdir().unwrap();
        let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
        let id = cancelled_job(&svc);
        let scene = svc.get_job(&id).unwrap().spec.scene;
        svc.delete_scene(&scene).unwrap();
        refused(&svc, &id, "was deleted");
        // The same scene uploaded again has the same id: now it can run.
        svc.upload_scene(SCENE.as_bytes()).unwrap();
        assert_eq!(svc.retry(&id).unwrap().state, JobState::Queued);
        svc.shutdown();
    }

    #[test]
    fn a_job_whose_settings_do_not_parse_is_not_queued_again() {
        let dir = tempfile::tempdir().unwrap();
        let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
        let id = cancelled_job(&svc);
        svc.shutdown();
        drop(svc);
        let file = Path::new(dir.path())
            .join("jobs")
            .join(&id)
            .join("job.json");
        let mut job: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&file).unwrap()).unwrap();
        job["settings"]["renamed_in_a_later_version"] = 1.into();
        std::fs::write(&file, job.to_string()).unwrap();
        let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
        refused(&svc, &id, "do not parse in this version of caustic");
        svc.shutdown();
    }
}
