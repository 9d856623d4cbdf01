//! The job directory (DESIGN.md): job.json, checkpoint, snapshots, log.csv, final
//! images. Every file a reader may see is written atomically (temp file + rename), so
//! a crash at any moment leaves the previous complete version.

use super::spec::JobStatus;
use super::JobError;
use crate::film::{write_bytes_atomic, Film};
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

/// The state a job resumes from: the film's exact f64 sums after `iteration`
/// iterations, so a resumed job finishes bit-identical to an uninterrupted one, and
/// the integrator's own state for algorithms whose iterations are not independent
/// (SPPM's per-pixel statistics; see `Integrator::save_state`).
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    pub iteration: u64,
    pub elapsed_s: f64,
    pub samples: u64,
    pub film: Film,
    pub state: Option<Vec<u8>>,
}

const MAGIC: &[u8; 8] = b"CAUSTCK1";
/// Tags the optional integrator-state section after the film (absent in checkpoints
/// written before it existed, which still load, with no state).
const STATE_TAG: &[u8; 8] = b"INTSTATE";

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
            out.extend_from_slice(STATE_TAG);
            out.extend_from_slice(&(state.len() as u64).to_le_bytes());
            out.extend_from_slice(state);
        }
        out
    }

    pub fn decode(bytes: &[u8]) -> Option<Checkpoint> {
        let head = 8 + 4 + 4 + 8 + 8 + 8 + 8;
        if bytes.len() < head || &bytes[..8] != MAGIC {
            return None;
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
        let (w, h) = (u32_at(8), u32_at(12));
        let n = w as usize * h as usize;
        let film_end = head.checked_add(n.checked_mul(24)?)?;
        let state = match bytes.len().checked_sub(film_end)? {
            0 => None,
            rest => {
                let t = &bytes[film_end..];
                if rest < 16 || &t[..8] != STATE_TAG {
                    return None;
                }
                let len = u64::from_le_bytes(t[8..16].try_into().unwrap());
                if len != (rest - 16) as u64 {
                    return None;
                }
                Some(t[16..].to_vec())
            }
        };
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

/// One row of log.csv.
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
    pub rays_per_s: f64,
}

pub const LOG_HEADER: &str = "iteration,elapsed_s,samples,rmse,rel_mse,dropped,rays_per_s";

impl LogRow {
    pub fn csv(&self) -> String {
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.6e}")).unwrap_or_default();
        format!(
            "{},{:.4},{},{},{},{},{:.0}",
            self.iteration,
            self.elapsed_s,
            self.samples,
            opt(self.rmse),
            opt(self.rel_mse),
            self.dropped,
            self.rays_per_s
        )
    }

    pub fn parse(line: &str) -> Option<LogRow> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 7 {
            return None;
        }
        let opt = |s: &str| if s.is_empty() { None } else { s.parse().ok() };
        Some(LogRow {
            iteration: f[0].parse().ok()?,
            elapsed_s: f[1].parse().ok()?,
            samples: f[2].parse().ok()?,
            rmse: opt(f[3]),
            rel_mse: opt(f[4]),
            dropped: f[5].parse().ok()?,
            rays_per_s: f[6].parse().ok()?,
        })
    }
}

/// Appends a row; rows past the checkpoint are dropped on resume (see
/// [`truncate_log`]), so the log always matches the image.
pub fn append_log(dir: &JobDir, row: &LogRow) -> Result<(), JobError> {
    let path = dir.log_csv();
    let new = !path.exists();
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(|e| JobError::io(&path, e))?;
    let mut text = String::new();
    if new {
        text.push_str(LOG_HEADER);
        text.push('\n');
    }
    text.push_str(&row.csv());
    text.push('\n');
    f.write_all(text.as_bytes())
        .and_then(|_| f.sync_data())
        .map_err(|e| JobError::io(&path, e))
}

pub fn read_log(dir: &JobDir) -> Vec<LogRow> {
    std::fs::read_to_string(dir.log_csv())
        .unwrap_or_default()
        .lines()
        .skip(1)
        .filter_map(LogRow::parse)
        .collect()
}

/// Keeps only rows up to `iteration` (after a crash, rows may be ahead of the
/// checkpoint).
pub fn truncate_log(dir: &JobDir, iteration: u64) -> Result<(), JobError> {
    let rows: Vec<LogRow> = read_log(dir)
        .into_iter()
        .filter(|r| r.iteration <= iteration)
        .collect();
    let mut text = String::from(LOG_HEADER);
    text.push('\n');
    for r in rows {
        text.push_str(&r.csv());
        text.push('\n');
    }
    write_bytes_atomic(&dir.log_csv(), text.as_bytes()).map_err(JobError::from)
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
            };
            append_log(&jd, &row).unwrap();
        }
        assert_eq!(read_log(&jd).len(), 3);
        truncate_log(&jd, 2).unwrap();
        let rows = read_log(&jd);
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].rmse, Some(0.5));
    }
}
