//! The caustic command line: render, reference, diff and bench (and the server and
//! its client commands).

use anyhow::{bail, Context, Result};
use caustic::film::{self, Image};
use caustic::integrator::driver::{self, Halt};
use caustic::integrator::{RenderStats, Settings};
use caustic::scene::Scene;
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "caustic",
    version,
    about = "Progressive physically based rendering"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to EXR (and optionally PNG).
    Render(RenderArgs),
    /// Compare two images (EXR, or Radiance .hdr such as SmallVCM writes): RMSE and
    /// relative MSE, optional false-colour PNG.
    Diff {
        a: PathBuf,
        /// The reference.
        b: PathBuf,
        /// Write a false-colour difference image here.
        #[arg(long)]
        png: Option<PathBuf>,
    },
    /// Render a long reference image for error measurements (as `render`, with a time
    /// budget, and a seed unlike the default one of `render` and `bench`).
    Reference(ReferenceArgs),
    /// Measure speed (ms and CPU s per iteration, samples/s, rays/s; median of
    /// repeats), or with --time compare algorithms at equal time: RMSE against a
    /// reference over time, a CSV, a log-log plot and each algorithm's image.
    Bench(BenchArgs),
    /// Run the render server (REST and gRPC) on a local data directory.
    Serve(ServeArgs),
    /// Submit a render job to a server (uploading a local scene file first).
    ///
    /// Prints the job id. Exit status with --watch: 0 completed, 1 failed or
    /// cancelled, 2 on errors.
    Submit(SubmitArgs),
    /// Follow a job on a server until it ends: progress bar, then a summary.
    ///
    /// Exit status: 0 completed, 1 failed or cancelled, 2 on errors.
    Watch(WatchArgs),
    /// List a server's jobs.
    Jobs(JobsArgs),
    /// Run a parameter sweep on a server and print its table.
    ///
    /// Exit status: 0 when every job completed, 1 when some did not, 2 on errors.
    Sweep(SweepArgs),
}

/// Which server a client command talks to.
#[derive(Args)]
struct ServerArgs {
    /// Server URL.
    #[arg(long, env = "CAUSTIC_SERVER", default_value = caustic::client::DEFAULT_SERVER)]
    server: String,
    /// Bearer token, for a server started with --token.
    #[arg(long, env = "CAUSTIC_TOKEN", hide_env_values = true)]
    token: Option<String>,
}

/// Job settings shared by `submit` and `sweep`.
#[derive(Args)]
struct JobArgs {
    /// Algorithm (default: the scene's, else pt).
    #[arg(long, short)]
    algorithm: Option<String>,
    /// Halt after this many samples per pixel.
    #[arg(long, conflicts_with = "iterations")]
    spp: Option<u64>,
    /// Halt after this many seconds of rendering.
    #[arg(long, value_name = "SECONDS")]
    time: Option<f64>,
    /// Halt after this many iterations (light-pass algorithms).
    #[arg(long)]
    iterations: Option<u64>,
    /// Halt when the RMSE against the reference falls to this value.
    #[arg(long, requires = "reference_job")]
    target_rmse: Option<f64>,
    /// A completed job whose image is the reference for RMSE logs.
    #[arg(long, value_name = "JOB")]
    reference_job: Option<String>,
    #[arg(long)]
    seed: Option<u64>,
    /// Algorithm parameter, repeatable: --param max_depth=8
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// Higher runs first.
    #[arg(long, allow_negative_numbers = true)]
    priority: Option<i32>,
    /// Write a snapshot every N iterations.
    #[arg(long, value_name = "N", conflicts_with = "snapshot_every_seconds")]
    snapshot_every_iterations: Option<u64>,
    /// Write a snapshot every S seconds (server default: 5).
    #[arg(long, value_name = "S")]
    snapshot_every_seconds: Option<f64>,
}

#[derive(Args)]
struct SubmitArgs {
    /// A built-in or uploaded scene id, or a local scene file (.json; the meshes and
    /// maps it names are bundled) or bundle (.tar, .zip) to upload.
    scene: String,
    #[command(flatten)]
    job: JobArgs,
    #[arg(long)]
    name: Option<String>,
    /// Tag, repeatable.
    #[arg(long = "tag", value_name = "TAG")]
    tags: Vec<String>,
    /// Follow the job to its end, as `caustic watch`.
    #[arg(long)]
    watch: bool,
    /// Print the job as JSON (with --watch: one line, then one line per event).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    server: ServerArgs,
}

