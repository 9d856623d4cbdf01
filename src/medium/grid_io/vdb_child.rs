//! OpenVDB files from uploads, read in a child process (issue 40). The `vdb-rs`
//! crate can abort the process on a malformed file (it allocates whatever a size
//! field says) and may loop for long on others, which `catch_unwind` cannot stop. A
//! server or worker therefore reads an upload's `.vdb` by running its own binary as
//! `caustic vdb-grid` (hidden) with a memory limit and a deadline: the child reads the
//! grid and writes it to its standard output as a Mitsuba `.vol`, which the parent
//! reads with its own checked reader. An abort, a signal or the deadline kills only
//! the child and becomes an error naming the file.
//!
//! The child runs in the file's folder and is given only the file's name, so its
//! messages name no server path.

use super::{decode_vol, vdb, DenseGrid, GridError, Result, MAX_VALUES};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// How a process reads `.vdb` files: set once by `serve` and `worker`.
#[derive(Clone, Debug)]
pub struct Isolation {
    /// The caustic binary to run as the child.
    pub exe: PathBuf,
    /// Address space the child may use, in bytes.
    pub memory: u64,
    /// How long the child may take.
    pub time: Duration,
}

impl Isolation {
    /// The limits a server uses: room for the largest dense grid caustic accepts
    /// (1 GiB) twice over and the crate's tree beside it, and a minute.
    pub fn server(exe: PathBuf) -> Isolation {
        Isolation {
            exe,
            memory: 4 << 30,
            time: Duration::from_secs(60),
        }
    }
}

static ISOLATION: OnceLock<Isolation> = OnceLock::new();

/// From now on, this process reads `.vdb` files in a child process (`serve` and
/// `worker` call it at start; local renders read them in process).
pub fn isolate_vdb(isolation: Isolation) {
    let _ = ISOLATION.set(isolation);
}

/// The grid `name` of the `.vdb` file at `path`: in a child process if
/// [`isolate_vdb`] was called, else here.
pub(super) fn read(path: &Path, name: &str) -> Result<DenseGrid> {
    match ISOLATION.get() {
        Some(iso) => read_in_child(iso, path, name),
        None => vdb::read_vdb(path, name),
    }
}

/// Error text the child may send back; anything longer is cut.
const MAX_MESSAGE: u64 = 16 << 10;
/// Exit status of a child that reports an error on its standard error.
const REPORTED: i32 = 3;

/// The grid `name` of the `.vdb` file at `path`, read by a child process under
/// `iso`'s limits.
pub fn read_in_child(iso: &Isolation, path: &Path, name: &str) -> Result<DenseGrid> {
    let failed = |message: String| GridError::Vdb {
        path: path.to_path_buf(),
        message,
    };
    let (Some(folder), Some(file)) = (path.parent(), path.file_name()) else {
        return Err(failed("not a file".into()));
    };
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let mut child = Command::new(&iso.exe)
        .arg("vdb-grid")
        .arg("--grid")
        .arg(name)
        .arg("--memory")
        .arg(iso.memory.to_string())
        .arg(file)
        .current_dir(folder)
        .env("RUST_LOG", "off")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| failed(format!("cannot start the reader process: {e}")))?;
    // Drained while the child runs, so that a full pipe never stalls it.
    let most = 64 + 4 * MAX_VALUES;
    let out = drain(child.stdout.take(), most);
    let err = drain(child.stderr.take(), MAX_MESSAGE);
    let deadline = Instant::now() + iso.time;
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(5)),
            Ok(None) | Err(_) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(failed(format!(
                    "reading it took longer than {} s; the reader was stopped",
                    iso.time.as_secs()
                )));
            }
        }
    };
    let (out, err) = (joined(out), joined(err));
    let shown = Path::new(file).display().to_string();
    if status.success() {
        return decode_vol(&out).map_err(|e| failed(format!("the reader's output: {e}")));
    }
    if status.code() == Some(REPORTED) {
        let text = String::from_utf8_lossy(&err);
        let text = text.trim();
        let message = text.strip_prefix(&format!("{shown}: ")).unwrap_or(text);
        return Err(failed(message.to_string()));
    }
    Err(failed(format!(
        "the reader stopped ({}): the file is malformed, or needs more than the {} MiB \
         the reader may use",
        ended_how(&status),
        iso.memory >> 20
    )))
}

fn drain(pipe: Option<impl Read + Send + 'static>, most: u64) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(p) = pipe {
            let _ = p.take(most).read_to_end(&mut bytes);
        }
        bytes
    })
}

fn joined(h: std::thread::JoinHandle<Vec<u8>>) -> Vec<u8> {
    h.join().unwrap_or_default()
}

fn ended_how(status: &std::process::ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(signal) = status.signal() {
            return format!("signal {signal}");
        }
    }
    match status.code() {
        Some(code) => format!("exit status {code}"),
        None => "no exit status".into(),
    }
}

/// The child's side (`caustic vdb-grid --grid NAME --memory BYTES FILE`): limits its
/// own address space, reads the grid and writes it as a `.vol` to standard output.
/// Returns the exit status.
pub fn child_main(file: &Path, name: &str, memory: u64) -> i32 {
    use std::io::Write;
    limit_memory(memory);
    let grid = vdb::read_vdb(file, name).and_then(|g| {
        super::vol::encode_vol(&g).map_err(|e| GridError::Vdb {
            path: file.to_path_buf(),
            message: e.to_string(),
        })
    });
    match grid {
        Ok(bytes) => match std::io::stdout().lock().write_all(&bytes) {
            Ok(()) => 0,
            Err(_) => 1,
        },
        Err(e) => {
            eprint!("{e}");
            REPORTED
        }
    }
}

/// Caps this process's address space: an allocation past it fails (and aborts the
/// process) instead of taking the machine's memory.
fn limit_memory(bytes: u64) {
    #[cfg(unix)]
    {
        let limit = libc::rlimit {
            rlim_cur: bytes as libc::rlim_t,
            rlim_max: bytes as libc::rlim_t,
        };
        // SAFETY: setrlimit reads the struct we pass and changes only this process.
        unsafe {
            libc::setrlimit(libc::RLIMIT_AS, &limit);
        }
    }
    #[cfg(not(unix))]
    let _ = bytes;
}
