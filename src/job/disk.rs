//! What the server keeps on disk, and for how long: snapshot thinning, the tidy-up
//! of a finished job, leftovers of a kill, and the retention policy for finished
//! jobs. A 1000-job sweep must not fill the disk with copies of its images.

use super::spec::{JobSpec, KeepSnapshots};
use super::store::JobDir;
use std::path::{Path, PathBuf};

/// Keeps at most the spec's number of snapshots. The first and the latest always
/// stay; otherwise the snapshot whose removal leaves the smallest gap on a log scale
/// of iterations goes, so what is left stays spread over the whole run as an error
/// curve is (log-log).
pub fn thin_snapshots(dir: &JobDir, spec: &JobSpec) {
    let KeepSnapshots::Count(keep) = spec.keep_snapshots else {
        return;
    };
    let mut its = dir.list_snapshots();
    for it in to_drop(&mut its, keep as usize) {
        remove_snapshot(dir, it);
    }
}

/// Which of the ascending iterations `its` to drop so that `keep` remain; `its` is
/// left holding the kept ones.
fn to_drop(its: &mut Vec<u64>, keep: usize) -> Vec<u64> {
    let mut dropped = Vec::new();
    while its.len() > keep {
        let k = if its.len() <= 2 || keep < 2 {
            // Too few to thin in the middle: the oldest goes first.
            0
        } else {
            let ln = |i: usize| (its[i].max(1) as f64).ln();
            (1..its.len() - 1)
                .min_by(|&a, &b| (ln(a + 1) - ln(a - 1)).total_cmp(&(ln(b + 1) - ln(b - 1))))
                .expect("an interior snapshot")
        };
        dropped.push(its.remove(k));
    }
    dropped
}

fn remove_snapshot(dir: &JobDir, it: u64) {
    for ext in ["exr", "png"] {
        let _ = std::fs::remove_file(dir.snapshot(it, ext));
    }
}

/// Removes snapshots newer than a resumed job's checkpoint: the iterations that made
/// them run again, and a job cancelled before reaching them must not show them.
pub fn drop_snapshots_after(dir: &JobDir, iteration: u64) {
    for it in dir.list_snapshots() {
        if it > iteration {
            remove_snapshot(dir, it);
        }
    }
}

/// After completion: `final.*` replaces `latest.*`, and the checkpoint goes unless
/// the job asked to keep it. Best effort: a file left behind wastes space, nothing
/// more, and is removed again on the next start.
pub fn tidy_finished(dir: &JobDir, spec: &JobSpec) {
    for ext in ["exr", "png"] {
        let _ = std::fs::remove_file(dir.latest(ext));
    }
    if !spec.keep_checkpoint {
        let _ = std::fs::remove_file(dir.checkpoint());
    }
}

