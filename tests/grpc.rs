//! The gRPC front end end to end: a real server on 127.0.0.1:0 over a temp data
//! directory, driven by the generated client.

use caustic::job::{Service, ServiceConfig};
use caustic::server::grpc::{grpc_server, pb};
use pb::caustic_client::CausticClient;
use std::sync::Arc;
use tokio_stream::wrappers::TcpListenerStream;
use tonic::transport::Channel;
use tonic::{Code, Request};

/// A 16x16 diffuse sphere under a point light.
const SPHERE: &str = r#"{
  "format": 1,
  "camera": {"look_at": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]}, "fov": 40},
  "film": {"width": 16, "height": 16},
  "materials": {"grey": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
  "shapes": [{"type": "sphere", "radius": 1, "material": "grey"}],
  "lights": [{"type": "point", "position": [0, 3, 3], "intensity": [10, 10, 10]}]
}"#;

/// A running server; dropping it stops the scheduler (the data directory goes too).
struct TestServer {
    addr: std::net::SocketAddr,
    svc: Arc<Service>,
    _dir: tempfile::TempDir,
}

impl Drop for TestServer {
    fn drop(&mut self) {
        self.svc.shutdown();
    }
}

impl TestServer {
    async fn start(token: Option<&str>) -> TestServer {
        let dir = tempfile::tempdir().unwrap();
        let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let grpc = grpc_server(svc.clone(), token.map(String::from));
        tokio::spawn(async move {
            tonic::transport::Server::builder()
                .add_service(grpc)
                .serve_with_incoming(TcpListenerStream::new(listener))
                .await
                .unwrap();
        });
        TestServer {
            addr,
            svc,
            _dir: dir,
        }
    }

    async fn client(&self) -> CausticClient<Channel> {
        CausticClient::connect(format!("http://{}", self.addr))
            .await
            .unwrap()
            .max_decoding_message_size(64 << 20)
    }
}

fn spec(scene: &str, spp: u64) -> pb::JobSpec {
    pb::JobSpec {
        scene: scene.into(),
        halt: Some(pb::Halt {
            spp: Some(spp),
            ..Default::default()
        }),
        snapshot_every: Some(pb::SnapshotEvery {
            every: Some(pb::snapshot_every::Every::Iterations(2)),
        }),
        ..Default::default()
    }
}

async fn upload(c: &mut CausticClient<Channel>, scene: &str) -> pb::Scene {
    let req = pb::UploadSceneRequest {
        data: scene.as_bytes().to_vec(),
    };
    c.upload_scene(req).await.unwrap().into_inner()
}

async fn submit(c: &mut CausticClient<Channel>, spec: pb::JobSpec) -> pb::Job {
    c.submit_job(pb::SubmitJobRequest { spec: Some(spec) })
        .await
        .unwrap()
        .into_inner()
}

/// Every event of a job's WatchJob stream, until the stream ends.
async fn watch_all(
    c: &mut CausticClient<Channel>,
    id: &str,
    include_snapshots: bool,
) -> Vec<pb::job_event::Event> {
    drain(open_watch(c, id, include_snapshots).await).await
}

async fn open_watch(
    c: &mut CausticClient<Channel>,
    id: &str,
    include_snapshots: bool,
) -> tonic::Streaming<pb::JobEvent> {
    let req = pb::WatchJobRequest {
        id: id.into(),
        include_snapshots,
    };
    c.watch_job(req).await.unwrap().into_inner()
}

/// Every event until the stream ends.
async fn drain(mut stream: tonic::Streaming<pb::JobEvent>) -> Vec<pb::job_event::Event> {
    let mut out = Vec::new();
    let watching = async {
        while let Some(e) = stream.message().await.unwrap() {
            out.push(e.event.expect("event set"));
        }
    };
    tokio::time::timeout(std::time::Duration::from_secs(120), watching)
        .await
        .expect("job finishes within two minutes");
    out
}

