//! M-variable pointers: validation, reading and writing through a definition
//! ([`crate::domain::ast::MDef`]), and the canonical short form of a definition
//! (`Y:$C0A0,8,16,S`). pmac-variables §1.2, pmac-commands §3.2.3.

use super::error::StateError;
use super::float48::{decode_fixed, decode_float, dp_join, dp_split, encode_fixed, encode_float};
use super::memory::Space;
use super::regmap::Addr;
use crate::domain::ast::{MDef, MFormat, XySpace};

/// Word-level access to card memory (implemented by `CardState`, which applies the special
/// registers; and by [`super::memory::Memory`] for plain access).
pub(crate) trait WordAccess {
    /// Read one 24-bit word (may have side effects, e.g. I995 clear-on-read).
    fn read_word(&mut self, space: Space, addr: Addr) -> u32;
    /// Write one 24-bit word.
    fn write_word(&mut self, space: Space, addr: Addr, value: u32);
}

impl WordAccess for super::memory::Memory {
    fn read_word(&mut self, space: Space, addr: Addr) -> u32 {
        self.read(space, addr)
    }
    fn write_word(&mut self, space: Space, addr: Addr, value: u32) {
        self.write(space, addr, value)
    }
}

/// Upper end of the self-referenced value range.
pub(super) const SELF_MAX: i64 = (1 << 20) - 1;

fn space(s: XySpace) -> Space {
    match s {
        XySpace::X => Space::X,
        XySpace::Y => Space::Y,
    }
}

/// Check a definition against the legal widths/offsets (pmac-variables §1.2).
pub(super) fn validate(def: &MDef) -> Result<(), StateError> {
    let bad = |m: &str| Err(StateError::BadDefinition(m.into()));
    match *def {
        MDef::Bits { offset, width, .. } => {
            let ok = match width {
                1 => offset <= 23,
                4 | 8 | 12 | 16 | 20 | 24 => offset % 4 == 0 && offset as u16 + width as u16 <= 24,
                _ => return bad("width must be 1, 4, 8, 12, 16, 20 or 24"),
            };
            if ok {
                Ok(())
            } else {
                bad("offset not legal for this width")
            }
        }
        MDef::Twb { offset, size, .. } if offset > 7 || !(1..=32).contains(&size) => {
            bad("TWB offset/size")
        }
        MDef::Twd {
            offset,
            digits,
            decimals,
            ..
        } if !(offset == 0 || offset == 4) || !(1..=12).contains(&digits) || decimals > 8 => {
            bad("TWD offset/digits/decimals")
        }
        MDef::Twr { mux, offset } if mux % 2 != 0 || offset > 7 => bad("TWR mux/offset"),
        MDef::Tws { mux } if mux > 127 => bad("TWS mux"),
        _ => Ok(()),
    }
}

/// Canonical short form of a definition as `Mn->` reports it under I9=0/2
/// (`X:$C001,24,S`, `Y:$FFC2,8`, `Y:$C003,8,16,S`, `D:$002B`, `*`). Addresses print as `$`
/// plus 4 hex digits.
pub(super) fn format_def(def: &MDef, digits: usize) -> String {
    // One formatter for `Mn->` replies and listings: `Display for MDef` (lang::listing),
    // `{:#}` for six address digits.
    if digits > 4 {
        format!("{def:#}")
    } else {
        def.to_string()
    }
}

fn field_mask(width: u8) -> u32 {
    if width >= 24 {
        0xFF_FFFF
    } else {
        (1u32 << width) - 1
    }
}

fn bcd_decode(raw: u32, digits: u8) -> i64 {
    (0..digits as u32)
        .rev()
        .fold(0i64, |acc, k| acc * 10 + ((raw >> (4 * k)) & 0xF) as i64)
}

fn bcd_encode(v: i64, digits: u8) -> u32 {
    let modulus = 10i64.pow(digits as u32);
    let mut v = v.rem_euclid(modulus);
    let mut raw = 0u32;
    for k in 0..digits as u32 {
        raw |= ((v % 10) as u32) << (4 * k);
        v /= 10;
    }
    raw
}

