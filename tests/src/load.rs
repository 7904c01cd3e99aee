//! Load for tests that must pass with the machine fully loaded: threads spinning on the CPU.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

/// Threads spinning on the CPU until dropped.
#[derive(Debug)]
pub struct Busy {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Busy {
    /// Start `n` spinning threads.
    pub fn start(n: usize) -> Busy {
        let stop = Arc::new(AtomicBool::new(false));
        let threads = (0..n)
            .map(|_| {
                let stop = Arc::clone(&stop);
                std::thread::spawn(move || {
                    let mut x = 0u64;
                    while !stop.load(Ordering::Relaxed) {
                        x = std::hint::black_box(
                            x.wrapping_mul(6364136223846793005).wrapping_add(1),
                        );
                    }
                })
            })
            .collect();
        Busy { stop, threads }
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A member's ring error counters from `mcc status --json` (`members[i]`): byte violations,
/// checksum, overrun, underrun, bad frames (a missing counter reads as `u64::MAX`).
pub fn ring_errors(m: &serde_json::Value) -> Vec<u64> {
    [
        "byte_violation",
        "checksum",
        "overrun",
        "underrun",
        "bad_frames",
    ]
    .iter()
    .map(|k| m["errors"][k].as_u64().unwrap_or(u64::MAX))
    .collect()
}
