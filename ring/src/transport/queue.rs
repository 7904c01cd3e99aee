//! The bounded queue between a link's delivery side (zenoh's receive callback, a loopback
//! sender) and the member's cycle loop.
//!
//! A waiting receiver sleeps on a condition variable and is woken by the push of the next
//! frame: no spinning and no `sched_yield` before it blocks (a general-purpose channel spins
//! and yields first, which on a loaded 2-core machine costs more than the wake-up it saves).
//! A push only makes a wake-up system call when the receiver is actually waiting.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// A queued frame and its sender's send stamp (`CLOCK_MONOTONIC` ns, 0 = unknown).
pub type Stamped = (Vec<u8>, u64);

#[derive(Debug, Default)]
struct Inner {
    frames: VecDeque<Stamped>,
    /// Frames refused because the queue was full, not yet taken by the receiver.
    dropped: u64,
    /// Live senders; at 0 the queue is closed once drained.
    senders: usize,
    /// The receiver is blocked in `recv_timeout` or `wait`.
    waiting: bool,
    /// [`QueueWaker::poke`] since the last [`QueueReceiver::wait`].
    poked: bool,
}

#[derive(Debug)]
struct Shared {
    inner: Mutex<Inner>,
    ready: Condvar,
    cap: usize,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic while holding this lock leaves a consistent queue (every update is a
        // single push/pop/counter step), so a poisoned lock is taken over.
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// See [`QueueReceiver::wait`]; with `frames` false a queued frame does not end the wait.
    fn wait(&self, timeout: Duration, frames: bool) -> bool {
        let deadline = Instant::now().checked_add(timeout);
        let mut g = self.lock();
        loop {
            if (frames && !g.frames.is_empty()) || g.senders == 0 || std::mem::take(&mut g.poked) {
                return true;
            }
            let left = match deadline {
                Some(d) => d.saturating_duration_since(Instant::now()),
                None => Duration::from_secs(3600),
            };
            if left.is_zero() {
                return false;
            }
            g.waiting = true;
            g = match self.ready.wait_timeout(g, left) {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
            g.waiting = false;
        }
    }
}

/// Why a receive returned no frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecvError {
    /// Nothing arrived in time.
    Timeout,
    /// Every sender is gone and the queue is empty.
    Closed,
}

/// A new queue of at most `cap` frames: its delivery side and its receiving side.
pub fn frame_queue(cap: usize) -> (QueueSender, QueueReceiver) {
    let shared = Arc::new(Shared {
        inner: Mutex::new(Inner {
            senders: 1,
            ..Inner::default()
        }),
        ready: Condvar::new(),
        cap: cap.max(1),
    });
    (
        QueueSender {
            shared: Arc::clone(&shared),
        },
        QueueReceiver { shared },
    )
}

/// Delivery side (cloneable).
#[derive(Debug)]
pub struct QueueSender {
    shared: Arc<Shared>,
}

impl Clone for QueueSender {
    fn clone(&self) -> Self {
        self.shared.lock().senders += 1;
        QueueSender {
            shared: Arc::clone(&self.shared),
        }
    }
}

impl Drop for QueueSender {
    fn drop(&mut self) {
        let mut g = self.shared.lock();
        g.senders = g.senders.saturating_sub(1);
        let wake = g.senders == 0 && g.waiting;
        drop(g);
        if wake {
            self.shared.ready.notify_all();
        }
    }
}

impl QueueSender {
    /// Queue one frame sent at `sent_ns`; a full queue refuses it and counts it (see
    /// [`QueueReceiver::take_dropped`]). Returns whether it was queued.
    pub fn push(&self, frame: Vec<u8>, sent_ns: u64) -> bool {
        let mut g = self.shared.lock();
        if g.frames.len() >= self.shared.cap {
            g.dropped += 1;
            return false;
        }
        g.frames.push_back((frame, sent_ns));
        let wake = g.waiting;
        drop(g);
        if wake {
            self.shared.ready.notify_one();
        }
        true
    }
}

/// Wakes the receiver's [`QueueReceiver::wait`] without a frame (work for the member's own
/// thread), and can do that wait itself (for a receiver held elsewhere, behind a lock). Does
/// not keep the queue open.
#[derive(Debug, Clone)]
pub struct QueueWaker {
    shared: Arc<Shared>,
}

impl QueueWaker {
    /// Wake the receiver (now, or at its next wait).
    pub fn poke(&self) {
        let mut g = self.shared.lock();
        g.poked = true;
        let wake = g.waiting;
        drop(g);
        if wake {
            self.shared.ready.notify_one();
        }
    }

    /// [`QueueReceiver::wait`], for the queue's single receiver.
    pub fn wait(&self, timeout: Duration) -> bool {
        self.shared.wait(timeout, true)
    }

