//! The local holdover clock: when sync packets stop arriving a member keeps counting ring
//! cycles on its own, so its ring check sees the dead ring instead of waiting for it.
//!
//! After a sync packet for cycle k at time t, the member expects cycle k+1 at t + period. If
//! no sync packet has come by t + period + grace (grace = half a period by default), it runs
//! cycle k+1 on its own, then k+2 one period later, and so on until a sync packet arrives.
//! Before the first sync packet there is no cycle number to continue, so nothing runs.

/// Holdover clock of one member. Pure: time is passed in.
#[derive(Clone, Debug)]
pub struct HoldoverClock {
    period_ns: u64,
    grace_ns: u64,
    last_cycle: Option<u64>,
    due_ns: u64,
}

/// Most cycles one [`HoldoverClock::poll`] catch-up may skip over silently: beyond this (the
/// process was frozen) the clock jumps to `now` instead of replaying every missed cycle.
pub const MAX_CATCH_UP: u64 = 1000;

impl HoldoverClock {
    /// A clock for the nominal `period_ns` with a grace of half a period.
    pub fn new(period_ns: u64) -> Self {
        let period_ns = period_ns.max(1);
        Self::with_grace(period_ns, period_ns / 2)
    }

    /// A clock with an explicit grace (how late a sync packet may be before holdover runs).
    pub fn with_grace(period_ns: u64, grace_ns: u64) -> Self {
        HoldoverClock {
            period_ns: period_ns.max(1),
            grace_ns,
            last_cycle: None,
            due_ns: 0,
        }
    }

    /// Nominal period.
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// The last cycle run (from a sync packet or from holdover).
    pub fn last_cycle(&self) -> Option<u64> {
        self.last_cycle
    }

    /// A sync packet for `cycle` arrived at `now_ns`.
    pub fn on_sync(&mut self, cycle: u64, now_ns: u64) {
        self.last_cycle = Some(cycle);
        self.due_ns = now_ns
            .saturating_add(self.period_ns)
            .saturating_add(self.grace_ns);
    }

    /// Start counting without a sync packet (e.g. the synchronizing master's own clock).
    pub fn start(&mut self, cycle: u64, now_ns: u64) {
        self.on_sync(cycle, now_ns);
    }

    /// Skip the grace: nothing will come (the upstream member is known dead), so the next
    /// holdover cycle is due now unless one is due within a period anyway (the clock already
    /// runs). Does nothing before the first sync packet.
    pub fn expedite(&mut self, now_ns: u64) {
        if self.last_cycle.is_some() && self.due_ns > now_ns.saturating_add(self.period_ns) {
            self.due_ns = now_ns;
        }
    }

    /// When the next holdover cycle is due, if the clock runs.
    pub fn due_ns(&self) -> Option<u64> {
        self.last_cycle.map(|_| self.due_ns)
    }

    /// The cycle to run now on holdover, if one is due (call repeatedly to catch up).
    pub fn poll(&mut self, now_ns: u64) -> Option<u64> {
        let last = self.last_cycle?;
        if now_ns < self.due_ns {
            return None;
        }
        let behind = (now_ns - self.due_ns) / self.period_ns;
        let skip = if behind > MAX_CATCH_UP { behind } else { 0 };
        let cycle = last.saturating_add(1).saturating_add(skip);
        self.last_cycle = Some(cycle);
        self.due_ns = self
            .due_ns
            .saturating_add(self.period_ns.saturating_mul(skip + 1));
        Some(cycle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_before_first_sync() {
        let mut h = HoldoverClock::new(1000);
        assert_eq!(h.poll(1_000_000), None);
        assert_eq!(h.due_ns(), None);
    }

    #[test]
    fn runs_after_grace_then_every_period() {
        let mut h = HoldoverClock::new(1000);
        h.on_sync(10, 5000);
        assert_eq!(h.poll(6000), None);
        assert_eq!(h.poll(6499), None);
        assert_eq!(h.poll(6500), Some(11));
        assert_eq!(h.poll(6500), None);
        assert_eq!(h.poll(7500), Some(12));
        // catch up one cycle per call
        assert_eq!(h.poll(10_000), Some(13));
        assert_eq!(h.poll(10_000), Some(14));
        assert_eq!(h.poll(10_000), None);
        assert_eq!(h.poll(10_500), Some(15));
        // a sync packet re-locks
        h.on_sync(20, 10_100);
        assert_eq!(h.poll(11_500), None);
        assert_eq!(h.poll(11_600), Some(21));
    }

    #[test]
    fn expedite_runs_now_and_then_every_period() {
        let mut h = HoldoverClock::with_grace(1000, 1_000_000);
        h.expedite(5);
        assert_eq!(h.poll(5), None, "nothing before the first sync");
        h.on_sync(10, 5000);
        assert_eq!(h.poll(6000), None, "the grace is long");
        h.expedite(6000);
        assert_eq!(h.poll(6000), Some(11));
        // Once running, expediting again changes nothing: one cycle per period.
        h.expedite(6500);
        assert_eq!(h.poll(6999), None);
        assert_eq!(h.poll(7000), Some(12));
    }

    #[test]
    fn long_freeze_jumps() {
        let mut h = HoldoverClock::new(1000);
        h.on_sync(0, 0);
        // due at 1500; at 1500 + 5000 periods it is 5000 behind -> skip them.
        assert_eq!(h.poll(1500 + 5000 * 1000), Some(5001));
        assert_eq!(h.poll(1500 + 5000 * 1000), None);
        assert_eq!(h.poll(1500 + 5001 * 1000), Some(5002));
    }
}
