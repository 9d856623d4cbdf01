//! Watching one job: the event stream that SSE and gRPC `WatchJob` both serve, with
//! the one policy for a watcher that falls behind the broadcast channel.
//!
//! A [`Watch`] yields the job's current state first (then `done`, for a finished job),
//! then its live events, and ends after `done`, or with [`Watched::Stopping`] when the
//! server begins to stop. A `state` event that repeats the last state yielded is
//! dropped: watchers see changes only. A watcher that lags (the channel dropped events
//! it had not read) re-reads the job: a finished job yields its state and `done`, so
//! that the terminal event is never lost; a live one yields its state if that changed
//! and a `progress` event from its current status.

use super::events::Event;
use super::scheduler::Shared;
use super::spec::{JobState, JobStatus};
use super::{JobError, Service};
use futures::Stream;
use std::collections::VecDeque;
use std::sync::Arc;
use tokio::sync::broadcast::error::RecvError;
use tokio::sync::{broadcast, watch};

/// What a [`Watch`] yields.
#[derive(Debug)]
pub enum Watched {
    /// An event of the job; after `done` the stream ends.
    Event(Event),
    /// The server is stopping (the job resumes from its checkpoint when it starts
    /// again); the last item.
    Stopping,
    /// The job could not be read again after a lag (it was deleted); the last item.
    Lost(JobError),
}

/// One job's events; see the module documentation.
pub struct Watch {
    id: String,
    shared: Arc<Shared>,
    events: broadcast::Receiver<Event>,
    closing: watch::Receiver<bool>,
    /// What is yielded next, in order, before anything from the channel.
    pending: VecDeque<Watched>,
    /// The last state yielded.
    state: JobState,
    ended: bool,
}

impl Service {
    /// Opens a [`Watch`] on job `id`. Reads the job table: call it off the async
    /// runtime.
    pub fn watch(&self, id: &str) -> Result<Watch, JobError> {
        // Subscribe before reading the state, so no event after that read is missed.
        let events = self.subscribe();
        let status = self.get_job(id)?;
        Ok(Watch::new(
            self.shared().clone(),
            events,
            self.closing(),
            status,
        ))
    }
}

impl Watch {
    fn new(
        shared: Arc<Shared>,
        events: broadcast::Receiver<Event>,
        closing: watch::Receiver<bool>,
        status: JobStatus,
    ) -> Self {
        Watch {
            id: status.id.clone(),
            shared,
            events,
            closing,
            state: status.state,
            pending: Event::said(&status)
                .into_iter()
                .map(Watched::Event)
                .collect(),
            ended: false,
        }
    }

    /// The job's state as of the last item yielded (before the first: when the watch
    /// was opened).
    pub fn state(&self) -> JobState {
        self.state
    }

    /// The next item, or `None` once the last has been yielded.
    pub async fn next(&mut self) -> Option<Watched> {
        if self.ended {
            return None;
        }
        let item = match self.pending.pop_front() {
            Some(item) => item,
            None => self.receive().await,
        };
        match &item {
            Watched::Event(Event::State { state, .. }) => self.state = *state,
            Watched::Event(Event::Done { status, .. }) => {
                self.state = status.state;
                self.ended = true;
            }
            Watched::Event(_) => {}
            Watched::Stopping | Watched::Lost(_) => self.ended = true,
        }
        Some(item)
    }

    /// The watch as a stream.
    pub fn into_stream(self) -> impl Stream<Item = Watched> + Send + 'static {
        futures::stream::unfold(self, |mut w| async move {
            let item = w.next().await?;
            Some((item, w))
        })
    }

    /// The next item from the channel. The server stopping wins over events that are
    /// waiting, so that streams end promptly.
    async fn receive(&mut self) -> Watched {
        loop {
            let next = tokio::select! {
                biased;
                _ = self.closing.wait_for(|c| *c) => return Watched::Stopping,
                e = self.events.recv() => e,
            };
            match next {
                // Already said: the state read when the watch opened, or a repeat.
                Ok(Event::State { state, .. }) if state == self.state => continue,
                Ok(e) if e.job() == self.id => return Watched::Event(e),
                Ok(_) => continue,
                Err(RecvError::Lagged(missed)) => {
                    tracing::warn!(job = %self.id, missed, "watcher lagged behind");
                    return self.resync().await;
                }
                // The watch holds the sender (in `shared`): this cannot happen while
                // it lives; end as at shutdown.
                Err(RecvError::Closed) => return Watched::Stopping,
            }
        }
    }

    /// After a lag: the job as it is now. A state that changed comes first, queued
    /// behind it the progress (or `done`).
    async fn resync(&mut self) -> Watched {
        let (shared, id) = (self.shared.clone(), self.id.clone());
        let read = tokio::task::spawn_blocking(move || {
            let t = shared.table.lock().expect("job table");
            t.jobs.get(&id).map(|e| e.status.clone())
        })
        .await;
        let status = match read {
            Ok(Some(s)) => s,
            Ok(None) => return Watched::Lost(JobError::NotFound(format!("job {}", self.id))),
            Err(e) => return Watched::Lost(JobError::Internal(format!("watch task: {e}"))),
        };
        let changed = status.state != self.state;
        let mut now = if status.state.is_terminal() {
            Event::said(&status)
        } else {
            vec![
                Event::State {
                    job: status.id.clone(),
                    state: status.state,
                },
                progress(status),
            ]
        };
        if !changed {
            now.remove(0);
        }
        self.pending.extend(now.into_iter().map(Watched::Event));
        self.pending.pop_front().expect("an event after a lag")
    }
}

