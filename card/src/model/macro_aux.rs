//! The card side of MACRO auxiliary communications (spec pmac-commands §3.5, pmac-variables
//! §6.9) as a pure state machine over the node-15 channel ([`mcc_ring::aux_channel`]):
//! preconditions, one transaction in flight, the timeout (I1003 servo cycles for Type 1, a
//! fixed 32 for Type 0), and what a failure leaves in X:$0003 bit 5 and X:$0798.
//!
//! The servo tick feeds it the latched copy of the card's own node-15 packet and sends what
//! [`MacroAux::servo_tick`] returns in registers 2-3 of that packet; a finished transaction is
//! collected with [`MacroAux::take_finished`] by whoever started it (the on-line command, a
//! PLC's MSR/MSW/MXR/MXW).

use mcc_ring::aux_channel::{AuxMaster, AuxWord, Outcome, Reply, Request, ValueFormat, AUX_NODE};

/// X:$0798 after a timeout.
pub const X0798_TIMEOUT: u32 = 0x01_0000;
/// The fixed Type 0 (MX/MXR/MXW) timeout, servo cycles.
pub const TYPE0_TIMEOUT: u32 = 32;

/// Which protocol an access uses (their preconditions and timeouts differ).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Protocol {
    /// `MX`, `MXR`, `MXW`: needs I1000 bit n; 32 servo cycles.
    Type0,
    /// `MS…`, `MSR`, `MSW`: needs a master (I995 $xx90/$xx30), I1000 bit 15 = 0 and
    /// I1003 > 0, which is the timeout.
    Type1,
}

/// The ring settings the preconditions read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AuxSettings {
    /// I995.
    pub i995: u32,
    /// I1000.
    pub i1000: u32,
    /// I1003.
    pub i1003: u32,
}

/// Why an access failed: the value X:$0798 gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AuxFailure {
    /// X:$0798: $010000 timeout (also: the access could not be sent), $xxxxFE slave error.
    pub x0798: u32,
}

impl AuxFailure {
    fn timeout() -> Self {
        AuxFailure {
            x0798: X0798_TIMEOUT,
        }
    }
}

/// How a finished transaction ended for the card.
pub type Finished = Result<Reply, AuxFailure>;

/// The card's auxiliary channel.
#[derive(Clone, Debug, Default)]
pub struct MacroAux {
    master: AuxMaster,
    finished: Option<Finished>,
}

impl MacroAux {
    /// Start an access to `node`. Checks the protocol's preconditions; refuses (the caller
    /// answers ERR008) when they fail or another access is in flight.
    pub fn begin(
        &mut self,
        proto: Protocol,
        node: u8,
        request: Request,
        s: AuxSettings,
    ) -> Result<(), AuxFailure> {
        let timeout = match proto {
            Protocol::Type0 => {
                if s.i1000 & (1 << (node & 0xF)) == 0 {
                    return Err(AuxFailure::timeout());
                }
                TYPE0_TIMEOUT
            }
            Protocol::Type1 => {
                let master = s.i995 & 0x30 != 0;
                if !master || s.i1000 & (1 << AUX_NODE) != 0 || s.i1003 == 0 {
                    return Err(AuxFailure::timeout());
                }
                s.i1003.min(255)
            }
        };
        if !self.master.start(node, request, timeout) {
            return Err(AuxFailure::timeout());
        }
        self.finished = None;
        Ok(())
    }

    /// An access is in flight.
    pub fn busy(&self) -> bool {
        self.master.busy()
    }

    /// One servo cycle: `returned` = registers 2 and 3 of the latched copy of this card's
    /// node-15 packet. Returns registers 2 and 3 to send.
    pub fn servo_tick(&mut self, returned: (u16, u16)) -> (u16, u16) {
        let (out, regs) = self.master.tick(AuxWord::decode(returned.0, returned.1));
        if let Some(o) = out {
            self.finished = Some(match o {
                Outcome::Reply(Reply::Error(code)) => Err(AuxFailure {
                    x0798: u32::from(code) << 8 | 0xFE,
                }),
                Outcome::Reply(r) => Ok(r),
                Outcome::Timeout => Err(AuxFailure::timeout()),
            });
        }
        regs
    }

    /// The result of the access that finished, once.
    pub fn take_finished(&mut self) -> Option<Finished> {
        self.finished.take()
    }

