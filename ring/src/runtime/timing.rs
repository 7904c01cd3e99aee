//! Wall-clock bookkeeping of the synchronizing master (pure: times are passed in, in ns):
//! the paced clock's deadline grid with catch-up and re-basing ([`PaceGrid`]), and what it
//! reports ([`ClockStats`]: late cycles, lag distribution, lost time, longest stall, the
//! real-time factor achieved over the last second).

use std::collections::VecDeque;

use crate::control::ClockReport;

/// Paced clock: the most wall time the ring may fall behind its schedule and still catch up
/// by running the missed cycles back to back. Beyond it the schedule is re-based to the
/// present and the time is counted as lost (never hidden, never skipped cycles).
pub const PACED_BACKLOG_NS: u64 = 200_000_000;

/// The achieved real-time factor counts as "below the requested one" under this fraction of
/// it (a little slack: one late wake-up is not a slow clock).
pub const RTF_SLACK: f64 = 0.98;

/// Deadlines `origin + (k - base) × period` on the wall clock.
#[derive(Debug, Clone)]
pub struct PaceGrid {
    period_ns: f64,
    origin_ns: u64,
    base: u64,
    backlog_ns: u64,
}

/// What starting one cycle on the grid found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Start {
    /// How long after its deadline the cycle started, ns (0 when on time).
    pub lag_ns: u64,
    /// Started more than one period late (the real-time interrupt warning).
    pub late: bool,
    /// The lag exceeded the backlog: the grid was re-based; this much wall time is lost.
    pub lost_ns: u64,
}

impl PaceGrid {
    /// A grid of `period_ns` (wall time per cycle) on which cycle `base` is due at `now_ns`.
    pub fn new(period_ns: u64, base: u64, now_ns: u64, backlog_ns: u64) -> Self {
        PaceGrid {
            period_ns: period_ns.max(1) as f64,
            origin_ns: now_ns,
            base,
            backlog_ns,
        }
    }

    /// Wall-clock deadline of cycle `k`.
    pub fn deadline(&self, k: u64) -> u64 {
        let steps = k.saturating_sub(self.base) as f64;
        self.origin_ns
            .saturating_add((steps * self.period_ns) as u64)
    }

    /// Cycle `k` is due at `now_ns` from here on (no lost time counted).
    pub fn rebase(&mut self, k: u64, now_ns: u64) {
        self.origin_ns = now_ns;
        self.base = k;
    }

    /// Cycle `k` starts at `now_ns`: its lag; re-bases when the backlog is exceeded.
    pub fn on_start(&mut self, k: u64, now_ns: u64) -> Start {
        let lag_ns = now_ns.saturating_sub(self.deadline(k));
        let late = lag_ns as f64 > self.period_ns;
        let mut lost_ns = 0;
        if lag_ns > self.backlog_ns {
            lost_ns = lag_ns;
            self.rebase(k, now_ns);
        }
        Start {
            lag_ns,
            late,
            lost_ns,
        }
    }
}

/// Lag histogram: 8 buckets per octave of µs (values within 12.5 %).
#[derive(Debug, Clone)]
pub struct LagHistogram {
    counts: Vec<u64>,
    total: u64,
}

const SUB: u32 = 8;

impl Default for LagHistogram {
    fn default() -> Self {
        LagHistogram {
            counts: vec![0; (SUB * 44) as usize],
            total: 0,
        }
    }
}

impl LagHistogram {
    fn bucket(us: u64) -> usize {
        if us < u64::from(SUB) {
            return us as usize;
        }
        let exp = 63 - us.leading_zeros(); // ≥ 3
        let mant = (us >> (exp - 3)) & u64::from(SUB - 1);
        ((exp - 2) * SUB) as usize + mant as usize
    }

    fn lower_bound(idx: usize) -> u64 {
        let idx = idx as u64;
        let sub = u64::from(SUB);
        if idx < sub {
            return idx;
        }
        let exp = idx / sub + 2;
        (sub + idx % sub) << (exp - 3)
    }

    /// Count one lag of `us` µs.
    pub fn add(&mut self, us: u64) {
        let i = Self::bucket(us).min(self.counts.len() - 1);
        self.counts[i] += 1;
        self.total += 1;
    }

    /// Values counted.
    pub fn len(&self) -> u64 {
        self.total
    }

