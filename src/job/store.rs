//! The job directory (README, "Job directory"): job.json, checkpoint, snapshots, log.csv, final
//! images. Every file a reader may see is written atomically (temp file + rename), so
//! a crash at any moment leaves the previous complete version.

use super::spec::JobStatus;
use super::JobError;
use crate::film::{write_bytes_atomic, ExactSums, Film};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Paths inside `<data-dir>/jobs/<id>/`.
#[derive(Clone, Debug)]
pub struct JobDir {
    pub root: PathBuf,
}

impl JobDir {
    pub fn new(data_dir: &Path, id: &str) -> Self {
        JobDir {
            root: data_dir.join("jobs").join(id),
        }
    }

    pub fn create(&self) -> Result<(), JobError> {
        std::fs::create_dir_all(self.snapshots()).map_err(|e| JobError::io(&self.root, e))
    }

    pub fn job_json(&self) -> PathBuf {
        self.root.join("job.json")
    }
    pub fn checkpoint(&self) -> PathBuf {
        self.root.join("checkpoint.bin")
    }
    pub fn snapshots(&self) -> PathBuf {
        self.root.join("snapshots")
    }
    pub fn snapshot(&self, iteration: u64, ext: &str) -> PathBuf {
        self.snapshots().join(format!("{iteration}.{ext}"))
    }
    pub fn latest(&self, ext: &str) -> PathBuf {
        self.root.join(format!("latest.{ext}"))
    }
    pub fn final_image(&self, ext: &str) -> PathBuf {
        self.root.join(format!("final.{ext}"))
    }
    pub fn log_csv(&self) -> PathBuf {
        self.root.join("log.csv")
    }
    pub fn layers_csv(&self) -> PathBuf {
        self.root.join("layers.csv")
    }

    pub fn write_status(&self, s: &JobStatus) -> Result<(), JobError> {
        let bytes = serde_json::to_vec_pretty(s).expect("status serialises");
        write_bytes_atomic(&self.job_json(), &bytes).map_err(JobError::from)
    }

    pub fn read_status(&self) -> Result<JobStatus, JobError> {
        let path = self.job_json();
        let text = std::fs::read(&path).map_err(|e| JobError::io(&path, e))?;
        serde_json::from_slice(&text)
            .map_err(|e| JobError::Internal(format!("{}: {e}", path.display())))
    }

    /// Snapshot iterations present on disk, ascending.
    pub fn list_snapshots(&self) -> Vec<u64> {
        let mut v: Vec<u64> = std::fs::read_dir(self.snapshots())
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().into_string().ok()?;
                name.strip_suffix(".exr")?.parse().ok()
            })
            .collect();
        v.sort_unstable();
        v
    }
}

/// The state a job resumes from after `iteration` iterations: the job's exact sums
/// (`film::ExactSums`, layers included), so a resumed job finishes bit-identical to an
/// uninterrupted one; the same sums as an f64 film (what checkpoints held before exact
/// sums existed, and what such old checkpoints resume from, to rounding); and the
/// integrator's own state for algorithms whose iterations are not independent (SPPM's
/// per-pixel statistics; see `Integrator::save_state`).
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    pub iteration: u64,
    pub elapsed_s: f64,
    pub samples: u64,
    pub film: Film,
    pub state: Option<Vec<u8>>,
    pub exact: Option<ExactSums>,
}

const MAGIC: &[u8; 8] = b"CAUSTCK1";
/// Bytes before the pixel sums: magic, width, height, iteration, elapsed, samples,
/// dropped.
const HEAD: usize = 8 + 4 + 4 + 8 + 8 + 8 + 8;

/// What [`Checkpoint::read_header`] reads.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckpointHeader {
    pub iteration: u64,
    pub elapsed_s: f64,
    pub samples: u64,
}
/// Tags the optional sections after the film, each tag followed by its length in
/// bytes: the integrator's state and the exact sums (both absent in checkpoints written
/// before they existed, which still load without them).
const STATE_TAG: &[u8; 8] = b"INTSTATE";
const EXACT_TAG: &[u8; 8] = b"EXACTSUM";