    /// `$$$`: drop any access in flight.
    pub fn reset(&mut self) {
        self.master.abort();
        self.finished = None;
    }
}

/// The text a reported station value gets: numbers as the card prints them (`number`),
/// hexadecimal with `$` when I9 bit 1 is set, versions with three decimals, dates
/// `MM/DD/YYYY`.
pub fn format_value(v: f64, f: ValueFormat, i9: u32, number: impl Fn(f64) -> String) -> String {
    match f {
        ValueFormat::Decimal => number(v),
        ValueFormat::Hex => {
            let h = format!("{:X}", v.max(0.0) as u64 & 0xFF_FFFF);
            if i9 & 2 != 0 {
                format!("${h}")
            } else {
                h
            }
        }
        ValueFormat::Version => format!("{v:.3}"),
        ValueFormat::Date => {
            let d = v.max(0.0) as u64;
            format!("{:02}/{:02}/{:04}", d / 100 % 100, d % 100, d / 10_000)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcc_ring::aux_channel::{slave_error, stream_word, WordKind};

    const MASTER: AuxSettings = AuxSettings {
        i995: 0x30,
        i1000: 0x3333,
        i1003: 32,
    };

    #[test]
    fn preconditions_of_each_protocol() {
        let mut a = MacroAux::default();
        let fail = Err(AuxFailure { x0798: 0x01_0000 });
        for bad in [
            AuxSettings { i1003: 0, ..MASTER }, // Type 1 disabled
            AuxSettings {
                i995: 0x80,
                ..MASTER
            }, // not a master
            AuxSettings {
                i1000: 0xB333,
                ..MASTER
            }, // node 15 aux copy on
        ] {
            assert_eq!(a.begin(Protocol::Type1, 0, Request::ReadMi(8), bad), fail);
        }
        assert_eq!(
            a.begin(Protocol::Type0, 2, Request::ReadParam(8), MASTER),
            fail
        );
        assert_eq!(
            a.begin(Protocol::Type0, 1, Request::ReadParam(8), MASTER),
            Ok(())
        );
        assert_eq!(
            a.begin(Protocol::Type1, 0, Request::ReadMi(8), MASTER),
            fail,
            "one access in flight"
        );
        assert!(a.busy());
        a.reset();
        assert!(!a.busy());
        assert_eq!(
            a.begin(
                Protocol::Type1,
                0,
                Request::ReadMi(8),
                AuxSettings {
                    i995: 0x8090,
                    ..MASTER
                }
            ),
            Ok(())
        );
    }

    #[test]
    fn slave_errors_and_timeouts_set_x0798() {
        let mut a = MacroAux::default();
        let s = AuxSettings { i1003: 3, ..MASTER };
        a.begin(Protocol::Type1, 0, Request::ReadMi(7), s).unwrap();
        let first = a.servo_tick((0, 0));
        let tag = AuxWord::decode(first.0, first.1).tag;
        let err = Reply::Error(slave_error::UNKNOWN_VARIABLE).words();
        for k in 0..2 {
            let (r2, r3) = stream_word(WordKind::Reply, tag, 0, &err, k).encode();
            a.servo_tick((r2, r3));
        }
        assert_eq!(a.take_finished(), Some(Err(AuxFailure { x0798: 0x0001FE })));
        assert_eq!(a.take_finished(), None);
        a.begin(Protocol::Type1, 0, Request::ReadMi(7), s).unwrap();
        let mut n = 0;
        while a.take_finished().is_none() {
            a.servo_tick((0, 0));
            n += 1;
            assert!(n < 10);
        }
        assert_eq!(n, 4, "I1003 = 3 cycles of waiting, then the timeout");
    }

    #[test]
    fn value_formats() {
        let num = |v: f64| format!("{v}");
        assert_eq!(format_value(7.0, ValueFormat::Decimal, 0, num), "7");
        assert_eq!(format_value(1.104, ValueFormat::Version, 0, num), "1.104");
        assert_eq!(
            format_value(19_990_812.0, ValueFormat::Date, 0, num),
            "08/12/1999"
        );
        assert_eq!(
            format_value(f64::from(0x0F_8003), ValueFormat::Hex, 2, num),
            "$F8003"
        );
        assert_eq!(
            format_value(f64::from(0x0F_8003), ValueFormat::Hex, 0, num),
            "F8003"
        );
    }
}