/// Whether `name` is one of our temporary files, `<name>.<pid>-<n>.tmp`
/// (film::write_atomic), left behind by a kill during a write.
fn is_our_tmp(name: &str) -> bool {
    let Some(stem) = name.strip_suffix(".tmp") else {
        return false;
    };
    let Some((_, tag)) = stem.rsplit_once('.') else {
        return false;
    };
    let Some((pid, n)) = tag.split_once('-') else {
        return false;
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    digits(pid) && digits(n)
}

/// Where removed job folders wait to be deleted: outside `jobs/`, so that recovery
/// never sees them, and on the same file system, so that moving one there is atomic.
pub fn trash_dir(data_dir: &Path) -> PathBuf {
    data_dir.join("trash")
}

/// Moves job `id`'s folder out of `jobs/` in one step (a job that has left the table
/// must not leave a folder behind for a client to find) and returns where it went,
/// for the caller to delete; a deletion that a crash interrupts is finished by
/// [`clean_leftovers`].
pub fn move_job_to_trash(data_dir: &Path, id: &str) -> std::io::Result<PathBuf> {
    let trash = trash_dir(data_dir);
    std::fs::create_dir_all(&trash)?;
    let to = trash.join(id);
    std::fs::rename(JobDir::new(data_dir, id).root, &to)?;
    Ok(to)
}

/// Removes what a killed server left half-written: temporary files in the job,
/// reference and sweep folders, and unfinished scene uploads. Uploaded scene bundles
/// themselves are never looked into (their files are the user's).
pub fn clean_leftovers(data_dir: &Path) -> usize {
    let mut removed = 0;
    for sub in ["jobs", "references", "sweeps"] {
        removed += remove_tmp_files(&data_dir.join(sub), 3);
    }
    let trash = trash_dir(data_dir);
    let moved = std::fs::read_dir(&trash).map_or(0, |d| d.count());
    if moved > 0 && std::fs::remove_dir_all(&trash).is_ok() {
        removed += moved;
    }
    let uploads = std::fs::read_dir(data_dir.join("scenes"))
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(".upload-"));
    for e in uploads {
        if std::fs::remove_dir_all(e.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

fn remove_tmp_files(dir: &Path, depth: u32) -> usize {
    let mut removed = 0;
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let Ok(kind) = e.file_type() else { continue };
        if kind.is_dir() && depth > 0 {
            removed += remove_tmp_files(&e.path(), depth - 1);
        } else if kind.is_file()
            && is_our_tmp(&e.file_name().to_string_lossy())
            && std::fs::remove_file(e.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Bytes under `dir`, following no links.
pub fn dir_size(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => dir_size(&e.path()),
            Ok(t) if t.is_file() => e.metadata().map_or(0, |m| m.len()),
            _ => 0,
        })
        .sum()
}

/// How long finished jobs (completed, cancelled, failed) are kept: by age since they
/// ended, and by the total size of the job folders. Jobs that are queued, running or
/// paused are never removed, whatever the limits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Retention {
    pub max_age_s: Option<f64>,
    pub max_bytes: Option<u64>,
}

/// A finished job as the retention policy sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Finished {
    pub id: String,
    pub finished_at: f64,
    pub bytes: u64,
}

impl Retention {
    pub fn is_off(&self) -> bool {
        self.max_age_s.is_none() && self.max_bytes.is_none()
    }

    /// The finished jobs to delete, given all jobs' bytes in `total` and the time
    /// `now`: those past the age limit, then the oldest-finished others until the
    /// folders fit the size limit.
    pub fn expired(&self, mut finished: Vec<Finished>, total: u64, now: f64) -> Vec<String> {
        finished.sort_by(|a, b| a.finished_at.total_cmp(&b.finished_at));
        let mut total = total;
        let mut out = Vec::new();
        for f in finished {
            let too_old = self.max_age_s.is_some_and(|a| now - f.finished_at > a);
            let too_big = self.max_bytes.is_some_and(|m| total > m);
            if too_old || too_big {
                total = total.saturating_sub(f.bytes);
                out.push(f.id);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_ends_and_spreads_on_a_log_scale() {
        let mut its: Vec<u64> = (1..=64).collect();
        let dropped = to_drop(&mut its, 7);
        assert_eq!(dropped.len(), 57);
        assert_eq!(its.len(), 7);
        assert_eq!((its[0], its[6]), (1, 64));
        // Roughly log-spaced: consecutive ratios within a factor of 2.5 of each other.
        let ratios: Vec<f64> = its.windows(2).map(|w| w[1] as f64 / w[0] as f64).collect();
        let (lo, hi) = ratios
            .iter()
            .fold((f64::MAX, 0.0f64), |(l, h), &r| (l.min(r), h.max(r)));
        assert!(hi / lo < 2.5, "{its:?}");
        let mut few = vec![3, 9];
        assert_eq!(to_drop(&mut few, 1), vec![3]);
        assert_eq!(few, vec![9]);
        let mut none = vec![3, 9, 27];
        assert_eq!(to_drop(&mut none, 0).len(), 3);
    }

    #[test]
    fn a_removed_job_leaves_jobs_at_once_and_its_trash_is_cleared_at_start() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("jobs").join("j1");
        std::fs::create_dir_all(root.join("snapshots")).unwrap();
        std::fs::write(root.join("job.json"), b"{}").unwrap();
        let trash = move_job_to_trash(dir.path(), "j1").unwrap();
        assert!(!root.exists());
        assert!(trash.join("job.json").exists());
        assert!(!trash.starts_with(dir.path().join("jobs")));
        // A crash before the deletion: the next start removes it.
        assert_eq!(clean_leftovers(dir.path()), 1);
        assert!(!trash_dir(dir.path()).exists());
    }

    #[test]
    fn only_our_temporary_files_are_leftovers() {
        assert!(is_our_tmp("final.exr.1234-0.tmp"));
        assert!(is_our_tmp("job.json.7-42.tmp"));
        assert!(!is_our_tmp("final.exr"));
        assert!(!is_our_tmp("notes.tmp"));
        assert!(!is_our_tmp("a.b-c.tmp"));
        let dir = tempfile::tempdir().unwrap();
        let job = dir.path().join("jobs").join("j1").join("snapshots");
        std::fs::create_dir_all(&job).unwrap();
        std::fs::write(job.join("4.exr.99-1.tmp"), b"x").unwrap();
        std::fs::write(job.join("4.exr"), b"x").unwrap();
        let upload = dir.path().join("scenes").join(".upload-abc");
        std::fs::create_dir_all(&upload).unwrap();
        let bundle = dir.path().join("scenes").join("0123456789abcdef");
        std::fs::create_dir_all(&bundle).unwrap();
        std::fs::write(bundle.join("mesh.obj.1-2.tmp"), b"user's file").unwrap();
        assert_eq!(clean_leftovers(dir.path()), 2);
        assert!(job.join("4.exr").exists());
        assert!(!job.join("4.exr.99-1.tmp").exists());
        assert!(!upload.exists());
        assert!(bundle.join("mesh.obj.1-2.tmp").exists());
    }

    #[test]
    fn retention_removes_old_then_oldest_until_it_fits() {
        let f = |id: &str, at: f64, bytes: u64| Finished {
            id: id.into(),
            finished_at: at,
            bytes,
        };
        let jobs = vec![f("c", 300.0, 10), f("a", 100.0, 10), f("b", 200.0, 10)];
        let by_age = Retention {
            max_age_s: Some(150.0),
            max_bytes: None,
        };
        assert_eq!(by_age.expired(jobs.clone(), 30, 400.0), vec!["a", "b"]);
        let by_size = Retention {
            max_age_s: None,
            max_bytes: Some(15),
        };
        // 30 bytes of finished jobs plus 5 of running ones: two must go, oldest first.
        assert_eq!(by_size.expired(jobs.clone(), 35, 400.0), vec!["a", "b"]);
        assert!(Retention::default().expired(jobs, 1 << 40, 1e9).is_empty());
    }
}