fn progress(s: JobStatus) -> Event {
    Event::Progress {
        job: s.id,
        iteration: s.iteration,
        elapsed_s: s.elapsed_s,
        samples_per_s: s.samples_per_s,
        eta_s: s.eta_s,
        dropped: s.dropped,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::ServiceConfig;
    use std::time::Duration;

    fn other_job_progress(i: u64) -> Event {
        Event::Progress {
            job: "someone-else".into(),
            iteration: i,
            elapsed_s: 0.0,
            samples_per_s: 0.0,
            eta_s: None,
            dropped: 0,
        }
    }

    /// A watcher that does not read while far more events than the channel holds go
    /// by loses the job's `done` from the channel; the watch still ends with it.
    #[tokio::test]
    async fn done_arrives_after_the_watcher_lagged() {
        let (_dir, svc) = service();
        let job = long_job(&svc);
        let mut w = svc.watch(&job.id).unwrap();
        let cancelled = {
            let (svc, id) = (svc.clone(), job.id.clone());
            tokio::task::spawn_blocking(move || svc.cancel(&id))
                .await
                .unwrap()
                .unwrap()
        };
        assert_eq!(cancelled.state, JobState::Cancelled);
        for i in 0..4 * 1024 {
            svc.shared().ctx.emit(other_job_progress(i));
        }
        let mut seen = Vec::new();
        let drained = tokio::time::timeout(Duration::from_secs(30), async {
            while let Some(item) = w.next().await {
                seen.push(item);
            }
        })
        .await;
        assert!(drained.is_ok(), "the watch did not end: {seen:?}");
        match seen.last() {
            Some(Watched::Event(Event::Done { status, .. })) => {
                assert_eq!(status.state, JobState::Cancelled)
            }
            other => panic!("the last item is not done: {other:?} of {seen:?}"),
        }
        assert!(w.next().await.is_none());
        svc.shutdown();
    }

    fn service() -> (tempfile::TempDir, Arc<Service>) {
        let dir = tempfile::tempdir().unwrap();
        let svc = Service::start(ServiceConfig::for_tests(dir.path())).unwrap();
        (dir, svc)
    }

    fn long_job(svc: &Service) -> JobStatus {
        let spec = serde_json::from_value(serde_json::json!({
            "scene": "cornell-box", "halt": {"iterations": 1_000_000}
        }))
        .unwrap();
        svc.submit(spec).unwrap()
    }

    #[tokio::test]
    async fn a_finished_job_yields_its_state_then_done() {
        let (_dir, svc) = service();
        let job = long_job(&svc);
        let (s, id) = (svc.clone(), job.id.clone());
        tokio::task::spawn_blocking(move || s.cancel(&id))
            .await
            .unwrap()
            .unwrap();
        let mut w = svc.watch(&job.id).unwrap();
        assert_eq!(w.state(), JobState::Cancelled);
        assert!(matches!(
            w.next().await,
            Some(Watched::Event(Event::State {
                state: JobState::Cancelled,
                ..
            }))
        ));
        assert!(matches!(
            w.next().await,
            Some(Watched::Event(Event::Done { .. }))
        ));
        assert!(w.next().await.is_none());
        svc.shutdown();
    }

    /// A job that starts while watched says `running` before its first `progress`,
    /// and no state twice in a row.
    #[tokio::test]
    async fn a_starting_job_is_running_before_its_progress() {
        let (_dir, svc) = service();
        let job = long_job(&svc);
        let call = |f: fn(&Service, &str) -> Result<JobStatus, JobError>| {
            let (s, id) = (svc.clone(), job.id.clone());
            tokio::task::spawn_blocking(move || f(&s, &id))
        };
        call(Service::pause).await.unwrap().unwrap();
        let mut w = svc.watch(&job.id).unwrap();
        call(Service::resume).await.unwrap().unwrap();
        let mut states = Vec::new();
        let first_progress = tokio::time::timeout(Duration::from_secs(60), async {
            loop {
                match w.next().await {
                    Some(Watched::Event(Event::State { state, .. })) => states.push(state),
                    Some(Watched::Event(Event::Progress { .. })) => return,
                    other => panic!("unexpected {other:?} after {states:?}"),
                }
            }
        })
        .await;
        assert!(first_progress.is_ok(), "no progress after {states:?}");
        assert_eq!(
            states,
            [JobState::Paused, JobState::Queued, JobState::Running]
        );
        svc.shutdown();
    }

    #[tokio::test]
    async fn a_stopping_server_ends_a_watch() {
        let (_dir, svc) = service();
        let job = long_job(&svc);
        let mut w = svc.watch(&job.id).unwrap();
        assert!(matches!(
            w.next().await,
            Some(Watched::Event(Event::State { .. }))
        ));
        svc.begin_shutdown();
        let last = tokio::time::timeout(Duration::from_secs(30), async {
            loop {
                match w.next().await {
                    Some(Watched::Event(Event::Done { .. })) | None => return false,
                    Some(Watched::Stopping) => return true,
                    Some(_) => continue,
                }
            }
        })
        .await
        .unwrap();
        assert!(last, "the watch ends with Stopping");
        assert!(w.next().await.is_none());
        svc.shutdown();
    }
}