    /// Like [`Self::wait`], but frames already queued (or arriving) do not end it: only a poke,
    /// the queue closing, or the timeout (a receiver that must not take frames yet).
    pub fn wait_poke(&self, timeout: Duration) -> bool {
        self.shared.wait(timeout, false)
    }
}

/// Receiving side (one per queue).
#[derive(Debug)]
pub struct QueueReceiver {
    shared: Arc<Shared>,
}

impl QueueReceiver {
    /// The next frame, waiting up to `timeout` for one.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Stamped, RecvError> {
        let deadline = Instant::now().checked_add(timeout);
        let mut g = self.shared.lock();
        loop {
            if let Some(f) = g.frames.pop_front() {
                return Ok(f);
            }
            if g.senders == 0 {
                return Err(RecvError::Closed);
            }
            let left = match deadline {
                Some(d) => d.saturating_duration_since(Instant::now()),
                None => Duration::from_secs(3600),
            };
            if left.is_zero() {
                return Err(RecvError::Timeout);
            }
            g.waiting = true;
            g = match self.shared.ready.wait_timeout(g, left) {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
            g.waiting = false;
        }
    }

    /// Wait up to `timeout` until a frame is queued, the queue is poked (the poke is consumed)
    /// or closed, without taking anything. True unless it timed out.
    pub fn wait(&self, timeout: Duration) -> bool {
        self.shared.wait(timeout, true)
    }

    /// A handle that wakes [`Self::wait`].
    pub fn waker(&self) -> QueueWaker {
        QueueWaker {
            shared: Arc::clone(&self.shared),
        }
    }

    /// The next frame if one is waiting.
    pub fn try_recv(&self) -> Result<Stamped, RecvError> {
        let mut g = self.shared.lock();
        match g.frames.pop_front() {
            Some(f) => Ok(f),
            None if g.senders == 0 => Err(RecvError::Closed),
            None => Err(RecvError::Timeout),
        }
    }

    /// Frames waiting now.
    pub fn len(&self) -> usize {
        self.shared.lock().frames.len()
    }

    /// True when no frame is waiting.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Frames refused since the last call (queue full).
    pub fn take_dropped(&self) -> u64 {
        std::mem::take(&mut self.shared.lock().dropped)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_come_out_in_order_and_a_full_queue_counts_refusals() {
        let (tx, rx) = frame_queue(2);
        assert!(tx.push(b"a".to_vec(), 1));
        assert!(tx.push(b"b".to_vec(), 2));
        assert!(!tx.push(b"c".to_vec(), 3));
        assert_eq!(rx.len(), 2);
        assert_eq!(rx.take_dropped(), 1);
        assert_eq!(rx.take_dropped(), 0);
        assert_eq!(rx.try_recv().unwrap(), (b"a".to_vec(), 1));
        assert_eq!(rx.recv_timeout(Duration::ZERO).unwrap(), (b"b".to_vec(), 2));
        assert_eq!(rx.try_recv(), Err(RecvError::Timeout));
        assert!(rx.is_empty());
    }

    #[test]
    fn a_waiting_receiver_is_woken_by_a_push_from_another_thread() {
        let (tx, rx) = frame_queue(4);
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            tx.push(b"late".to_vec(), 0);
            tx
        });
        let started = Instant::now();
        assert_eq!(rx.recv_timeout(Duration::from_secs(30)).unwrap().0, b"late");
        assert!(started.elapsed() < Duration::from_secs(30));
        drop(t.join().unwrap());
    }

    #[test]
    fn timeout_then_closed_when_every_sender_is_gone() {
        let (tx, rx) = frame_queue(4);
        let tx2 = tx.clone();
        assert_eq!(
            rx.recv_timeout(Duration::from_millis(5)),
            Err(RecvError::Timeout)
        );
        tx2.push(b"x".to_vec(), 0);
        drop(tx);
        drop(tx2);
        // Frames already queued are still delivered, then the queue reports closed.
        assert_eq!(rx.recv_timeout(Duration::from_secs(1)).unwrap().0, b"x");
        assert_eq!(
            rx.recv_timeout(Duration::from_secs(1)),
            Err(RecvError::Closed)
        );
    }

    #[test]
    fn wait_returns_for_a_frame_or_a_poke_and_takes_nothing() {
        let (tx, rx) = frame_queue(4);
        let waker = rx.waker();
        assert!(!rx.wait(Duration::from_millis(5)));
        waker.poke();
        assert!(rx.wait(Duration::from_secs(30)));
        // The poke is consumed.
        assert!(!rx.wait(Duration::ZERO));
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            waker.poke();
        });
        assert!(rx.wait(Duration::from_secs(30)));
        t.join().unwrap();
        tx.push(b"f".to_vec(), 7);
        let waker = rx.waker();
        assert!(
            !waker.wait_poke(Duration::from_millis(5)),
            "frames do not end a poke wait"
        );
        assert!(rx.wait(Duration::ZERO));
        assert!(rx.wait(Duration::ZERO), "a queued frame stays until taken");
        assert_eq!(rx.try_recv().unwrap(), (b"f".to_vec(), 7));
        drop(tx);
        assert!(rx.wait(Duration::from_secs(30)), "closed");
    }

    #[test]
    fn a_receiver_blocked_when_the_last_sender_goes_is_released() {
        let (tx, rx) = frame_queue(4);
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            drop(tx);
        });
        assert_eq!(
            rx.recv_timeout(Duration::from_secs(30)),
            Err(RecvError::Closed)
        );
        t.join().unwrap();
    }
}
