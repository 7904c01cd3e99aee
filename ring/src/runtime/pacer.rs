//! Realtime pacing of ring cycles by the monotonic clock (`CLOCK_MONOTONIC` via `Instant`).
//!
//! Cycle k is due at `start + k * period`. Late cycles are counted, never hidden: the pacer
//! does not slip its schedule to make lateness disappear (the PMAC "real-time interrupt
//! warning"). When it falls more than a few periods behind it skips ahead and counts the
//! skipped cycles as late.

use std::time::{Duration, Instant};

/// Sleep until a little before the deadline, then spin: sleeping alone is ~60 µs late on Linux.
const SPIN_NS: u64 = 80_000;
/// A cycle that starts more than this fraction of a period after its deadline is late.
const LATE_FRACTION: f64 = 0.5;

/// Schedules realtime cycles.
#[derive(Debug)]
pub struct Pacer {
    start: Instant,
    start_ns: u64,
    period_ns: f64,
    next: u64,
    late: u64,
}

impl Pacer {
    /// A pacer starting now at `rate_hz` (> 0).
    pub fn new(rate_hz: f64) -> Self {
        Pacer {
            start: Instant::now(),
            start_ns: super::driver::monotonic_ns(),
            period_ns: 1e9 / rate_hz.max(1e-3),
            next: 0,
            late: 0,
        }
    }

    /// Deadline of cycle `k` relative to the start.
    pub fn deadline(&self, k: u64) -> Instant {
        self.start + Duration::from_nanos((k as f64 * self.period_ns) as u64)
    }

    /// Deadline of cycle `k` on the system-wide monotonic clock (ns).
    pub fn deadline_ns(&self, k: u64) -> u64 {
        self.start_ns + (k as f64 * self.period_ns) as u64
    }

    /// Time left until the next cycle is due (zero when due or late).
    pub fn until_next(&self) -> Duration {
        self.deadline(self.next)
            .saturating_duration_since(Instant::now())
    }

    /// Wait (sleep then spin) until the next cycle is due; returns its index and how late it
    /// started in nanoseconds.
    pub fn wait_next(&mut self) -> (u64, u64) {
        let due = self.deadline(self.next);
        loop {
            let now = Instant::now();
            if now >= due {
                break;
            }
            let left = due - now;
            if left.as_nanos() as u64 > SPIN_NS {
                std::thread::sleep(left - Duration::from_nanos(SPIN_NS));
            } else {
                std::hint::spin_loop();
            }
        }
        let lateness = Instant::now().saturating_duration_since(due).as_nanos() as u64;
        let k = self.next;
        if lateness as f64 > self.period_ns * LATE_FRACTION {
            self.late += 1;
        }
        // Far behind (e.g. the process was stopped): skip to the present, counting the skipped.
        let behind = (lateness as f64 / self.period_ns) as u64;
        if behind > 4 {
            self.late += behind;
            self.next += behind;
        }
        self.next += 1;
        (k, lateness)
    }

    /// Cycles that started late (or were skipped) so far.
    pub fn late_cycles(&self) -> u64 {
        self.late
    }

    /// Nominal period in nanoseconds.
    pub fn period_ns(&self) -> f64 {
        self.period_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deadlines_are_a_fixed_grid() {
        let p = Pacer::new(1000.0);
        let d = p.deadline(10) - p.deadline(0);
        assert_eq!(d, Duration::from_millis(10));
    }

    #[test]
    fn cycles_are_numbered_in_order() {
        let mut p = Pacer::new(20_000.0);
        let (a, _) = p.wait_next();
        let (b, _) = p.wait_next();
        assert_eq!((a, b), (0, 1));
    }
}