impl Checkpoint {
    pub fn encode(&self) -> Vec<u8> {
        let f = &self.film;
        let mut out = Vec::with_capacity(48 + f.sums().len() * 24);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&f.width().to_le_bytes());
        out.extend_from_slice(&f.height().to_le_bytes());
        out.extend_from_slice(&self.iteration.to_le_bytes());
        out.extend_from_slice(&self.elapsed_s.to_le_bytes());
        out.extend_from_slice(&self.samples.to_le_bytes());
        out.extend_from_slice(&f.dropped().to_le_bytes());
        for p in f.sums() {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(state) = &self.state {
            put_section(&mut out, STATE_TAG, state);
        }
        if let Some(exact) = &self.exact {
            put_section(&mut out, EXACT_TAG, &exact.encode());
        }
        out
    }

    pub fn decode(bytes: &[u8]) -> Option<Checkpoint> {
        let head = HEAD;
        if bytes.len() < head || &bytes[..8] != MAGIC {
            return None;
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
        let (w, h) = (u32_at(8), u32_at(12));
        let n = w as usize * h as usize;
        let film_end = head.checked_add(n.checked_mul(24)?)?;
        let (mut state, mut exact) = (None, None);
        let mut rest = bytes.get(film_end..)?;
        while !rest.is_empty() {
            let (tag, body, after) = take_section(rest)?;
            match tag {
                t if t == STATE_TAG && state.is_none() => state = Some(body.to_vec()),
                t if t == EXACT_TAG && exact.is_none() => {
                    let e = ExactSums::decode(body).ok()?;
                    if e.size() != (w, h) {
                        return None;
                    }
                    exact = Some(e);
                }
                _ => return None,
            }
            rest = after;
        }
        let sums = bytes[head..film_end]
            .chunks_exact(24)
            .map(|c| {
                let f = |k: usize| f64::from_le_bytes(c[k * 8..k * 8 + 8].try_into().unwrap());
                [f(0), f(1), f(2)]
            })
            .collect();
        Some(Checkpoint {
            iteration: u64_at(16),
            elapsed_s: f64::from_bits(u64_at(24)),
            samples: u64_at(32),
            film: Film::from_parts(w, h, sums, u64_at(40)),
            state,
            exact,
        })
    }

    /// The iteration, time and samples of the checkpoint in `dir`, read without its
    /// pixel sums; None when there is none or its length does not match its header
    /// (then [`Checkpoint::read`] would refuse it too).
    pub fn read_header(dir: &JobDir) -> Option<CheckpointHeader> {
        use std::io::Read;
        let mut f = std::fs::File::open(dir.checkpoint()).ok()?;
        let len = f.metadata().ok()?.len();
        let mut head = [0u8; HEAD];
        f.read_exact(&mut head).ok()?;
        if &head[..8] != MAGIC {
            return None;
        }
        let u32_at = |o: usize| u32::from_le_bytes(head[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(head[o..o + 8].try_into().unwrap());
        let film = u64::from(u32_at(8)) * u64::from(u32_at(12)) * 24;
        if len < HEAD as u64 + film {
            return None;
        }
        Some(CheckpointHeader {
            iteration: u64_at(16),
            elapsed_s: f64::from_bits(u64_at(24)),
            samples: u64_at(32),
        })
    }

    pub fn write(&self, dir: &JobDir) -> Result<(), JobError> {
        write_bytes_atomic(&dir.checkpoint(), &self.encode()).map_err(JobError::from)
    }

    /// The checkpoint, or None when there is none or it is unreadable (then the job
    /// restarts from zero, which is still correct).
    pub fn read(dir: &JobDir) -> Option<Checkpoint> {
        Checkpoint::decode(&std::fs::read(dir.checkpoint()).ok()?)
    }
}

/// One row of log.csv: the job at a snapshot. The last five figures describe the batch
/// of iterations that ended at the snapshot (per iteration, averaged over the batch).
#[derive(
    Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize, utoipa::ToSchema,
)]
pub struct LogRow {
    pub iteration: u64,
    pub elapsed_s: f64,
    pub samples: u64,
    pub rmse: Option<f64>,
    pub rel_mse: Option<f64>,
    pub dropped: u64,
    /// Closest-hit plus shadow rays per second.
    pub rays_per_s: f64,
    /// Merge radius of the latest iteration; 0 for algorithms that do not merge (and
    /// in logs written before the column existed).
    #[serde(default)]
    pub merge_radius: f64,
    /// Light-subpath vertices (or photons) stored per iteration.
    #[serde(default)]
    pub light_vertices: f64,
    /// Vertex connections per pixel per iteration.
    #[serde(default)]
    pub connections_per_pixel: f64,
    /// Merges per pixel per iteration.
    #[serde(default)]
    pub merges_per_pixel: f64,
    /// RMSE and relative MSE of the image estimated from its own iterations, with no
    /// reference (`film::noise`): the variance only, not a consistent method's bias.
    /// Empty before two iterations, for `sppm`/`ppm`, and in older logs.
    #[serde(default)]
    pub est_rmse: Option<f64>,
    #[serde(default)]
    pub est_rel_mse: Option<f64>,
}

pub const LOG_HEADER: &str = "iteration,elapsed_s,samples,rmse,rel_mse,dropped,rays_per_s,merge_radius,light_vertices,connections_per_pixel,merges_per_pixel,est_rmse,est_rel_mse";

/// Columns of logs written before the per-iteration figures were added; such rows
/// still parse, with those figures 0.
const OLD_COLUMNS: usize = 7;
/// Columns of logs written before the noise estimates; such rows parse without them.
const PRE_NOISE_COLUMNS: usize = 11;

impl LogRow {
    pub fn csv(&self) -> String {
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.6e}")).unwrap_or_default();
        format!(
            "{},{:.4},{},{},{},{},{:.0},{:.6e},{:.1},{:.4},{:.4},{},{}",
            self.iteration,
            self.elapsed_s,
            self.samples,
            opt(self.rmse),
            opt(self.rel_mse),
            self.dropped,
            self.rays_per_s,
            self.merge_radius,
            self.light_vertices,
            self.connections_per_pixel,
            self.merges_per_pixel,
            opt(self.est_rmse),
            opt(self.est_rel_mse)
        )
    }

