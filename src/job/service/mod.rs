//! The transport-neutral service: every operation the REST and gRPC front ends offer,
//! as plain methods that validate, act and return domain values or [`JobError`]s.

mod metrics;
mod outputs;
mod recover;
mod retry;
mod sweeps;

use super::context::{Context, Metrics};
use super::disk::{self, Retention};
use super::events::Event;
use super::limits;
use super::lock::DirLock;
use super::run;
use super::scenes::{SceneInfo, SceneStore};
use super::scheduler::{self, Control, Entry, Shared, Table};
use super::spec::{unix_now, JobSpec, JobState, JobStatus, ReferenceSpec};
use super::store::JobDir;
use super::transition::{self, To};
use super::JobError;
use crate::integrator::Settings;
use crate::job::remote::coordinator::NatsExecutor;
use crate::scene::CompileBudget;
use recover::recover;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Condvar, Mutex};

/// Server limits and paths; `for_tests()` gives a temp-friendly small configuration.
#[derive(Clone, Debug)]
pub struct ServiceConfig {
    pub data_dir: PathBuf,
    /// Worker threads for rendering (0 = all cores).
    pub workers: usize,
    /// Largest accepted upload (scene bundle or reference EXR), bytes.
    pub max_upload: u64,
    /// Most primitives a scene may compile to ([`CompileBudget`]).
    pub max_primitives: usize,
    /// Largest image side a job may render.
    pub max_resolution: u32,
    /// Jobs whose render state is held in memory at once (the others wait queued,
    /// their checkpoints on disk).
    pub max_active_jobs: usize,
    /// Largest estimated peak memory of one job, bytes (`job::memory`).
    pub max_job: u64,
    /// How long finished jobs are kept.
    pub retention: Retention,
    /// Longest pause while a request body arrives, and longest wait for a request's
    /// headers on an open connection (idle ones included) before it is closed.
    pub body_timeout: std::time::Duration,
    pub header_timeout: std::time::Duration,
    /// A NATS server whose pool of `caustic worker`s renders the iterations (None:
    /// this process renders them).
    pub nats: Option<String>,
}

impl ServiceConfig {
    pub fn new(data_dir: impl Into<PathBuf>) -> Self {
        ServiceConfig {
            data_dir: data_dir.into(),
            workers: 0,
            max_upload: 256 << 20,
            max_primitives: CompileBudget::SERVER.max_primitives,
            max_resolution: 8192,
            max_active_jobs: 4,
            max_job: super::memory::default_budget(4),
            retention: Retention::default(),
            body_timeout: std::time::Duration::from_secs(30),
            header_timeout: std::time::Duration::from_secs(30),
            nats: None,
        }
    }

    pub fn for_tests(data_dir: &Path) -> Self {
        ServiceConfig {
            workers: 2,
            max_upload: 8 << 20,
            max_resolution: 1024,
            max_job: 1 << 30,
            ..ServiceConfig::new(data_dir)
        }
    }
}

/// Which jobs `list_jobs` returns.
#[derive(Clone, Debug, Default, serde::Deserialize)]
pub struct JobFilter {
    pub state: Option<JobState>,
    pub tag: Option<String>,
    pub sweep: Option<String>,
}

pub struct Service {
    shared: Arc<Shared>,
    config: ServiceConfig,
    scheduler: Mutex<Option<std::thread::JoinHandle<()>>>,
    ids: std::sync::atomic::AtomicU64,
    /// Becomes true when the server begins to stop: event streams end on it.
    closing: tokio::sync::watch::Sender<bool>,
    /// The data directory's lock, released by [`Service::shutdown`].
    dir_lock: Mutex<Option<DirLock>>,
}

/// How long a pause or cancel of a running job waits for its batch to end.
const TRANSITION_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

fn bad(m: impl Into<String>) -> JobError {
    JobError::BadRequest(m.into())
}

