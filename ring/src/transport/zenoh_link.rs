//! Ring links over zenoh: member k publishes on `mcc/<cluster>/ring/<ring>/link/<k>` and
//! subscribes to its upstream neighbour's key.

use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::Wait;

use std::sync::{Arc, OnceLock};

use super::queue::frame_queue;
use super::{
    deliver, monotonic_ns, upstream_of, InlineSlot, LinkRx, LinkTx, TransportError, RX_QUEUE_FRAMES,
};
use crate::control::link_key;

/// Sending half of a zenoh ring link (a declared publisher: express, real-time priority, dropped
/// rather than blocking when the link's queue is full).
pub struct ZenohTx {
    publisher: Publisher<'static>,
}

impl std::fmt::Debug for ZenohTx {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohTx").finish_non_exhaustive()
    }
}

impl LinkTx for ZenohTx {
    fn send(&self, frame: &[u8]) -> Result<(), TransportError> {
        // The send stamp travels out of band, as an attachment (hop latency, see `hops`).
        self.publisher
            .put(frame.to_vec())
            .attachment(monotonic_ns().to_le_bytes().to_vec())
            .wait()
            .map_err(|e| TransportError::Io(e.to_string()))
    }
}

/// The subscriber must stay alive as long as the receiver is used.
pub struct ZenohRxGuard {
    _subscriber: Subscriber<()>,
}

impl std::fmt::Debug for ZenohRxGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohRxGuard").finish_non_exhaustive()
    }
}

/// Join ring `ring` of `cluster` as member `k` of `n`.
pub fn join(
    session: &zenoh::Session,
    cluster: &str,
    ring: &str,
    k: usize,
    n: usize,
) -> Result<(ZenohTx, LinkRx, ZenohRxGuard), TransportError> {
    if n == 0 || k >= n {
        return Err(TransportError::Io(format!(
            "member {k} out of range 0..{n}"
        )));
    }
    // Express: never held back to share a batch with later messages. Drop: a frame that
    // finds the link's queue full (the downstream member stopped reading) is lost, as on a
    // fibre, instead of blocking the sender — which may be zenoh's single receive thread
    // (`runtime::inline`), whose stall would stop everything else this process receives.
    let publisher = session
        .declare_publisher(link_key(cluster, ring, k))
        .congestion_control(CongestionControl::Block)
        .priority(Priority::RealTime)
        .express(true)
        .wait()
        .map_err(|e| TransportError::Io(format!("declare publisher: {e}")))?;
    let (tx, rx) = frame_queue(RX_QUEUE_FRAMES);
    let slot: InlineSlot = Arc::new(OnceLock::new());
    let slot2 = Arc::clone(&slot);
    let subscriber = session
        .declare_subscriber(link_key(cluster, ring, upstream_of(k, n)))
        .callback(move |sample| {
            let sent_ns = sample
                .attachment()
                .and_then(|a| <[u8; 8]>::try_from(a.to_bytes().as_ref()).ok())
                .map(u64::from_le_bytes)
                .unwrap_or(0);
            deliver(
                &slot2,
                &tx,
                sample.payload().to_bytes().into_owned(),
                sent_ns,
            );
        })
        .wait()
        .map_err(|e| TransportError::Io(format!("declare subscriber: {e}")))?;
    Ok((
        ZenohTx { publisher },
        LinkRx::new(rx, Some(slot)),
        ZenohRxGuard {
            _subscriber: subscriber,
        },
    ))
}
