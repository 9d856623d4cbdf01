//! Conversions between protobuf messages and the service's job, scene, sweep and
//! event types.

use super::{bad, pb};
use crate::job::events::Event;
use crate::job::scenes::SceneInfo;
use crate::job::spec::{KeepSnapshots, ReferenceSpec, SnapshotEvery};
use crate::job::sweep::{Sweep, SweepSpec};
use crate::job::{HaltSpec, JobError, JobSpec, JobState, JobStatus};

pub(super) fn scene_to_pb(s: SceneInfo) -> pb::Scene {
    pb::Scene {
        id: s.id,
        builtin: s.builtin,
        width: s.width,
        height: s.height,
        shapes: s.shapes as u64,
        lights: s.lights as u64,
        size_bytes: s.size_bytes,
        warnings: s.warnings,
    }
}

fn state_to_pb(s: JobState) -> pb::JobState {
    match s {
        JobState::Queued => pb::JobState::Queued,
        JobState::Running => pb::JobState::Running,
        JobState::Paused => pb::JobState::Paused,
        JobState::Completed => pb::JobState::Completed,
        JobState::Cancelled => pb::JobState::Cancelled,
        JobState::Failed => pb::JobState::Failed,
    }
}

/// `None` for `JOB_STATE_UNSPECIFIED`.
pub(super) fn state_from_pb(v: i32) -> Result<Option<JobState>, JobError> {
    let s = pb::JobState::try_from(v).map_err(|_| bad(format!("unknown job state {v}")))?;
    Ok(match s {
        pb::JobState::Unspecified => None,
        pb::JobState::Queued => Some(JobState::Queued),
        pb::JobState::Running => Some(JobState::Running),
        pb::JobState::Paused => Some(JobState::Paused),
        pb::JobState::Completed => Some(JobState::Completed),
        pb::JobState::Cancelled => Some(JobState::Cancelled),
        pb::JobState::Failed => Some(JobState::Failed),
    })
}

fn halt_to_pb(h: &HaltSpec) -> pb::Halt {
    pb::Halt {
        spp: h.spp,
        iterations: h.iterations,
        time_s: h.time_s,
        target_rmse: h.target_rmse,
        noise: h.noise,
    }
}

fn halt_from_pb(h: pb::Halt) -> HaltSpec {
    HaltSpec {
        spp: h.spp,
        iterations: h.iterations,
        time_s: h.time_s,
        target_rmse: h.target_rmse,
        noise: h.noise,
    }
}

fn reference_to_pb(r: &ReferenceSpec) -> pb::ReferenceSource {
    use pb::reference_source::Source;
    let source = match r {
        ReferenceSpec::Upload(id) => Source::Upload(id.clone()),
        ReferenceSpec::Job(id) => Source::Job(id.clone()),
    };
    pb::ReferenceSource {
        source: Some(source),
    }
}

fn reference_from_pb(r: pb::ReferenceSource) -> Result<ReferenceSpec, JobError> {
    use pb::reference_source::Source;
    match r.source {
        Some(Source::Upload(id)) => Ok(ReferenceSpec::Upload(id)),
        Some(Source::Job(id)) => Ok(ReferenceSpec::Job(id)),
        None => Err(bad("reference: set upload or job")),
    }
}

fn snapshot_every_to_pb(s: &SnapshotEvery) -> pb::SnapshotEvery {
    use pb::snapshot_every::Every;
    let every = match *s {
        SnapshotEvery::Iterations(n) => Every::Iterations(n),
        SnapshotEvery::Seconds(t) => Every::Seconds(t),
    };
    pb::SnapshotEvery { every: Some(every) }
}

fn snapshot_every_from_pb(s: pb::SnapshotEvery) -> SnapshotEvery {
    use pb::snapshot_every::Every;
    match s.every {
        Some(Every::Iterations(n)) => SnapshotEvery::Iterations(n),
        Some(Every::Seconds(t)) => SnapshotEvery::Seconds(t),
        None => SnapshotEvery::default(),
    }
}

fn spec_to_pb(s: &JobSpec) -> pb::JobSpec {
    pb::JobSpec {
        scene: s.scene.clone(),
        algorithm: s.algorithm.clone(),
        params_json: if s.params.is_empty() {
            String::new()
        } else {
            serde_json::Value::Object(s.params.clone()).to_string()
        },
        seed: s.seed,
        halt: Some(halt_to_pb(&s.halt)),
        reference: s.reference.as_ref().map(reference_to_pb),
        snapshot_every: Some(snapshot_every_to_pb(&s.snapshot_every)),
        priority: s.priority,
        name: s.name.clone(),
        tags: s.tags.clone(),
        sweep: s.sweep.clone(),
        keep_snapshots: match s.keep_snapshots {
            KeepSnapshots::Count(n) => Some(n),
            KeepSnapshots::All => None,
        },
        keep_all_snapshots: s.keep_snapshots == KeepSnapshots::All,
        keep_checkpoint: s.keep_checkpoint,
        variance_layer: s.variance_layer,
    }
}

