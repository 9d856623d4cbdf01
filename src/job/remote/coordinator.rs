//! The coordinator's side: publishes scenes and work units, collects the workers'
//! answers, and fetches their results. The scheduler thread calls it synchronously;
//! it runs its own small tokio runtime, so the render core and the scheduler stay
//! free of async (DESIGN.md "Rules of the house"). Results are fetched there as their
//! answers arrive, several at once, and decoded and added to their job's groups on
//! its blocking threads (`intake`), so the scheduler thread only adds whole groups.

use super::claim::{self, Holder};
use super::intake::{Filed, Intake, Intakes};
use super::{
    connect, read_object, setup, Done, RemoteError, Unit, WorkerInfo, DONE_STREAM, WORKERS_BUCKET,
};
use async_nats::jetstream::consumer::{pull, AckPolicy, PullConsumer};
use async_nats::jetstream::object_store::ObjectStore;
use async_nats::jetstream::stream::Stream;
use async_nats::jetstream::Context as Js;
use futures::StreamExt;
use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// Durable consumer of the workers' answers.
const COORDINATOR: &str = "caustic-coordinator";

/// Results fetched at once; more answers wait their turn (bounds the memory held
/// by fetches in flight: 64 MB each at 1080p, packed).
const FETCHES: usize = 8;

/// A worker's answer with what became of its result.
pub struct Arrival {
    pub done: Done,
    pub result: Fetched,
}

pub enum Fetched {
    /// Offered to the job's intake.
    Filed(Filed),
    /// Fetched but not decoded (a chained job's checkpoint, or a job without an
    /// intake here).
    Bytes(Vec<u8>),
    /// Not fetched (none, or NATS failed): the job's runner fetches it again with
    /// [`NatsExecutor::fetch`] if it has one.
    Missing,
}

/// The intake's smoothed cost per range, as measured: what units are sized by.
#[derive(Default)]
struct Costs {
    /// Seconds to fetch a result (up to [`FETCHES`] at once).
    fetch_s: f64,
    /// Seconds of a blocking thread to decode and add one (up to one per core).
    cpu_s: f64,
    ranges: u64,
}

impl Costs {
    /// Smoothing weight of the latest range.
    const WEIGHT: f64 = 0.2;

    fn add(cost: &mut f64, first: bool, secs: f64) {
        *cost = if first {
            secs
        } else {
            (1.0 - Self::WEIGHT) * *cost + Self::WEIGHT * secs
        };
    }
}

/// Answers received, by job, until the job's runner takes them.
#[derive(Default)]
struct Inbox {
    by_job: Mutex<HashMap<String, Vec<Arrival>>>,
    arrived: Condvar,
}

pub struct NatsExecutor {
    rt: tokio::runtime::Runtime,
    js: Js,
    units: Stream,
    scenes: ObjectStore,
    results: ObjectStore,
    inbox: Arc<Inbox>,
    intakes: Arc<Intakes>,
    costs: Arc<Mutex<Costs>>,
    /// Scenes already in the object store.
    published: Mutex<HashSet<String>>,
}

impl NatsExecutor {
    /// Connects, creates the streams and buckets, and starts collecting answers.
    pub fn connect(url: &str, me: Holder) -> Result<NatsExecutor, RemoteError> {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("nats")
            .enable_all()
            .build()
            .map_err(RemoteError::nats)?;
        let inbox = Arc::new(Inbox::default());
        let intakes = Arc::new(Intakes::default());
        let costs = Arc::new(Mutex::new(Costs::default()));
        let (js, handles) = rt.block_on(async {
            let (_client, js) = connect(url, "caustic-coordinator").await?;
            claim::claim(&js, me).await?;
            let handles = setup(&js).await?;
            let done = js
                .get_stream(DONE_STREAM)
                .await
                .map_err(RemoteError::nats)?;
            let consumer = done
                .get_or_create_consumer(
                    COORDINATOR,
                    pull::Config {
                        durable_name: Some(COORDINATOR.into()),
                        ack_policy: AckPolicy::Explicit,
                        ..Default::default()
                    },
                )
                .await
                .map_err(RemoteError::nats)?;
            let sinks = Sinks {
                inbox: inbox.clone(),
                intakes: intakes.clone(),
                costs: costs.clone(),
                results: handles.results.clone(),
            };
            tokio::spawn(collect(consumer, sinks));
            Ok::<_, RemoteError>((js, handles))
        })?;
        Ok(NatsExecutor {
            rt,
            js,
            units: handles.units,
            scenes: handles.scenes,
            results: handles.results,
            inbox,
            intakes,
            costs,
            published: Mutex::new(HashSet::new()),
        })
    }

    /// Results of the job's ranges go to `intake` from now on.
    pub fn receive(&self, job: &str, intake: Arc<Intake>) {
        self.intakes.insert(job, intake);
    }

    /// Stops [`NatsExecutor::receive`] for the job's stream of units `generation`.
    pub fn stop_receiving(&self, job: &str, generation: u64) {
        self.intakes.remove(job, generation);
    }

