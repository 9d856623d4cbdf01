//! One server per data directory: an exclusive advisory lock on `<data-dir>/lock`,
//! held for the life of the service. Two servers on one directory would both resume
//! and render the same jobs, interleaving rows in their logs and overwriting each
//! other's checkpoints.
//!
//! The lock is the kernel's (`flock` through `File::try_lock`), so it dies with its
//! process: after a `kill -9` the next server starts at once, and a leftover lock
//! file alone never keeps anyone out. The file's text says who holds it, for the
//! message the second server prints.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The lock file's name inside the data directory.
pub const LOCK_FILE: &str = "lock";

/// Why the data directory could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "data directory {dir} is in use by another caustic process ({holder}); stop it, or \
         give this one another --data-dir"
    )]
    Held { dir: String, holder: String },
    #[error("cannot lock data directory {dir}: {source}")]
    Io {
        dir: String,
        #[source]
        source: std::io::Error,
    },
}

/// The held lock; dropping it (or the process ending) releases it.
#[derive(Debug)]
pub struct DirLock {
    /// Holds the lock while open.
    _file: File,
    path: PathBuf,
    /// What the file says about the holder; [`DirLock::announce`] extends it.
    holder: String,
}

impl DirLock {
    /// Takes the lock on `dir` (which must exist), or says who holds it.
    pub fn acquire(dir: &Path, role: &str) -> Result<DirLock, LockError> {
        let path = dir.join(LOCK_FILE);
        let io = |source| LockError::Io {
            dir: dir.display().to_string(),
            source,
        };
        // Created if missing, never truncated here: the holder's text must survive a
        // rival's attempt. The descriptor kept is read-only, since a file held open
        // for writing would stop the filesystem from being remounted read-only.
        drop(
            OpenOptions::new()
                .append(true)
                .create(true)
                .open(&path)
                .map_err(io)?,
        );
        let mut file = File::open(&path).map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut text = String::new();
                let _ = file.read_to_string(&mut text);
                return Err(LockError::Held {
                    dir: dir.display().to_string(),
                    holder: describe_holder(&text),
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        let holder = format!(
            "{role}, pid {} on {}, started {}",
            std::process::id(),
            hostname(),
            utc_now()
        );
        let lock = DirLock {
            _file: file,
            path,
            holder,
        };
        lock.write_holder(&lock.holder).map_err(io)?;
        Ok(lock)
    }

    /// Adds where the holder can be reached (its URL) to what the lock file says.
    pub fn announce(&self, what: &str) {
        let text = format!("{}, {what}", self.holder);
        if let Err(e) = self.write_holder(&text) {
            tracing::warn!(path = %self.path.display(), "cannot update the lock file: {e}");
        }
    }

    /// This server as the holder of a worker pool (`remote::claim`): the same host
    /// and data directory are the same coordinator.
    pub fn pool_holder(&self) -> crate::job::remote::claim::Holder {
        let dir = self.path.parent().unwrap_or(&self.path);
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
        crate::job::remote::claim::Holder {
            identity: format!("{}:{}", hostname(), dir.display()),
            description: format!("{}, data directory {}", self.holder, dir.display()),
        }
    }

    fn write_holder(&self, text: &str) -> std::io::Result<()> {
        std::fs::write(&self.path, text)
    }
}

/// The holder as the file describes it; a holder that has not written yet (or a
/// file from elsewhere) is still a holder.
fn describe_holder(text: &str) -> String {
    let line = text.lines().next().unwrap_or("").trim();
    if line.is_empty() || line.len() > 512 {
        "holder unknown".into()
    } else {
        line.to_string()
    }
}

/// This machine's name, for telling which host holds a shared directory.
pub fn hostname() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: the buffer is valid for its length; gethostname writes at most that
    // many bytes and we read only up to the first NUL within it.
    let ok = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) } == 0;
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    match std::str::from_utf8(&buf[..end]) {
        Ok(h) if ok && !h.is_empty() => h.to_string(),
        _ => "unknown host".into(),
    }
}

/// Now, as RFC 3339 in UTC to the second.
fn utc_now() -> String {
    humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_names_the_first_holder_and_a_dropped_one_is_free() {
        let dir = tempfile::tempdir().unwrap();
        let first = DirLock::acquire(dir.path(), "caustic serve").unwrap();
        first.announce("REST http://127.0.0.1:1");
        let err = DirLock::acquire(dir.path(), "caustic serve").unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("pid {}", std::process::id())),
            "{msg}"
        );
        assert!(msg.contains("REST http://127.0.0.1:1"), "{msg}");
        assert!(msg.contains("--data-dir"), "{msg}");
        drop(first);
        DirLock::acquire(dir.path(), "caustic serve").unwrap();
    }
}