pub(super) fn spec_from_pb(s: pb::JobSpec) -> Result<JobSpec, JobError> {
    let params = if s.params_json.trim().is_empty() {
        serde_json::Map::new()
    } else {
        serde_json::from_str(&s.params_json).map_err(|e| {
            let e = crate::json_numbers::name_out_of_range(&e.to_string(), &s.params_json);
            bad(format!("params_json must be a JSON object: {e}"))
        })?
    };
    Ok(JobSpec {
        scene: s.scene,
        algorithm: s.algorithm,
        params,
        seed: s.seed,
        halt: s.halt.map(halt_from_pb).unwrap_or_default(),
        reference: s.reference.map(reference_from_pb).transpose()?,
        snapshot_every: s
            .snapshot_every
            .map(snapshot_every_from_pb)
            .unwrap_or_default(),
        priority: s.priority,
        name: s.name,
        tags: s.tags,
        sweep: s.sweep,
        keep_snapshots: match (s.keep_all_snapshots, s.keep_snapshots) {
            (true, _) => KeepSnapshots::All,
            (false, Some(n)) => KeepSnapshots::Count(n),
            (false, None) => KeepSnapshots::DEFAULT,
        },
        keep_checkpoint: s.keep_checkpoint,
        variance_layer: s.variance_layer,
    })
}

pub(super) fn job_to_pb(j: JobStatus) -> pb::Job {
    pb::Job {
        spec: Some(spec_to_pb(&j.spec)),
        settings_json: j.settings.to_string(),
        state: state_to_pb(j.state) as i32,
        iteration: j.iteration,
        elapsed_s: j.elapsed_s,
        samples_per_s: j.samples_per_s,
        last_rmse: j.last_rmse,
        noise: j.noise,
        eta_s: j.eta_s,
        dropped: j.dropped,
        width: j.width,
        height: j.height,
        created_at: j.created_at,
        finished_at: j.finished_at,
        error: j.error,
        workers: j.workers,
        id: j.id,
    }
}

pub(super) fn sweep_to_pb(s: Sweep) -> pb::Sweep {
    let layers: Vec<String> = (0..s.jobs.len())
        .map(|i| s.layer(i).unwrap_or_default().to_string())
        .collect();
    pb::Sweep {
        spec_json: serde_json::to_string(&s.spec).expect("sweep spec serialises"),
        jobs: s
            .jobs
            .into_iter()
            .zip(layers)
            .map(|((point, job_id), layer)| pb::SweepJob {
                point_json: point.into_iter().map(|(k, v)| (k, v.to_string())).collect(),
                job_id,
                layer,
            })
            .collect(),
        id: s.id,
    }
}

pub(super) fn sweep_spec_from_json(text: &str) -> Result<SweepSpec, JobError> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let e = crate::json_numbers::name_out_of_range(&e.to_string(), text);
        bad(format!("spec_json: {e}"))
    })
}

fn event(e: pb::job_event::Event) -> pb::JobEvent {
    pb::JobEvent { event: Some(e) }
}

pub(super) fn state_event(s: JobState) -> pb::JobEvent {
    event(pb::job_event::Event::State(pb::StateChange {
        state: state_to_pb(s) as i32,
    }))
}

fn done_event(j: JobStatus) -> pb::JobEvent {
    event(pb::job_event::Event::Done(pb::Done {
        job: Some(job_to_pb(j)),
    }))
}

/// A domain event as a stream message; snapshot PNGs are attached by the caller.
pub(super) fn event_to_pb(e: Event) -> pb::JobEvent {
    use pb::job_event::Event as E;
    match e {
        Event::Progress {
            iteration,
            elapsed_s,
            samples_per_s,
            eta_s,
            dropped,
            ..
        } => event(E::Progress(pb::Progress {
            iteration,
            elapsed_s,
            samples_per_s,
            eta_s,
            dropped,
        })),
        Event::Snapshot {
            iteration,
            rmse,
            rel_mse,
            est_rmse,
            est_rel_mse,
            ..
        } => event(E::Snapshot(pb::Snapshot {
            iteration,
            rmse,
            rel_mse,
            est_rmse,
            est_rel_mse,
            png: Vec::new(),
        })),
        Event::State { state, .. } => state_event(state),
        Event::Done { status, .. } => done_event(*status),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn job_spec_round_trips_through_protobuf() {
        let spec: JobSpec = serde_json::from_value(serde_json::json!({
            "scene": "cornell-box",
            "algorithm": "pt",
            "params": {"max_depth": 8, "rr": true, "name": "x", "list": [1, 2.5]},
            "seed": 7,
            "halt": {"spp": 16, "time_s": 2.5},
            "reference": {"job": "j1"},
            "snapshot_every": {"iterations": 4},
            "priority": -3,
            "name": "test",
            "tags": ["a", "b"],
            "sweep": "s1"
        }))
        .unwrap();
        assert_eq!(spec_from_pb(spec_to_pb(&spec)).unwrap(), spec);
        let minimal: JobSpec =
            serde_json::from_value(serde_json::json!({"scene": "x", "halt": {"iterations": 1}}))
                .unwrap();
        assert_eq!(spec_from_pb(spec_to_pb(&minimal)).unwrap(), minimal);
    }

    #[test]
    fn states_round_trip_and_unspecified_is_no_filter() {
        for s in JobState::ALL {
            assert_eq!(state_from_pb(state_to_pb(s) as i32).unwrap(), Some(s));
        }
        assert_eq!(state_from_pb(0).unwrap(), None);
        assert!(state_from_pb(99).is_err());
    }

    #[test]
    fn params_must_be_a_json_object() {
        let mut p = spec_to_pb(
            &serde_json::from_value(serde_json::json!({"scene": "x", "halt": {"spp": 1}})).unwrap(),
        );
        p.params_json = "[1]".into();
        assert!(matches!(spec_from_pb(p), Err(JobError::BadRequest(_))));
    }
}
