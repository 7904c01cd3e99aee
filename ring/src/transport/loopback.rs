//! In-process loopback ring: one bounded channel per link. Same interface as the zenoh
//! transport, used by deterministic tests and benchmarks that run members as threads.

use std::sync::{Arc, Mutex};

use super::queue::{frame_queue, QueueReceiver, QueueSender};
use super::{monotonic_ns, upstream_of, LinkRx, LinkTx, TransportError, RX_QUEUE_FRAMES};

/// A ring of `n` in-process links. Link k carries member k's frames to member k+1.
#[derive(Debug)]
pub struct LoopbackRing {
    links: Vec<QueueSender>,
    receivers: Mutex<Vec<Option<QueueReceiver>>>,
    cut: Arc<Vec<std::sync::atomic::AtomicBool>>,
}

impl LoopbackRing {
    /// A ring of `n` members (n ≥ 1).
    pub fn new(n: usize) -> Self {
        let mut links = Vec::with_capacity(n);
        let mut receivers = Vec::with_capacity(n);
        for _ in 0..n {
            let (tx, rx) = frame_queue(RX_QUEUE_FRAMES);
            links.push(tx);
            receivers.push(Some(rx));
        }
        let cut = Arc::new(
            (0..n)
                .map(|_| std::sync::atomic::AtomicBool::new(false))
                .collect(),
        );
        LoopbackRing {
            links,
            receivers: Mutex::new(receivers),
            cut,
        }
    }

    /// Number of members.
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// True for an empty ring.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// The link ends of member `k`: its sender on link k and the receiver of link k-1.
    /// Each member's receiver can be taken once.
    pub fn member(&self, k: usize) -> Result<(LoopbackTx, LinkRx), TransportError> {
        let n = self.links.len();
        if k >= n {
            return Err(TransportError::Io(format!(
                "member {k} out of range 0..{n}"
            )));
        }
        let up = upstream_of(k, n);
        let rx = self
            .receivers
            .lock()
            .map_err(|_| TransportError::Closed)?
            .get_mut(up)
            .and_then(Option::take)
            .ok_or_else(|| TransportError::Io(format!("member {k} already joined")))?;
        Ok((
            LoopbackTx {
                tx: self.links[k].clone(),
                cut: Arc::clone(&self.cut),
                k,
            },
            LinkRx::new(rx, None),
        ))
    }

    /// Physically cut (or mend) link k, below the fault layer (a pulled fibre).
    pub fn set_cut(&self, k: usize, cut: bool) {
        if let Some(c) = self.cut.get(k) {
            c.store(cut, std::sync::atomic::Ordering::Relaxed);
        }
    }
}

/// Sending half of a loopback link.
#[derive(Debug)]
pub struct LoopbackTx {
    tx: QueueSender,
    cut: Arc<Vec<std::sync::atomic::AtomicBool>>,
    k: usize,
}

impl LinkTx for LoopbackTx {
    fn send(&self, frame: Vec<u8>) -> Result<(), TransportError> {
        if self.cut[self.k].load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(());
        }
        self.tx.push(frame, monotonic_ns());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn frames_go_to_the_next_member_and_wrap() {
        let ring = LoopbackRing::new(3);
        let (tx0, rx0) = ring.member(0).unwrap();
        let (tx1, rx1) = ring.member(1).unwrap();
        let (tx2, rx2) = ring.member(2).unwrap();
        tx0.send(b"a".to_vec()).unwrap();
        tx1.send(b"b".to_vec()).unwrap();
        tx2.send(b"c".to_vec()).unwrap();
        let t = Duration::from_millis(100);
        assert_eq!(rx1.recv_timeout(t).unwrap().unwrap(), b"a");
        assert_eq!(rx2.recv_timeout(t).unwrap().unwrap(), b"b");
        assert_eq!(rx0.recv_timeout(t).unwrap().unwrap(), b"c");
        assert!(rx0.try_recv().unwrap().is_none());
    }

    #[test]
    fn a_member_joins_once_and_out_of_range_is_an_error() {
        let ring = LoopbackRing::new(2);
        assert!(ring.member(0).is_ok());
        assert!(ring.member(0).is_err());
        assert!(ring.member(5).is_err());
    }

    #[test]
    fn cut_link_delivers_nothing_and_full_queue_counts_drops() {
        let ring = LoopbackRing::new(2);
        let (tx0, _rx0) = ring.member(0).unwrap();
        let (_tx1, rx1) = ring.member(1).unwrap();
        ring.set_cut(0, true);
        tx0.send(b"x".to_vec()).unwrap();
        assert!(rx1.try_recv().unwrap().is_none());
        ring.set_cut(0, false);
        for _ in 0..RX_QUEUE_FRAMES + 3 {
            tx0.send(b"y".to_vec()).unwrap();
        }
        assert_eq!(rx1.pending(), RX_QUEUE_FRAMES);
        assert_eq!(rx1.take_dropped(), 3);
        assert_eq!(rx1.take_dropped(), 0);
    }
}