/// The events in short, for failure messages (PNG bytes left out).
fn kinds(events: &[pb::job_event::Event]) -> String {
    use pb::job_event::Event as E;
    let short: Vec<String> = events
        .iter()
        .map(|e| match e {
            E::Progress(p) => format!("progress {}", p.iteration),
            E::Snapshot(s) => format!("snapshot {} ({} png bytes)", s.iteration, s.png.len()),
            E::State(s) => format!("state {:?}", s.state()),
            E::Done(d) => format!("done {:?}", d.job.as_ref().map(|j| j.state())),
        })
        .collect();
    short.join(", ")
}

fn done_job(events: &[pb::job_event::Event]) -> &pb::Job {
    match events.last() {
        Some(pb::job_event::Event::Done(d)) => d.job.as_ref().unwrap(),
        _ => panic!("stream must end with done: {}", kinds(events)),
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn scenes_upload_idempotently_and_list_builtins() {
    let server = TestServer::start(None).await;
    let mut c = server.client().await;
    let a = upload(&mut c, SPHERE).await;
    let b = upload(&mut c, SPHERE).await;
    assert_eq!(a.id, b.id, "same bytes, same id");
    assert_eq!(
        (a.width, a.height, a.shapes, a.lights, a.builtin),
        (16, 16, 1, 1, false)
    );
    let list = c
        .list_scenes(pb::ListScenesRequest {})
        .await
        .unwrap()
        .into_inner()
        .scenes;
    assert!(list.iter().any(|s| s.id == "cornell-box" && s.builtin));
    assert!(list.iter().any(|s| s.id == a.id));
    let got = c
        .get_scene(pb::GetSceneRequest { id: a.id.clone() })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(got, a);

    let invalid = pb::UploadSceneRequest {
        data: br#"{"format": 1}"#.to_vec(),
    };
    let err = c.upload_scene(invalid).await.unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");

    c.delete_scene(pb::DeleteSceneRequest { id: a.id.clone() })
        .await
        .unwrap();
    let err = c
        .get_scene(pb::GetSceneRequest { id: a.id })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::NotFound);
    let err = c
        .delete_scene(pb::DeleteSceneRequest {
            id: "cornell-box".into(),
        })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::FailedPrecondition);
}

#[tokio::test(flavor = "multi_thread")]
async fn watch_streams_a_job_in_order_until_done() {
    let server = TestServer::start(None).await;
    let mut c = server.client().await;
    let scene = upload(&mut c, SPHERE).await;
    // A long job of high priority holds the scheduler, so the watched job is still
    // queued when the stream opens and every one of its events is seen.
    let mut blocker = spec(&scene.id, 1_000_000);
    blocker.priority = 1000;
    let blocker = submit(&mut c, blocker).await;
    let mut s = spec(&scene.id, 4);
    s.tags = vec!["watched".into()];
    let job = submit(&mut c, s).await;
    assert_eq!(job.state(), pb::JobState::Queued);
    assert_eq!((job.width, job.height), (16, 16));
    assert!(
        job.settings_json.contains("\"algorithm\""),
        "{}",
        job.settings_json
    );

    let stream = open_watch(&mut c, &job.id, true).await;
    let req = pb::CancelJobRequest { id: blocker.id };
    c.cancel_job(req).await.unwrap();
    let events = drain(stream).await;
    use pb::job_event::Event as E;
    let states: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            E::State(s) => Some(s.state()),
            _ => None,
        })
        .collect();
    assert!(
        matches!(events.first(), Some(E::State(_))),
        "first event is the state: {}",
        kinds(&events)
    );
    use pb::JobState::{Completed, Queued, Running};
    assert_eq!(states, [Queued, Running, Completed], "{}", kinds(&events));
    let running = events
        .iter()
        .position(|e| matches!(e, E::State(s) if s.state() == Running));
    let progress = events.iter().position(|e| matches!(e, E::Progress(_)));
    assert!(
        running < progress,
        "running before the first progress: {}",
        kinds(&events)
    );
    let mut last_iteration = 0;
    let mut snapshots = Vec::new();
    for e in &events {
        let it = match e {
            E::Progress(p) => p.iteration,
            E::Snapshot(s) => {
                assert!(
                    s.png.starts_with(b"\x89PNG"),
                    "snapshot {} carries its PNG",
                    s.iteration
                );
                snapshots.push(s.iteration);
                s.iteration
            }
            _ => last_iteration,
        };
        assert!(
            it >= last_iteration,
            "iterations go forward: {}",
            kinds(&events)
        );
        last_iteration = it;
    }
    assert_eq!(snapshots, [2, 4]);
    let done = done_job(&events);
    assert_eq!(done.state(), pb::JobState::Completed);
    assert_eq!(done.iteration, 4);
    assert_eq!(done.dropped, 0);
    assert!(done.finished_at.is_some());

    // A finished job's stream is its state, then done at once.
    let again = watch_all(&mut c, &job.id, false).await;
    assert_eq!(again.len(), 2, "{}", kinds(&again));
    assert!(matches!(&again[0], E::State(s) if s.state() == pb::JobState::Completed));
    assert_eq!(done_job(&again).iteration, 4);

    let req = pb::ListJobsRequest {
        tag: Some("watched".into()),
        ..Default::default()
    };
    let listed = c.list_jobs(req).await.unwrap().into_inner().jobs;
    assert_eq!(
        listed.iter().map(|j| j.id.as_str()).collect::<Vec<_>>(),
        [job.id.as_str()]
    );
    let req = pb::ListJobsRequest {
        state: Some(pb::JobState::Running as i32),
        ..Default::default()
    };
    assert!(c.list_jobs(req).await.unwrap().into_inner().jobs.is_empty());

    // Cancelling a completed job conflicts with its state.
    let err = c
        .cancel_job(pb::CancelJobRequest { id: job.id.clone() })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::FailedPrecondition, "{err:?}");

    c.delete_job(pb::DeleteJobRequest { id: job.id.clone() })
        .await
        .unwrap();
    let err = c
        .get_job(pb::GetJobRequest { id: job.id })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::NotFound);
}

