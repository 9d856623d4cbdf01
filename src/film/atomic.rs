use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::FilmError;

/// Writes a file so that readers (a browser polling `latest.png`, a resumed job)
/// only ever see the old or the complete new content: write a temporary file in
/// the same directory (same file system, so rename is atomic), sync, rename.
pub(crate) fn write_atomic<F>(path: &Path, write: F) -> Result<(), FilmError>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<(), FilmError>,
{
    let tmp = tmp_path(path);
    let result = write_then_rename(path, &tmp, write);
    if result.is_err() {
        // Best effort: a leftover temporary file is harmless but untidy.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Writes `bytes` to `path` atomically (see [`write_atomic`]).
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<(), FilmError> {
    write_atomic(path, |out| {
        out.write_all(bytes).map_err(|source| FilmError::Io {
            path: path.to_path_buf(),
            source,
        })
    })
}

fn write_then_rename<F>(path: &Path, tmp: &Path, write: F) -> Result<(), FilmError>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<(), FilmError>,
{
    let io_err = |source| FilmError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut out = BufWriter::new(File::create(tmp).map_err(io_err)?);
    write(&mut out)?;
    out.flush().map_err(io_err)?;
    out.get_ref().sync_all().map_err(io_err)?;
    drop(out);
    fs::rename(tmp, path).map_err(io_err)
}

/// `<name>.<pid>-<n>.tmp` beside the target: unique per process and call, so two
/// threads writing the same snapshot cannot clobber each other's temporary file.
fn tmp_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!("{name}.{}-{n}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.bin");
        write_atomic(&path, |w| {
            w.write_all(b"hello").unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"hello");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn failed_write_keeps_old_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.bin");
        fs::write(&path, b"old").unwrap();
        let r = write_atomic(&path, |w| {
            w.write_all(b"partial").unwrap();
            Err(FilmError::Png("boom".into()))
        });
        assert!(r.is_err());
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn missing_directory_names_the_file() {
        let path = Path::new("/nonexistent-dir-for-film-test/x.png");
        let err = write_atomic(path, |_| Ok(())).unwrap_err();
        assert!(err
            .to_string()
            .contains("/nonexistent-dir-for-film-test/x.png"));
    }
}