impl Service {
    /// Opens the data directory, recovers every job in it, and starts the scheduler.
    pub fn start(config: ServiceConfig) -> Result<Arc<Service>, JobError> {
        let dir = &config.data_dir;
        std::fs::create_dir_all(dir).map_err(|e| JobError::io(dir, e))?;
        // Before anything reads or tidies the directory: a second server must not
        // remove the first one's half-written files or resume its jobs.
        let lock = DirLock::acquire(dir, "caustic serve")
            .map_err(|e| JobError::Conflict(e.to_string()))?;
        for sub in ["jobs", "references", "sweeps"] {
            std::fs::create_dir_all(dir.join(sub)).map_err(|e| JobError::io(dir, e))?;
        }
        // One pool for everything the server computes: renders and scene compiles.
        let mut pool = rayon::ThreadPoolBuilder::new().thread_name(|i| format!("render-{i}"));
        if config.workers > 0 {
            pool = pool.num_threads(config.workers);
        }
        let pool = Arc::new(
            pool.build()
                .map_err(|e| JobError::Internal(e.to_string()))?,
        );
        // A scene's textures may take what one job may take, at most the server's
        // default: a scene is compiled for its jobs, so no larger one could render.
        let budget = CompileBudget {
            max_primitives: config.max_primitives,
            max_texture_bytes: CompileBudget::SERVER
                .max_texture_bytes
                .min(usize::try_from(config.max_job).unwrap_or(usize::MAX)),
        };
        let scenes = SceneStore::new(dir, config.max_upload, pool.clone())?.with_budget(budget);
        let scenes = Arc::new(scenes);
        let remote = match &config.nats {
            Some(url) => Some(Arc::new(
                NatsExecutor::connect(url, lock.pool_holder())
                    .map_err(|e| JobError::Internal(e.to_string()))?,
            )),
            None => None,
        };
        let leftovers = disk::clean_leftovers(dir);
        if leftovers > 0 {
            tracing::info!(
                files = leftovers,
                "removed half-written files of an earlier run"
            );
        }
        let (events, _) = tokio::sync::broadcast::channel(1024);
        let shared = Arc::new(Shared {
            ctx: Context {
                events,
                scenes,
                data_dir: dir.clone(),
                metrics: Metrics::default(),
                remote,
                max_job: config.max_job,
            },
            table: Mutex::new(recover(dir)),
            wake: Condvar::new(),
            shutdown: Default::default(),
            max_active: config.max_active_jobs.max(1),
            retention: config.retention,
            stepped: Condvar::new(),
        });
        let s = shared.clone();
        let handle = std::thread::Builder::new()
            .name("scheduler".into())
            .spawn(move || scheduler::run(s, pool))
            .map_err(|e| JobError::Internal(e.to_string()))?;
        Ok(Arc::new(Service {
            shared,
            config,
            scheduler: Mutex::new(Some(handle)),
            ids: Default::default(),
            closing: tokio::sync::watch::channel(false).0,
            dir_lock: Mutex::new(Some(lock)),
        }))
    }

    /// Says in the data directory's lock file where this server can be reached, for
    /// the message a second server on the same directory prints.
    pub fn announce(&self, what: &str) {
        if let Some(lock) = self.dir_lock.lock().expect("dir lock").as_ref() {
            lock.announce(what);
        }
    }

    /// Tells event streams that the server is stopping, so that they end (with a last
    /// event) and the front ends can close their connections.
    pub fn begin_shutdown(&self) {
        self.closing.send_replace(true);
    }

    /// Stops the scheduler after its current batch, writes a checkpoint for every job
    /// held in memory and any job.json still unwritten; jobs resume on the next start.
    pub fn shutdown(&self) {
        self.begin_shutdown();
        self.shared.shutdown.store(true, Ordering::Relaxed);
        self.shared.wake.notify_all();
        if let Some(h) = self.scheduler.lock().expect("scheduler").take() {
            let _ = h.join();
            scheduler::checkpoint_all(&self.shared);
            scheduler::retry_unsaved(&self.shared);
            if let Some(remote) = &self.shared.ctx.remote {
                remote.release();
            }
        }
        self.dir_lock.lock().expect("dir lock").take();
    }

    pub fn config(&self) -> &ServiceConfig {
        &self.config
    }

    pub fn subscribe(&self) -> tokio::sync::broadcast::Receiver<Event> {
        self.shared.ctx.events.subscribe()
    }

    pub(super) fn shared(&self) -> &Arc<Shared> {
        &self.shared
    }

