//! `caustic worker --simulate N`: a load generator for the coordinator's scaling
//! benchmark (`deploy/scripts/bench-pool-scaling.sh`), not a renderer. One process
//! plays N workers: each pulls units like a worker, waits as long as rendering them
//! would take at a given number of seconds per iteration, and returns a copy of one
//! real result (the job's first iteration, rendered once), so the coordinator
//! fetches, decodes and adds results of the true size and content at the rate N real
//! workers would send them. The job's image is then wrong, by design: only its
//! progress and the coordinator's costs mean anything.

use super::worker::{compiled_scene, next_unit, render_range, units_consumer};
use super::{connect, setup, Done, RemoteError, Unit, WorkerInfo, WORKERS_BUCKET};
use crate::integrator::RenderStats;
use crate::job::scenes::SceneStore;
use async_nats::jetstream::consumer::PullConsumer;
use async_nats::jetstream::object_store::ObjectStore;
use async_nats::jetstream::{AckKind, Context as Js, Message};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

/// What the simulated workers share.
struct Sim {
    name: String,
    js: Js,
    scenes: ObjectStore,
    results: ObjectStore,
    store: SceneStore,
    /// Seconds one iteration would take a worker.
    iteration_s: f64,
    /// Each job's result to copy, by job id.
    copies: tokio::sync::Mutex<HashMap<String, Arc<Vec<u8>>>>,
}

/// Runs `workers` simulated workers until the process is stopped.
pub fn run(
    opts: super::worker::WorkerOptions,
    workers: usize,
    iteration_s: f64,
) -> Result<(), RemoteError> {
    let pool = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(opts.threads)
            .build()
            .map_err(RemoteError::nats)?,
    );
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(RemoteError::nats)?;
    rt.block_on(async move {
        let (_client, js) = connect(&opts.url, &opts.name).await?;
        let handles = setup(&js).await?;
        let consumer = units_consumer(&handles).await?;
        let store =
            SceneStore::new(&opts.cache_dir, opts.max_scene, pool).map_err(RemoteError::nats)?;
        let sim = Arc::new(Sim {
            name: opts.name,
            js,
            scenes: handles.scenes,
            results: handles.results,
            store,
            iteration_s,
            copies: tokio::sync::Mutex::new(HashMap::new()),
        });
        tracing::info!(workers, iteration_s, "simulated workers ready");
        tokio::spawn(heartbeats(sim.clone(), workers));
        for k in 0..workers {
            tokio::spawn(play(sim.clone(), consumer.clone(), k));
        }
        std::future::pending::<()>().await;
        Ok(())
    })
}

/// One simulated worker: units one at a time, for ever.
async fn play(sim: Arc<Sim>, consumer: PullConsumer, k: usize) {
    loop {
        if let Some(msg) = next_unit(&consumer).await {
            if let Err(e) = answer(&sim, k, msg).await {
                tracing::warn!("simulated worker {k}: {e}");
            }
        }
    }
}

/// Waits out the unit's render time and returns the job's copied result.
async fn answer(sim: &Sim, k: usize, msg: Message) -> Result<(), String> {
    let unit: Unit = serde_json::from_slice(&msg.payload).map_err(|e| e.to_string())?;
    tracing::debug!(k, first = unit.first, end = unit.end, "unit taken");
    let (object, error) = if unit.carry.is_some() {
        (
            None,
            Some("simulated workers do not run chained jobs".to_string()),
        )
    } else {
        let bytes = copy_for(sim, &unit).await?;
        let msg = Arc::new(msg.clone());
        let alive = tokio::spawn(async move {
            loop {
                tokio::time::sleep(super::ack_wait() / 3).await;
                let _ = msg.ack_with(AckKind::Progress).await;
            }
        });
        let secs = (unit.end - unit.first) as f64 * sim.iteration_s;
        tokio::time::sleep(Duration::from_secs_f64(secs)).await;
        let name = unit.object_name();
        let stored = sim.results.put(name.as_str(), &mut bytes.as_slice()).await;
        alive.abort();
        stored.map_err(|e| e.to_string())?;
        (Some(name), None)
    };
    let done = Done {
        job: unit.job.clone(),
        generation: unit.generation,
        first: unit.first,
        end: unit.end,
        worker: format!("{}-{k}", sim.name),
        object,
        error,
        stats: RenderStats::default(),
        seconds: (unit.end - unit.first) as f64 * sim.iteration_s,
    };
    let body = serde_json::to_vec(&done).map_err(|e| e.to_string())?;
    sim.js
        .publish(format!("caustic.done.{}", unit.job), body.into())
        .await
        .map_err(|e| e.to_string())?
        .await
        .map_err(|e| e.to_string())?;
    tracing::debug!(k, first = unit.first, end = unit.end, "unit answered");
    msg.double_ack().await.map_err(|e| e.to_string())
}

/// The job's result to copy: its iteration `unit.first`, rendered once.
async fn copy_for(sim: &Sim, unit: &Unit) -> Result<Arc<Vec<u8>>, String> {
    let mut copies = sim.copies.lock().await;
    if let Some(c) = copies.get(&unit.job) {
        return Ok(c.clone());
    }
    let scene = compiled_scene(&sim.store, &sim.scenes, &unit.scene)
        .await
        .map_err(|_| format!("scene {} is not available", unit.scene))?;
    let one = Unit {
        end: unit.first + 1,
        ..unit.clone()
    };
    let range = tokio::task::spawn_blocking(move || render_range(&scene, &one, None))
        .await
        .map_err(|e| e.to_string())??;
    let copy = Arc::new(range.result);
    copies.insert(unit.job.clone(), copy.clone());
    Ok(copy)
}

/// Reports every simulated worker, so that the coordinator counts them as a pool.
async fn heartbeats(sim: Arc<Sim>, workers: usize) {
    let Ok(kv) = sim.js.get_key_value(WORKERS_BUCKET).await else {
        return tracing::warn!("no heartbeat bucket");
    };
    loop {
        for k in 0..workers {
            let info = WorkerInfo {
                name: format!("{}-{k}", sim.name),
                threads: 1,
                last_heartbeat: crate::job::spec::unix_now(),
                ..Default::default()
            };
            let body = serde_json::to_vec(&info).unwrap_or_default();
            let _ = kv.put(format!("{}-{k}", sim.name), body.into()).await;
        }
        tokio::time::sleep(super::WORKER_TTL / 3).await;
    }
}
