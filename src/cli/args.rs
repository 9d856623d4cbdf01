//! The command line's arguments (clap): one struct per command.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "caustic",
    version,
    about = "Progressive physically based rendering"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
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
    /// Convert a Mitsuba 3 XML scene to caustic's JSON scene format, printing what the
    /// import approximated. (`render`, `bench`, `reference` and `submit` also take
    /// `.xml` scenes directly.)
    Import(ImportArgs),
    /// Render a long reference image for error measurements (as `render`, with a time
    /// budget, and a seed unlike the default one of `render` and `bench`); or, as
    /// `reference upload FILE.exr`, upload one to a server.
    Reference(ReferenceCommand),
    /// Measure speed (ms and CPU s per iteration, samples/s, rays/s; median of
    /// repeats), or with --time compare algorithms at equal time: RMSE against a
    /// reference over time, a CSV, a log-log plot and each algorithm's image.
    Bench(BenchArgs),
    /// Run the render server (REST and gRPC) on a local data directory.
    Serve(ServeArgs),
    /// Render work units for a server started with --nats: pull iteration ranges from
    /// the NATS JetStream work queue, render them, return their sums.
    Worker(WorkerArgs),
    /// Internal: reads one grid of an OpenVDB file for a server or worker, in a
    /// process of its own, and writes it as a Mitsuba .vol to standard output.
    #[command(hide = true)]
    VdbGrid {
        file: PathBuf,
        #[arg(long)]
        grid: String,
        /// Address space this process may use, in bytes.
        #[arg(long)]
        memory: u64,
    },
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
    /// Cancel a queued, running or paused job (it keeps its checkpoint: `retry`
    /// resumes it).
    Cancel(JobIdArgs),
    /// Pause a queued or running job (a running one at the end of its batch).
    Pause(JobIdArgs),
    /// Queue a paused job again.
    Resume(JobIdArgs),
    /// Queue a failed or cancelled job again: it resumes from its checkpoint.
    Retry(JobIdArgs),
    /// Delete a job that is not running, with its images and logs.
    Delete(JobIdArgs),
    /// Run a parameter sweep on a server and print its table.
    ///
    /// Exit status: 0 when every job completed, 1 when some did not, 2 on errors.
    Sweep(SweepArgs),
}

/// Which server a client command talks to.
#[derive(Args)]
pub struct ServerArgs {
    /// Server URL.
    #[arg(long, env = "CAUSTIC_SERVER", default_value = caustic::client::DEFAULT_SERVER)]
    pub server: String,
    /// Bearer token, for a server started with --token.
    #[arg(long, env = "CAUSTIC_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
}

/// Job settings shared by `submit` and `sweep`.
#[derive(Args)]
pub struct JobArgs {
    /// Algorithm (default: the scene's, else pt).
    #[arg(long, short)]
    pub algorithm: Option<String>,
    /// Halt after this many samples per pixel.
    #[arg(long, conflicts_with = "iterations")]
    pub spp: Option<u64>,
    /// Halt after this many seconds of rendering.
    #[arg(long, value_name = "SECONDS", value_parser = finite)]
    pub time: Option<f64>,
    /// Halt after this many iterations (light-pass algorithms).
    #[arg(long)]
    pub iterations: Option<u64>,
    /// Halt when the RMSE against the reference falls to this value.
    #[arg(long, requires = "any_reference", value_parser = finite)]
    pub target_rmse: Option<f64>,
    /// Halt when the image's estimated relative error, from its own iterations, falls
    /// to this value (0.01 for 1 %); needs no reference.
    #[arg(long, value_name = "REL_ERROR", value_parser = positive)]
    pub noise: Option<f64>,
    /// Add a per-pixel variance layer to the EXR snapshots and the final EXR.
    #[arg(long)]
    pub variance_layer: bool,
    /// A completed job whose image is the reference for RMSE logs.
    #[arg(long, value_name = "JOB", group = "any_reference")]
    pub reference_job: Option<String>,
    /// The reference for RMSE logs: a local EXR file (uploaded first), the id that
    /// `caustic reference upload` printed, a job id, or `job:ID` / `upload:ID`.
    #[arg(long, value_name = "REF", group = "any_reference")]
    pub reference: Option<String>,
    #[arg(long)]
    pub seed: Option<u64>,
    /// Algorithm parameter, repeatable: --param max_depth=8
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
    /// Higher runs first.
    #[arg(long, allow_negative_numbers = true)]
    pub priority: Option<i32>,
    /// Write a snapshot every N iterations.
    #[arg(long, value_name = "N", conflicts_with = "snapshot_every_seconds")]
    pub snapshot_every_iterations: Option<u64>,
    /// Write a snapshot every S seconds (server default: 5).
    #[arg(long, value_name = "S", value_parser = finite)]
    pub snapshot_every_seconds: Option<f64>,
}