#[tokio::test(flavor = "multi_thread")]
async fn errors_map_to_status_codes() {
    let server = TestServer::start(None).await;
    let mut c = server.client().await;

    let mut s = spec("cornell-box", 1);
    s.algorithm = Some("vcmm".into());
    let err = c
        .submit_job(pb::SubmitJobRequest { spec: Some(s) })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument);
    assert!(err.message().contains("vcmm"), "{}", err.message());

    let mut s = spec("cornell-box", 1);
    s.params_json = "not json".into();
    let err = c
        .submit_job(pb::SubmitJobRequest { spec: Some(s) })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument);
    assert!(err.message().contains("params_json"), "{}", err.message());

    let err = c
        .submit_job(pb::SubmitJobRequest {
            spec: Some(spec("nope", 1)),
        })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::NotFound);

    for id in ["j0000000000000000000000", "../etc", ""] {
        let err = c
            .get_job(pb::GetJobRequest { id: id.into() })
            .await
            .unwrap_err();
        assert_eq!(err.code(), Code::NotFound, "{id}: {err:?}");
        let err = c
            .watch_job(pb::WatchJobRequest {
                id: id.into(),
                include_snapshots: false,
            })
            .await
            .unwrap_err();
        assert_eq!(err.code(), Code::NotFound, "{id}: {err:?}");
    }

    let err = c
        .create_sweep(pb::CreateSweepRequest {
            spec_json: r#"{"base": {"scene": "cornell-box", "halt": {"spp": 1}}, "grid": {}}"#
                .into(),
        })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");

    let too_big = pb::UploadSceneRequest {
        data: vec![b' '; (server.svc.config().max_upload + 1) as usize],
    };
    let err = c.upload_scene(too_big).await.unwrap_err();
    assert_eq!(err.code(), Code::ResourceExhausted, "{err:?}");
    // Far above the limit, the message is refused before the service sees it: the
    // code is still the documented one.
    let far_too_big = pb::UploadSceneRequest {
        data: vec![b' '; (server.svc.config().max_upload + (1 << 20)) as usize],
    };
    let err = c.upload_scene(far_too_big).await.unwrap_err();
    assert_eq!(err.code(), Code::ResourceExhausted, "{err:?}");
}

