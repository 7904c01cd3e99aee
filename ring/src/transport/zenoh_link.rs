//! Ring links over zenoh: member k publishes on `mcc/<cluster>/ring/<ring>/link/<k>` and
//! subscribes to its upstream neighbour's key.

use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::Wait;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use super::queue::frame_queue;
use super::{
    deliver, monotonic_ns, upstream_of, InlineSlot, LinkRx, LinkTx, TransportError, RX_QUEUE_FRAMES,
};
use crate::control::link_key;

/// Sending half of a zenoh ring link (a declared publisher: express, real-time priority, a link
/// queue that a healthy ring can never fill; see [`join`]).
pub struct ZenohTx {
    publisher: Publisher<'static>,
    /// zenoh's matching status of the publisher: a subscriber of the link (the downstream
    /// neighbour's) is known to this process, kept by a matching listener.
    matched: Arc<AtomicBool>,
}

impl std::fmt::Debug for ZenohTx {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohTx").finish_non_exhaustive()
    }
}

impl LinkTx for ZenohTx {
    fn send(&self, frame: Vec<u8>) -> Result<(), TransportError> {
        // The send stamp travels out of band, as an attachment (hop latency, see `hops`).
        self.publisher
            .put(frame)
            .attachment(monotonic_ns().to_le_bytes())
            .wait()
            .map_err(|e| TransportError::Io(e.to_string()))
    }

    fn matched(&self) -> Option<bool> {
        Some(self.matched.load(Ordering::Relaxed))
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
    // Express: never held back to share a batch with later messages; real-time priority: no
    // other traffic shares its queue.
    //
    // Drop, not Block, and still no frame is lost while the ring is healthy: a paced or lockstep
    // ring carries at most `ring.in_flight` (<= 8) frames per link at a time (cycle k+N starts
    // only once the frame of cycle k came back, so the frame of k on this link was written and
    // read), and the link's real-time queue holds `session::RING_TX_QUEUE_BATCHES` (16) express
    // frames: a put always finds room and never waits. The queue can only fill when the
    // downstream member truly stopped reading (frozen, hung) while the sync master runs the
    // downed ring on its own clock. Then Drop loses frames to a member that is not listening, as
    // light into a dead fibre; Block would stall the put, which runs on zenoh's single receive
    // thread (`runtime::inline`) — the same thread that runs this link's transmit task, so it
    // would wait for itself — stopping everything else this process receives (status, control,
    // the upstream frames) for zenoh's 5 s block timeout and then closing the link.
    // (tests/scenarios/cluster.rs `lockstep_rings_under_full_load_lose_no_frame`.)
    let publisher = session
        .declare_publisher(link_key(cluster, ring, k))
        .congestion_control(CongestionControl::Drop)
        .priority(Priority::RealTime)
        .express(true)
        .wait()
        .map_err(|e| TransportError::Io(format!("declare publisher: {e}")))?;
    // "The link is up" is a fact zenoh gives (see `runtime::links_up`): the matching status
    // of the link's publisher, followed as it changes (the downstream neighbour restarted).
    let matched = Arc::new(AtomicBool::new(false));
    let m2 = Arc::clone(&matched);
    publisher
        .matching_listener()
        .callback(move |s| m2.store(s.matching(), Ordering::Relaxed))
        .background()
        .wait()
        .map_err(|e| TransportError::Io(format!("declare matching listener: {e}")))?;
    if let Ok(s) = publisher.matching_status().wait() {
        matched.fetch_or(s.matching(), Ordering::Relaxed);
    }
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
            // Contiguous payloads (a ring frame is one small message) are borrowed, not
            // copied: a frame handled inline is never allocated by us.
            deliver(&slot2, &tx, &sample.payload().to_bytes(), sent_ns);
        })
        .wait()
        .map_err(|e| TransportError::Io(format!("declare subscriber: {e}")))?;
    Ok((
        ZenohTx { publisher, matched },
        LinkRx::new(rx, Some(slot)),
        ZenohRxGuard {
            _subscriber: subscriber,
        },
    ))
}
