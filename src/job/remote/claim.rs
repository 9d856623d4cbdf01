//! One coordinator per pool. Two coordinators on one NATS server would both queue
//! units on the shared work stream and take each other's answers, so the first to
//! start claims the pool: a key in the bucket [`COORDINATOR_BUCKET`], renewed every
//! [`RENEW`] and gone [`CLAIM_TTL`] after its coordinator stops renewing it. A second
//! coordinator is refused with a message naming the holder.
//!
//! A coordinator restarted on the same data directory on the same host (after a
//! crash, before its old claim expired) takes the claim over at once: the data
//! directory's own lock (`job::lock`) already proves the old process is gone.

use super::RemoteError;
use async_nats::jetstream::kv::{CreateErrorKind, Entry, Operation, Store};
use async_nats::jetstream::Context as Js;
use serde::{Deserialize, Serialize};
use std::time::Duration;

pub const COORDINATOR_BUCKET: &str = "caustic-coordinator";
const KEY: &str = "holder";
/// How long a claim outlives its last renewal.
pub const CLAIM_TTL: Duration = Duration::from_secs(15);
const RENEW: Duration = Duration::from_secs(3);

/// Who holds the pool.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Holder {
    /// Host and data directory: equal for a restart of the same coordinator.
    pub identity: String,
    /// For people: process, host, data directory, start time.
    pub description: String,
}

/// Claims the pool for `me`, or says who has it; keeps renewing the claim on the
/// current runtime until the returned task is aborted.
pub async fn claim(js: &Js, me: Holder) -> Result<tokio::task::JoinHandle<()>, RemoteError> {
    let kv = bucket(js).await?;
    let value = serde_json::to_vec(&me).expect("holder");
    let revision = match kv.create(KEY, value.clone().into()).await {
        Ok(r) => r,
        Err(e) if e.kind() == CreateErrorKind::AlreadyExists => {
            let current = live(&kv).await.map_err(RemoteError::nats)?;
            let holder = current.and_then(|e| serde_json::from_slice::<Holder>(&e.value).ok());
            match holder {
                Some(h) if h.identity != me.identity => {
                    return Err(RemoteError::Claimed {
                        holder: h.description,
                        ttl_s: CLAIM_TTL.as_secs(),
                    })
                }
                // Ours from before a restart, or unreadable: take it over.
                _ => kv
                    .put(KEY, value.clone().into())
                    .await
                    .map_err(RemoteError::nats)?,
            }
        }
        Err(e) => return Err(RemoteError::nats(e)),
    };
    Ok(tokio::spawn(renew(kv, value, revision)))
}

/// Gives the pool up at a clean stop, so that another coordinator may start at once.
pub async fn release(js: &Js) {
    if let Ok(kv) = js.get_key_value(COORDINATOR_BUCKET).await {
        let _ = kv.delete(KEY).await;
    }
}

async fn bucket(js: &Js) -> Result<Store, RemoteError> {
    if let Ok(kv) = js.get_key_value(COORDINATOR_BUCKET).await {
        return Ok(kv);
    }
    js.create_key_value(async_nats::jetstream::kv::Config {
        bucket: COORDINATOR_BUCKET.into(),
        max_age: CLAIM_TTL,
        ..Default::default()
    })
    .await
    .map_err(RemoteError::nats)
}

/// The claim's current entry, unless deleted or expired.
async fn live(kv: &Store) -> Result<Option<Entry>, async_nats::jetstream::kv::EntryError> {
    Ok(kv
        .entry(KEY)
        .await?
        .filter(|e| e.operation == Operation::Put))
}

/// Renews the claim, expecting to be the last writer. Losing it means this
/// coordinator stalled for longer than the claim lives and another one took the pool:
/// that is logged as an error for the operator (both now queue units), and this one
/// stops renewing rather than fight over the key.
async fn renew(kv: Store, value: Vec<u8>, mut revision: u64) {
    loop {
        tokio::time::sleep(RENEW).await;
        let Err(e) = kv
            .update(KEY, value.clone().into(), revision)
            .await
            .map(|r| revision = r)
        else {
            continue;
        };
        match live(&kv).await {
            Ok(Some(entry)) if entry.value[..] != value[..] => {
                tracing::error!(
                    "another coordinator took this pool over while this one stalled; stop \
                     one of them"
                );
                return;
            }
            Ok(Some(entry)) => revision = entry.revision,
            // Expired during a NATS outage: claim it again.
            Ok(None) => {
                if let Ok(r) = kv.create(KEY, value.clone().into()).await {
                    revision = r;
                }
            }
            Err(_) => tracing::warn!("renewing the pool claim: {e}"),
        }
    }
}
