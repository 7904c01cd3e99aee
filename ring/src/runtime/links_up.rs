//! "The links are up" after a ring member came back (a restarted process) or the sync master's
//! upstream returned from the dead: a decision on facts, not on a timer. Pure: the facts and
//! the cycle numbers come in as arguments (the stepped sync master, [`super::stepped`], reads
//! them from the watches of [`super::light`]).
//!
//! The links are up once
//! - every ring member's liveliness token is present (`mcc/<cluster>/alive/<member>`) and the
//!   sync master's upstream is not known dead,
//! - every member reported, since the latest rejoin, that its link publisher has a matching
//!   subscriber (zenoh's matching status on `link/<k>`: its downstream neighbour's subscriber
//!   reached it), and
//! - [`CLEAN_REVOLUTIONS`] cycles started once those facts held came back in a row, each lit,
//!   without receive errors and carrying the sync master's own sync packet. A gap in the
//!   returned cycles is a frame some link lost: the count starts again.
//!
//! Until then the sync master runs on its own clock (lost frames cost nothing but their cycle);
//! a fact that stops holding (another member goes away) starts the wait again.

/// Consecutive clean revolutions of the sync packet, started once the facts held, that show
/// the links are up.
pub const CLEAN_REVOLUTIONS: u64 = 3;

/// What zenoh and the ring's watches say now.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkFacts {
    /// Every ring member's liveliness token is present and the upstream is not known dead.
    pub tokens: bool,
    /// Every member's link publisher has a matching subscriber (reported since the latest
    /// rejoin), the sync master's own included.
    pub matched: bool,
}

impl LinkFacts {
    /// Both facts hold.
    pub fn hold(&self) -> bool {
        self.tokens && self.matched
    }
}

/// The decision for one rejoin (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinksUp {
    need: u64,
    /// The first cycle started while the facts held (since they last failed).
    from: Option<u64>,
    /// The latest clean return of the current run, and the run's length.
    run: Option<(u64, u64)>,
}

impl LinksUp {
    /// Waiting for `need` clean revolutions (at least 1).
    pub fn new(need: u64) -> Self {
        LinksUp {
            need: need.max(1),
            from: None,
            run: None,
        }
    }

    fn forget(&mut self) {
        self.from = None;
        self.run = None;
    }

    /// Cycle `k` starts now, with `facts`.
    pub fn on_start(&mut self, k: u64, facts: LinkFacts) {
        if !facts.hold() {
            self.forget();
        } else if self.from.is_none() {
            self.from = Some(k);
        }
    }

    /// The frame of cycle `c` came back, `clean` (lit, no receive error, the own sync packet
    /// in it) or not, with `facts` now. True: the links are up.
    pub fn on_return(&mut self, c: u64, clean: bool, facts: LinkFacts) -> bool {
        if !facts.hold() {
            self.forget();
            return false;
        }
        let Some(from) = self.from else {
            return false;
        };
        if c < from {
            // Started before the facts held: proves nothing.
            return false;
        }
        if !clean {
            self.run = None;
            return false;
        }
        self.run = match self.run {
            Some((last, n)) if c == last + 1 => Some((c, n + 1)),
            // A repeat or an older frame: no revolution, no gap either.
            Some((last, n)) if c <= last => Some((last, n)),
            // The first, or after a gap (a frame lost between): count again.
            _ => Some((c, 1)),
        };
        self.run.is_some_and(|(_, n)| n >= self.need)
    }

    /// Clean revolutions counted so far.
    pub fn clean(&self) -> u64 {
        self.run.map_or(0, |(_, n)| n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOLD: LinkFacts = LinkFacts {
        tokens: true,
        matched: true,
    };

    #[test]
    fn up_after_the_clean_revolutions_of_cycles_started_once_the_facts_held() {
        let mut l = LinksUp::new(3);
        // Cycles 10, 11 start before every publisher matched: their returns prove nothing.
        let unmatched = LinkFacts {
            tokens: true,
            matched: false,
        };
        l.on_start(10, unmatched);
        l.on_start(11, unmatched);
        assert!(!l.on_return(10, true, unmatched));
        assert!(!l.on_return(11, true, HOLD), "11 started before the facts");
        l.on_start(12, HOLD);
        l.on_start(13, HOLD);
        l.on_start(14, HOLD);
        assert!(!l.on_return(12, true, HOLD));
        assert!(!l.on_return(13, true, HOLD));
        assert_eq!(l.clean(), 2);
        assert!(l.on_return(14, true, HOLD));
    }

    #[test]
    fn a_lost_frame_after_the_first_lit_return_starts_the_count_again() {
        // What the first-lit-return rule missed: 20 came back lit, 21 was lost.
        let mut l = LinksUp::new(3);
        for k in 20..=26 {
            l.on_start(k, HOLD);
        }
        assert!(!l.on_return(20, true, HOLD));
        assert!(!l.on_return(22, true, HOLD), "21 is missing");
        assert_eq!(l.clean(), 1);
        assert!(!l.on_return(23, true, HOLD));
        assert!(l.on_return(24, true, HOLD));
    }

    #[test]
    fn a_dark_or_damaged_return_starts_the_count_again_and_a_repeat_counts_nothing() {
        let mut l = LinksUp::new(2);
        for k in 0..=5 {
            l.on_start(k, HOLD);
        }
        assert!(!l.on_return(0, true, HOLD));
        assert!(
            !l.on_return(1, false, HOLD),
            "dark, errors or no sync packet"
        );
        assert_eq!(l.clean(), 0);
        assert!(!l.on_return(2, true, HOLD));
        assert!(!l.on_return(2, true, HOLD), "a repeat is no revolution");
        assert!(!l.on_return(1, true, HOLD), "an older frame neither");
        assert_eq!(l.clean(), 1);
        assert!(l.on_return(3, true, HOLD));
    }

    #[test]
    fn a_fact_that_stops_holding_starts_the_wait_again() {
        let mut l = LinksUp::new(2);
        l.on_start(5, HOLD);
        l.on_start(6, HOLD);
        assert!(!l.on_return(5, true, HOLD));
        // A member's token went away (another restart): nothing counted so far stands.
        let gone = LinkFacts {
            tokens: false,
            matched: true,
        };
        assert!(!l.on_return(6, true, gone));
        assert_eq!(l.clean(), 0);
        l.on_start(7, gone);
        l.on_start(8, HOLD);
        l.on_start(9, HOLD);
        assert!(
            !l.on_return(7, true, HOLD),
            "started while a token was missing"
        );
        assert!(!l.on_return(8, true, HOLD));
        assert!(l.on_return(9, true, HOLD));
    }

    #[test]
    fn without_the_facts_no_number_of_clean_returns_is_enough() {
        let mut l = LinksUp::new(1);
        let none = LinkFacts::default();
        for k in 0..100 {
            l.on_start(k, none);
            assert!(!l.on_return(k, true, none));
        }
        assert!(LinksUp::new(0).need == 1, "at least one revolution");
    }
}