    /// A row in the current format, or in an older one (7 or 11 columns).
    pub fn parse(line: &str) -> Option<LogRow> {
        let f: Vec<&str> = line.split(',').collect();
        let columns = LOG_HEADER.split(',').count();
        if ![columns, PRE_NOISE_COLUMNS, OLD_COLUMNS].contains(&f.len()) {
            return None;
        }
        let opt = |s: &str| if s.is_empty() { None } else { s.parse().ok() };
        // A figure the row does not have (an old row) is 0.
        let extra = |i: usize| -> Option<f64> { f.get(i).map_or(Some(0.0), |s| s.parse().ok()) };
        Some(LogRow {
            iteration: f[0].parse().ok()?,
            elapsed_s: f[1].parse().ok()?,
            samples: f[2].parse().ok()?,
            rmse: opt(f[3]),
            rel_mse: opt(f[4]),
            dropped: f[5].parse().ok()?,
            rays_per_s: f[6].parse().ok()?,
            merge_radius: extra(7)?,
            light_vertices: extra(8)?,
            connections_per_pixel: extra(9)?,
            merges_per_pixel: extra(10)?,
            est_rmse: f.get(11).and_then(|s| opt(s)),
            est_rel_mse: f.get(12).and_then(|s| opt(s)),
        })
    }
}

/// Appends a row; rows past the checkpoint are dropped on resume (see
/// [`truncate_log`]), so the log always matches the image.
/// A log in an older format is first rewritten in the current one, so that the file
/// keeps one header and one shape of row.
pub fn append_log(dir: &JobDir, row: &LogRow) -> Result<(), JobError> {
    let path = dir.log_csv();
    if path.exists() && !has_current_header(&path) {
        write_log(dir, &read_log(dir))?;
    }
    append_csv(&path, LOG_HEADER, [row.csv()])
}

/// Appends `rows` to the CSV file at `path` (with `header` first if the file is new)
/// and syncs it.
pub fn append_csv(
    path: &Path,
    header: &str,
    rows: impl IntoIterator<Item = String>,
) -> Result<(), JobError> {
    let mut text = String::new();
    if !path.exists() {
        text.push_str(header);
        text.push('\n');
    }
    for r in rows {
        text.push_str(&r);
        text.push('\n');
    }
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| JobError::io(path, e))?;
    f.write_all(text.as_bytes())
        .and_then(|_| f.sync_data())
        .map_err(|e| JobError::io(path, e))
}

