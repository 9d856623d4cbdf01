//! WatchJob: forwarding a service watch to a gRPC stream.

use super::convert::event_to_pb;
use super::{pb, to_status};
use crate::job::events::Event;
use crate::job::watch::{Watch, Watched};
use crate::job::Service;
use std::sync::Arc;
use tokio::sync::mpsc;
use tonic::Status;

type EventSender = mpsc::Sender<Result<pb::JobEvent, Status>>;

/// Forwards a watch ([`crate::job::watch`]: the job's state first, then changes)
/// until its last item or the client leaving.
pub(super) async fn forward(
    svc: Arc<Service>,
    id: String,
    include_snapshots: bool,
    mut watch: Watch,
    tx: EventSender,
) {
    loop {
        let item = tokio::select! {
            w = watch.next() => w,
            _ = tx.closed() => return,
        };
        let msg = match item {
            None => return,
            Some(Watched::Event(e @ Event::Snapshot { iteration, .. })) if include_snapshots => {
                let mut msg = event_to_pb(e);
                if let Some(pb::job_event::Event::Snapshot(s)) = &mut msg.event {
                    s.png = snapshot_png(&svc, &id, iteration).await;
                }
                Ok(msg)
            }
            Some(Watched::Event(e)) => Ok(event_to_pb(e)),
            Some(Watched::Stopping) => Err(Status::unavailable(
                "the server is stopping; the job resumes from its checkpoint when it starts again",
            )),
            Some(Watched::Lost(e)) => Err(to_status(e)),
        };
        if tx.send(msg).await.is_err() {
            return;
        }
    }
}

/// The snapshot's PNG, or empty if it cannot be read (e.g. the job was deleted).
async fn snapshot_png(svc: &Arc<Service>, id: &str, iteration: u64) -> Vec<u8> {
    let (svc, id) = (svc.clone(), id.to_string());
    match tokio::task::spawn_blocking(move || svc.snapshot(&id, iteration, "png")).await {
        Ok(Ok(png)) => png,
        Ok(Err(e)) => {
            tracing::warn!(error = %e, iteration, "snapshot for a watcher is gone");
            Vec::new()
        }
        Err(e) => {
            tracing::error!(error = %e, "snapshot read task failed");
            Vec::new()
        }
    }
}
