//! `caustic worker`: pulls work units one at a time, renders them on its own thread
//! pool, returns each range's exact sums, and only then acknowledges (module notes in
//! `remote`).

use super::{
    ack_wait, connect, read_object, setup, Done, RemoteError, Unit, WorkerInfo, HEARTBEAT,
    MAX_DELIVERIES, WORKERS, WORKERS_BUCKET,
};
use crate::film::{ExactSums, Film};
use crate::integrator::RenderStats;
use crate::job::runtime::render_iterations;
use crate::job::scenes::SceneStore;
use crate::job::store::Checkpoint;
use crate::scene::{CompileBudget, Scene};
use async_nats::jetstream::consumer::{pull, AckPolicy, PullConsumer};
use async_nats::jetstream::object_store::ObjectStore;
use async_nats::jetstream::{AckKind, Context as Js, Message};
use futures::StreamExt;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What a worker is started with.
pub struct WorkerOptions {
    pub url: String,
    pub name: String,
    /// Render threads (0: one per core).
    pub threads: usize,
    /// Where fetched scenes are unpacked.
    pub cache_dir: PathBuf,
    /// Largest scene bundle accepted, in bytes.
    pub max_scene: u64,
    /// Most primitives a scene may compile to.
    pub max_primitives: usize,
}

/// Runs the worker until the process is stopped (or NATS refuses it).
pub fn run(opts: WorkerOptions) -> Result<(), RemoteError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .thread_name(|i| format!("render-{i}"))
        .build()
        .map_err(RemoteError::nats)?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(RemoteError::nats)?;
    rt.block_on(serve(opts, Arc::new(pool)))
}

/// Pull requests the shared consumer lets wait: idle workers at once.
const MAX_WAITING: i64 = 1 << 14;

/// The next unit, waiting up to 5 s for one (None: none came, or NATS failed, after
/// a pause of a second so that a failing NATS is not asked in a tight loop).
pub(super) async fn next_unit(consumer: &PullConsumer) -> Option<Message> {
    let batch = consumer
        .fetch()
        .max_messages(1)
        .expires(Duration::from_secs(5))
        .messages()
        .await;
    let failed = match batch {
        Ok(mut batch) => match batch.next().await {
            Some(Ok(msg)) => return Some(msg),
            Some(Err(e)) => e.to_string(),
            None => return None,
        },
        Err(e) => e.to_string(),
    };
    tracing::warn!("fetching a unit: {failed}");
    tokio::time::sleep(Duration::from_secs(1)).await;
    None
}

/// The workers' shared consumer of the units stream.
pub(super) async fn units_consumer(handles: &super::Handles) -> Result<PullConsumer, RemoteError> {
    handles
        .units
        .get_or_create_consumer(
            WORKERS,
            pull::Config {
                durable_name: Some(WORKERS.into()),
                ack_policy: AckPolicy::Explicit,
                ack_wait: ack_wait(),
                // Every idle worker waits with one pull request; NATS's default of 512
                // waiting requests would turn workers past the 512th away.
                max_waiting: MAX_WAITING,
                ..Default::default()
            },
        )
        .await
        .map_err(RemoteError::nats)
}

struct Worker {
    name: String,
    /// What the heartbeat task reports.
    info: Arc<Mutex<WorkerInfo>>,
    js: Js,
    /// The scenes and results object stores.
    buckets: (ObjectStore, ObjectStore),
    pool: Arc<rayon::ThreadPool>,
    store: SceneStore,
    scenes: HashMap<String, Arc<Scene>>,
}

async fn serve(opts: WorkerOptions, pool: Arc<rayon::ThreadPool>) -> Result<(), RemoteError> {
    let (_client, js) = connect(&opts.url, &opts.name).await?;
    let handles = setup(&js).await?;
    let consumer = units_consumer(&handles).await?;
    let budget = CompileBudget {
        max_primitives: opts.max_primitives,
        ..CompileBudget::SERVER
    };
    let store = SceneStore::new(&opts.cache_dir, opts.max_scene, pool.clone())
        .map_err(RemoteError::nats)?
        .with_budget(budget);
    tracing::info!(worker = %opts.name, threads = pool.current_num_threads(), "worker ready");
    let info = Arc::new(Mutex::new(WorkerInfo {
        name: opts.name.clone(),
        threads: pool.current_num_threads(),
        ..Default::default()
    }));
    tokio::spawn(heartbeat(js.clone(), info.clone()));
    let mut w = Worker {
        name: opts.name,
        info,
        js,
        buckets: (handles.scenes, handles.results),
        pool,
        store,
        scenes: HashMap::new(),
    };
    loop {
        while let Some(msg) = next_unit(&consumer).await {
            w.handle(msg).await;
        }
    }
}

