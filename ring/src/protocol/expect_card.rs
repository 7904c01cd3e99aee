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
//! | amplifier fault on motor 1's node | killed: `#1?` word 2 bit 3 (amplifier fault error) set, word 1 bit 18 (open loop) set | same | killed: `Motor[1].Status[0]` bit 24 (`AmpFault`) set, bits 13, 12 clear |

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

/// What a card of one profile shows after the amplifier of motor 1's servo node faulted (an
/// axis fault at the station: `mcc fault STATION axis NODE amp-fault`): motor 1 killed with
/// its amplifier-fault bit, and nothing latched on the ring.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AmpFaultEffect {
    /// The amplifier-fault error bit of motor 1 (set).
    pub fault_bit: ReadBack,
    /// Motor 1's loop bits once killed, and their value then.
    pub killed: ReadBack,
    /// The value of [`Self::killed`]'s bits for a killed motor.
    pub killed_value: u32,
    /// Motor 1 as the card's state report (`killed_motors`) numbers it: the model's motor
    /// blocks from 1, so a Power card's `Motor[1]` (its second block) is 2.
    pub reported_as: u16,
}

/// The amplifier-fault expectation of `p` (seed 004 L6857 and L6791: `?` word 2 bit 3 *Amplifier
/// Fault Error*, word 1 bit 18 *Open Loop Mode*; seed 000 `Motor[x].AmpFault`,
/// `ClosedLoop`, `AmpEna` as bits of `Motor[x].Status[0]`).
pub fn amp_fault_effect(p: CardProfile) -> AmpFaultEffect {
    match p {
        CardProfile::Pmac2 | CardProfile::Turbo => AmpFaultEffect {
            fault_bit: ReadBack {
                query: "#1?",
                width: 6,
                word: 1,
                mask: 1 << 3,
            },
            killed: ReadBack {
                query: "#1?",
                width: 6,
                word: 0,
                mask: 1 << 18,
            },
            killed_value: 1 << 18,
            reported_as: 1,
        },
        CardProfile::Power => AmpFaultEffect {
            fault_bit: ReadBack {
                query: "#1?",
                width: 8,
                word: 0,
                mask: 1 << 24,
            },
            killed: ReadBack {
                query: "#1?",
                width: 8,
                word: 0,
                mask: (1 << 13) | (1 << 12),
            },
            killed_value: 0,
            reported_as: 2,
        },
    }
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
        let amp = amp_fault_effect(CardProfile::Pmac2);
        assert_eq!(amp.fault_bit.bits("850000800008"), Some(8));
        assert_eq!(amp.killed.bits("850000800008"), Some(amp.killed_value));
        assert_eq!(amp.fault_bit.bits("830000804000"), Some(0));
        let amp = amp_fault_effect(CardProfile::Power);
        assert_eq!(amp.fault_bit.bits("0100000000000000"), Some(1 << 24));
        assert_eq!(amp.killed.bits("0100000000000000"), Some(amp.killed_value));
        assert_eq!(amp.killed.bits("0000300000000000"), Some(0x3000));
        assert_eq!(CardProfile::parse("turbo"), Some(CardProfile::Turbo));
        assert_eq!(CardProfile::parse("pmac3"), None);
    }
}