#[derive(Args)]
struct WatchArgs {
    /// Job id.
    job: String,
    /// Print each event as one JSON line instead of the progress bar.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    server: ServerArgs,
}

#[derive(Args)]
struct JobsArgs {
    /// Only jobs in this state (queued, running, paused, completed, cancelled, failed).
    #[arg(long)]
    state: Option<String>,
    /// Only jobs with this tag.
    #[arg(long)]
    tag: Option<String>,
    /// Only the jobs of this sweep.
    #[arg(long)]
    sweep: Option<String>,
    /// Print the jobs as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    server: ServerArgs,
}

#[derive(Args)]
struct SweepArgs {
    /// Scene id or local scene file, as for `submit` (with --file: overrides its scene).
    #[arg(required_unless_present = "file")]
    scene: Option<String>,
    /// Grid axis, repeatable: --grid algorithm=pt,albedo --grid params.max_depth=2,4.
    /// Keys: algorithm, seed, priority, spp, iterations, time, target_rmse (or
    /// halt.<key>), params.<name>. Values are JSON when they parse, else strings.
    #[arg(
        long = "grid",
        value_name = "KEY=V1,V2,...",
        required_unless_present = "file"
    )]
    grid: Vec<String>,
    /// Read a full sweep spec ({"base": job, "grid": {...}, "name": ...}) from this
    /// JSON file; other options override its values.
    #[arg(long)]
    file: Option<PathBuf>,
    #[command(flatten)]
    job: JobArgs,
    /// The sweep's name.
    #[arg(long)]
    name: Option<String>,
    /// Tag every job, repeatable.
    #[arg(long = "tag", value_name = "TAG")]
    tags: Vec<String>,
    /// Print the sweep id and return at once.
    #[arg(long)]
    no_wait: bool,
    /// Print the final table as CSV.
    #[arg(long, conflicts_with = "json")]
    csv: bool,
    /// Print the final table as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    server: ServerArgs,
}

#[derive(Args)]
struct ServeArgs {
    /// REST address.
    #[arg(long, default_value = "127.0.0.1:7878")]
    addr: std::net::SocketAddr,
    /// gRPC address.
    #[arg(long, default_value = "127.0.0.1:7879")]
    grpc_addr: std::net::SocketAddr,
    /// Where scenes, jobs and images are kept.
    #[arg(long, default_value = "caustic-data")]
    data_dir: PathBuf,
    /// Render threads (default: all cores).
    #[arg(long, alias = "threads")]
    workers: Option<usize>,
    /// Require `Authorization: Bearer TOKEN` on every request (except /healthz).
    #[arg(long, env = "CAUSTIC_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Largest image side a job may render.
    #[arg(long, default_value_t = 8192)]
    max_resolution: u32,
    /// Largest upload in MiB.
    #[arg(long, default_value_t = 256)]
    max_upload_mib: u64,
    /// Jobs whose render state is held in memory at once; the others wait queued,
    /// their checkpoints on disk (a job of higher priority sets a lower one aside).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    max_active_jobs: u32,
    /// Delete finished jobs (completed, cancelled, failed) this many days after they
    /// ended. Running, queued and paused jobs are never deleted.
    #[arg(long, value_name = "DAYS")]
    retention_days: Option<f64>,
    /// Delete the oldest finished jobs while the job folders hold more than this many
    /// GiB.
    #[arg(long, value_name = "GIB")]
    retention_gib: Option<f64>,
    /// Seconds a connection may wait for a request's headers (idle keep-alive
    /// connections too) and a body may pause before the server gives up on it.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    request_timeout: f64,
}