/// Read the value an M-variable pointing at `def` has. `SelfRef` is not handled here (its
/// value lives in the definition table) and reads 0; thumbwheel forms read 0 ([DECISION]).
pub(super) fn read(def: &MDef, mem: &mut impl WordAccess) -> f64 {
    match *def {
        MDef::Bits {
            space: s,
            addr,
            offset,
            width,
            format,
        } => {
            let mask = field_mask(width);
            let raw = (mem.read_word(space(s), addr) >> offset) & mask;
            match (width, format) {
                (1, _) | (_, MFormat::U) => raw as f64,
                (_, MFormat::S) => {
                    let sign = 1u32 << (width - 1);
                    (raw as i64 - if raw & sign != 0 { 1i64 << width } else { 0 }) as f64
                }
                (_, MFormat::D) => bcd_decode(raw, width / 4) as f64,
                (_, MFormat::C) => bcd_decode(!raw & mask, width / 4) as f64,
            }
        }
        MDef::D(a) => decode_fixed(long(mem, a)),
        MDef::L(a) => decode_float(long(mem, a)),
        MDef::Dp(a) => dp_word(mem, a) as i32 as f64,
        MDef::F(a) => f32::from_bits(dp_word(mem, a)) as f64,
        _ => 0.0,
    }
}

/// Write `v` through `def` (integer forms round half away from zero and wrap to the field).
/// `SelfRef` and thumbwheel forms do nothing here.
pub(super) fn write(def: &MDef, mem: &mut impl WordAccess, v: f64) {
    let int = if v.is_finite() {
        v.round().clamp(-1.8e18, 1.8e18) as i64
    } else {
        0
    };
    match *def {
        MDef::Bits {
            space: s,
            addr,
            offset,
            width,
            format,
        } => {
            let mask = field_mask(width);
            let raw = match (width, format) {
                (_, MFormat::D) if width > 1 => bcd_encode(int, width / 4),
                (_, MFormat::C) if width > 1 => !bcd_encode(int, width / 4) & mask,
                _ => (int as u64 as u32) & mask,
            };
            let sp = space(s);
            let old = mem.read_word(sp, addr);
            mem.write_word(sp, addr, (old & !(mask << offset)) | (raw << offset));
        }
        MDef::D(a) => set_long(mem, a, encode_fixed(v)),
        MDef::L(a) => set_long(mem, a, encode_float(v)),
        MDef::Dp(a) => set_dp_word(mem, a, int as i32 as u32),
        MDef::F(a) => set_dp_word(mem, a, (v as f32).to_bits()),
        _ => {}
    }
}

/// Read the 48-bit long word at `addr` (X high).
pub(crate) fn long(mem: &mut impl WordAccess, addr: Addr) -> u64 {
    ((mem.read_word(Space::X, addr) as u64) << 24) | mem.read_word(Space::Y, addr) as u64
}

/// Write the 48-bit long word at `addr` (X high).
pub(super) fn set_long(mem: &mut impl WordAccess, addr: Addr, w: u64) {
    mem.write_word(Space::X, addr, ((w >> 24) & 0xFF_FFFF) as u32);
    mem.write_word(Space::Y, addr, (w & 0xFF_FFFF) as u32);
}

fn dp_word(mem: &mut impl WordAccess, a: Addr) -> u32 {
    dp_join(mem.read_word(Space::X, a), mem.read_word(Space::Y, a))
}

fn set_dp_word(mem: &mut impl WordAccess, a: Addr, w: u32) {
    let (hi, lo) = dp_split(w);
    let x = mem.read_word(Space::X, a);
    let y = mem.read_word(Space::Y, a);
    mem.write_word(Space::X, a, (x & 0xFF_0000) | hi);
    mem.write_word(Space::Y, a, (y & 0xFF_0000) | lo);
}

/// Wrap an integer into the self-referenced range (21-bit two's complement).
pub(super) fn wrap_self(v: f64) -> i32 {
    let i = if v.is_finite() {
        v.round().clamp(-1.8e18, 1.8e18) as i64
    } else {
        0
    };
    let w = i.rem_euclid(1 << 21);
    (if w > SELF_MAX { w - (1 << 21) } else { w }) as i32
}

#[cfg(test)]
#[path = "tests_mvar.rs"]
mod tests;