impl Worker {
    async fn handle(&mut self, msg: Message) {
        let unit: Unit = match serde_json::from_slice(&msg.payload) {
            Ok(u) => u,
            Err(e) => {
                // Not ours to render, ever: terminate it rather than see it again.
                tracing::warn!("dropping a malformed unit: {e}");
                let _ = msg.ack_with(AckKind::Term).await;
                return;
            }
        };
        let delivered = msg.info().map(|i| i.delivered).unwrap_or(1);
        let outcome = if delivered > MAX_DELIVERIES {
            Outcome::Failed(format!(
                "iterations {}..{} were handed out {} times without a result (workers died rendering them)",
                unit.first,
                unit.end,
                delivered - 1
            ))
        } else {
            crate::job::failpoint::hit("unit", unit.first);
            self.render(&unit, Arc::new(msg.clone())).await
        };
        let done = match outcome {
            Outcome::Rendered(object, stats, seconds) => {
                self.done(&unit, Some(object), None, stats, seconds)
            }
            Outcome::Failed(e) => self.done(&unit, None, Some(e), RenderStats::default(), 0.0),
            Outcome::Transient(e) => {
                // Not acknowledged: the unit comes back after its ack wait, to this
                // worker or another, once NATS answers again.
                tracing::warn!("{}: {e}; the unit will come back", unit.object_name());
                return;
            }
        };
        match self.publish_done(&unit, &done).await {
            Ok(()) => {
                if let Err(e) = msg.double_ack().await {
                    tracing::warn!("acknowledging {}: {e}", unit.object_name());
                }
            }
            // Not acknowledged: the unit comes back after its ack wait.
            Err(e) => tracing::warn!("returning {}: {e}", unit.object_name()),
        }
    }

    fn done(
        &self,
        unit: &Unit,
        object: Option<String>,
        error: Option<String>,
        stats: RenderStats,
        seconds: f64,
    ) -> Done {
        Done {
            job: unit.job.clone(),
            generation: unit.generation,
            first: unit.first,
            end: unit.end,
            worker: self.name.clone(),
            object,
            error,
            stats,
            seconds,
        }
    }

    /// Renders the range, keeping the unit alive meanwhile, and stores its result:
    /// the range's exact sums, or for a chained unit the checkpoint after it.
    async fn render(&mut self, unit: &Unit, msg: Arc<Message>) -> Outcome {
        let scene = match self.scene(&unit.scene).await {
            Ok(s) => s,
            Err(e) => return e,
        };
        let from = match &unit.carry {
            None => None,
            Some(name) => match self.carried(name).await {
                Ok(c) => Some(c),
                Err(e) => return e,
            },
        };
        let alive = tokio::spawn(async move {
            loop {
                tokio::time::sleep(ack_wait() / 3).await;
                let _ = msg.ack_with(AckKind::Progress).await;
            }
        });
        self.info.lock().expect("info").current_job = Some(unit.job.clone());
        let (pool, u) = (self.pool.clone(), unit.clone());
        let rendered =
            tokio::task::spawn_blocking(move || pool.install(|| render_range(&scene, &u, from)))
                .await;
        self.info.lock().expect("info").current_job = None;
        let range = match rendered {
            Ok(Ok(r)) => r,
            Ok(Err(e)) => {
                alive.abort();
                return Outcome::Failed(e);
            }
            // A panic in the render core: a bug that this range will hit again.
            Err(e) => {
                alive.abort();
                return Outcome::Failed(format!("render task: {e}"));
            }
        };
        let name = unit.object_name();
        // Still kept alive: storing a large result on a busy NATS can outlast the
        // ack wait, and the unit must not go to another worker meanwhile.
        let stored = self
            .buckets
            .1
            .put(name.as_str(), &mut range.result.as_slice())
            .await;
        alive.abort();
        if let Err(e) = stored {
            return Outcome::Transient(format!("storing the result: {e}"));
        }
        let mut info = self.info.lock().expect("info");
        info.ranges_done += 1;
        info.iterations_done += unit.end - unit.first;
        Outcome::Rendered(name, range.stats, range.seconds)
    }

    /// The checkpoint a chained unit continues from.
    async fn carried(&self, name: &str) -> Result<Checkpoint, Outcome> {
        let bytes = read_object(&self.buckets.1, name)
            .await
            .map_err(|e| Outcome::Transient(format!("carried state {name}: {e}")))?;
        Checkpoint::decode(&bytes)
            .ok_or_else(|| Outcome::Failed(format!("carried state {name} is damaged")))
    }