    /// Turns true when [`Service::begin_shutdown`] is called.
    pub(super) fn closing(&self) -> tokio::sync::watch::Receiver<bool> {
        self.closing.subscribe()
    }

    // ---- scenes -------------------------------------------------------------

    pub fn upload_scene(&self, bytes: &[u8]) -> Result<SceneInfo, JobError> {
        let id = self.shared.ctx.scenes.upload(bytes)?;
        self.shared.ctx.scenes.info(&id)
    }

    pub fn list_scenes(&self) -> Vec<SceneInfo> {
        self.shared.ctx.scenes.list()
    }

    pub fn get_scene(&self, id: &str) -> Result<SceneInfo, JobError> {
        self.shared.ctx.scenes.info(id)
    }

    pub fn delete_scene(&self, id: &str) -> Result<(), JobError> {
        let t = self.shared.table.lock().expect("job table");
        if let Some((jid, _)) = t
            .jobs
            .iter()
            .find(|(_, e)| e.status.spec.scene == id && !e.status.state.is_terminal())
        {
            return Err(JobError::Conflict(format!(
                "scene {id} is used by job {jid}"
            )));
        }
        self.shared.ctx.scenes.delete(id)
    }

    pub fn upload_reference(&self, bytes: &[u8]) -> Result<String, JobError> {
        if bytes.len() as u64 > self.config.max_upload {
            return Err(JobError::TooLarge(
                "reference exceeds the upload size limit".into(),
            ));
        }
        if let Some(why) = crate::film::not_exr(bytes) {
            return Err(bad(format!("reference: the upload is {why}")));
        }
        crate::film::decode_exr(bytes).map_err(|e| bad(format!("reference: {}", e)))?;
        use sha2::Digest;
        let id: String = sha2::Sha256::digest(bytes)[..8]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        let path = run::reference_path(&self.config.data_dir, &id)?;
        crate::film::write_bytes_atomic(&path, bytes)?;
        Ok(id)
    }

    // ---- jobs ---------------------------------------------------------------

    fn new_id(&self) -> String {
        // Time-ordered, so listing by id lists by creation.
        let n = self.ids.fetch_add(1, Ordering::Relaxed);
        let ms = (unix_now() * 1e3) as u64;
        format!(
            "j{ms:013x}{:04x}{}",
            n & 0xffff,
            &uuid::Uuid::new_v4().simple().to_string()[..6]
        )
    }

    /// Validates a client's spec and queues the job.
    pub fn submit(&self, spec: JobSpec) -> Result<JobStatus, JobError> {
        if spec.sweep.is_some() {
            return Err(bad(
                "sweep is set by the server for the jobs of a sweep (POST /v1/sweeps)",
            ));
        }
        let (status, settings) = self.prepare(spec)?;
        self.queue(status, settings)
    }

    /// Stores a prepared job and queues it.
    fn queue(&self, status: JobStatus, settings: Settings) -> Result<JobStatus, JobError> {
        self.store_new(&status)?;
        self.enqueue(vec![(status.clone(), settings)]);
        Ok(status)
    }

    /// Writes a new job's directory. A job that cannot be stored leaves nothing on
    /// disk.
    fn store_new(&self, status: &JobStatus) -> Result<(), JobError> {
        let dir = self.job_dir_of(&status.id);
        let r = dir.create().and_then(|()| dir.write_status(status));
        if r.is_err() {
            let _ = std::fs::remove_dir_all(&dir.root);
        }
        r
    }

    /// Puts stored jobs in the table, all at once, and wakes the scheduler.
    fn enqueue(&self, jobs: Vec<(JobStatus, Settings)>) {
        let mut t = self.shared.table.lock().expect("job table");
        let tick = t.tick;
        // Said before the scheduler can start them, so `queued` comes before `running`.
        for (status, settings) in jobs {
            transition::announce(&self.shared.ctx, &status);
            t.jobs
                .insert(status.id.clone(), Entry::new(status, Ok(settings), tick));
        }
        drop(t);
        self.shared.wake.notify_all();
    }

