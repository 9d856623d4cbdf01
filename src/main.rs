//! The caustic command line: render, diff and bench.

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
    /// Compare two EXR images: RMSE and relative MSE, optional false-colour PNG.
    Diff {
        a: PathBuf,
        /// The reference.
        b: PathBuf,
        /// Write a false-colour difference image here.
        #[arg(long)]
        png: Option<PathBuf>,
    },
    /// Measure speed: time per iteration, samples/s and rays/s (median of repeats).
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
struct BenchArgs {
    scene: PathBuf,
    /// Comma-separated algorithms.
    #[arg(long, default_value = "pt")]
    algorithms: String,
    /// Iterations per timed run.
    #[arg(long, default_value_t = 16)]
    spp: u64,
    /// Timed runs per algorithm; the median is reported.
    #[arg(long, default_value_t = 5)]
    repeat: usize,
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
    match Cli::parse().command {
        Command::Render(a) => with_threads(a.threads, || render(&a)),
        Command::Diff { a, b, png } => diff(&a, &b, png.as_deref()),
        Command::Bench(a) => with_threads(a.threads, || bench(&a)),
        Command::Serve(a) => serve(a),
        Command::Submit(a) => submit(a),
        Command::Watch(a) => watch(a),
        Command::Jobs(a) => jobs(a),
        Command::Sweep(a) => sweep(a),
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
        "scene: {} triangles, {} spheres, {} disks, {} lights; BVH {:.1} ms, {:.1} KiB; loaded in {:.1} ms",
        s.triangles,
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
    let integrator = settings.build();
    let bar = progress_bar(halt);
    let out = driver::render(&scene, integrator.as_ref(), a.seed, halt, |i, el| {
        match halt.iterations {
            Some(_) => bar.set_position(i),
            None => bar.set_position(el.as_millis() as u64),
        }
        bar.set_message(format!("{i} it"));
    });
    bar.finish_and_clear();
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

fn progress_bar(halt: Halt) -> ProgressBar {
    let (len, unit) = match (halt.iterations, halt.time) {
        (Some(n), _) => (n, "it"),
        (None, Some(t)) => (t.as_millis() as u64, "ms"),
        _ => (1, "it"),
    };
    let bar = ProgressBar::new(len);
    let style = format!("{{bar:40}} {{pos}}/{{len}} {unit} {{msg}} [{{elapsed}} < {{eta}}]");
    bar.set_style(ProgressStyle::with_template(&style).expect("template"));
    bar
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
}

fn diff(a: &Path, b: &Path, png: Option<&Path>) -> Result<()> {
    let ia = film::read_exr(a)?;
    let ib = film::read_exr(b)?;
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

fn bench(a: &BenchArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let params = parse_params(&a.params)?;
    println!(
        "{:<10} {:>12} {:>14} {:>12} {:>10}",
        "algorithm", "ms/iteration", "M samples/s", "M rays/s", "dropped"
    );
    for alg in a.algorithms.split(',').map(str::trim) {
        let settings = Settings::resolve(Some(alg), scene.integrator.as_ref(), &params)?;
        let integrator = settings.build();
        let halt = Halt {
            iterations: Some(a.spp),
            time: None,
        };
        // One untimed warm-up run, then the timed repeats.
        driver::render(
            &scene,
            integrator.as_ref(),
            1,
            Halt {
                iterations: Some(1),
                time: None,
            },
            |_, _| {},
        );
        let mut ms = Vec::new();
        let mut sps = Vec::new();
        let mut rps = Vec::new();
        let mut dropped = 0;
        for r in 0..a.repeat.max(1) {
            let out = driver::render(&scene, integrator.as_ref(), r as u64, halt, |_, _| {});
            let secs = out.elapsed.as_secs_f64();
            ms.push(secs * 1e3 / out.iterations as f64);
            sps.push(out.stats.samples as f64 / secs / 1e6);
            rps.push((out.stats.rays + out.stats.shadow_rays) as f64 / secs / 1e6);
            dropped += out.film.dropped();
        }
        println!(
            "{:<10} {:>12.2} {:>14.3} {:>12.2} {:>10}",
            alg,
            median(ms),
            median(sps),
            median(rps),
            dropped
        );
    }
    Ok(())
}

fn serve(a: ServeArgs) -> Result<()> {
    let mut config = caustic::job::ServiceConfig::new(&a.data_dir);
    config.workers = a.workers.unwrap_or(0);
    config.max_resolution = a.max_resolution;
    config.max_upload = a.max_upload_mib << 20;
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
        let app = caustic::server::http::app(svc.clone(), a.token.clone());
        let grpc_server = async {
            caustic::server::grpc::serve(grpc, svc.clone(), a.token.clone(), shutdown_signal())
                .await
                .map_err(anyhow::Error::from)
        };
        tokio::select! {
            r = axum::serve(http, app).with_graceful_shutdown(shutdown_signal()) => r.map_err(anyhow::Error::from),
            r = grpc_server => r,
        }
    });
    svc.shutdown();
    result
}

async fn shutdown_signal() {
    let _ = tokio::signal::ctrl_c().await;
    eprintln!("shutting down: running jobs resume from their checkpoints on the next start");
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
