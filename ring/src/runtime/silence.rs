//! The frozen-member judgement counts *attended* silence: only the time during which the
//! judging member's own loop was running and looking. A member's loop looks at least every few
//! ms (its receive waits are ≤ 5 ms); a longer gap between two looks means the judge itself
//! was not running (descheduled on a loaded machine, the whole machine stalled, swapped out),
//! and a silence nobody was there to see is no evidence that the other member stopped
//! answering — it was most likely starved by the same stall. Such a gap counts only
//! [`ATTEND_CAP_NS`].
//!
//! This is what keeps a loaded machine from turning a stall into an unrequested fault: on a
//! machine with load ~8 on 2 cores, both ends of a link can be starved for seconds together;
//! the one that wakes first used to find "10 s of silence" and declare the other frozen.
//!
//! Pure: times are passed in (ns).

/// The most one gap between two looks adds to the attended silence.
pub const ATTEND_CAP_NS: u64 = 25_000_000;

/// Attended silence on a member's input.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Silence {
    attended_ns: u64,
    last_look_ns: u64,
}

impl Silence {
    /// Silence starts now (a frame arrived, a cycle started).
    pub fn reset(&mut self, now_ns: u64) {
        self.attended_ns = 0;
        self.last_look_ns = now_ns;
    }

    /// The judge looks at `now_ns`: the attended silence so far.
    pub fn look(&mut self, now_ns: u64) -> u64 {
        let gap = now_ns.saturating_sub(self.last_look_ns);
        self.attended_ns = self.attended_ns.saturating_add(gap.min(ATTEND_CAP_NS));
        self.last_look_ns = self.last_look_ns.max(now_ns);
        self.attended_ns
    }

    /// Attended silence at the last look.
    pub fn attended_ns(&self) -> u64 {
        self.attended_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn looking_often_counts_all_of_the_silence() {
        let mut s = Silence::default();
        s.reset(1000 * MS);
        for i in 1..=2000u64 {
            s.look(1000 * MS + i * 5 * MS);
        }
        assert_eq!(s.attended_ns(), 10_000 * MS);
    }

    #[test]
    fn a_gap_in_which_the_judge_did_not_run_counts_only_the_cap() {
        let mut s = Silence::default();
        s.reset(0);
        assert_eq!(s.look(2 * MS), 2 * MS);
        // The judge was descheduled for 3 s.
        assert_eq!(s.look(3002 * MS), 2 * MS + ATTEND_CAP_NS);
        assert_eq!(s.look(3004 * MS), 4 * MS + ATTEND_CAP_NS);
        // A clock that goes backwards adds nothing.
        assert_eq!(s.look(3000 * MS), 4 * MS + ATTEND_CAP_NS);
        s.reset(3010 * MS);
        assert_eq!(s.look(3011 * MS), MS);
    }
}
