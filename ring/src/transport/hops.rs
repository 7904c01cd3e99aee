//! Hop latency of a member's input link: from the upstream member's send call to the moment
//! this member's cycle loop takes the frame (both on the system-wide `CLOCK_MONOTONIC`, so the
//! two ends may be different processes). The link's senders stamp each frame out of band (a
//! zenoh attachment, a field of the in-process queue), never in the frame itself.
//!
//! The last [`WINDOW`] hops are kept; `mcc status --json` shows their median, 99th percentile
//! and maximum per member (`hop` in the member's extras), `mcc bench ring` compares them with a
//! raw UDP ring.

use serde::{Deserialize, Serialize};

/// Hops kept for the percentiles.
pub const WINDOW: usize = 4096;

/// The recent hop latencies of one link.
#[derive(Debug, Clone)]
pub struct HopStats {
    recent: Vec<u32>,
    next: usize,
    count: u64,
    inline: u64,
}

impl Default for HopStats {
    fn default() -> Self {
        HopStats {
            recent: Vec::with_capacity(WINDOW),
            next: 0,
            count: 0,
            inline: 0,
        }
    }
}

/// A summary of the recent hop latencies.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct HopSummary {
    /// Hops measured since start.
    pub count: u64,
    /// Frames handled on the receive thread since start (the rest went through the queue to
    /// the member's thread).
    pub inline: u64,
    /// Hops in the window the percentiles are taken over.
    pub window: u64,
    /// Median, ns.
    pub p50_ns: u64,
    /// 99th percentile, ns.
    pub p99_ns: u64,
    /// Largest in the window, ns.
    pub max_ns: u64,
}

impl HopStats {
    /// A frame stamped `sent_ns` was taken at `now_ns`. A stamp of 0 (unknown) or from the
    /// future (another clock) is not counted.
    pub fn record(&mut self, sent_ns: u64, now_ns: u64) {
        if sent_ns == 0 || now_ns < sent_ns {
            return;
        }
        let ns = u32::try_from(now_ns - sent_ns).unwrap_or(u32::MAX);
        if self.recent.len() < WINDOW {
            self.recent.push(ns);
        } else {
            self.recent[self.next] = ns;
        }
        self.next = (self.next + 1) % WINDOW;
        self.count += 1;
    }

    /// A frame was handled on the receive thread (see [`HopSummary::inline`]).
    pub fn count_inline(&mut self) {
        self.inline += 1;
    }

    /// Percentiles over the window.
    pub fn summary(&self) -> HopSummary {
        let mut v = self.recent.clone();
        v.sort_unstable();
        let pick = |p: f64| -> u64 {
            if v.is_empty() {
                return 0;
            }
            let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
            u64::from(v[rank.clamp(1, v.len()) - 1])
        };
        HopSummary {
            count: self.count,
            inline: self.inline,
            window: v.len() as u64,
            p50_ns: pick(50.0),
            p99_ns: pick(99.0),
            max_ns: v.last().copied().map(u64::from).unwrap_or(0),
        }
    }
}

impl HopSummary {
    /// The summary as a status extra (`hop`: µs with one decimal).
    pub fn to_json(&self) -> serde_json::Value {
        let us = |ns: u64| (ns as f64 / 100.0).round() / 10.0;
        serde_json::json!({
            "count": self.count,
            "inline": self.inline,
            "window": self.window,
            "p50_us": us(self.p50_ns),
            "p99_us": us(self.p99_ns),
            "max_us": us(self.max_ns),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_over_the_recent_window() {
        let mut h = HopStats::default();
        assert_eq!(h.summary(), HopSummary::default());
        for ns in 1..=100u64 {
            h.record(1_000, 1_000 + ns * 1_000);
        }
        let s = h.summary();
        assert_eq!((s.count, s.window), (100, 100));
        assert_eq!((s.p50_ns, s.p99_ns, s.max_ns), (50_000, 99_000, 100_000));
        // Unknown stamps and stamps from the future are ignored.
        h.record(0, 5);
        h.record(10, 5);
        assert_eq!(h.summary().count, 100);
        // The window keeps the most recent hops only.
        for _ in 0..WINDOW {
            h.record(1, 8);
        }
        let s = h.summary();
        assert_eq!(
            (s.count, s.window, s.max_ns),
            (100 + WINDOW as u64, WINDOW as u64, 7)
        );
        h.count_inline();
        assert_eq!(h.summary().inline, 1);
        let j = s.to_json();
        assert_eq!(j["p50_us"], 0.0);
        assert_eq!(j["inline"], 0);
        assert_eq!(j["window"], WINDOW as u64);
    }
}