    /// Nothing counted yet.
    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// The `q`-quantile (0–1), as the lower bound of its bucket; 0 when empty.
    pub fn quantile(&self, q: f64) -> u64 {
        if self.total == 0 {
            return 0;
        }
        let want = ((q.clamp(0.0, 1.0) * self.total as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (i, c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= want {
                return Self::lower_bound(i);
            }
        }
        Self::lower_bound(self.counts.len() - 1)
    }
}

/// Samples of (wall ns, cycle) for the real-time factor over the last second.
#[derive(Debug, Clone, Default)]
struct RateWindow {
    samples: VecDeque<(u64, u64)>,
}

const WINDOW_NS: u64 = 1_000_000_000;
const SAMPLE_EVERY_NS: u64 = 20_000_000;

impl RateWindow {
    fn add(&mut self, now_ns: u64, cycle: u64) {
        if self
            .samples
            .back()
            .is_some_and(|&(t, _)| now_ns.saturating_sub(t) < SAMPLE_EVERY_NS)
        {
            return;
        }
        self.samples.push_back((now_ns, cycle));
        // Keep one sample at or before the start of the window.
        while self.samples.len() > 2
            && self
                .samples
                .get(1)
                .is_some_and(|&(t, _)| now_ns.saturating_sub(t) >= WINDOW_NS)
        {
            self.samples.pop_front();
        }
    }

    /// Ring time over wall time since the oldest sample, up to `now_ns` / `cycle`.
    fn rtf(&self, now_ns: u64, cycle: u64, period_ns: u64) -> Option<f64> {
        let &(t0, c0) = self.samples.front()?;
        let wall = now_ns.saturating_sub(t0);
        if wall < SAMPLE_EVERY_NS {
            return None;
        }
        Some(cycle.saturating_sub(c0) as f64 * period_ns as f64 / wall as f64)
    }
}

/// The sync master's clock figures (see [`ClockReport`]).
#[derive(Debug, Clone)]
pub struct ClockStats {
    mode: &'static str,
    period_ns: u64,
    rtf_requested: f64,
    late: u64,
    lags: LagHistogram,
    max_lag_ns: u64,
    lost_ns: u64,
    rebases: u64,
    last_start_ns: Option<u64>,
    longest_stall_ns: u64,
    window: RateWindow,
    last: (u64, u64),
    below_since_ns: Option<u64>,
    ring_down: bool,
    ring_down_count: u64,
}

impl ClockStats {
    /// Figures for clock `mode` with nominal `period_ns` and the requested real-time factor.
    pub fn new(mode: &'static str, period_ns: u64, rtf_requested: f64) -> Self {
        ClockStats {
            mode,
            period_ns: period_ns.max(1),
            rtf_requested,
            late: 0,
            lags: LagHistogram::default(),
            max_lag_ns: 0,
            lost_ns: 0,
            rebases: 0,
            last_start_ns: None,
            longest_stall_ns: 0,
            window: RateWindow::default(),
            last: (0, 0),
            below_since_ns: None,
            ring_down: false,
            ring_down_count: 0,
        }
    }

    /// Cycle `cycle` started at `now_ns`; `start` is the grid's verdict when the cycle had a
    /// deadline (paced, or running on the own clock).
    pub fn on_start(&mut self, cycle: u64, now_ns: u64, start: Option<Start>) {
        if let Some(s) = start {
            self.lags.add(s.lag_ns / 1000);
            self.max_lag_ns = self.max_lag_ns.max(s.lag_ns);
            self.late += u64::from(s.late);
            if s.lost_ns > 0 {
                self.lost_ns += s.lost_ns;
                self.rebases += 1;
            }
        }
        if let Some(prev) = self.last_start_ns {
            self.longest_stall_ns = self.longest_stall_ns.max(now_ns.saturating_sub(prev));
        }
        self.last_start_ns = Some(now_ns);
        self.window.add(now_ns, cycle);
        self.last = (now_ns, cycle);
        if self.mode == "paced" {
            let below = self
                .rtf(now_ns)
                .is_some_and(|r| r < self.rtf_requested * RTF_SLACK);
            match (below, self.below_since_ns) {
                (true, None) => self.below_since_ns = Some(now_ns),
                (false, Some(_)) => self.below_since_ns = None,
                _ => {}
            }
        }
    }

    /// The ring went down (nothing came back within the frozen-member wait) or up again.
    pub fn set_ring_down(&mut self, down: bool) {
        if down && !self.ring_down {
            self.ring_down_count += 1;
        }
        self.ring_down = down;
    }

    /// Cycles that started more than a period late.
    pub fn late_cycles(&self) -> u64 {
        self.late
    }

    fn rtf(&self, now_ns: u64) -> Option<f64> {
        self.window.rtf(now_ns, self.last.1, self.period_ns)
    }

    /// The report at `now_ns` (a stopped clock shows a falling real-time factor).
    pub fn report(&self, now_ns: u64) -> ClockReport {
        let rtf = self.rtf(now_ns).unwrap_or(0.0);
        let below = match self.below_since_ns {
            Some(t) => now_ns.saturating_sub(t),
            None if self.mode == "paced"
                && self.last_start_ns.is_some()
                && rtf < self.rtf_requested * RTF_SLACK =>
            {
                // Nothing started since: the clock has stopped.
                now_ns.saturating_sub(self.last.0)
            }
            None => 0,
        };
        ClockReport {
            mode: self.mode.to_string(),
            rtf_requested: self.rtf_requested,
            rtf: (rtf * 1000.0).round() / 1000.0,
            late_cycles: self.late,
            max_lag_us: self.max_lag_ns / 1000,
            lag_p50_us: self.lags.quantile(0.5),
            lag_p99_us: self.lags.quantile(0.99),
            lost_ms: self.lost_ns / 1_000_000,
            rebases: self.rebases,
            longest_stall_us: self.longest_stall_ns / 1000,
            below_rtf_ms: below / 1_000_000,
            ring_down: self.ring_down,
            ring_down_count: self.ring_down_count,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_deadlines_catch_up_and_rebase() {
        let mut g = PaceGrid::new(1000, 0, 10_000, 5_000);
        assert_eq!(g.deadline(0), 10_000);
        assert_eq!(g.deadline(3), 13_000);
        // On time, then a little late (< a period: not late), then late.
        assert_eq!(
            g.on_start(0, 10_000),
            Start {
                lag_ns: 0,
                late: false,
                lost_ns: 0
            }
        );
        assert!(!g.on_start(1, 11_900).late);
        let s = g.on_start(2, 13_500);
        assert!(s.late && s.lost_ns == 0 && s.lag_ns == 1500);
        // A stall within the backlog: the deadlines stay, the missed cycles run back to back.
        assert_eq!(g.on_start(3, 17_000).lag_ns, 4_000);
        assert_eq!(g.deadline(4), 14_000);
        // Beyond the backlog: re-based, the lag counted as lost.
        let s = g.on_start(4, 30_000);
        assert_eq!(s.lost_ns, 16_000);
        assert_eq!(g.deadline(4), 30_000);
        assert_eq!(g.deadline(5), 31_000);
        // Early starts have no lag.
        assert_eq!(g.on_start(5, 30_500).lag_ns, 0);
    }

    #[test]
    fn histogram_quantiles_within_an_eighth() {
        let mut h = LagHistogram::default();
        assert_eq!(h.quantile(0.5), 0);
        for us in 0..1000u64 {
            h.add(us);
        }
        let p50 = h.quantile(0.5);
        assert!((440..=500).contains(&p50), "{p50}");
        let p99 = h.quantile(0.99);
        assert!((860..=990).contains(&p99), "{p99}");
        for v in [0u64, 7, 8, 9, 100, 12345, 1 << 30] {
            let lb = LagHistogram::lower_bound(LagHistogram::bucket(v));
            assert!(lb <= v && v - lb <= v / 8, "{v} -> {lb}");
        }
        h.add(u64::MAX);
        assert_eq!(h.len(), 1001);
    }

    #[test]
    fn report_rtf_late_and_stall() {
        let period = 1_000_000; // 1 ms ring cycles
        let mut s = ClockStats::new("paced", period, 1.0);
        // 2 s at real time.
        for k in 0..2000u64 {
            s.on_start(k, k * period, None);
        }
        let r = s.report(1999 * period);
        assert!((r.rtf - 1.0).abs() < 0.01, "{r:?}");
        assert_eq!(r.below_rtf_ms, 0);
        // Half speed for 2 s: below the requested factor for more than a second.
        for k in 2000..3000u64 {
            s.on_start(k, 1999 * period + (k - 1999) * 2 * period, None);
        }
        let now = 1999 * period + 1001 * 2 * period;
        let r = s.report(now);
        assert!((r.rtf - 0.5).abs() < 0.02, "{r:?}");
        assert!(r.below_rtf_ms >= 1000, "{r:?}");
        assert_eq!(r.longest_stall_us, 2000);
        // A stopped clock is below too.
        let r = s.report(now + 3_000_000_000);
        assert!(r.rtf < 0.5 && r.below_rtf_ms >= 3000, "{r:?}");
        // Lag and late figures come from the grid.
        let mut g = PaceGrid::new(period, 0, 0, PACED_BACKLOG_NS);
        let mut s = ClockStats::new("paced", period, 1.0);
        for k in 0..10u64 {
            let now = k * period + if k == 5 { 3 * period } else { 0 };
            s.on_start(k, now, Some(g.on_start(k, now)));
        }
        let r = s.report(10 * period);
        assert_eq!((r.late_cycles, r.max_lag_us, r.lost_ms), (1, 3000, 0));
        assert_eq!(r.lag_p50_us, 0);
    }
}