    /// A validated job, with the settings it runs with: typed for the scheduler, and
    /// as JSON in the status that clients and job.json see.
    fn prepare(&self, spec: JobSpec) -> Result<(JobStatus, Settings), JobError> {
        limits::check_spec(&spec)?;
        let scenes = &self.shared.ctx.scenes;
        if !scenes.exists(&spec.scene) {
            return Err(JobError::NotFound(format!("scene {}", spec.scene)));
        }
        let scene = scenes.compiled(&spec.scene)?;
        let max = self.config.max_resolution;
        if scene.width() > max || scene.height() > max {
            return Err(bad(format!(
                "scene renders {}x{}, above this server's limit of {max} per side",
                scene.width(),
                scene.height()
            )));
        }
        if let Some(ReferenceSpec::Job(j)) = &spec.reference {
            let done = self.get_job(j)?.state == JobState::Completed;
            if !done {
                return Err(JobError::Conflict(format!(
                    "reference job {j} has not completed"
                )));
            }
        }
        run::load_reference(&self.shared.ctx, &spec, &scene)?;
        let settings = Settings::for_scene(spec.algorithm.as_deref(), &scene, &spec.params)?;
        if spec.halt.noise.is_some() && settings.build().chained() {
            return Err(bad(format!(
                "halt.noise: {} carries its statistics from one iteration to the next, so \
                 its noise cannot be estimated from its iterations; use a time or \
                 iteration limit",
                settings.parts().0
            ))
            .at_field(Some("halt.noise")));
        }
        super::memory::check(&settings, &scene, &spec, self.config.max_job)?;
        let status = JobStatus {
            id: self.new_id(),
            settings: crate::json_numbers::to_value(&settings).expect("settings serialise"),
            state: JobState::Queued,
            iteration: 0,
            elapsed_s: 0.0,
            samples_per_s: 0.0,
            last_rmse: None,
            noise: None,
            eta_s: None,
            dropped: 0,
            width: scene.width(),
            height: scene.height(),
            created_at: unix_now(),
            finished_at: None,
            error: None,
            workers: None,
            spec,
        };
        Ok((status, settings))
    }

    pub fn get_job(&self, id: &str) -> Result<JobStatus, JobError> {
        let t = self.shared.table.lock().expect("job table");
        t.jobs
            .get(id)
            .map(|e| e.status.clone())
            .ok_or_else(|| JobError::NotFound(format!("job {id}")))
    }

    pub fn list_jobs(&self, f: &JobFilter) -> Vec<JobStatus> {
        let t = self.shared.table.lock().expect("job table");
        t.jobs
            .values()
            .map(|e| &e.status)
            .filter(|s| f.state.is_none_or(|st| s.state == st))
            .filter(|s| f.tag.as_ref().is_none_or(|tag| s.spec.tags.contains(tag)))
            .filter(|s| {
                f.sweep
                    .as_ref()
                    .is_none_or(|w| s.spec.sweep.as_ref() == Some(w))
            })
            .cloned()
            .collect()
    }

    /// Applies pause or cancel: at once for idle jobs; for the job rendering right now,
    /// at the end of its batch, which this call waits for. Returns the job as it is
    /// after the transition.
    fn control(&self, id: &str, c: Control) -> Result<JobStatus, JobError> {
        loop {
            let mut t = self.shared.table.lock().expect("job table");
            let e = t
                .jobs
                .get_mut(id)
                .ok_or_else(|| JobError::NotFound(format!("job {id}")))?;
            let state = e.status.state;
            let allowed = match c {
                Control::Pause => matches!(state, JobState::Queued | JobState::Running),
                Control::Cancel => !state.is_terminal(),
                Control::None => false,
            };
            if !allowed || e.control == Control::Cancel {
                return Err(JobError::Conflict(format!(
                    "job {id} is {}",
                    state.as_str()
                )));
            }
            if e.active {
                e.control = c;
                return self.wait_transition(t, id);
            }
            if e.runtime.is_some() {
                drop(t);
                // Then look again: the scheduler may have taken the job meanwhile.
                self.set_aside(id)?;
                continue;
            }
            let status = e.status.clone();
            let to = c
                .to()
                .expect("pause or cancel (Control::None is never allowed)");
            return self.commit(t, status, to);
        }
    }

