//! The card side of MACRO auxiliary communications (spec pmac-commands §3.5, pmac-variables
//! §6.9) as a pure state machine over the node-15 channel ([`mcc_ring::aux_channel`]):
//! preconditions, one transaction in flight, the timeout (I1003 servo cycles for Type 1, a
//! fixed 32 for Type 0), and what a failure leaves in X:$0003 bit 5 and X:$0798.
//!
//! The servo tick feeds it the latched copy of the card's own node-15 packet and sends what
//! [`MacroAux::servo_tick`] returns in registers 2-3 of that packet; a finished transaction is
//! collected with [`MacroAux::take_finished`] by whoever started it (the on-line command, a
//! PLC's MSR/MSW/MXR/MXW).

use crate::domain::ast::SlaveVar;
use mcc_ring::aux_channel::{AuxMaster, AuxWord, Outcome, Reply, Request, ValueFormat, AUX_NODE};

/// X:$0798 after a timeout.
pub(crate) const X0798_TIMEOUT: u32 = 0x01_0000;
/// The fixed Type 0 (MX/MXR/MXW) timeout, servo cycles.
pub(crate) const TYPE0_TIMEOUT: u32 = 32;

/// Which protocol an access uses (their preconditions and timeouts differ).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Protocol {
    /// `MX`, `MXR`, `MXW`: needs I1000 bit n; 32 servo cycles.
    Type0,
    /// `MS…`, `MSR`, `MSW`: needs a master (I995 $xx90/$xx30), I1000 bit 15 = 0 and
    /// I1003 > 0, which is the timeout.
    Type1,
}

/// The ring settings the preconditions read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct AuxSettings {
    /// I995.
    pub i995: u32,
    /// I1000.
    pub i1000: u32,
    /// I1003.
    pub i1003: u32,
}

/// Why an access failed: the value X:$0798 gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct AuxFailure {
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
pub(crate) type Finished = Result<Reply, AuxFailure>;

/// Who started a transaction (and alone collects its result).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AuxOwner {
    /// A host command line (its id from [`MacroAux::line_id`]).
    Line(u64),
    /// A background PLC's `MSR`/`MSW`/`MXR`/`MXW`.
    Plc(u8),
}

/// What [`MacroAux::begin`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Begin {
    /// The transaction is on its way.
    Started,
    /// Another owner's transaction is in flight (or its result not yet collected): try again
    /// later (the caller waits its turn).
    Busy,
}

/// Servo ticks a finished result waits for its owner before it is dropped (a PLC disabled
/// while its access was in flight never collects it).
pub(crate) const UNCLAIMED_TICKS: u32 = 64;

/// The card's auxiliary channel.
#[derive(Clone, Debug, Default)]
pub(crate) struct MacroAux {
    master: AuxMaster,
    owner: Option<AuxOwner>,
    finished: Option<(AuxOwner, Finished, u32)>,
    next_line: u64,
}

impl MacroAux {
    /// A fresh owner id for a host command.
    pub(crate) fn line_id(&mut self) -> AuxOwner {
        self.next_line += 1;
        AuxOwner::Line(self.next_line)
    }

    /// Start an access to `node` for `owner`. Checks the protocol's preconditions (refused:
    /// the caller reports the failure, ERR008); [`Begin::Busy`] while another owner's access
    /// is in flight or its result is not yet collected.
    pub(crate) fn begin(
        &mut self,
        owner: AuxOwner,
        proto: Protocol,
        node: u8,
        request: Request,
        s: AuxSettings,
    ) -> Result<Begin, AuxFailure> {
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
        if self.master.busy() || self.finished.is_some() {
            return Ok(Begin::Busy);
        }
        if !self.master.start(node, request, timeout) {
            return Ok(Begin::Busy);
        }
        self.owner = Some(owner);
        Ok(Begin::Started)
    }

    /// `owner`'s access is in flight or its result waits to be collected.
    pub(crate) fn holds(&self, owner: AuxOwner) -> bool {
        (self.master.busy() && self.owner == Some(owner))
            || self.finished.as_ref().is_some_and(|f| f.0 == owner)
    }

    /// One servo cycle: `returned` = registers 2 and 3 of the latched copy of this card's
    /// node-15 packet. Returns registers 2 and 3 to send.
    pub(crate) fn servo_tick(&mut self, returned: (u16, u16)) -> (u16, u16) {
        if let Some(f) = self.finished.as_mut() {
            f.2 += 1;
            if f.2 >= UNCLAIMED_TICKS {
                self.finished = None;
            }
        }
        let (out, regs) = self.master.tick(AuxWord::decode(returned.0, returned.1));
        if let Some(o) = out {
            let r = match o {
                Outcome::Reply(Reply::Error(code)) => Err(AuxFailure {
                    x0798: u32::from(code) << 8 | 0xFE,
                }),
                Outcome::Reply(r) => Ok(r),
                Outcome::Timeout => Err(AuxFailure::timeout()),
            };
            if let Some(owner) = self.owner.take() {
                self.finished = Some((owner, r, 0));
            }
        }
        regs
    }