#[derive(Args)]
struct RenderArgs {
    scene: PathBuf,
    /// Algorithm (default: the scene's, else pt).
    #[arg(long, short)]
    algorithm: Option<String>,
    /// Iterations (samples per pixel for pt).
    #[arg(long, conflicts_with = "time")]
    spp: Option<u64>,
    /// Wall-clock budget in seconds.
    #[arg(long)]
    time: Option<f64>,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Algorithm parameter, repeatable: --param max_depth=8
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// Output EXR (linear float32 RGB).
    #[arg(short, long, default_value = "out.exr")]
    output: PathBuf,
    /// Also write an sRGB PNG here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0)]
    exposure: f32,
    /// Add albedo and normal layers to the EXR.
    #[arg(long)]
    exr_layers: bool,
}

#[derive(Args)]
struct ReferenceArgs {
    scene: PathBuf,
    /// Algorithm (default: the scene's, else pt).
    #[arg(long, short)]
    algorithm: Option<String>,
    /// Wall-clock budget in seconds.
    #[arg(long, value_name = "SECONDS", required_unless_present = "spp")]
    time: Option<f64>,
    /// A number of iterations instead of a time budget.
    #[arg(long, conflicts_with = "time")]
    spp: Option<u64>,
    /// 1 by default, so that a reference shares no samples with a `render` or
    /// `bench` run at their default seed 0.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Algorithm parameter, repeatable: --param max_depth=8
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// Output EXR (linear float32 RGB).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write an sRGB PNG here.
    #[arg(long)]
    png: Option<PathBuf>,
}

#[derive(Args)]
struct BenchArgs {
    scene: PathBuf,
    /// Comma-separated algorithms.
    #[arg(long, default_value = "pt")]
    algorithms: String,
    /// Speed mode: iterations per timed run.
    #[arg(long, default_value_t = 16, conflicts_with = "time")]
    spp: u64,
    /// Speed mode: timed runs per algorithm; the median is reported.
    #[arg(long, default_value_t = 5, conflicts_with = "time")]
    repeat: usize,
    /// Equal-time mode: seconds of iterations per algorithm (needs --reference or
    /// --reference-from).
    #[arg(long, value_name = "SECONDS")]
    time: Option<f64>,
    /// Equal-time mode: the reference image (EXR, or Radiance .hdr).
    #[arg(
        long,
        value_name = "IMAGE",
        requires = "time",
        conflicts_with = "reference_from"
    )]
    reference: Option<PathBuf>,
    /// Equal-time mode: render the reference first with this algorithm for this many
    /// seconds (seed --seed + 1), saved as DIR/reference.exr.
    #[arg(long, value_name = "ALG:SECONDS", requires = "time")]
    reference_from: Option<String>,
    /// Equal-time mode: output directory (bench.csv, rmse_vs_time.png, <algorithm>.exr).
    #[arg(short, long, value_name = "DIR", default_value = "bench-out")]
    output: PathBuf,
    /// Equal-time mode: measuring times per run, spaced evenly on a log scale over
    /// the last three decades of the budget (plus the first iteration and the end).
    #[arg(long, default_value_t = 20)]
    points: usize,
    /// Equal-time mode: the seed of every algorithm's run.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[arg(long)]
    threads: Option<usize>,
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
}