#[derive(Args)]
pub struct SubmitArgs {
    /// A built-in or uploaded scene id, or a local scene file (.json; the meshes and
    /// maps it names are bundled) or bundle (.tar, .zip) to upload.
    pub scene: String,
    #[command(flatten)]
    pub job: JobArgs,
    #[arg(long)]
    pub name: Option<String>,
    /// Tag, repeatable.
    #[arg(long = "tag", value_name = "TAG")]
    pub tags: Vec<String>,
    /// Follow the job to its end, as `caustic watch`.
    #[arg(long)]
    pub watch: bool,
    /// Print the job as JSON (with --watch: one line, then one line per event).
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub server: ServerArgs,
}

#[derive(Args)]
pub struct WatchArgs {
    /// Job id.
    pub job: String,
    /// Print each event as one JSON line instead of the progress bar.
    #[arg(long)]
    pub json: bool,
    /// Show each snapshot in the tev viewer listening at HOST:PORT.
    #[arg(long, value_name = "HOST:PORT")]
    pub tev: Option<String>,
    #[command(flatten)]
    pub server: ServerArgs,
}

/// The commands that change one job on a server.
#[derive(Args)]
pub struct JobIdArgs {
    /// Job id.
    pub job: String,
    /// Print the job as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub server: ServerArgs,
}

#[derive(Args)]
pub struct JobsArgs {
    /// Only jobs in this state (queued, running, paused, completed, cancelled, failed).
    #[arg(long)]
    pub state: Option<String>,
    /// Only jobs with this tag.
    #[arg(long)]
    pub tag: Option<String>,
    /// Only the jobs of this sweep.
    #[arg(long)]
    pub sweep: Option<String>,
    /// Print the jobs as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub server: ServerArgs,
}

#[derive(Args)]
pub struct SweepArgs {
    /// Scene id or local scene file, as for `submit` (with --file: overrides its scene).
    #[arg(required_unless_present = "file")]
    pub scene: Option<String>,
    /// Grid axis, repeatable: --grid algorithm=pt,albedo --grid params.max_depth=2,4.
    /// Keys: algorithm, seed, priority, spp, iterations, time, target_rmse, noise (or
    /// halt.<key>), params.<name>. Values are JSON when they parse, else strings.
    #[arg(
        long = "grid",
        value_name = "KEY=V1,V2,...",
        required_unless_present = "file"
    )]
    pub grid: Vec<String>,
    /// Read a full sweep spec ({"base": job, "grid": {...}, "name": ...}) from this
    /// JSON file; other options override its values.
    #[arg(long)]
    pub file: Option<PathBuf>,
    #[command(flatten)]
    pub job: JobArgs,
    /// The sweep's name.
    #[arg(long)]
    pub name: Option<String>,
    /// Tag every job, repeatable.
    #[arg(long = "tag", value_name = "TAG")]
    pub tags: Vec<String>,
    /// Print the sweep id and return at once.
    #[arg(long)]
    pub no_wait: bool,
    /// Print the final table as CSV.
    #[arg(long, conflicts_with = "json")]
    pub csv: bool,
    /// Print the final table as JSON.
    #[arg(long)]
    pub json: bool,
    /// One job per grid point, even where points differ only in params.radius (by
    /// default those share one job that renders the other radii as layers).
    #[arg(long)]
    pub separate_radii: bool,
    #[command(flatten)]
    pub server: ServerArgs,
}