    async fn publish_done(&self, unit: &Unit, done: &Done) -> Result<(), String> {
        let body = serde_json::to_vec(done).map_err(|e| e.to_string())?;
        self.js
            .publish(format!("caustic.done.{}", unit.job), body.into())
            .await
            .map_err(|e| e.to_string())?
            .await
            .map_err(|e| e.to_string())?;
        Ok(())
    }

    /// The compiled scene of content id `id`, cached.
    async fn scene(&mut self, id: &str) -> Result<Arc<Scene>, Outcome> {
        if let Some(s) = self.scenes.get(id) {
            return Ok(s.clone());
        }
        let scene = compiled_scene(&self.store, &self.buckets.0, id).await?;
        self.scenes.insert(id.to_string(), scene.clone());
        Ok(scene)
    }
}

/// The compiled scene of content id `id`: built in, kept in `store`, or fetched from
/// the `scenes` bucket. A scene that does not validate fails the job; one that cannot
/// be fetched now is tried again when the unit comes back.
pub(super) async fn compiled_scene(
    store: &SceneStore,
    scenes: &ObjectStore,
    id: &str,
) -> Result<Arc<Scene>, Outcome> {
    let local = if store.exists(id) {
        id.to_string()
    } else {
        let bytes = read_object(scenes, id)
            .await
            .map_err(|e| Outcome::Transient(format!("scene {id}: {e}")))?;
        store
            .upload(&bytes)
            .map_err(|e| Outcome::Failed(e.client_message()))?
    };
    store
        .compiled(&local)
        .map_err(|e| Outcome::Failed(e.client_message()))
}

/// What became of a unit.
pub(super) enum Outcome {
    /// Rendered; its sums are stored under this name.
    Rendered(String, RenderStats, f64),
    /// It cannot be rendered (its job fails with this).
    Failed(String),
    /// NATS did not answer: left unacknowledged, to come back.
    Transient(String),
}

/// Reports `info` every [`HEARTBEAT`] under the worker's name (it expires when the
/// worker stops reporting).
pub(super) async fn heartbeat(js: Js, info: Arc<Mutex<WorkerInfo>>) {
    let kv = match js.get_key_value(WORKERS_BUCKET).await {
        Ok(kv) => kv,
        Err(e) => return tracing::warn!("no heartbeat bucket: {e}"),
    };
    loop {
        let (key, body) = {
            let mut i = info.lock().expect("info");
            i.last_heartbeat = crate::job::spec::unix_now();
            (key_of(&i.name), serde_json::to_vec(&*i).unwrap_or_default())
        };
        if let Err(e) = kv.put(key, body.into()).await {
            tracing::warn!("heartbeat: {e}");
        }
        tokio::time::sleep(HEARTBEAT).await;
    }
}

/// A key-value key for a worker name (keys allow letters, digits and `-_=.`).
fn key_of(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_=".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A rendered range: what goes back to the coordinator.
pub struct Range {
    /// The range's exact sums, encoded; for a chained unit, the checkpoint after it.
    pub result: Vec<u8>,
    pub stats: RenderStats,
    pub seconds: f64,
}

/// Iterations `unit.first..unit.end`, in order: from fresh state, or for a chained
/// unit from the checkpoint `from` it carried.
pub fn render_range(scene: &Scene, unit: &Unit, from: Option<Checkpoint>) -> Result<Range, String> {
    let integrator = unit.settings.build();
    let (w, h) = (scene.width(), scene.height());
    let mut scratch = Film::new(w, h);
    if let Some(c) = &from {
        if c.film.width() != w || c.film.height() != h {
            return Err(format!(
                "carried state is {}x{}, the scene {w}x{h}",
                c.film.width(),
                c.film.height()
            ));
        }
        if let Some(state) = &c.state {
            integrator
                .load_state(state)
                .map_err(|e| format!("carried state: {e}"))?;
        }
        scratch = c.film.clone();
    }
    let mut sums = ExactSums::new(w, h);
    let start = Instant::now();
    let stats = render_iterations(
        scene,
        integrator.as_ref(),
        unit.seed,
        unit.first..unit.end,
        &mut scratch,
        &mut sums,
    );
    let seconds = start.elapsed().as_secs_f64();
    let result = match from {
        // A third of the plain encoding's bytes at 1080p (`film::exact::packed`).
        None => sums.encode_packed(),
        Some(_) => Checkpoint {
            iteration: unit.end,
            elapsed_s: 0.0,
            samples: 0,
            film: scratch,
            state: integrator.save_state(),
            exact: Some(sums),
        }
        .encode(),
    };
    Ok(Range {
        result,
        stats,
        seconds,
    })
}