fn main() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let command = Cli::parse().command;
    if !matches!(command, Command::Serve(_)) {
        quiet_broken_pipe();
    }
    match command {
        Command::Render(a) => with_threads(a.threads, || render(&a)),
        Command::Diff { a, b, png } => diff(&a, &b, png.as_deref()),
        Command::Reference(a) => with_threads(a.threads, || reference(&a)),
        Command::Bench(a) => with_threads(a.threads, || match a.time {
            Some(t) => bench_equal_time(&a, t),
            None => bench(&a),
        }),
        Command::Serve(a) => serve(a),
        Command::Submit(a) => submit(a),
        Command::Watch(a) => watch(a),
        Command::Jobs(a) => jobs(a),
        Command::Sweep(a) => sweep(a),
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

/// `key=value` pairs; values parse as JSON when they can, else as strings.
fn parse_params(params: &[String]) -> Result<serde_json::Map<String, serde_json::Value>> {
    let mut m = serde_json::Map::new();
    for p in params {
        let Some((k, v)) = p.split_once('=') else {
            bail!("--param {p}: expected KEY=VALUE");
        };
        let val = serde_json::from_str(v).unwrap_or_else(|_| serde_json::Value::String(v.into()));
        m.insert(k.trim().to_string(), val);
    }
    Ok(m)
}

fn load_scene(path: &Path) -> Result<Scene> {
    let t = Instant::now();
    let scene = Scene::load(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let s = &scene.stats;
    eprintln!(
        "scene: {} triangles ({} pairs as parallelograms), {} spheres, {} disks, {} lights; BVH {:.1} ms, {:.1} KiB; loaded in {:.1} ms",
        s.triangles,
        s.quads,
        s.spheres,
        s.disks,
        scene.lights.len(),
        s.bvh_build.as_secs_f64() * 1e3,
        s.bvh_bytes as f64 / 1024.0,
        t.elapsed().as_secs_f64() * 1e3
    );
    if s.degenerate_dropped > 0 {
        eprintln!(
            "warning: {} degenerate triangles dropped",
            s.degenerate_dropped
        );
    }
    Ok(scene)
}

fn render(a: &RenderArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let settings = Settings::resolve(
        a.algorithm.as_deref(),
        scene.integrator.as_ref(),
        &parse_params(&a.params)?,
    )?;
    settings.check_scene(&scene)?;
    let halt = match (a.spp, a.time) {
        (None, None) => Halt {
            iterations: Some(16),
            time: None,
        },
        (spp, time) => Halt {
            iterations: spp,
            time: time.map(Duration::from_secs_f64),
        },
    };
    let out = render_with_progress(&scene, &settings, a.seed, halt, "");
    let image = out.image();
    write_outputs(a, &scene, &image, &out.film.layer_images())?;
    print_summary(
        settings.name(),
        out.iterations,
        out.elapsed,
        &out.stats,
        out.film.dropped(),
    );
    Ok(())
}

/// A progress bar over iterations, or over milliseconds for a time budget, with an
/// optional label in front.
fn progress_bar(halt: Halt, label: &str) -> ProgressBar {
    let (len, unit) = match (halt.iterations, halt.time) {
        (Some(n), _) => (n, "it"),
        (None, Some(t)) => (t.as_millis() as u64, "ms"),
        _ => (1, "it"),
    };
    let bar = ProgressBar::new(len);
    let style =
        format!("{{prefix}}{{bar:40}} {{pos}}/{{len}} {unit} {{msg}} [{{elapsed}} < {{eta}}]");
    bar.set_style(ProgressStyle::with_template(&style).expect("template"));
    if !label.is_empty() {
        bar.set_prefix(format!("{label} "));
    }
    bar
}

/// Advances `bar` after `i` iterations and `elapsed` time.
fn show_progress(bar: &ProgressBar, by_count: bool, i: u64, elapsed: Duration) {
    if by_count {
        bar.set_position(i);
    } else {
        bar.set_position(elapsed.as_millis() as u64);
    }
    bar.set_message(format!("{i} it"));
}

/// `driver::render` with a progress bar on stderr.
fn render_with_progress(
    scene: &Scene,
    settings: &Settings,
    seed: u64,
    halt: Halt,
    label: &str,
) -> driver::RenderOutcome {
    let integrator = settings.build();
    let bar = progress_bar(halt, label);
    let by_count = halt.iterations.is_some();
    let out = driver::render(scene, integrator.as_ref(), seed, halt, |i, el| {
        show_progress(&bar, by_count, i, el)
    });
    bar.finish_and_clear();
    out
}

fn reference(a: &ReferenceArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let settings = Settings::resolve(
        a.algorithm.as_deref(),
        scene.integrator.as_ref(),
        &parse_params(&a.params)?,
    )?;
    settings.check_scene(&scene)?;
    let halt = Halt {
        iterations: a.spp,
        time: a.time.map(Duration::from_secs_f64),
    };
    let out = render_with_progress(&scene, &settings, a.seed, halt, "");
    let image = out.image();
    film::write_exr(&a.output, &image)?;
    eprintln!("wrote {}", a.output.display());
    if let Some(p) = &a.png {
        film::write_png(p, &image, 0.0)?;
        eprintln!("wrote {}", p.display());
    }
    print_summary(
        settings.name(),
        out.iterations,
        out.elapsed,
        &out.stats,
        out.film.dropped(),
    );
    Ok(())
}

/// Writes the image, with the integrator's own layers (technique or strategy parts)
/// and, with `--exr-layers`, albedo and normal layers.
fn write_outputs(
    a: &RenderArgs,
    scene: &Scene,
    image: &Image,
    own: &[(String, Image)],
) -> Result<()> {
    let mut layers: Vec<(&str, &Image)> = own.iter().map(|(n, i)| (n.as_str(), i)).collect();
    let aovs;
    if a.exr_layers {
        let aov = |s: Settings| {
            driver::render(
                scene,
                s.build().as_ref(),
                a.seed,
                Halt {
                    iterations: Some(4),
                    time: None,
                },
                |_, _| {},
            )
            .image()
        };
        aovs = [aov(Settings::Albedo {}), aov(Settings::Normals {})];
        layers.push(("albedo", &aovs[0]));
        layers.push(("normal", &aovs[1]));
    }
    if layers.is_empty() {
        film::write_exr(&a.output, image)?;
    } else {
        film::write_exr_layers(&a.output, image, &layers)?;
    }
    eprintln!("wrote {}", a.output.display());
    if let Some(p) = &a.png {
        film::write_png(p, image, a.exposure)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

fn print_summary(alg: &str, iterations: u64, elapsed: Duration, s: &RenderStats, dropped: u64) {
    let secs = elapsed.as_secs_f64().max(1e-9);
    println!(
        "{alg}: {iterations} iterations in {secs:.3} s ({:.2} ms/iteration), {:.3} M samples/s, {:.2} M rays/s ({} closest + {} shadow), {dropped} dropped samples",
        secs * 1e3 / iterations.max(1) as f64,
        s.samples as f64 / secs / 1e6,
        (s.rays + s.shadow_rays) as f64 / secs / 1e6,
        s.rays,
        s.shadow_rays,
    );
    if s.light_vertices > 0 || s.merges > 0 || s.connections > 0 {
        let n = iterations.max(1) as f64;
        println!(
            "  per iteration: {:.0} light vertices stored ({:.1} MiB of vertex storage), {:.0} connections, {:.0} merges; last merge radius {:.3e}",
            s.light_vertices as f64 / n,
            s.vertex_bytes as f64 / 1048576.0,
            s.connections as f64 / n,
            s.merges as f64 / n,
            s.merge_radius,
        );
    }
}

fn diff(a: &Path, b: &Path, png: Option<&Path>) -> Result<()> {
    let ia = film::read_image(a)?;
    let ib = film::read_image(b)?;
    let m = film::compare(&ia, &ib)?;
    println!("rmse {:.6e}\nrel_mse {:.6e}", m.rmse, m.rel_mse);
    let (ma, mb) = (ia.mean(), ib.mean());
    println!(
        "mean_a {:.6} {:.6} {:.6}\nmean_b {:.6} {:.6} {:.6}",
        ma.x, ma.y, ma.z, mb.x, mb.y, mb.z
    );
    if let Some(p) = png {
        let d = film::false_colour_diff(&ia, &ib)?;
        film::write_png(p, &d, 0.0).with_context(|| format!("writing {}", p.display()))?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The algorithms of `--algorithms`, each resolved against the scene and `--param`.
fn bench_settings(a: &BenchArgs, scene: &Scene) -> Result<Vec<Settings>> {
    let params = parse_params(&a.params)?;
    a.algorithms
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|alg| {
            let s = Settings::resolve(Some(alg), scene.integrator.as_ref(), &params)?;
            s.check_scene(scene)?;
            Ok(s)
        })
        .collect()
}

/// Speed: per algorithm, one untimed warm-up iteration, then `--repeat` timed runs of
/// `--spp` iterations; medians of wall and process CPU time per iteration.
fn bench(a: &BenchArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let all = bench_settings(a, &scene)?;
    println!(
        "{:<10} {:>12} {:>15} {:>14} {:>12} {:>10} {:>9}",
        "algorithm",
        "ms/iteration",
        "CPU s/iteration",
        "M samples/s",
        "M rays/s",
        "dropped",
        "peak MiB"
    );
    let iterations = |n| Halt {
        iterations: Some(n),
        time: None,
    };
    for settings in all {
        // Each algorithm's own peak: the scene, plus what its iterations allocate.
        caustic::bench::reset_peak_rss();
        driver::render(
            &scene,
            settings.build().as_ref(),
            1,
            iterations(1),
            |_, _| {},
        );
        let mut ms = Vec::new();
        let mut cpu = Vec::new();
        let mut sps = Vec::new();
        let mut rps = Vec::new();
        let mut dropped = 0;
        for r in 0..a.repeat.max(1) {
            // A fresh integrator per run: algorithms with state start over.
            let integrator = settings.build();
            let sw = caustic::bench::Stopwatch::start();
            let out = driver::render(
                &scene,
                integrator.as_ref(),
                r as u64,
                iterations(a.spp),
                |_, _| {},
            );
            let (_, cpu_time) = sw.elapsed();
            let secs = out.elapsed.as_secs_f64();
            let n = out.iterations.max(1) as f64;
            ms.push(secs * 1e3 / n);
            cpu.push(cpu_time.as_secs_f64() / n);
            sps.push(out.stats.samples as f64 / secs / 1e6);
            rps.push((out.stats.rays + out.stats.shadow_rays) as f64 / secs / 1e6);
            dropped += out.film.dropped();
        }
        println!(
            "{:<10} {:>12.2} {:>15.4} {:>14.3} {:>12.2} {:>10} {:>9}",
            settings.name(),
            median(ms),
            median(cpu),
            median(sps),
            median(rps),
            dropped,
            caustic::bench::peak_rss_mib()
        );
    }
    Ok(())
}

/// `ALG:SECONDS` of `--reference-from`.
fn parse_reference_from(s: &str) -> Result<(String, f64)> {
    let parsed = s
        .rsplit_once(':')
        .and_then(|(alg, t)| Some((alg.trim().to_string(), t.trim().parse::<f64>().ok()?)));
    match parsed {
        Some((alg, t)) if !alg.is_empty() && t > 0.0 && t.is_finite() => Ok((alg, t)),
        _ => bail!("--reference-from {s}: expected ALGORITHM:SECONDS, e.g. vcm:3600"),
    }
}

/// Equal time: every algorithm runs for `time` seconds of iterations; the error
/// against the reference is measured at log-spaced times (untimed).
fn bench_equal_time(a: &BenchArgs, time: f64) -> Result<()> {
    if !(time > 0.0 && time.is_finite()) {
        bail!("--time {time}: expected a positive number of seconds");
    }
    let scene = load_scene(&a.scene)?;
    let all = bench_settings(a, &scene)?;
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let reference = match (&a.reference, &a.reference_from) {
        (Some(path), _) => film::read_image(path)?,
        (None, Some(spec)) => {
            let (alg, secs) = parse_reference_from(spec)?;
            let params = parse_params(&a.params)?;
            let settings = Settings::resolve(Some(&alg), scene.integrator.as_ref(), &params)?;
            settings.check_scene(&scene)?;
            let halt = Halt {
                iterations: None,
                time: Some(Duration::from_secs_f64(secs)),
            };
            let seed = a.seed.wrapping_add(1);
            let out = render_with_progress(&scene, &settings, seed, halt, "reference");
            let image = out.image();
            let path = a.output.join("reference.exr");
            film::write_exr(&path, &image)?;
            eprintln!(
                "reference: {alg}, {} iterations in {:.1} s, wrote {}",
                out.iterations,
                out.elapsed.as_secs_f64(),
                path.display()
            );
            image
        }
        (None, None) => {
            bail!("--time needs a reference: --reference EXR or --reference-from ALG:SECONDS")
        }
    };
    let plan = caustic::bench::Plan {
        seed: a.seed,
        budget: Duration::from_secs_f64(time),
        points: a.points,
    };
    let halt = Halt {
        iterations: None,
        time: Some(plan.budget),
    };
    let mut runs = Vec::new();
    let mut peaks = Vec::new();
    for settings in &all {
        let label = unique_label(settings.name(), &runs);
        caustic::bench::reset_peak_rss();
        let integrator = settings.build();
        let bar = progress_bar(halt, &label);
        let run = caustic::bench::converge(
            &label,
            &scene,
            integrator.as_ref(),
            &reference,
            plan,
            |i, el| show_progress(&bar, false, i, el),
        )?;
        bar.finish_and_clear();
        peaks.push(caustic::bench::peak_rss_mib());
        let path = a.output.join(format!("{label}.exr"));
        film::write_exr(&path, &run.image())?;
        runs.push(run);
    }
    let csv = a.output.join("bench.csv");
    caustic::bench::write_csv(&csv, &runs)?;
    let png = a.output.join("rmse_vs_time.png");
    let title = format!(
        "{}: RMSE vs time",
        a.scene.file_stem().unwrap_or_default().to_string_lossy()
    );
    caustic::bench::plot_rmse_vs_time(&png, &title, &runs)?;
    eprintln!(
        "wrote {}, {} and the final images in {}",
        csv.display(),
        png.display(),
        a.output.display()
    );
    println!(
        "{:<10} {:>10} {:>9} {:>9} {:>12} {:>12} {:>10} {:>8} {:>9}",
        "algorithm",
        "iterations",
        "time s",
        "CPU s",
        "RMSE",
        "rel MSE",
        "M rays/s",
        "dropped",
        "peak MiB"
    );
    for (run, peak) in runs.iter().zip(&peaks) {
        let p = run.last();
        println!(
            "{:<10} {:>10} {:>9.2} {:>9.2} {:>12.4e} {:>12.4e} {:>10.2} {:>8} {:>9}",
            run.label,
            p.iteration,
            p.elapsed_s,
            p.cpu_s,
            p.rmse,
            p.rel_mse,
            p.rays_per_s() / 1e6,
            p.dropped,
            peak
        );
    }
    Ok(())
}

/// `name`, or `name-2`, `name-3`, ... when earlier runs already use it.
fn unique_label(name: &str, runs: &[caustic::bench::ConvergenceRun]) -> String {
    let taken = |l: &str| runs.iter().any(|r| r.label == l);
    if !taken(name) {
        return name.to_string();
    }
    (2..)
        .map(|k| format!("{name}-{k}"))
        .find(|l| !taken(l))
        .expect("a free label")
}

fn serve(a: ServeArgs) -> Result<()> {
    let mut config = caustic::job::ServiceConfig::new(&a.data_dir);
    config.workers = a.workers.unwrap_or(0);
    config.max_resolution = a.max_resolution;
    config.max_upload = a.max_upload_mib << 20;
    config.max_active_jobs = a.max_active_jobs as usize;
    config.retention = retention(&a)?;
    if !(a.request_timeout.is_finite() && a.request_timeout > 0.0) {
        bail!(
            "--request-timeout {}: expected a positive number of seconds",
            a.request_timeout
        );
    }
    config.header_timeout = Duration::from_secs_f64(a.request_timeout);
    config.body_timeout = config.header_timeout;
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
        eprintln!("caustic serving REST on {url} and gRPC on {}", grpc.local_addr()?);
        eprintln!("data directory: {}", a.data_dir.display());
        eprintln!(
            "try: curl -X POST {url}/v1/jobs -H 'content-type: application/json' -d '{{\"scene\": \"cornell-box\", \"halt\": {{\"spp\": 64}}}}'"
        );
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
        let grpc_server = caustic::server::grpc::serve(grpc, svc.clone(), a.token.clone(), stopped());
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

// Client commands: thin wrappers over `caustic::client`.

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
        reference_job: j.reference_job,
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

fn submit(a: SubmitArgs) -> Result<()> {
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

fn watch(a: WatchArgs) -> Result<()> {
    let c = connect(&a.server);
    client_exit(caustic::client::watch(
        &c,
        &a.job,
        a.json,
        &mut std::io::stdout(),
    ))
}

fn jobs(a: JobsArgs) -> Result<()> {
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

fn sweep(a: SweepArgs) -> Result<()> {
    let o = caustic::client::SweepOptions {
        scene: a.scene,
        grid: a.grid,
        file: a.file,
        job: job_options(a.job, None, a.tags),
        name: a.name,
        no_wait: a.no_wait,
        csv: a.csv,
        json: a.json,
    };
    client_exit(caustic::client::sweep(
        &connect(&a.server),
        &o,
        &mut std::io::stdout(),
    ))
}