#[derive(Args)]
pub struct ServeArgs {
    /// REST address.
    #[arg(long, default_value = "127.0.0.1:7878")]
    pub addr: std::net::SocketAddr,
    /// gRPC address.
    #[arg(long, default_value = "127.0.0.1:7879")]
    pub grpc_addr: std::net::SocketAddr,
    /// Where scenes, jobs and images are kept.
    #[arg(long, default_value = "caustic-data")]
    pub data_dir: PathBuf,
    /// Render threads (default: all cores).
    #[arg(long, alias = "threads")]
    pub workers: Option<usize>,
    /// Require `Authorization: Bearer TOKEN` on every request (except /healthz).
    #[arg(long, env = "CAUSTIC_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Largest image side a job may render.
    #[arg(long, default_value_t = 8192)]
    pub max_resolution: u32,
    /// Largest upload in MiB.
    #[arg(long, default_value_t = 256)]
    pub max_upload_mib: u64,
    /// Most primitives (triangles, spheres, ...) a scene may compile to.
    #[arg(long, default_value_t = caustic::scene::CompileBudget::SERVER.max_primitives)]
    pub max_primitives: usize,
    /// Jobs whose render state is held in memory at once; the others wait queued,
    /// their checkpoints on disk (a job of higher priority sets a lower one aside).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_active_jobs: u32,
    /// Largest estimated peak memory of one job, in MiB: jobs above it are refused when
    /// submitted (default: the machine's memory, or its container's limit, divided by
    /// --max-active-jobs).
    #[arg(long, value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_job_mib: Option<u64>,
    /// Delete finished jobs (completed, cancelled, failed) this many days after they
    /// ended. Running, queued and paused jobs are never deleted.
    #[arg(long, value_name = "DAYS")]
    pub retention_days: Option<f64>,
    /// Delete the oldest finished jobs while the job folders hold more than this many
    /// GiB.
    #[arg(long, value_name = "GIB")]
    pub retention_gib: Option<f64>,
    /// Seconds a connection may wait for a request's headers (idle keep-alive
    /// connections too) and a body may pause before the server gives up on it.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub request_timeout: f64,
    /// Coordinate a pool of `caustic worker` processes through this NATS server (with
    /// JetStream) instead of rendering here: nats://host:4222, credentials as
    /// nats://TOKEN@host:4222 or nats://USER:PASSWORD@host:4222.
    #[arg(long, env = "CAUSTIC_NATS", hide_env_values = true, value_name = "URL")]
    pub nats: Option<String>,
}

#[derive(Args)]
pub struct WorkerArgs {
    /// The NATS server the coordinator (`caustic serve --nats`) uses, with the same
    /// credentials form.
    #[arg(long, env = "CAUSTIC_NATS", hide_env_values = true, value_name = "URL")]
    pub nats: String,
    /// Render threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Name shown for this worker (default: host name and process id).
    #[arg(long)]
    pub name: Option<String>,
    /// Where fetched scenes are kept.
    #[arg(long, default_value = "caustic-worker-cache")]
    pub cache_dir: PathBuf,
    /// Largest scene bundle accepted, in MiB.
    #[arg(long, default_value_t = 256)]
    pub max_scene_mib: u64,
    /// Most primitives a scene may compile to (as the coordinator's `--max-primitives`).
    #[arg(long, default_value_t = caustic::scene::CompileBudget::SERVER.max_primitives)]
    pub max_primitives: usize,
    /// Benchmark only (bench-pool-scaling.sh): play this many workers that answer
    /// with copies of one real result, so the images are wrong.
    #[arg(long, hide = true)]
    pub simulate: Option<usize>,
    /// Seconds per iteration the simulated workers pretend to take.
    #[arg(long, hide = true, default_value_t = 1.0)]
    pub simulate_iteration_s: f64,
}

#[derive(Args)]
pub struct ImportArgs {
    /// The Mitsuba 3 XML scene.
    pub scene: PathBuf,
    /// Where to write the JSON scene (standard output when not given, its file
    /// references relative to the XML's folder). In another folder, the files the
    /// scene names are copied beside it (or named by their path from there, when the
    /// XML's folder is inside it).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

#[derive(Args)]
pub struct RenderArgs {
    pub scene: PathBuf,
    /// Algorithm (default: the scene's, else pt).
    #[arg(long, short)]
    pub algorithm: Option<String>,
    /// Iterations (samples per pixel for pt).
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u64>,
    /// Wall-clock budget in seconds.
    #[arg(long, value_parser = finite)]
    pub time: Option<f64>,
    /// Stop when the image's estimated relative error, from its own iterations, falls
    /// to this value (0.01 for 1 %), after at least 16 iterations; with --spp or
    /// --time, whichever comes first.
    #[arg(long, value_name = "REL_ERROR", value_parser = positive)]
    pub noise: Option<f64>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Algorithm parameter, repeatable: --param max_depth=8
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
    /// Output EXR (linear float32 RGB).
    #[arg(short, long, default_value = "out.exr")]
    pub output: PathBuf,
    /// Also write an sRGB PNG here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Add albedo and normal layers to the EXR.
    #[arg(long)]
    pub exr_layers: bool,
    /// Stream the image, as it converges, to the tev viewer listening at HOST:PORT.
    #[arg(long, value_name = "HOST:PORT")]
    pub tev: Option<String>,
}

/// `caustic reference`: a local render, or `reference upload`.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct ReferenceCommand {
    #[command(subcommand)]
    pub action: Option<ReferenceAction>,
    #[command(flatten)]
    pub render: Option<ReferenceArgs>,
}

