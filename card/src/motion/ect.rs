//! Encoder conversion table (pmac-variables-servo-macro.md §6.6, §4.1) for MACRO feedback.
//!
//! An Ultralite ECT entry for a MACRO servo node is two Y words: `$28C0An` (method `$2` =
//! parallel Y word, second digit `$8` = no shift because the node data already carries 5
//! fractional bits, source address `$C0An`) and the mask `$FFFFFF`. Method `$6` is the same
//! from an X word (I/O nodes). Second digit `$0` means "whole counts": the source is shifted
//! left 5 bits so the result has 5 fractional bits too.
//!
//! Two stages of rollover handling:
//! - [`EctState`]: the entry result is a 24-bit word; the masked source (any width up to 24
//!   bits) is extended to it by adding the sign-extended change of the source each cycle.
//! - [`PositionExtender`]: the motor adds the sign-extended 24-bit change of the ECT result to
//!   its 48-bit position each cycle, so a wrapping 24-bit source becomes a continuous position
//!   (valid while the source moves less than 2^23 units, i.e. 2^18 counts, per cycle).

use crate::model::Space;

/// Mask of a 24-bit word.
const W24: u32 = 0xFF_FFFF;

/// Sign-extend the low `bits` bits of `v`.
pub(crate) fn sign_extend(v: u32, bits: u32) -> i64 {
    let bits = bits.clamp(1, 32);
    let shift = 64 - bits;
    ((v as u64) << shift) as i64 >> shift
}

/// A decoded parallel-read ECT entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct EctEntry {
    /// Memory space of the source word.
    pub space: Space,
    /// Source address (e.g. `$C0A0` = node 0 register 0, Turbo `$078420`).
    pub source: u32,
    /// True for the "no shift" variant (data already in 1/32 counts).
    pub no_shift: bool,
    /// Source mask (second line).
    pub mask: u32,
}

impl EctEntry {
    /// Decode a two-line parallel entry; `None` for the end marker (`$000000`) or a method this
    /// emulator does not convert (those entries produce no result).
    pub(crate) fn decode(line1: u32, line2: u32) -> Option<EctEntry> {
        let line1 = line1 & W24;
        let space = match line1 >> 20 {
            0x2 => Space::Y,
            0x6 => Space::X,
            _ => return None,
        };
        let no_shift = match (line1 >> 16) & 0xF {
            0x8 => true,
            0x0 => false,
            _ => return None,
        };
        let mask = line2 & W24;
        if mask == 0 {
            return None;
        }
        Some(EctEntry {
            space,
            source: line1 & 0xFFFF,
            no_shift,
            mask,
        })
    }

    /// Decode a Turbo two-line parallel entry [DECISION, after the Turbo Ultralite defaults
    /// `I8000=$2F8420 I8001=$018000`]: line 1 = method digit (`$2` Y word, `$6` X word), bit
    /// 19 = no shift (the MACRO data already carries 5 fractional bits), bits 0-18 = source
    /// address; line 2 = field width in bits 12-17 (`$018` = 24) and its lowest bit in bits
    /// 0-4. `None` for the end marker or a method not converted.
    pub(crate) fn decode_turbo(line1: u32, line2: u32) -> Option<EctEntry> {
        let line1 = line1 & W24;
        let space = match line1 >> 20 {
            0x2 => Space::Y,
            0x6 => Space::X,
            _ => return None,
        };
        let width = (line2 >> 12) & 0x3F;
        let offset = line2 & 0x1F;
        if width == 0 || width + offset > 24 {
            return None;
        }
        Some(EctEntry {
            space,
            source: line1 & 0x7_FFFF,
            no_shift: line1 & (1 << 19) != 0,
            mask: (((1u64 << width) - 1) << offset) as u32,
        })
    }

    /// The entry for MACRO servo node register 0 at `$C0An` (`$28C0An`, `$FFFFFF`).
    #[cfg(test)]
    pub(crate) fn macro_servo(source: u32) -> EctEntry {
        EctEntry {
            space: Space::Y,
            source,
            no_shift: true,
            mask: W24,
        }
    }

    /// Width in bits of the masked field (position of the highest mask bit + 1 − lowest).
    pub(crate) fn width(&self) -> u32 {
        32 - self.mask.leading_zeros() - self.mask.trailing_zeros().min(31)
    }
}

/// Running state of one ECT entry: its 24-bit result word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct EctState {
    last_src: Option<u32>,
    result: u32,
}

