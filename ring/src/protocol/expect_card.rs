//! What each card profile shows for a fault (issue 23 items 1 and 3), written down from the
//! seeds beside the ring rules ([`super::expect`]): the campaign and the drills judge a card
//! by the expectation of its profile (the config's `profile` word).
//!
//! | | PMAC2 (seed 004) | Turbo (seed 004) | Power (seed 000) |
//! |---|---|---|---|
//! | ring check variables | I1001/I1004/I1005 | I80/I81/I82 | `Macro.TestPeriod/TestMaxErrors/TestReqdSynchs` |
//! | ring fault latch | `???` word 1 bit 4 (X:$0003) | `???` word 1 bit 4 | the card's ring-fault latch (no `Sys` bit is printed for it) |
//! | ring fault kills | every activated motor | every activated motor | every motor with `Motor[x].ServoCtrl` |
//! | abort input | JPAN STOP/ (I2 = 0), FPD-selected C.S.: `A` | same | global abort (`Sys.pAbortAll` wired), `Coord[x].AbortAllMode` 0: abort |
//! | motor 1 after the abort input | closed: `#1?` word 1 bit 18 clear | same | closed: `Motor[1].Status[0]` bits 13, 12 set |
//! | C.S. 1 program | aborted (`??` word 1 bit 0 clear) | same | aborted |

/// A card profile, as the config names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CardProfile {
    /// `pmac2`.
    Pmac2,
    /// `turbo`.
    Turbo,
    /// `power`.
    Power,
}

impl CardProfile {
    /// The profile a config's `profile` word names (`None`: not a card profile).
    pub fn parse(word: &str) -> Option<CardProfile> {
        match word {
            "pmac2" => Some(CardProfile::Pmac2),
            "turbo" => Some(CardProfile::Turbo),
            "power" => Some(CardProfile::Power),
            _ => None,
        }
    }
}

/// A status bit a host reads back: the query, which word of the reply (hex words of `width`
/// digits), which bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadBack {
    /// The line the host sends.
    pub query: &'static str,
    /// Hex digits per word of the reply.
    pub width: usize,
    /// Word (0-based).
    pub word: usize,
    /// Bit mask within the word.
    pub mask: u32,
}

impl ReadBack {
    /// The masked bits in `reply` (`None`: the reply is not that many hex words).
    pub fn bits(&self, reply: &str) -> Option<u32> {
        let w = reply.get(self.width * self.word..self.width * (self.word + 1))?;
        u32::from_str_radix(w, 16).ok().map(|v| v & self.mask)
    }
}

/// What a card of one profile shows after a ring fault it latched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RingFaultEffect {
    /// The config keys of its ring check (period, error limit, required syncs).
    pub check_keys: [&'static str; 3],
    /// The host-visible latch bit (`None`: the profile prints none).
    pub latch: Option<ReadBack>,
    /// Every activated motor is killed.
    pub kills_every_motor: bool,
}

/// What a card of one profile shows after its abort input acted on C.S. 1 (motor 1 in it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AbortInputEffect {
    /// What the card needs before the input acts (sent once after every reset).
    pub wiring: &'static [&'static str],
    /// Motor 1 closed-loop: these bits as `closed_value` once stopped.
    pub motor1: ReadBack,
    /// The value of [`Self::motor1`]'s bits for a closed loop.
    pub closed_value: u32,
    /// The C.S. program is aborted (its motion stops; no ring fault is latched anywhere).
    pub aborts_program: bool,
}

/// The ring-fault expectation of `p`.
pub fn ring_fault_effect(p: CardProfile) -> RingFaultEffect {
    let latch = Some(ReadBack {
        query: "???",
        width: 6,
        word: 0,
        mask: 1 << 4,
    });
    match p {
        CardProfile::Pmac2 => RingFaultEffect {
            check_keys: ["I1001", "I1004", "I1005"],
            latch,
            kills_every_motor: true,
        },
        CardProfile::Turbo => RingFaultEffect {
            check_keys: ["I80", "I81", "I82"],
            latch,
            kills_every_motor: true,
        },
        CardProfile::Power => RingFaultEffect {
            check_keys: [
                "Macro.TestPeriod",
                "Macro.TestMaxErrors",
                "Macro.TestReqdSynchs",
            ],
            latch: None,
            kills_every_motor: true,
        },
    }
}

/// The abort-input expectation of `p`.
pub fn abort_input_effect(p: CardProfile) -> AbortInputEffect {
    match p {
        CardProfile::Pmac2 | CardProfile::Turbo => AbortInputEffect {
            wiring: &["I2=0"],
            motor1: ReadBack {
                query: "#1?",
                width: 6,
                word: 0,
                mask: 1 << 18,
            },
            closed_value: 0,
            aborts_program: true,
        },
        CardProfile::Power => AbortInputEffect {
            // A Power Brick's default wiring (seed 000 L20029-20036).
            wiring: &["Sys.pAbortAll=Gate3[0].GpioData[0].a"],
            motor1: ReadBack {
                query: "#1?",
                width: 8,
                word: 0,
                mask: (1 << 13) | (1 << 12),
            },
            closed_value: (1 << 13) | (1 << 12),
            aborts_program: true,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_backs_pick_their_bits() {
        let pmac = abort_input_effect(CardProfile::Pmac2).motor1;
        assert_eq!(pmac.bits("870000804000"), Some(1 << 18));
        assert_eq!(pmac.bits("830000804000"), Some(0));
        let power = abort_input_effect(CardProfile::Power).motor1;
        assert_eq!(power.bits("0000790000000000"), Some(0x3000));
        assert_eq!(power.bits("00004100"), Some(0));
        assert_eq!(power.bits("0041"), None);
        let latch = ring_fault_effect(CardProfile::Turbo).latch.unwrap();
        assert_eq!(latch.bits("000010000800000000"), Some(0x10));
        assert!(ring_fault_effect(CardProfile::Power).latch.is_none());
        assert_eq!(CardProfile::parse("turbo"), Some(CardProfile::Turbo));
        assert_eq!(CardProfile::parse("pmac3"), None);
    }
}