    /// Ranges per second the intake can take, from its measured costs (None until a
    /// few ranges came in): fetches and decodes run several at once.
    pub fn intake_capacity(&self) -> Option<f64> {
        let c = self.costs.lock().expect("costs");
        (c.ranges >= 4).then(|| {
            let fetching = FETCHES as f64 / c.fetch_s.max(1e-3);
            let decoding = cores() as f64 / c.cpu_s.max(1e-3);
            fetching.min(decoding)
        })
    }

    /// How many workers reported within the heartbeats' time to live (counted from
    /// the keys alone).
    pub fn worker_count(&self) -> Result<usize, RemoteError> {
        let js = self.js.clone();
        self.run(async move {
            let kv = js
                .get_key_value(WORKERS_BUCKET)
                .await
                .map_err(RemoteError::nats)?;
            let keys = kv.keys().await.map_err(RemoteError::nats)?;
            Ok(keys.filter(|k| std::future::ready(k.is_ok())).count().await)
        })
    }

    /// Makes scene `id` available to workers: `bundle` is its tar, None for a
    /// built-in scene (every worker has those).
    pub fn publish_scene(&self, id: &str, bundle: Option<Vec<u8>>) -> Result<(), RemoteError> {
        let Some(bytes) = bundle else {
            return Ok(());
        };
        if self.published.lock().expect("published").contains(id) {
            return Ok(());
        }
        self.rt.block_on(async {
            if self.scenes.info(id).await.is_err() {
                self.scenes
                    .put(id, &mut bytes.as_slice())
                    .await
                    .map_err(RemoteError::nats)?;
            }
            Ok::<_, RemoteError>(())
        })?;
        self.published.lock().expect("published").insert(id.into());
        Ok(())
    }

    /// Publishes one unit on the work queue.
    pub fn publish(&self, unit: &Unit) -> Result<(), RemoteError> {
        let body = serde_json::to_vec(unit).map_err(RemoteError::nats)?;
        self.rt.block_on(async {
            self.js
                .publish(unit.subject(), body.into())
                .await
                .map_err(RemoteError::nats)?
                .await
                .map_err(RemoteError::nats)?;
            Ok(())
        })
    }

    /// Withdraws the job's units still waiting in the queue (a unit already with a
    /// worker still finishes; its answer is then ignored or dropped).
    pub fn withdraw(&self, job: &str) -> Result<(), RemoteError> {
        let subject = format!("caustic.units.{job}");
        self.rt.block_on(async {
            self.units
                .purge()
                .filter(subject)
                .await
                .map_err(RemoteError::nats)?;
            Ok(())
        })
    }

    /// [`NatsExecutor::withdraw`] without waiting, from any thread (also from async
    /// code, where blocking on this executor's runtime is not allowed).
    pub fn withdraw_later(&self, job: &str) {
        let (units, subject) = (self.units.clone(), format!("caustic.units.{job}"));
        self.rt.spawn(async move {
            if let Err(e) = units.purge().filter(subject).await {
                tracing::warn!("withdrawing units: {e}");
            }
        });
    }

    /// Stores `bytes` as object `name` of the results bucket.
    pub fn put(&self, name: &str, bytes: Vec<u8>) -> Result<(), RemoteError> {
        self.rt.block_on(async {
            self.results
                .put(name, &mut bytes.as_slice())
                .await
                .map_err(RemoteError::nats)?;
            Ok(())
        })
    }

    /// The job's answers that arrived, waiting up to `timeout` for the first one.
    pub fn take(&self, job: &str, timeout: Duration) -> Vec<Arrival> {
        let mut map = self.inbox.by_job.lock().expect("inbox");
        if map.get(job).is_none_or(Vec::is_empty) {
            map = self
                .inbox
                .arrived
                .wait_timeout(map, timeout)
                .expect("inbox")
                .0;
        }
        map.remove(job).unwrap_or_default()
    }

    /// The workers that reported within the heartbeats' time to live, by name.
    pub fn workers(&self) -> Result<Vec<WorkerInfo>, RemoteError> {
        let js = self.js.clone();
        self.run(async move {
            let kv = js
                .get_key_value(WORKERS_BUCKET)
                .await
                .map_err(RemoteError::nats)?;
            let mut keys = kv.keys().await.map_err(RemoteError::nats)?;
            let mut out = Vec::new();
            while let Some(k) = keys.next().await {
                let Ok(k) = k else { continue };
                if let Ok(Some(v)) = kv.get(k).await {
                    if let Ok(info) = serde_json::from_slice::<WorkerInfo>(&v) {
                        out.push(info);
                    }
                }
            }
            out.sort_by(|a, b| a.name.cmp(&b.name));
            Ok(out)
        })
    }

