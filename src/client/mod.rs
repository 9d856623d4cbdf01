//! The REST client behind `caustic submit / watch / jobs / sweep`: uploads local scenes
//! (bundling the meshes and maps they name), submits jobs and sweeps, follows a job's
//! Server-Sent Events with a progress bar, and prints tables.
//!
//! Every command function writes its results to `out` (stdout in the CLI) and progress
//! to stderr, and returns `Ok(true)` when everything it waited for completed.

mod bundle;
mod control;
mod http;
mod options;
mod progress;
mod sse;
mod table;

pub use bundle::{referenced_files, resolve_scene, resolve_scene_spp, scene_upload, ResolvedScene};
pub use control::{job_action, reference_spec, upload_reference, JobAction};
pub use http::Client;
pub use options::{parse_grid, parse_params, require_halt, JobOptions};
pub use progress::{summary, watch};
pub use sse::{SseMessage, SseReader, WatchEvent};
pub use table::{jobs, sweep_text, JobsOptions};

use crate::job::spec::JobState;
use crate::job::sweep::SweepSpec;
use indicatif::{ProgressBar, ProgressStyle};
use progress::watch_job;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where `caustic serve` listens by default.
pub const DEFAULT_SERVER: &str = "http://127.0.0.1:7878";

#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The server answered with an error status; `code` and `message` come from its
    /// `{"error": {"code", "message"}}` body.
    #[error("{status} {code}: {message}")]
    Server {
        status: u16,
        code: String,
        message: String,
    },
    /// No answer: connection refused, DNS, timeout, broken stream.
    #[error("cannot reach the server: {0}")]
    Transport(String),
    /// The server answered something this client does not understand.
    #[error("unexpected response from {url}: {message}")]
    Protocol { url: String, message: String },
    /// A command-line value is malformed.
    #[error("{0}")]
    Input(String),
    /// A local file could not be read.
    #[error("{path}: {message}")]
    File { path: String, message: String },
    /// `--tev` names no address or no viewer listens there.
    #[error(transparent)]
    Tev(#[from] crate::tev::TevError),
    /// Writing the results failed (e.g. a closed pipe).
    #[error("writing output: {0}")]
    Output(#[from] std::io::Error),
}

type Result<T, E = ClientError> = std::result::Result<T, E>;

fn file_error(path: &Path, e: impl std::fmt::Display) -> ClientError {
    ClientError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

// ---------------------------------------------------------------------------------
// Commands

pub struct SubmitOptions {
    /// Scene id or local scene file.
    pub scene: String,
    pub job: JobOptions,
    pub watch: bool,
    pub json: bool,
}

/// `caustic submit`: prints the job id (or the job as JSON), then follows it with
/// `watch`. Returns whether the job completed (always true without `watch`).
pub fn submit(client: &Client, o: &SubmitOptions, out: &mut impl Write) -> Result<bool> {
    let scene = resolve_scene_spp(client, &o.scene, None)?;
    let mut spec = o.job.spec(&scene.id)?;
    if let Some(r) = &o.job.reference {
        spec.reference = Some(reference_spec(client, r)?);
    }
    if spec.halt == crate::job::HaltSpec::default() {
        // As `caustic render` does: an XML scene's sampler says how many samples.
        spec.halt.spp = scene.spp.map(u64::from);
    }
    require_halt(&spec)?;
    let job = client.submit(&spec)?;
    if o.json {
        if o.watch {
            // One JSON document per line, followed by the event lines.
            writeln!(
                out,
                "{}",
                serde_json::to_string(&job).expect("job serialises")
            )?;
        } else {
            writeln!(
                out,
                "{}",
                serde_json::to_string_pretty(&job).expect("job serialises")
            )?;
        }
    } else {
        writeln!(out, "{}", job.job.id)?;
    }
    out.flush()?;
    if o.watch {
        watch_job(client, job.job, o.json, &mut |_, _| {}, out)
    } else {
        Ok(true)
    }
}

pub struct SweepOptions {
    /// Scene id or local scene file; with `file`, overrides the file's base scene.
    pub scene: Option<String>,
    pub grid: Vec<String>,
    /// A SweepSpec JSON file; the other options override its values.
    pub file: Option<PathBuf>,
    pub job: JobOptions,
    /// The sweep's name.
    pub name: Option<String>,
    pub no_wait: bool,
    pub csv: bool,
    pub json: bool,
    /// One job per grid point even where points differ only in `params.radius`.
    pub separate_radii: bool,
}

fn sweep_spec(client: &Client, o: &SweepOptions) -> Result<SweepSpec> {
    // An XML scene's sample count, for a sweep that sets no halt.
    let mut scene_spp = None;
    let mut spec = match &o.file {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| file_error(path, e))?;
            let mut spec: SweepSpec = serde_json::from_str(&text).map_err(|e| {
                file_error(
                    path,
                    crate::json_numbers::name_out_of_range(&e.to_string(), &text),
                )
            })?;
            if o.scene.is_none() {
                // A scene file named by the sweep file is relative to the sweep file.
                let dir = path.parent().unwrap_or(Path::new("."));
                let scene = resolve_scene_spp(client, &spec.base.scene, Some(dir))?;
                (spec.base.scene, scene_spp) = (scene.id, scene.spp);
            }
            spec
        }
        None => SweepSpec {
            base: JobOptions::default().spec("")?,
            grid: BTreeMap::new(),
            name: None,
            radius_layers: true,
        },
    };
    if let Some(scene) = &o.scene {
        let scene = resolve_scene_spp(client, scene, None)?;
        (spec.base.scene, scene_spp) = (scene.id, scene.spp);
    }
    o.job.apply(&mut spec.base)?;
    if let Some(r) = &o.job.reference {
        spec.base.reference = Some(reference_spec(client, r)?);
    }
    for (k, v) in parse_grid(&o.grid)? {
        spec.grid.insert(k, v);
    }
    if !spec.grid.keys().any(|k| k.starts_with("halt.")) {
        if spec.base.halt == crate::job::HaltSpec::default() {
            spec.base.halt.spp = scene_spp.map(u64::from);
        }
        require_halt(&spec.base)?;
    }
    if o.name.is_some() {
        spec.name = o.name.clone();
    }
    if o.separate_radii {
        spec.radius_layers = false;
    }
    Ok(spec)
}

