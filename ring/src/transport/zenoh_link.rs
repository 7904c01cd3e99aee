//! Ring links over zenoh: member k publishes on `mcc/<cluster>/ring/<ring>/link/<k>` and
//! subscribes to its upstream neighbour's key.

use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use crossbeam_channel::bounded;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::Wait;

use super::{deliver, upstream_of, LinkRx, LinkTx, TransportError, RX_QUEUE_FRAMES};
use crate::control::link_key;

/// Sending half of a zenoh ring link (a declared publisher, express, real-time priority).
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
        self.publisher
            .put(frame.to_vec())
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

/// Join ring `ring` of `cluster` as member `k` of `n` (publisher with blocking congestion
/// control: on one machine a frame is never dropped).
pub fn join(
    session: &zenoh::Session,
    cluster: &str,
    ring: &str,
    k: usize,
    n: usize,
) -> Result<(ZenohTx, LinkRx, ZenohRxGuard), TransportError> {
    join_with(session, cluster, ring, k, n, false)
}

/// [`join`]; with `drop_when_congested` the publisher drops a frame its link cannot take
/// (clusters on several hosts: a member never waits for a dead network, as a MACRO
/// transmitter sends into a cut fibre; the loss is loss of light downstream).
pub fn join_with(
    session: &zenoh::Session,
    cluster: &str,
    ring: &str,
    k: usize,
    n: usize,
    drop_when_congested: bool,
) -> Result<(ZenohTx, LinkRx, ZenohRxGuard), TransportError> {
    if n == 0 || k >= n {
        return Err(TransportError::Io(format!(
            "member {k} out of range 0..{n}"
        )));
    }
    let publisher = session
        .declare_publisher(link_key(cluster, ring, k))
        .congestion_control(if drop_when_congested {
            CongestionControl::Drop
        } else {
            CongestionControl::Block
        })
        .priority(Priority::RealTime)
        .express(true)
        .wait()
        .map_err(|e| TransportError::Io(format!("declare publisher: {e}")))?;
    let (tx, rx) = bounded(RX_QUEUE_FRAMES);
    let dropped = Arc::new(AtomicU64::new(0));
    let d2 = Arc::clone(&dropped);
    let subscriber = session
        .declare_subscriber(link_key(cluster, ring, upstream_of(k, n)))
        .callback(move |sample| {
            deliver(&tx, &d2, sample.payload().to_bytes().into_owned());
        })
        .wait()
        .map_err(|e| TransportError::Io(format!("declare subscriber: {e}")))?;
    Ok((
        ZenohTx { publisher },
        LinkRx::new(rx, dropped),
        ZenohRxGuard {
            _subscriber: subscriber,
        },
    ))
}
