//! The client commands: thin wrappers over [`caustic::client`].

use super::args::{
    JobArgs, JobIdArgs, JobsArgs, ReferenceUploadArgs, ServerArgs, SubmitArgs, SweepArgs, WatchArgs,
};
use anyhow::Result;
use caustic::client::JobAction;

fn connect(s: &ServerArgs) -> caustic::client::Client {
    caustic::client::Client::new(&s.server, s.token.clone())
}

fn job_options(j: JobArgs, name: Option<String>, tags: Vec<String>) -> caustic::client::JobOptions {
    caustic::client::JobOptions {
        algorithm: j.algorithm,
        spp: j.spp,
        time_s: j.time,
        iterations: j.iterations,
        target_rmse: j.target_rmse,
        noise: j.noise,
        variance_layer: j.variance_layer,
        reference_job: j.reference_job,
        reference: j.reference,
        seed: j.seed,
        params: j.params,
        priority: j.priority,
        snapshot_every_iterations: j.snapshot_every_iterations,
        snapshot_every_seconds: j.snapshot_every_seconds,
        name,
        tags,
    }
}

/// Exit status of a client command: 0 when it succeeded, 1 when a job it waited for
/// did not complete, 2 (after `error: ...`) when it failed.
fn client_exit(r: Result<bool, caustic::client::ClientError>) -> Result<()> {
    use std::io::Write;
    let code = match r {
        Ok(true) => return Ok(()),
        Ok(false) => 1,
        Err(e) => {
            eprintln!("error: {e}");
            2
        }
    };
    let _ = std::io::stdout().flush();
    std::process::exit(code)
}

pub fn submit(a: SubmitArgs) -> Result<()> {
    let o = caustic::client::SubmitOptions {
        scene: a.scene,
        job: job_options(a.job, a.name, a.tags),
        watch: a.watch,
        json: a.json,
    };
    client_exit(caustic::client::submit(
        &connect(&a.server),
        &o,
        &mut std::io::stdout(),
    ))
}

pub fn watch(a: WatchArgs) -> Result<()> {
    let c = connect(&a.server);
    let tev = match a
        .tev
        .as_deref()
        .map(|addr| caustic::tev::TevClient::connect(addr, &a.job))
    {
        Some(Ok(t)) => Some(t),
        Some(Err(e)) => return client_exit(Err(e.into())),
        None => None,
    };
    let done = caustic::client::watch(&c, &a.job, a.json, tev.as_ref(), &mut std::io::stdout());
    if let Some(t) = tev {
        t.finish();
    }
    client_exit(done)
}

pub fn jobs(a: JobsArgs) -> Result<()> {
    let o = caustic::client::JobsOptions {
        state: a.state,
        tag: a.tag,
        sweep: a.sweep,
        json: a.json,
    };
    client_exit(caustic::client::jobs(
        &connect(&a.server),
        &o,
        &mut std::io::stdout(),
    ))
}

pub fn sweep(a: SweepArgs) -> Result<()> {
    let o = caustic::client::SweepOptions {
        scene: a.scene,
        grid: a.grid,
        file: a.file,
        job: job_options(a.job, None, a.tags),
        name: a.name,
        no_wait: a.no_wait,
        csv: a.csv,
        json: a.json,
        separate_radii: a.separate_radii,
    };
    client_exit(caustic::client::sweep(
        &connect(&a.server),
        &o,
        &mut std::io::stdout(),
    ))
}

/// `caustic cancel | pause | resume | retry | delete JOB`.
pub fn job_action(a: JobIdArgs, action: JobAction) -> Result<()> {
    client_exit(caustic::client::job_action(
        &connect(&a.server),
        &a.job,
        action,
        a.json,
        &mut std::io::stdout(),
    ))
}

/// `caustic reference upload FILE.exr`.
pub fn reference_upload(a: ReferenceUploadArgs) -> Result<()> {
    client_exit(caustic::client::upload_reference(
        &connect(&a.server),
        &a.file,
        &mut std::io::stdout(),
    ))
}