    /// Runs `f` on this executor's runtime and waits for it from any thread, also one
    /// inside another tokio runtime (the HTTP server's blocking pool), where
    /// `block_on` is not allowed.
    fn run<T: Send + 'static>(
        &self,
        f: impl std::future::Future<Output = T> + Send + 'static,
    ) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        self.rt.spawn(async move {
            let _ = tx.send(f.await);
        });
        rx.recv().expect("NATS runtime stopped")
    }

    /// Gives the pool up, so that another coordinator may start at once (at a clean
    /// stop; after a crash the claim lapses by itself).
    pub fn release(&self) {
        let js = self.js.clone();
        self.run(async move { claim::release(&js).await });
    }

    /// A result, removed from the object store once read.
    pub fn fetch(&self, object: &str) -> Result<Vec<u8>, RemoteError> {
        self.rt.block_on(take_object(&self.results, object))
    }

    /// Deletes a result that will not be used (a stale or duplicate answer, or a
    /// chain's carried checkpoint once its successor is in).
    pub fn discard(&self, object: &str) {
        self.rt.block_on(async {
            let _ = self.results.delete(object).await;
        });
    }
}

/// Reads object `name` whole and deletes it.
async fn take_object(results: &ObjectStore, name: &str) -> Result<Vec<u8>, RemoteError> {
    let bytes = read_object(results, name).await?;
    let _ = results.delete(name).await;
    Ok(bytes)
}

/// Where [`collect`] puts what arrives.
struct Sinks {
    inbox: Arc<Inbox>,
    intakes: Arc<Intakes>,
    costs: Arc<Mutex<Costs>>,
    results: ObjectStore,
}

/// The coordinator's cores: how many results it decodes at once.
fn cores() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get())
}

/// Files each answer under its job with its result, acknowledging it: from here on
/// the coordinator owns it (an answer lost in a coordinator crash only means the range
/// is rendered again after the job resumes from its checkpoint). A result whose job
/// has an intake here is decoded and added to its group on a blocking thread, as many
/// at once as the machine has cores. Starts over when the stream of messages ends (the
/// NATS server went away).
async fn collect(consumer: PullConsumer, sinks: Sinks) {
    let sinks = Arc::new(sinks);
    let fetches = Arc::new(tokio::sync::Semaphore::new(FETCHES));
    let decodes = Arc::new(tokio::sync::Semaphore::new(cores()));
    loop {
        match consumer.messages().await {
            Ok(mut messages) => {
                while let Some(m) = messages.next().await {
                    let Ok(m) = m else { continue };
                    let done = match serde_json::from_slice::<Done>(&m.payload) {
                        Ok(d) => d,
                        Err(e) => {
                            tracing::warn!("ignoring a malformed answer: {e}");
                            let _ = m.ack().await;
                            continue;
                        }
                    };
                    let Ok(permit) = fetches.clone().acquire_owned().await else {
                        return;
                    };
                    let (sinks, decodes) = (sinks.clone(), decodes.clone());
                    tokio::spawn(async move {
                        let started = std::time::Instant::now();
                        let body = match &done.object {
                            Some(o) => take_object(&sinks.results, o).await.ok(),
                            None => None,
                        };
                        let fetch_s = started.elapsed().as_secs_f64();
                        // The per-range cost of the coordinator, for the scaling
                        // model (README).
                        tracing::debug!(job = %done.job, fetch_s, "range fetched");
                        drop(permit);
                        let started = std::time::Instant::now();
                        let result = offer(&sinks.intakes, &decodes, &done, body).await;
                        if let Fetched::Filed(Filed::Added) = result {
                            let mut c = sinks.costs.lock().expect("costs");
                            let first = c.ranges == 0;
                            Costs::add(&mut c.fetch_s, first, fetch_s);
                            Costs::add(&mut c.cpu_s, first, started.elapsed().as_secs_f64());
                            c.ranges += 1;
                        }
                        file(&sinks.inbox, Arrival { done, result });
                        let _ = m.ack().await;
                    });
                }
            }
            Err(e) => tracing::warn!("answers: {e}"),
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
    }
}

/// Offers a fetched result to its job's intake, decoding on a blocking thread.
async fn offer(
    intakes: &Intakes,
    decodes: &Arc<tokio::sync::Semaphore>,
    done: &Done,
    body: Option<Vec<u8>>,
) -> Fetched {
    let Some(bytes) = body else {
        return Fetched::Missing;
    };
    let intake = intakes.get(&done.job).filter(|_| done.error.is_none());
    let Some(intake) = intake else {
        return Fetched::Bytes(bytes);
    };
    let Ok(_permit) = decodes.clone().acquire_owned().await else {
        return Fetched::Bytes(bytes);
    };
    let done = done.clone();
    match tokio::task::spawn_blocking(move || intake.fold(&done, &bytes)).await {
        Ok(filed) => Fetched::Filed(filed),
        // A panic while decoding: treat the result as damaged.
        Err(_) => Fetched::Filed(Filed::Damaged),
    }
}

fn file(inbox: &Inbox, arrival: Arrival) {
    let mut map = inbox.by_job.lock().expect("inbox");
    map.entry(arrival.done.job.clone())
        .or_default()
        .push(arrival);
    inbox.arrived.notify_all();
}