    /// The workers of the pool (`caustic serve --nats`), as they last reported; empty
    /// when this process renders the iterations itself.
    pub fn workers(&self) -> Result<Vec<crate::job::remote::WorkerInfo>, JobError> {
        match &self.shared.ctx.remote {
            Some(ex) => ex.workers().map_err(|e| JobError::Internal(e.to_string())),
            None => Ok(Vec::new()),
        }
    }

    /// Writes the checkpoint of a job held in memory between batches and drops its
    /// render state, so that a pause or cancel keeps every iteration rendered.
    fn set_aside(&self, id: &str) -> Result<(), JobError> {
        let Some((rt, status)) = scheduler::take_runtime(&self.shared, id) else {
            return Ok(());
        };
        let written = rt.checkpoint(&status).write(&self.job_dir_of(id));
        let mut t = self.shared.table.lock().expect("job table");
        if let Some(e) = t.jobs.get_mut(id) {
            e.active = false;
            if written.is_err() {
                e.runtime = Some(rt);
            }
        }
        drop(t);
        self.shared.wake.notify_all();
        written
    }

    /// Waits (releasing the table) until the scheduler has applied the control
    /// request on `id`, then returns the job.
    fn wait_transition(
        &self,
        mut t: std::sync::MutexGuard<'_, Table>,
        id: &str,
    ) -> Result<JobStatus, JobError> {
        let deadline = std::time::Instant::now() + TRANSITION_WAIT;
        loop {
            let e = t
                .jobs
                .get(id)
                .ok_or_else(|| JobError::NotFound(format!("job {id}")))?;
            let now = std::time::Instant::now();
            if e.control == Control::None || now >= deadline {
                return Ok(e.status.clone());
            }
            t = self
                .shared
                .stepped
                .wait_timeout(t, deadline - now)
                .expect("job table")
                .0;
        }
    }

    /// Moves an idle job, whose status is `status`, to `to` and stores that, then
    /// makes it the job's: a transition that cannot be stored is refused (the error
    /// says why) and changes nothing.
    fn commit(
        &self,
        mut t: std::sync::MutexGuard<'_, Table>,
        mut status: JobStatus,
        to: To,
    ) -> Result<JobStatus, JobError> {
        let id = status.id.clone();
        transition::make(&self.job_dir_of(&id), &mut status, to)?;
        let e = t.jobs.get_mut(&id).expect("job in table");
        // Under the lock: no other change of the job can be said before this one.
        scheduler::settle(&self.shared.ctx, e, status.clone(), true);
        drop(t);
        if status.state == JobState::Queued {
            self.shared.wake.notify_all();
        }
        Ok(status)
    }

    fn job_dir_of(&self, id: &str) -> JobDir {
        JobDir::new(&self.config.data_dir, id)
    }

    pub fn cancel(&self, id: &str) -> Result<JobStatus, JobError> {
        self.control(id, Control::Cancel)
    }

    pub fn pause(&self, id: &str) -> Result<JobStatus, JobError> {
        self.control(id, Control::Pause)
    }

    pub fn resume(&self, id: &str) -> Result<JobStatus, JobError> {
        let t = self.shared.table.lock().expect("job table");
        let e = t
            .jobs
            .get(id)
            .ok_or_else(|| JobError::NotFound(format!("job {id}")))?;
        if e.status.state != JobState::Paused || e.control != Control::None {
            return Err(JobError::Conflict(format!(
                "job {id} is {}, not paused",
                e.status.state.as_str()
            )));
        }
        let status = e.status.clone();
        self.commit(t, status, To::Queued)
    }

    /// Removes a job and its directory; a running job must be cancelled first.
    pub fn delete_job(&self, id: &str) -> Result<(), JobError> {
        let mut t = self.shared.table.lock().expect("job table");
        let e = t
            .jobs
            .get(id)
            .ok_or_else(|| JobError::NotFound(format!("job {id}")))?;
        if e.active || matches!(e.status.state, JobState::Running) {
            return Err(JobError::Conflict(format!(
                "job {id} is running: cancel it first"
            )));
        }
        t.jobs.remove(id);
        drop(t);
        let dir = self.job_dir_of(id);
        std::fs::remove_dir_all(&dir.root).map_err(|e| JobError::io(&dir.root, e))
    }
}
