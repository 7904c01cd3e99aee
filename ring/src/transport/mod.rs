//! Ring transports: how one member's frames reach the next member.
//!
//! A member publishes its frames on its own link (`link/<k>`) and receives the frames of its
//! upstream neighbour (`link/<k-1 mod n>`). Two implementations share this interface:
//! [`zenoh_link`] (real processes, zenoh peer mode) and [`loopback`] (in-process channels for
//! deterministic tests and benchmarks).

pub mod cluster;
pub mod loopback;
pub mod session;
pub mod zenoh_link;

use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, TryRecvError};

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
    /// Put one encoded frame on the link.
    fn send(&self, frame: &[u8]) -> Result<(), TransportError>;
}

/// Receiving half: the frames of the upstream neighbour, in arrival order.
#[derive(Debug)]
pub struct LinkRx {
    rx: Receiver<Vec<u8>>,
    dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

impl LinkRx {
    pub(crate) fn new(
        rx: Receiver<Vec<u8>>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Self {
        LinkRx { rx, dropped }
    }

    /// Wait up to `timeout` for the next frame. `Ok(None)` on timeout.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<Vec<u8>>, TransportError> {
        match self.rx.recv_timeout(timeout) {
            Ok(f) => Ok(Some(f)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(TransportError::Closed),
        }
    }

    /// The next frame if one is already waiting.
    pub fn try_recv(&self) -> Result<Option<Vec<u8>>, TransportError> {
        match self.rx.try_recv() {
            Ok(f) => Ok(Some(f)),
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(TransportError::Closed),
        }
    }

    /// Frames waiting in the queue now.
    pub fn pending(&self) -> usize {
        self.rx.len()
    }

    /// Frames dropped because the receive queue was full (counted as overruns by the member).
    pub fn take_dropped(&self) -> u64 {
        self.dropped.swap(0, std::sync::atomic::Ordering::Relaxed)
    }
}

/// Push a received frame into a bounded queue, counting what does not fit.
pub(crate) fn deliver(
    tx: &crossbeam_channel::Sender<Vec<u8>>,
    dropped: &std::sync::atomic::AtomicU64,
    frame: Vec<u8>,
) {
    if tx.try_send(frame).is_err() {
        dropped.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
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