#[derive(Subcommand)]
pub enum ReferenceAction {
    /// Upload a reference EXR to a server and print its id, for `submit --reference
    /// ID` (or a job body's `"reference": {"upload": ID}`).
    Upload(ReferenceUploadArgs),
}

#[derive(Args)]
pub struct ReferenceUploadArgs {
    /// The image (OpenEXR).
    pub file: PathBuf,
    #[command(flatten)]
    pub server: ServerArgs,
}

#[derive(Args)]
pub struct ReferenceArgs {
    pub scene: PathBuf,
    /// Algorithm (default: the scene's, else pt).
    #[arg(long, short)]
    pub algorithm: Option<String>,
    /// Wall-clock budget in seconds.
    #[arg(
        long,
        value_name = "SECONDS",
        required_unless_present = "spp",
        value_parser = finite
    )]
    pub time: Option<f64>,
    /// A number of iterations instead of a time budget.
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u64>,
    /// 1 by default, so that a reference shares no samples with a `render` or
    /// `bench` run at their default seed 0.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Algorithm parameter, repeatable: --param max_depth=8
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
    /// Output EXR (linear float32 RGB).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write an sRGB PNG here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Also write each pixel's estimated variance (of its mean, from the reference's
    /// own iterations) as the EXR layer `variance`, so that error measurements can
    /// take the reference's own noise out of squared errors.
    #[arg(long)]
    pub variance_layer: bool,
}

#[derive(Args)]
pub struct BenchArgs {
    pub scene: PathBuf,
    /// Comma-separated algorithms, each with its own parameters after colons
    /// (`vrl:sampler=uniform,vpl:clamp=compensate`); `--param` applies to all.
    #[arg(long, default_value = "pt")]
    pub algorithms: String,
    /// Speed mode: iterations per timed run.
    #[arg(long, default_value_t = 16, conflicts_with = "time")]
    pub spp: u64,
    /// Speed mode: timed runs per algorithm; the median is reported.
    #[arg(long, default_value_t = 5, conflicts_with = "time")]
    pub repeat: usize,
    /// Equal-time mode: seconds of iterations per algorithm (needs --reference or
    /// --reference-from).
    #[arg(long, value_name = "SECONDS", value_parser = finite)]
    pub time: Option<f64>,
    /// Equal-time mode: the reference image (EXR, or Radiance .hdr).
    #[arg(
        long,
        value_name = "IMAGE",
        requires = "time",
        conflicts_with = "reference_from"
    )]
    pub reference: Option<PathBuf>,
    /// Equal-time mode: render the reference first with this algorithm for this many
    /// seconds (seed --seed + 1), saved as DIR/reference.exr.
    #[arg(long, value_name = "ALG:SECONDS", requires = "time")]
    pub reference_from: Option<String>,
    /// Equal-time mode: output directory (bench.csv, rmse_vs_time.png, <algorithm>.exr).
    #[arg(short, long, value_name = "DIR", default_value = "bench-out")]
    pub output: PathBuf,
    /// Equal-time mode: measuring times per run, spaced evenly on a log scale over
    /// the last three decades of the budget (plus the first iteration and the end).
    #[arg(long, default_value_t = 20)]
    pub points: usize,
    /// Equal-time mode: the seed of every algorithm's run.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
}

/// A number flag's value: finite, or refused as written (`1e999` would be infinity,
/// which no duration or error bound can be).
fn finite(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(format!("{text} is out of range")),
        Err(e) => Err(e.to_string()),
    }
}

/// A finite number above zero.
fn positive(text: &str) -> Result<f64, String> {
    match finite(text)? {
        x if x > 0.0 => Ok(x),
        _ => Err(format!("{text} is not above zero")),
    }
}
