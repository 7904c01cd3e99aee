//! Ring transports: how one member's frames reach the next member.
//!
//! A member publishes its frames on its own link (`link/<k>`) and receives the frames of its
//! upstream neighbour (`link/<k-1 mod n>`). Two implementations share this interface:
//! [`zenoh_link`] (real processes, zenoh peer mode) and [`loopback`] (in-process channels for
//! deterministic tests and benchmarks).

pub mod cluster;
pub mod hops;
pub mod loopback;
pub mod queue;
pub mod session;
pub mod zenoh_link;

use std::cell::RefCell;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use hops::{HopStats, HopSummary};
use queue::{QueueReceiver, QueueSender, QueueWaker, RecvError, Stamped};

/// Upper bound of frames waiting in a member's receive queue; beyond it frames are dropped
/// and counted (a real ring has no buffer at all).
pub const RX_QUEUE_FRAMES: usize = 256;

/// Error of a link operation.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// The link is closed (the other side or the session went away).
    #[error("ring link closed")]
    Closed,
    /// The underlying transport failed.
    #[error("ring transport: {0}")]
    Io(String),
}

/// Sending half of a member's outgoing link.
pub trait LinkTx: Send {
    /// Put one encoded frame on the link (taken as it is: no copy on the way to zenoh).
    fn send(&self, frame: Vec<u8>) -> Result<(), TransportError>;

    /// Whether the link has a receiver: zenoh's matching status of the link's publisher (a
    /// subscriber of the link is known); None where the transport cannot tell (loopback).
    fn matched(&self) -> Option<bool> {
        None
    }
}

/// Handles frames on the thread that delivers them (zenoh's receive thread), without a hand-off
/// to the member's own thread; see [`LinkRx::set_inline`].
pub trait InlineHandler: Send + Sync {
    /// A frame stamped `sent_ns` arrived: handle it now (true), or decline (false) and the
    /// delivery side queues a copy (the member is busy, or frames are already waiting: order
    /// is kept). A frame handled here is read in place: nothing is allocated for it.
    fn offer(&self, frame: &[u8], sent_ns: u64) -> bool;
}

/// Where a link's delivery side finds its inline handler, once installed.
pub(crate) type InlineSlot = Arc<OnceLock<Arc<dyn InlineHandler>>>;

/// The delivery side of a link: offer each frame to the inline handler if there is one, else
/// (or when it declines) queue it.
pub(crate) fn deliver(slot: &InlineSlot, queue: &QueueSender, frame: &[u8], sent_ns: u64) {
    if slot.get().is_some_and(|h| h.offer(frame, sent_ns)) {
        return;
    }
    queue.push(frame.to_vec(), sent_ns);
}

/// Receiving half: the frames of the upstream neighbour, in arrival order.
pub struct LinkRx {
    rx: QueueReceiver,
    hops: RefCell<HopStats>,
    /// Set when the link can deliver frames inline (zenoh: on its receive thread).
    inline: Option<InlineSlot>,
}

impl std::fmt::Debug for LinkRx {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LinkRx")
            .field("rx", &self.rx)
            .field("inline", &self.inline.is_some())
            .finish_non_exhaustive()
    }
}

impl LinkRx {
    pub(crate) fn new(rx: QueueReceiver, inline: Option<InlineSlot>) -> Self {
        LinkRx {
            rx,
            hops: RefCell::new(HopStats::default()),
            inline,
        }
    }

    /// From now on, offer each arriving frame to `handler` on the delivering thread before
    /// queueing it. False when this link cannot (the in-process loopback: its delivering
    /// thread is the upstream member's own) or a handler is already installed.
    pub fn set_inline(&self, handler: Arc<dyn InlineHandler>) -> bool {
        self.inline
            .as_ref()
            .is_some_and(|slot| slot.set(handler).is_ok())
    }

    /// Whether [`Self::set_inline`] can work on this link.
    pub fn supports_inline(&self) -> bool {
        self.inline.as_ref().is_some_and(|s| s.get().is_none())
    }

    /// No frame is queued.
    pub fn is_empty(&self) -> bool {
        self.rx.is_empty()
    }

    /// Wait until a frame is queued or [`Self::waker`] is poked (see [`QueueReceiver::wait`]).
    pub fn wait(&self, timeout: Duration) -> bool {
        self.rx.wait(timeout)
    }

    /// Wakes [`Self::wait`] without a frame.
    pub fn waker(&self) -> QueueWaker {
        self.rx.waker()
    }

    /// A frame stamped `sent_ns` was handled inline just now (hop statistics).
    pub fn record_hop(&self, sent_ns: u64) {
        let mut h = self.hops.borrow_mut();
        h.record(sent_ns, monotonic_ns());
        h.count_inline();
    }

    fn took(&self, r: Result<Stamped, RecvError>) -> Result<Option<Vec<u8>>, TransportError> {
        match r {
            Ok((frame, sent_ns)) => {
                self.hops.borrow_mut().record(sent_ns, monotonic_ns());
                Ok(Some(frame))
            }
            Err(RecvError::Timeout) => Ok(None),
            Err(RecvError::Closed) => Err(TransportError::Closed),
        }
    }

    /// Wait up to `timeout` for the next frame. `Ok(None)` on timeout.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<Vec<u8>>, TransportError> {
        self.took(self.rx.recv_timeout(timeout))
    }

    /// The next frame if one is already waiting.
    pub fn try_recv(&self) -> Result<Option<Vec<u8>>, TransportError> {
        self.took(self.rx.try_recv())
    }

    /// Latency of the recent hops into this member (see [`hops`]).
    pub fn hop_summary(&self) -> HopSummary {
        self.hops.borrow().summary()
    }

    /// Frames waiting in the queue now.
    pub fn pending(&self) -> usize {
        self.rx.len()
    }

    /// Frames dropped because the receive queue was full (counted as overruns by the member).
    pub fn take_dropped(&self) -> u64 {
        self.rx.take_dropped()
    }
}

/// System-wide monotonic clock in ns (`CLOCK_MONOTONIC`): comparable across the processes of
/// one machine (the send stamps of [`hops`]).
pub fn monotonic_ns() -> u64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .map(|t| (t.tv_sec() as u64).saturating_mul(1_000_000_000) + t.tv_nsec() as u64)
        .unwrap_or(0)
}

/// Index of the upstream neighbour of member `k` in a ring of `n`.
pub fn upstream_of(k: usize, n: usize) -> usize {
    (k + n - 1) % n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upstream_wraps() {
        assert_eq!(upstream_of(0, 4), 3);
        assert_eq!(upstream_of(1, 4), 0);
        assert_eq!(upstream_of(3, 4), 2);
        assert_eq!(upstream_of(0, 1), 0);
    }
}