impl EctState {
    /// Process one cycle's raw source word; returns the 24-bit result (1/32 counts).
    /// The first call takes the source as it is; later calls add its change, sign-extended to
    /// the mask width, so a source narrower than 24 bits rolls over correctly.
    pub(crate) fn process(&mut self, entry: &EctEntry, raw: u32) -> u32 {
        let src = (raw & entry.mask) >> entry.mask.trailing_zeros().min(31);
        let scale = if entry.no_shift { 1 } else { 32 };
        match self.last_src {
            None => {
                self.result = ((sign_extend(src, entry.width()) * scale) as u32) & W24;
            }
            Some(prev) => {
                let field = (1u64 << entry.width()) - 1;
                let delta = sign_extend(src.wrapping_sub(prev) & field as u32, entry.width());
                self.result = ((self.result as i64 + delta * scale) as u32) & W24;
            }
        }
        self.last_src = Some(src);
        self.result
    }
}

/// 48-bit position accumulator fed by a 24-bit ECT result (units: 1/32 count).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct PositionExtender {
    last: Option<u32>,
    pos: i64,
}

impl PositionExtender {
    /// Add the sign-extended change of `word24` since the last call; the first call starts at
    /// the sign-extended word itself. The position wraps at 48 bits like PMAC's register.
    pub(crate) fn update(&mut self, word24: u32) -> i64 {
        let w = word24 & W24;
        self.pos = match self.last {
            None => sign_extend(w, 24),
            Some(prev) => self.pos + sign_extend(w.wrapping_sub(prev) & W24, 24),
        };
        self.pos = wrap48(self.pos);
        self.last = Some(w);
        self.pos
    }
}

/// Wrap to a signed 48-bit value.
fn wrap48(v: i64) -> i64 {
    (v << 16) >> 16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decode_default_ultralite_entry() {
        let e = EctEntry::decode(0x28C0A4, 0xFFFFFF).unwrap();
        assert_eq!(e, EctEntry::macro_servo(0xC0A4));
        assert_eq!(e.width(), 24);
        let e = EctEntry::decode(0x68C0B8, 0xFFFFFF).unwrap();
        assert_eq!((e.space, e.source), (Space::X, 0xC0B8));
        assert_eq!(EctEntry::decode(0, 0xFFFFFF), None);
        assert_eq!(EctEntry::decode(0x18C0A0, 0xFFFFFF), None);
        assert_eq!(EctEntry::decode(0x28C0A0, 0), None);
    }

    /// A source moving `step` units per cycle for `n` cycles from `start` (24-bit wrapping)
    /// must give a continuous position through both stages.
    fn run(start: i64, step: i64, n: usize) {
        let e = EctEntry::macro_servo(0xC0A0);
        let mut ect = EctState::default();
        let mut ext = PositionExtender::default();
        let mut truth = sign_extend(start as u32 & W24, 24);
        let mut raw = start as u32 & W24;
        let first = ext.update(ect.process(&e, raw));
        assert_eq!(first, truth);
        for _ in 0..n {
            raw = (raw as i64 + step) as u32 & W24;
            truth += step;
            assert_eq!(ext.update(ect.process(&e, raw)), truth);
        }
    }

    #[test]
    fn rollover_positive_and_negative() {
        // Up through +2^23 → -2^23 (signed wrap) and through 2^24 → 0.
        run(0x7F_F000, 1000, 100);
        run(0xFF_F000, 1000, 100);
        // Down through 0 → $FFFFFF and through -2^23.
        run(0x00_1000, -1000, 100);
        run(0x80_0800, -1000, 100);
        // Several full turns of the 24-bit word at the largest legal speed.
        run(0, (1 << 23) - 1, 10);
        run(0, -((1 << 23) - 1), 10);
    }

    #[test]
    fn narrow_mask_and_shift() {
        // 16-bit source in whole counts: result in 1/32 counts, rolls over at 2^16.
        let e = EctEntry::decode(0x20C000, 0x00FFFF).unwrap();
        assert!(!e.no_shift);
        let mut s = EctState::default();
        assert_eq!(s.process(&e, 0xFFF0), (-16i64 * 32) as u32 & W24);
        assert_eq!(s.process(&e, 0x0010), (16 * 32) as u32);
        assert_eq!(
            s.process(&e, 0xAB_0020),
            (32 * 32) as u32,
            "bits above mask ignored"
        );
    }

    #[test]
    fn position_wraps_at_48_bits() {
        assert_eq!(wrap48(1 << 47), -(1 << 47));
        assert_eq!(wrap48((1 << 47) - 1), (1 << 47) - 1);
    }
}
