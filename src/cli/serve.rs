//! `caustic serve`: the REST and gRPC servers over one service until Ctrl-C.

use super::args::{ServeArgs, WorkerArgs};
use anyhow::{bail, Context, Result};
use std::time::Duration;

pub fn serve(a: ServeArgs) -> Result<()> {
    isolate_vdb()?;
    let mut config = caustic::job::ServiceConfig::new(&a.data_dir);
    config.workers = a.workers.unwrap_or(0);
    config.max_resolution = a.max_resolution;
    config.max_upload = a.max_upload_mib << 20;
    config.max_primitives = a.max_primitives;
    config.max_active_jobs = a.max_active_jobs as usize;
    config.max_job = match a.max_job_mib {
        Some(mib) => mib.saturating_mul(1 << 20),
        None => caustic::job::memory::default_budget(config.max_active_jobs),
    };
    config.retention = retention(&a)?;
    if !(a.request_timeout.is_finite() && a.request_timeout > 0.0) {
        bail!(
            "--request-timeout {}: expected a positive number of seconds",
            a.request_timeout
        );
    }
    config.header_timeout = Duration::from_secs_f64(a.request_timeout);
    config.body_timeout = config.header_timeout;
    config.nats = a.nats.clone();
    let svc = caustic::job::Service::start(config)?;
    let rt = tokio::runtime::Runtime::new()?;
    let result = rt.block_on(async {
        let http = tokio::net::TcpListener::bind(a.addr)
            .await
            .with_context(|| format!("binding {}", a.addr))?;
        let grpc = tokio::net::TcpListener::bind(a.grpc_addr)
            .await
            .with_context(|| format!("binding {}", a.grpc_addr))?;
        let url = format!("http://{}", http.local_addr()?);
        let grpc_addr = grpc.local_addr()?;
        svc.announce(&format!("REST {url}, gRPC {grpc_addr}"));
        eprintln!("caustic serving REST on {url} and gRPC on {grpc_addr}");
        eprintln!("data directory: {}", a.data_dir.display());
        eprintln!(
            "memory per job: at most {} MiB (--max-job-mib)",
            svc.config().max_job >> 20
        );
        eprintln!("{}", try_hint(&url, a.token.is_some()));
        let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
        let stopped = move || {
            let mut rx = stop_rx.clone();
            async move {
                let _ = rx.wait_for(|s| *s).await;
            }
        };
        let signal_svc = svc.clone();
        tokio::spawn(async move {
            stop_signal().await;
            eprintln!("shutting down: running jobs are checkpointed and resume on the next start");
            // Event streams end first, so that both servers can close their connections.
            signal_svc.begin_shutdown();
            let _ = stop_tx.send(true);
        });
        let limits = caustic::server::listen::ConnLimits {
            header_timeout: svc.config().header_timeout,
            drain: Duration::from_secs(2),
        };
        let app = caustic::server::http::app(svc.clone(), a.token.clone());
        let rest = caustic::server::listen::serve(http, app, limits, stopped());
        let grpc_server =
            caustic::server::grpc::serve(grpc, svc.clone(), a.token.clone(), stopped());
        let (_, grpc_result) = tokio::join!(rest, async {
            // tonic waits for open calls without a bound; the streams end on the
            // service's shutdown, the rest get the same grace as REST connections.
            let stop = stopped();
            tokio::pin!(grpc_server);
            tokio::select! {
                r = &mut grpc_server => r,
                () = async { stop.await; tokio::time::sleep(limits.drain).await } => Ok(()),
            }
        });
        grpc_result.map_err(anyhow::Error::from)
    });
    svc.shutdown();
    rt.shutdown_timeout(Duration::from_millis(500));
    result
}

/// The curl line printed at start. Behind a token it sends one, as the server asks,
/// from the environment: the token itself stays out of logs.
fn try_hint(url: &str, token: bool) -> String {
    let (auth, note) = if token {
        (
            " -H \"Authorization: Bearer $CAUSTIC_TOKEN\"",
            "  # CAUSTIC_TOKEN: the token given to --token",
        )
    } else {
        ("", "")
    };
    format!(
        "try: curl -X POST {url}/v1/jobs{auth} -H 'content-type: application/json' -d '{{\"scene\": \"cornell-box\", \"halt\": {{\"spp\": 64}}}}'{note}"
    )
}

/// The retention policy from --retention-days and --retention-gib.
fn retention(a: &ServeArgs) -> Result<caustic::job::disk::Retention> {
    let positive = |v: Option<f64>, flag: &str| -> Result<Option<f64>> {
        match v {
            Some(x) if !(x.is_finite() && x > 0.0) => {
                bail!("{flag} {x}: expected a positive number")
            }
            v => Ok(v),
        }
    };
    Ok(caustic::job::disk::Retention {
        max_age_s: positive(a.retention_days, "--retention-days")?.map(|d| d * 86400.0),
        max_bytes: positive(a.retention_gib, "--retention-gib")?
            .map(|g| (g * (1u64 << 30) as f64) as u64),
    })
}

/// Ctrl-C, or SIGTERM (what `kill` and Kubernetes send).
async fn stop_signal() {
    #[cfg(unix)]
    {
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
            .expect("SIGTERM handler");
        tokio::select! {
            _ = tokio::signal::ctrl_c() => {}
            _ = term.recv() => {}
        }
    }
    #[cfg(not(unix))]
    let _ = tokio::signal::ctrl_c().await;
}

/// Uploaded `.vdb` files are read in a child process (`grid_io::vdb_child`).
fn isolate_vdb() -> Result<()> {
    let exe = std::env::current_exe()?;
    caustic::medium::grid_io::isolate_vdb(caustic::medium::grid_io::Isolation::server(exe));
    Ok(())
}

/// `caustic worker`: renders work units until stopped.
pub fn worker(a: WorkerArgs) -> Result<()> {
    isolate_vdb()?;
    let name = a
        .name
        .unwrap_or_else(|| format!("{}-{}", caustic::job::lock::hostname(), std::process::id()));
    eprintln!(
        "caustic worker {name} on {}",
        caustic::job::remote::redact(&a.nats)
    );
    let opts = caustic::job::remote::worker::WorkerOptions {
        url: a.nats,
        name,
        threads: a.threads.unwrap_or(0),
        cache_dir: a.cache_dir,
        max_scene: a.max_scene_mib << 20,
        max_primitives: a.max_primitives,
    };
    match a.simulate {
        Some(n) => caustic::job::remote::simulate::run(opts, n, a.simulate_iteration_s)?,
        None => caustic::job::remote::worker::run(opts)?,
    }
    Ok(())
}
