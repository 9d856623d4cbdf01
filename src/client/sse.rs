//! Server-Sent Events: the message reader and the job events the client knows.

use crate::job::spec::{JobState, JobStatus};
use serde::Deserialize;
use std::io::BufRead;

/// One SSE message: its `event:` name (default `message`) and joined `data:` lines.
#[derive(Debug, Clone, PartialEq)]
pub struct SseMessage {
    pub event: String,
    pub data: String,
}

/// Reads SSE messages line by line; comments (keep-alives) and `id:`/`retry:` fields
/// are skipped.
pub struct SseReader<R> {
    inner: R,
}

impl<R: BufRead> SseReader<R> {
    pub fn new(inner: R) -> Self {
        SseReader { inner }
    }

    /// The next complete message, or `None` at the end of the stream.
    pub fn next_message(&mut self) -> std::io::Result<Option<SseMessage>> {
        let mut event = String::new();
        let mut data: Option<String> = None;
        let mut line = String::new();
        loop {
            line.clear();
            if self.inner.read_line(&mut line)? == 0 {
                // An unterminated message at the end is discarded, as the spec says.
                return Ok(None);
            }
            let l = line.trim_end_matches(['\n', '\r']);
            if l.is_empty() {
                if let Some(data) = data.take() {
                    let event = if event.is_empty() {
                        "message".to_string()
                    } else {
                        std::mem::take(&mut event)
                    };
                    return Ok(Some(SseMessage { event, data }));
                }
                event.clear();
                continue;
            }
            if l.starts_with(':') {
                continue;
            }
            let (field, value) = match l.split_once(':') {
                Some((f, v)) => (f, v.strip_prefix(' ').unwrap_or(v)),
                None => (l, ""),
            };
            match field {
                "event" => event = value.to_string(),
                "data" => match &mut data {
                    Some(d) => {
                        d.push('\n');
                        d.push_str(value);
                    }
                    None => data = Some(value.to_string()),
                },
                _ => {}
            }
        }
    }
}

/// The data of a job event (see `job::events::Event`), as the client reads it.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum WatchEvent {
    Progress {
        iteration: u64,
        elapsed_s: f64,
        samples_per_s: f64,
        #[serde(default)]
        eta_s: Option<f64>,
        #[serde(default)]
        dropped: u64,
    },
    Snapshot {
        iteration: u64,
        #[serde(default)]
        rmse: Option<f64>,
        /// Estimated from the job's own iterations; the watcher shows its square root.
        #[serde(default)]
        est_rel_mse: Option<f64>,
    },
    State {
        state: JobState,
    },
    Done {
        status: Box<JobStatus>,
    },
    /// The server is stopping; the stream ends after this (the job resumes when the
    /// server starts again, and the watcher reconnects).
    Shutdown,
    /// An event this client does not know yet.
    #[serde(other)]
    Other,
}