pub fn read_log(dir: &JobDir) -> Vec<LogRow> {
    read_csv(&dir.log_csv(), LogRow::parse)
}

/// The rows of the CSV file at `path` that `parse` reads, after its header (none if
/// the file is missing).
pub fn read_csv<R>(path: &Path, parse: impl Fn(&str) -> Option<R>) -> Vec<R> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines().skip(1).filter_map(parse).collect()
}

/// Keeps only rows up to `iteration` (after a crash, rows may be ahead of the
/// checkpoint, or the last one half-written). The file is rewritten whole, so the next
/// append starts on a fresh line; a job with no log yet gets none.
pub fn truncate_log(dir: &JobDir, iteration: u64) -> Result<(), JobError> {
    if !dir.log_csv().exists() {
        return Ok(());
    }
    let rows: Vec<LogRow> = read_log(dir)
        .into_iter()
        .filter(|r| r.iteration <= iteration)
        .collect();
    write_log(dir, &rows)
}

/// Replaces log.csv with `rows` in the current format, atomically.
fn write_log(dir: &JobDir, rows: &[LogRow]) -> Result<(), JobError> {
    write_csv(&dir.log_csv(), LOG_HEADER, rows.iter().map(LogRow::csv))
}

/// Replaces the CSV file at `path` with `header` and `rows`, atomically.
pub fn write_csv(
    path: &Path,
    header: &str,
    rows: impl IntoIterator<Item = String>,
) -> Result<(), JobError> {
    let mut text = String::from(header);
    text.push('\n');
    for r in rows {
        text.push_str(&r);
        text.push('\n');
    }
    write_bytes_atomic(path, text.as_bytes()).map_err(JobError::from)
}

fn has_current_header(path: &Path) -> bool {
    use std::io::BufRead;
    let Ok(f) = std::fs::File::open(path) else {
        return false;
    };
    let mut first = String::new();
    let _ = std::io::BufReader::new(f).read_line(&mut first);
    first.trim_end() == LOG_HEADER
}