#[tokio::test(flavor = "multi_thread")]
async fn sweeps_create_one_job_per_grid_point() {
    let server = TestServer::start(None).await;
    let mut c = server.client().await;
    let scene = upload(&mut c, SPHERE).await;
    let spec_json = serde_json::json!({
        "base": {"scene": scene.id, "halt": {"spp": 1}},
        "grid": {"seed": [1, 2], "params.max_depth": [2, 3]}
    })
    .to_string();
    let sweep = c
        .create_sweep(pb::CreateSweepRequest { spec_json })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(sweep.jobs.len(), 4);
    assert!(sweep
        .jobs
        .iter()
        .all(|j| j.point_json.len() == 2 && j.point_json["seed"].parse::<u64>().is_ok()));
    let got = c
        .get_sweep(pb::GetSweepRequest {
            id: sweep.id.clone(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(got, sweep);
    let req = pb::ListJobsRequest {
        sweep: Some(sweep.id.clone()),
        ..Default::default()
    };
    let jobs = c.list_jobs(req).await.unwrap().into_inner().jobs;
    assert_eq!(jobs.len(), 4);
    assert!(jobs
        .iter()
        .all(|j| j.spec.as_ref().unwrap().sweep.as_deref() == Some(sweep.id.as_str())));
    for j in &sweep.jobs {
        let events = watch_all(&mut c, &j.job_id, false).await;
        assert_eq!(done_job(&events).state(), pb::JobState::Completed);
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn pause_and_resume_keep_the_job() {
    let server = TestServer::start(None).await;
    let mut c = server.client().await;
    let scene = upload(&mut c, SPHERE).await;
    let mut s = spec(&scene.id, 1_000_000);
    s.snapshot_every = None;
    let job = submit(&mut c, s).await;
    let paused = c
        .pause_job(pb::PauseJobRequest { id: job.id.clone() })
        .await
        .unwrap()
        .into_inner();
    // A job the scheduler has picked up pauses after its batch (the reply still shows
    // its previous state); wait for it.
    let mut state = paused.state();
    for _ in 0..200 {
        if state == pb::JobState::Paused {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
        state = c
            .get_job(pb::GetJobRequest { id: job.id.clone() })
            .await
            .unwrap()
            .into_inner()
            .state();
    }
    assert_eq!(state, pb::JobState::Paused);
    let resumed = c
        .resume_job(pb::ResumeJobRequest { id: job.id.clone() })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(resumed.state(), pb::JobState::Queued);
    let err = c
        .resume_job(pb::ResumeJobRequest { id: job.id.clone() })
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::FailedPrecondition);
    c.cancel_job(pb::CancelJobRequest { id: job.id.clone() })
        .await
        .unwrap();
    let events = watch_all(&mut c, &job.id, false).await;
    assert_eq!(done_job(&events).state(), pb::JobState::Cancelled);
}

#[tokio::test(flavor = "multi_thread")]
async fn bearer_token_guards_every_call() {
    let server = TestServer::start(Some("s3cret")).await;
    let mut c = server.client().await;
    let err = c.list_scenes(pb::ListScenesRequest {}).await.unwrap_err();
    assert_eq!(err.code(), Code::Unauthenticated);

    let with = |token: &str| {
        let mut req = Request::new(pb::ListScenesRequest {});
        req.metadata_mut()
            .insert("authorization", format!("Bearer {token}").parse().unwrap());
        req
    };
    let err = c.list_scenes(with("wrong")).await.unwrap_err();
    assert_eq!(err.code(), Code::Unauthenticated);
    let scenes = c
        .list_scenes(with("s3cret"))
        .await
        .unwrap()
        .into_inner()
        .scenes;
    assert!(scenes.iter().any(|s| s.id == "cornell-box"));
}

#[tokio::test(flavor = "multi_thread")]
async fn serve_stops_on_shutdown() {
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(caustic::server::grpc::serve(
        listener,
        svc.clone(),
        None,
        async {
            let _ = stopped.await;
        },
    ));
    let mut c = CausticClient::connect(format!("http://{addr}"))
        .await
        .unwrap();
    c.list_scenes(pb::ListScenesRequest {}).await.unwrap();
    drop(c);
    stop.send(()).unwrap();
    tokio::time::timeout(std::time::Duration::from_secs(10), server)
        .await
        .expect("server stops")
        .unwrap()
        .unwrap();
    svc.shutdown();
}