    /// The result of `owner`'s access once it has finished (once).
    pub(crate) fn take_finished(&mut self, owner: AuxOwner) -> Option<Finished> {
        if self.finished.as_ref()?.0 != owner {
            return None;
        }
        self.finished.take().map(|f| f.1)
    }

    /// `$$$`: drop any access in flight.
    pub(crate) fn reset(&mut self) {
        self.master.abort();
        self.owner = None;
        self.finished = None;
    }
}

/// The Type 1 request for a station variable access: `MI{n}` read or write, `C{n}` a
/// C-command (a read sends its value as 0, as `MSR`'s "dummy variable" suggests).
pub(crate) fn slave_request(var: SlaveVar, value: Option<f64>) -> Option<Request> {
    Some(match (var, value) {
        (SlaveVar::Mi(n), None) => Request::ReadMi(u16::try_from(n).ok()?),
        (SlaveVar::Mi(n), Some(v)) => Request::WriteMi(u16::try_from(n).ok()?, v),
        (SlaveVar::Mc(n), v) => Request::CCommand(u16::try_from(n).ok()?, v.unwrap_or(0.0)),
    })
}

/// The text a reported station value gets: numbers as the card prints them (`number`),
/// hexadecimal with `$` when I9 bit 1 is set, versions with three decimals, dates
/// `MM/DD/YYYY`.
pub(crate) fn format_value(
    v: f64,
    f: ValueFormat,
    i9: u32,
    number: impl Fn(f64) -> String,
) -> String {
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
        let me = a.line_id();
        let other = a.line_id();
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
            assert_eq!(
                a.begin(me, Protocol::Type1, 0, Request::ReadMi(8), bad),
                fail
            );
        }
        assert_eq!(
            a.begin(me, Protocol::Type0, 2, Request::ReadParam(8), MASTER),
            fail
        );
        assert_eq!(
            a.begin(me, Protocol::Type0, 1, Request::ReadParam(8), MASTER),
            Ok(Begin::Started)
        );
        assert_eq!(
            a.begin(other, Protocol::Type1, 0, Request::ReadMi(8), MASTER),
            Ok(Begin::Busy),
            "one access in flight"
        );
        assert!(a.holds(me) && !a.holds(other));
        a.reset();
        assert!(!a.holds(me));
        assert_eq!(
            a.begin(
                other,
                Protocol::Type1,
                0,
                Request::ReadMi(8),
                AuxSettings {
                    i995: 0x8090,
                    ..MASTER
                }
            ),
            Ok(Begin::Started)
        );
    }

    #[test]
    fn slave_errors_and_timeouts_set_x0798() {
        let mut a = MacroAux::default();
        let s = AuxSettings { i1003: 3, ..MASTER };
        let me = AuxOwner::Plc(3);
        a.begin(me, Protocol::Type1, 0, Request::ReadMi(7), s)
            .unwrap();
        let first = a.servo_tick((0, 0));
        let tag = AuxWord::decode(first.0, first.1).tag;
        let err = Reply::Error(slave_error::UNKNOWN_VARIABLE).words();
        for k in 0..2 {
            let (r2, r3) = stream_word(WordKind::Reply, tag, 0, &err, k).encode();
            a.servo_tick((r2, r3));
        }
        assert_eq!(a.take_finished(AuxOwner::Plc(4)), None, "not the owner");
        assert_eq!(
            a.take_finished(me),
            Some(Err(AuxFailure { x0798: 0x0001FE }))
        );
        assert_eq!(a.take_finished(me), None);
        a.begin(me, Protocol::Type1, 0, Request::ReadMi(7), s)
            .unwrap();
        let mut n = 0;
        while a.take_finished(me).is_none() {
            a.servo_tick((0, 0));
            n += 1;
            assert!(n < 10);
        }
        assert_eq!(n, 4, "I1003 = 3 cycles of waiting, then the timeout");
        // an uncollected result blocks others until it expires
        a.begin(me, Protocol::Type1, 0, Request::ReadMi(7), s)
            .unwrap();
        for _ in 0..4 {
            a.servo_tick((0, 0));
        }
        let other = AuxOwner::Plc(9);
        assert_eq!(
            a.begin(other, Protocol::Type1, 0, Request::ReadMi(7), s),
            Ok(Begin::Busy)
        );
        for _ in 0..UNCLAIMED_TICKS {
            a.servo_tick((0, 0));
        }
        assert!(!a.holds(me));
        assert_eq!(
            a.begin(other, Protocol::Type1, 0, Request::ReadMi(7), s),
            Ok(Begin::Started)
        );
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