/// Appends a tagged section: tag, length, bytes.
fn put_section(out: &mut Vec<u8>, tag: &[u8; 8], body: &[u8]) {
    out.extend_from_slice(tag);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

/// Splits off one tagged section: (tag, body, what follows); None if truncated.
fn take_section(bytes: &[u8]) -> Option<(&[u8], &[u8], &[u8])> {
    let tag = bytes.get(..8)?;
    let len = u64::from_le_bytes(bytes.get(8..16)?.try_into().unwrap());
    let end = 16usize.checked_add(usize::try_from(len).ok()?)?;
    Some((tag, bytes.get(16..end)?, &bytes[end..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoint_round_trips_bit_exactly() {
        let mut film = Film::new(3, 2);
        film.add(1, 1, glam::Vec3::new(0.1, 1e-30, 7.0));
        film.add(0, 0, glam::Vec3::new(f32::NAN, 0.0, 0.0));
        let c = Checkpoint {
            iteration: 17,
            elapsed_s: 1.25,
            samples: 99,
            film,
            state: None,
            exact: None,
        };
        let back = Checkpoint::decode(&c.encode()).unwrap();
        assert_eq!(c, back);
        assert!(Checkpoint::decode(&c.encode()[..20]).is_none());
        // With integrator state; a checkpoint without it (the old format) is a prefix.
        let with = Checkpoint {
            state: Some(vec![1, 2, 3, 250]),
            ..c.clone()
        };
        let bytes = with.encode();
        assert_eq!(Checkpoint::decode(&bytes).unwrap(), with);
        assert_eq!(bytes[..c.encode().len()], c.encode()[..]);
        assert!(Checkpoint::decode(&bytes[..bytes.len() - 1]).is_none());
        let empty = Checkpoint {
            state: Some(Vec::new()),
            ..c
        };
        assert_eq!(Checkpoint::decode(&empty.encode()).unwrap(), empty);
        // With exact sums after the state; their size must be the film's.
        let mut exact = ExactSums::new(3, 2);
        exact.add_film(&with.film).unwrap();
        let full = Checkpoint {
            exact: Some(exact),
            ..with.clone()
        };
        let bytes = full.encode();
        assert_eq!(Checkpoint::decode(&bytes).unwrap(), full);
        assert!(Checkpoint::decode(&bytes[..bytes.len() - 1]).is_none());
        let wrong = Checkpoint {
            exact: Some(ExactSums::new(2, 3)),
            ..with
        };
        assert!(Checkpoint::decode(&wrong.encode()).is_none());
    }

    #[test]
    fn log_rows_round_trip_and_truncate() {
        let dir = tempfile::tempdir().unwrap();
        let jd = JobDir::new(dir.path(), "j");
        jd.create().unwrap();
        for i in [1u64, 2, 3] {
            let row = LogRow {
                iteration: i,
                elapsed_s: i as f64,
                samples: i * 10,
                rmse: (i > 1).then_some(0.5),
                rel_mse: None,
                dropped: 0,
                rays_per_s: 1e6,
                merge_radius: 0.25,
                light_vertices: 1234.0,
                connections_per_pixel: 3.5,
                merges_per_pixel: 0.125,
                est_rmse: (i > 2).then_some(2.5e-3),
                est_rel_mse: Some(1e-4 * i as f64),
            };
            append_log(&jd, &row).unwrap();
        }
        assert_eq!(read_log(&jd).len(), 3);
        truncate_log(&jd, 2).unwrap();
        let rows = read_log(&jd);
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].rmse, Some(0.5));
        assert_eq!(rows[1].merge_radius, 0.25);
        assert_eq!(rows[1].light_vertices, 1234.0);
        assert_eq!(rows[1].connections_per_pixel, 3.5);
        assert_eq!((rows[1].est_rmse, rows[1].est_rel_mse), (None, Some(2e-4)));
        assert_eq!(rows[1].merges_per_pixel, 0.125);
    }

    #[test]
    fn old_seven_column_logs_parse_and_are_upgraded_on_append() {
        let dir = tempfile::tempdir().unwrap();
        let jd = JobDir::new(dir.path(), "j");
        jd.create().unwrap();
        let old = "iteration,elapsed_s,samples,rmse,rel_mse,dropped,rays_per_s\n\
                   4,0.5000,262144,1.000000e-1,,0,2000000\n\
                   8,1.0000,524288,5.000000e-2,2.000000e-3,1,2100000\n";
        std::fs::write(jd.log_csv(), old).unwrap();
        let rows = read_log(&jd);
        assert_eq!(rows.len(), 2);
        assert_eq!(
            rows[0],
            LogRow {
                iteration: 4,
                elapsed_s: 0.5,
                samples: 262144,
                rmse: Some(0.1),
                rel_mse: None,
                dropped: 0,
                rays_per_s: 2e6,
                ..Default::default()
            }
        );
        assert_eq!(rows[1].rel_mse, Some(2e-3));
        assert_eq!(rows[1].merges_per_pixel, 0.0);

        // Appending rewrites the file in the current format first: one header, one shape.
        let new = LogRow {
            iteration: 12,
            merge_radius: 0.01,
            ..Default::default()
        };
        append_log(&jd, &new).unwrap();
        let text = std::fs::read_to_string(jd.log_csv()).unwrap();
        assert!(text.starts_with(&format!("{LOG_HEADER}\n")), "{text}");
        let columns = LOG_HEADER.split(',').count();
        assert!(
            text.lines().all(|l| l.split(',').count() == columns),
            "{text}"
        );
        let rows = read_log(&jd);
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[1].rmse, Some(0.05));
        assert_eq!(rows[2].merge_radius, 0.01);

        // Rows of neither shape are skipped.
        assert!(LogRow::parse("1,2,3").is_none());
        assert!(LogRow::parse("1,0.5,10,,,0,5,x,0,0,0").is_none());
        // Rows from before the noise estimates (11 columns) parse without them.
        let pre = LogRow::parse("1,0.5,10,,,0,5,0.1,0,0,0").unwrap();
        assert_eq!((pre.merge_radius, pre.est_rel_mse), (0.1, None));
    }

    #[test]
    fn log_rows_deserialise_from_old_json() {
        let row: LogRow = serde_json::from_str(
            r#"{"iteration":1,"elapsed_s":0.1,"samples":9,"rmse":null,"rel_mse":null,"dropped":0,"rays_per_s":5.0}"#,
        )
        .unwrap();
        assert_eq!(row.light_vertices, 0.0);
    }
}