/// `caustic sweep`: creates a sweep, waits for its jobs with one progress bar and
/// prints its table (or CSV, or JSON). Returns whether every job completed.
pub fn sweep(client: &Client, o: &SweepOptions, out: &mut impl Write) -> Result<bool> {
    let spec = sweep_spec(client, o)?;
    let mut table = client.create_sweep(&spec)?;
    let id = table.id.clone();
    if o.no_wait {
        if o.json {
            writeln!(
                out,
                "{}",
                serde_json::to_string_pretty(&table).expect("table")
            )?;
        } else {
            writeln!(out, "{id}")?;
        }
        return Ok(true);
    }
    // Points that differ only in a radius may share a job (its radius layers).
    let jobs: std::collections::BTreeSet<&str> =
        table.rows.iter().map(|r| r.job.as_str()).collect();
    eprintln!(
        "sweep {id}: {} points, {} jobs",
        table.rows.len(),
        jobs.len()
    );
    let bar = ProgressBar::new(table.rows.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} points  {msg} [{elapsed}]")
            .expect("template"),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    loop {
        let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
        for r in &table.rows {
            *counts.entry(r.state.as_str()).or_default() += 1;
        }
        let done = table.rows.iter().filter(|r| r.state.is_terminal()).count();
        bar.set_position(done as u64);
        bar.set_message(
            counts
                .iter()
                .map(|(s, n)| format!("{n} {s}"))
                .collect::<Vec<_>>()
                .join(", "),
        );
        if done == table.rows.len() {
            break;
        }
        std::thread::sleep(Duration::from_millis(500));
        table = match client.sweep(&id) {
            Ok(t) => t,
            Err(e) => {
                bar.finish_and_clear();
                return Err(e);
            }
        };
    }
    bar.finish_and_clear();
    let ok = table.rows.iter().all(|r| r.state == JobState::Completed);
    if o.csv {
        out.write_all(client.sweep_csv(&id)?.as_bytes())?;
    } else if o.json {
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&table).expect("table")
        )?;
    } else {
        out.write_all(sweep_text(&table).as_bytes())?;
    }
    Ok(ok)
}

#[cfg(test)]
mod tests {
    use super::http::segment;
    use super::table::table;
    use super::*;
    use crate::job::spec::{ReferenceSpec, SnapshotEvery};
    use serde_json::Value;

    #[test]
    fn sse_messages_are_parsed_and_keepalives_skipped() {
        let text = ": keep-alive\n\nevent: progress\ndata: {\"a\":1}\n\nevent:done\ndata:x\ndata: y\r\n\r\ndata: z\n\nevent: cut\ndata: 1";
        let mut r = SseReader::new(text.as_bytes());
        let m = |e: &str, d: &str| SseMessage {
            event: e.into(),
            data: d.into(),
        };
        assert_eq!(r.next_message().unwrap(), Some(m("progress", "{\"a\":1}")));
        assert_eq!(r.next_message().unwrap(), Some(m("done", "x\ny")));
        assert_eq!(r.next_message().unwrap(), Some(m("message", "z")));
        assert_eq!(r.next_message().unwrap(), None);
    }

