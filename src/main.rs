//! The caustic command line: render, reference, diff and bench (and the server and
//! its client commands). The commands live in [`cli`].

mod cli;

use anyhow::Result;
use caustic::client::JobAction;
use clap::Parser;
use cli::args::{Cli, Command, ReferenceAction};
use cli::{bench, client, import, render, serve};
use std::process::ExitCode;

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let command = Cli::parse().command;
    if let Command::VdbGrid { file, grid, memory } = &command {
        let status = caustic::medium::grid_io::vdb_child_main(file, grid, *memory);
        return ExitCode::from(status as u8);
    }
    if !matches!(command, Command::Serve(_) | Command::Worker(_)) {
        quiet_broken_pipe();
    }
    match run(command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", cli::report::error_line(&e));
            ExitCode::FAILURE
        }
    }
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Render(a) => with_threads(a.threads, || render::render(&a)),
        Command::Diff { a, b, png } => render::diff(&a, &b, png.as_deref()),
        Command::Import(a) => import::import(&a),
        Command::Reference(r) => match (r.action, r.render) {
            (Some(ReferenceAction::Upload(a)), _) => client::reference_upload(a),
            (None, Some(a)) => with_threads(a.threads, || render::reference(&a)),
            (None, None) => unreachable!("clap requires the render arguments"),
        },
        Command::Bench(a) => with_threads(a.threads, || match a.time {
            Some(t) => bench::bench_equal_time(&a, t),
            None => bench::bench(&a),
        }),
        Command::Serve(a) => serve::serve(a),
        Command::Worker(a) => serve::worker(a),
        Command::VdbGrid { .. } => unreachable!("handled in main"),
        Command::Submit(a) => client::submit(a),
        Command::Watch(a) => client::watch(a),
        Command::Jobs(a) => client::jobs(a),
        Command::Cancel(a) => client::job_action(a, JobAction::Cancel),
        Command::Pause(a) => client::job_action(a, JobAction::Pause),
        Command::Resume(a) => client::job_action(a, JobAction::Resume),
        Command::Retry(a) => client::job_action(a, JobAction::Retry),
        Command::Delete(a) => client::job_action(a, JobAction::Delete),
        Command::Sweep(a) => client::sweep(a),
    }
}

/// Output piped into a reader that stops early (`caustic jobs | head -1`) ends the
/// process quietly, as with other command-line tools, instead of a panic in
/// `println!`. Rust ignores SIGPIPE by default; the server keeps that, so a closed
/// connection there is an error on one socket and never kills the process. (The
/// client commands' sockets are written with MSG_NOSIGNAL and are unaffected.)
fn quiet_broken_pipe() {
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of one signal, before any thread is
    // started; no handler code is involved.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .expect("thread pool")
            .install(f),
        None => f(),
    }
}