    #[test]
    fn grid_values_are_json_when_possible() {
        let g = parse_grid(&[
            "algorithm=pt,albedo".into(),
            "spp=1,2.5".into(),
            "params.x=[[1,2],[3]]".into(),
        ])
        .unwrap();
        assert_eq!(
            g["algorithm"],
            vec![Value::from("pt"), Value::from("albedo")]
        );
        assert_eq!(g["halt.spp"], vec![Value::from(1), Value::from(2.5)]);
        assert_eq!(g["params.x"].len(), 2);
        assert!(parse_grid(&["spp".into()]).is_err());
        assert!(parse_grid(&["spp=1,,2".into()]).is_err());
    }

    #[test]
    fn options_override_a_spec() {
        let o = JobOptions {
            spp: Some(4),
            params: vec!["max_depth=3".into(), "mode=fast".into()],
            snapshot_every_iterations: Some(2),
            reference_job: Some("j1".into()),
            tags: vec!["t".into()],
            ..Default::default()
        };
        let s = o.spec("cornell-box").unwrap();
        assert_eq!(s.halt.spp, Some(4));
        assert_eq!(s.params["max_depth"], 3);
        assert_eq!(s.params["mode"], "fast");
        assert_eq!(s.snapshot_every, SnapshotEvery::Iterations(2));
        assert_eq!(s.reference, Some(ReferenceSpec::Job("j1".into())));
        assert_eq!(s.tags, vec!["t".to_string()]);
        assert!(JobOptions {
            params: vec!["oops".into()],
            ..Default::default()
        }
        .spec("x")
        .is_err());
    }

    #[test]
    fn scenes_with_files_become_deterministic_tar_bundles() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        std::fs::write(dir.join("meshes/a.obj"), "mtllib a.mtl\nv 0 0 0\n").unwrap();
        std::fs::write(dir.join("meshes/a.mtl"), "newmtl x\n").unwrap();
        let scene = serde_json::json!({"shapes": [{"type": "obj", "filename": "./meshes/a.obj"}]});
        std::fs::write(dir.join("s.json"), scene.to_string()).unwrap();
        let (a, ct, n) = scene_upload(&dir.join("s.json")).unwrap();
        let (b, _, _) = scene_upload(&dir.join("s.json")).unwrap();
        assert_eq!((ct, n), ("application/x-tar", 2));
        assert_eq!(a, b);
        assert_eq!(&a[257..262], b"ustar");
        let names = |bytes: &[u8]| -> Vec<String> {
            tar::Archive::new(bytes)
                .entries()
                .unwrap()
                .map(|e| e.unwrap().path().unwrap().display().to_string())
                .collect()
        };
        // OBJ material libraries stay home: the server reads no OBJ materials.
        assert_eq!(names(&a), ["scene.json", "meshes/a.obj"]);

        // Media grids: a .vol, and a raw grid's header with the data file it names.
        std::fs::create_dir_all(dir.join("grids/raw")).unwrap();
        std::fs::write(dir.join("grids/smoke.vol"), b"VOL").unwrap();
        std::fs::write(dir.join("grids/raw/d.bin"), [0u8; 4]).unwrap();
        std::fs::write(
            dir.join("grids/albedo.json"),
            r#"{"dims": [1, 1, 1], "data": "raw/d.bin"}"#,
        )
        .unwrap();
        let media = serde_json::json!({"media": {"smoke": {"type": "grid", "file": "grids/smoke.vol",
                                        "albedo_file": "grids/albedo.json"}}});
        std::fs::write(dir.join("m.json"), media.to_string()).unwrap();
        let (tar, _, n) = scene_upload(&dir.join("m.json")).unwrap();
        assert_eq!(n, 4);
        assert_eq!(
            names(&tar),
            [
                "scene.json",
                "grids/albedo.json",
                "grids/raw/d.bin",
                "grids/smoke.vol"
            ]
        );

        let bad = serde_json::json!({"lights": [{"type": "envmap", "filename": "../x.exr"}]});
        std::fs::write(dir.join("bad.json"), bad.to_string()).unwrap();
        assert!(scene_upload(&dir.join("bad.json")).is_err());
        let missing = serde_json::json!({"lights": [{"type": "envmap", "filename": "x.exr"}]});
        std::fs::write(dir.join("missing.json"), missing.to_string()).unwrap();
        assert!(scene_upload(&dir.join("missing.json")).is_err());
        let plain = serde_json::json!({"shapes": []});
        std::fs::write(dir.join("plain.json"), plain.to_string()).unwrap();
        assert_eq!(
            scene_upload(&dir.join("plain.json")).unwrap().1,
            "application/json"
        );
    }

    #[test]
    fn tables_align() {
        let t = table(
            &["a", "num"],
            &[
                vec!["xyz".into(), "1".into()],
                vec!["b".into(), "100".into()],
            ],
            &[false, true],
        );
        assert_eq!(t, "a    num\nxyz    1\nb    100\n");
        assert_eq!(segment("a/b c"), "a%2Fb%20c");
    }
}
