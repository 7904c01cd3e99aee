//! Power PMAC M-variables (seed L36823-37075, digest §2.5): pointers a user defines with
//! `Mn->…`, in three forms, and the memory they point into.
//!
//! - **Address form** `{fmt}.{bank}:{offset}[.{bit}[.{width}]]`: `fmt` is `s` (signed,
//!   saturating), `i` (signed, wrapping), `u` (unsigned, wrapping), `f` (float32) or `d`
//!   (float64); `bank` is `user` (the user shared-memory buffer, base `Sys.pushm`, 1 MB) or
//!   `io` (memory-mapped I/O, base `Sys.piom`); the byte offset is 4-aligned (8 for `d`). No
//!   bit: bit 0, width 32; a bit without a width: width 1; bit + width ≤ 32, integer formats
//!   only.
//! - **Element form** `Motor[1].ActPos`: the element's own value and format (kept by the
//!   caller as an element key; this module only keeps it).
//! - **Self-referenced form** `*[{fmt}[.{width}]]` (default `d`): a global user variable of
//!   that format.
//!
//! The user buffer is the same memory as `Sys.Idata[n]` / `Sys.Udata[n]` / `Sys.Fdata[n]`
//! (the 32-bit word at byte 4n) and `Sys.Ddata[n]` (the 64-bit word at byte 8n).
//! [DECISION] The `io` bank is memory with nothing behind it (the card models its ring IC
//! through the `Gate3[0]` elements, not through I/O addresses): a 16 MB window whose words
//! read 0 until written, at most [`IO_WORDS`] distinct words. An M-variable nobody defined is
//! self-referenced `d` (`*`), value 0. Values written to integer formats are rounded to the
//! nearest integer first.

use crate::domain::PowerErr;
use std::collections::HashMap;

/// Bytes in the user shared-memory buffer (the seed's default size, as `size` reports).
pub(crate) const USER_BYTES: u32 = 1_048_576;
/// Bytes in the `io` window.
pub(crate) const IO_BYTES: u32 = 16 * 1_048_576;
/// Most distinct 32-bit words of the `io` window that can hold a value.
pub(crate) const IO_WORDS: usize = 65_536;

/// How the bits at an address are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fmt {
    /// Signed integer, saturating on assignment.
    S,
    /// Signed integer, wrapping.
    I,
    /// Unsigned integer, wrapping.
    U,
    /// 32-bit float.
    F,
    /// 64-bit float.
    D,
}

impl Fmt {
    fn of(c: u8) -> Option<Fmt> {
        Some(match c.to_ascii_lowercase() {
            b's' => Fmt::S,
            b'i' => Fmt::I,
            b'u' => Fmt::U,
            b'f' => Fmt::F,
            b'd' => Fmt::D,
            _ => return None,
        })
    }

    fn letter(self) -> char {
        match self {
            Fmt::S => 's',
            Fmt::I => 'i',
            Fmt::U => 'u',
            Fmt::F => 'f',
            Fmt::D => 'd',
        }
    }

    fn integer(self) -> bool {
        matches!(self, Fmt::S | Fmt::I | Fmt::U)
    }
}

/// Memory bank of the address form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Bank {
    /// `user`: the user shared-memory buffer.
    User,
    /// `io`: memory-mapped I/O.
    Io,
}

/// An address or self-referenced definition (the element form is kept by the caller).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ptr {
    /// `*{fmt}.{width}`
    SelfRef {
        /// Format.
        fmt: Fmt,
        /// Bits (integer formats; 32 otherwise).
        width: u8,
    },
    /// `{fmt}.{bank}:{offset}.{bit}.{width}`
    Addr {
        /// Format.
        fmt: Fmt,
        /// Bank.
        bank: Bank,
        /// Byte offset in the bank.
        offset: u32,
        /// First bit (integer formats).
        bit: u8,
        /// Bits (integer formats; 32 otherwise).
        width: u8,
    },
}

/// Why a definition text is refused: at which byte, with which error number (20: not a
/// definition; 21: a definition out of range — misaligned, past the bank, bad bit field).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct DefError {
    /// Byte offset in the text.
    pub at: usize,
    /// The refusal.
    pub code: PowerErr,
}

fn bad<T>(at: usize, code: PowerErr) -> Result<T, DefError> {
    Err(DefError { at, code })
}

/// Parse an address or self-referenced definition at the start of `s`: the definition and
/// the bytes it took; `Ok(None)` when `s` starts with neither form (an element, perhaps).
pub(crate) fn parse(s: &[u8]) -> Result<Option<(Ptr, usize)>, DefError> {
    let mut i = 0;
    let num = |i: &mut usize| -> Option<u64> {
        let hex = s.get(*i) == Some(&b'$');
        if hex {
            *i += 1;
        }
        let st = *i;
        while s
            .get(*i)
            .is_some_and(|c| c.is_ascii_hexdigit() && (hex || c.is_ascii_digit()))
        {
            *i += 1;
        }
        let t = std::str::from_utf8(&s[st..*i]).ok()?;
        if t.is_empty() || t.len() > 12 {
            return None;
        }
        u64::from_str_radix(t, if hex { 16 } else { 10 }).ok()
    };
    let ends = |i: usize| {
        !s.get(i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
    };
    if s.first() == Some(&b'*') {
        i += 1;
        let fmt = match s.get(i).copied().and_then(Fmt::of) {
            Some(f) if ends(i + 1) || s.get(i + 1) == Some(&b'.') => {
                i += 1;
                f
            }
            _ if ends(i) => {
                return Ok(Some((
                    Ptr::SelfRef {
                        fmt: Fmt::D,
                        width: 32,
                    },
                    i,
                )))
            }
            _ => return bad(i, PowerErr::IllegalCmd),
        };
        let mut width = 32;
        if s.get(i) == Some(&b'.') {
            let at = i;
            i += 1;
            let w = num(&mut i).ok_or(DefError {
                at: i,
                code: PowerErr::IllegalCmd,
            })?;
            if !fmt.integer() || !(1..=32).contains(&w) {
                return bad(at, PowerErr::IllegalParameter);
            }
            width = w as u8;
        }
        if !ends(i) {
            return bad(i, PowerErr::IllegalCmd);
        }
        return Ok(Some((Ptr::SelfRef { fmt, width }, i)));
    }
    // `{fmt}.{bank}:` — anything else is not this form.
    let Some(fmt) = s.first().copied().and_then(Fmt::of) else {
        return Ok(None);
    };
    if s.get(1) != Some(&b'.') {
        return Ok(None);
    }
    let rest = &s[2..];
    let (bank, blen) = if rest.len() >= 5 && rest[..5].eq_ignore_ascii_case(b"user:") {
        (Bank::User, 5)
    } else if rest.len() >= 3 && rest[..3].eq_ignore_ascii_case(b"io:") {
        (Bank::Io, 3)
    } else {
        return Ok(None);
    };
    i = 2 + blen;
    let at_off = i;
    let offset = num(&mut i).ok_or(DefError {
        at: i,
        code: PowerErr::IllegalCmd,
    })?;
    let size = match bank {
        Bank::User => USER_BYTES,
        Bank::Io => IO_BYTES,
    };
    let bytes = if fmt == Fmt::D { 8 } else { 4 };
    if offset % bytes != 0 || offset + bytes > u64::from(size) {
        return bad(at_off, PowerErr::IllegalParameter);
    }
    let (mut bit, mut width) = (0u64, 32u64);
    if s.get(i) == Some(&b'.') {
        let at = i;
        i += 1;
        bit = num(&mut i).ok_or(DefError {
            at: i,
            code: PowerErr::IllegalCmd,
        })?;
        width = 1;
        if s.get(i) == Some(&b'.') {
            i += 1;
            width = num(&mut i).ok_or(DefError {
                at: i,
                code: PowerErr::IllegalCmd,
            })?;
        }
        if !fmt.integer() || bit > 31 || !(1..=32).contains(&width) || bit + width > 32 {
            return bad(at, PowerErr::IllegalParameter);
        }
    }
    if !ends(i) {
        return bad(i, PowerErr::IllegalCmd);
    }
    Ok(Some((
        Ptr::Addr {
            fmt,
            bank,
            offset: offset as u32,
            bit: bit as u8,
            width: width as u8,
        },
        i,
    )))
}

/// The definition as `Mn->` reports it (`u.io:$A00000.8.1`, `s.user:$0`, `*`, `*s.16`).
pub(crate) fn text(p: &Ptr) -> String {
    match *p {
        Ptr::SelfRef { fmt: Fmt::D, .. } => "*".to_string(),
        Ptr::SelfRef { fmt, width } if fmt.integer() && width != 32 => {
            format!("*{}.{width}", fmt.letter())
        }
        Ptr::SelfRef { fmt, .. } => format!("*{}", fmt.letter()),
        Ptr::Addr {
            fmt,
            bank,
            offset,
            bit,
            width,
        } => {
            let b = match bank {
                Bank::User => "user",
                Bank::Io => "io",
            };
            let mut s = format!("{}.{b}:${offset:X}", fmt.letter());
            if fmt.integer() && (bit, width) != (0, 32) {
                s.push_str(&format!(".{bit}.{width}"));
            }
            s
        }
    }
}

/// The integer a value becomes in a field of `width` bits of format `fmt` (as the field's
/// raw bits, low `width` bits significant).
fn to_field(fmt: Fmt, width: u8, v: f64) -> u32 {
    let w = u32::from(width.clamp(1, 32));
    let mask: u64 = if w == 32 {
        0xFFFF_FFFF
    } else {
        (1u64 << w) - 1
    };
    let r = if v.is_nan() { 0.0 } else { v.round() };
    let raw: i64 = match fmt {
        Fmt::S => {
            let lo = -(1i64 << (w - 1));
            let hi = (1i64 << (w - 1)) - 1;
            (r.clamp(lo as f64, hi as f64)) as i64
        }
        // Wrapping: the value modulo 2^64 first (`as` saturates at the i64 range; values
        // beyond it keep their low bits only as far as f64 has them).
        _ => {
            if r.abs() < 9.2e18 {
                r as i64
            } else {
                (r.rem_euclid(18_446_744_073_709_551_616.0) as u64) as i64
            }
        }
    };
    ((raw as u64) & mask) as u32
}

/// The value of the raw field bits `raw` (low `width` bits).
fn from_field(fmt: Fmt, width: u8, raw: u32) -> f64 {
    let w = u32::from(width.clamp(1, 32));
    let mask: u64 = if w == 32 {
        0xFFFF_FFFF
    } else {
        (1u64 << w) - 1
    };
    let u = u64::from(raw) & mask;
    match fmt {
        Fmt::U => u as f64,
        _ => {
            if u & (1u64 << (w - 1)) != 0 {
                (u as i64 - (1i64 << w)) as f64
            } else {
                u as f64
            }
        }
    }
}

/// The value a self-referenced M-variable keeps when `v` is assigned.
fn self_value(fmt: Fmt, width: u8, v: f64) -> f64 {
    match fmt {
        Fmt::D => v,
        Fmt::F => f64::from(v as f32),
        _ => from_field(fmt, width, to_field(fmt, width, v)),
    }
}

/// The user buffer and the `io` window.
#[derive(Debug, Default, Clone)]
pub(crate) struct Memory {
    /// The user buffer (grown on first write up to [`USER_BYTES`]).
    user: Vec<u8>,
    /// `io` words written (byte offset / 4 → word).
    io: HashMap<u32, u32>,
}

impl Memory {
    /// The 32-bit word at byte `offset` (4-aligned) of `bank`.
    pub(crate) fn word(&self, bank: Bank, offset: u32) -> u32 {
        match bank {
            Bank::User => {
                let o = offset as usize;
                self.user
                    .get(o..o + 4)
                    .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            }
            Bank::Io => self.io.get(&(offset / 4)).copied().unwrap_or(0),
        }
    }

    /// Store the 32-bit word at byte `offset`; `false` when the bank cannot hold it.
    pub(crate) fn set_word(&mut self, bank: Bank, offset: u32, w: u32) -> bool {
        match bank {
            Bank::User => {
                let o = offset as usize;
                if o + 4 > USER_BYTES as usize {
                    return false;
                }
                if self.user.len() < o + 4 {
                    self.user.resize(o + 4, 0);
                }
                self.user[o..o + 4].copy_from_slice(&w.to_le_bytes());
                true
            }
            Bank::Io => {
                if offset + 4 > IO_BYTES {
                    return false;
                }
                if self.io.len() >= IO_WORDS && !self.io.contains_key(&(offset / 4)) {
                    return false;
                }
                self.io.insert(offset / 4, w);
                true
            }
        }
    }

    /// The 64-bit float at byte `offset` (8-aligned).
    pub(crate) fn double(&self, bank: Bank, offset: u32) -> f64 {
        let lo = u64::from(self.word(bank, offset));
        let hi = u64::from(self.word(bank, offset + 4));
        f64::from_bits(lo | (hi << 32))
    }

    /// Store a 64-bit float at byte `offset`.
    pub(crate) fn set_double(&mut self, bank: Bank, offset: u32, v: f64) -> bool {
        let b = v.to_bits();
        self.set_word(bank, offset, b as u32) && self.set_word(bank, offset + 4, (b >> 32) as u32)
    }

    /// Read through an address definition.
    pub(crate) fn read(&self, p: &Ptr) -> f64 {
        match *p {
            Ptr::Addr {
                fmt,
                bank,
                offset,
                bit,
                width,
            } => match fmt {
                Fmt::D => self.double(bank, offset),
                Fmt::F => f64::from(f32::from_bits(self.word(bank, offset))),
                _ => from_field(fmt, width, self.word(bank, offset) >> bit),
            },
            Ptr::SelfRef { .. } => 0.0,
        }
    }

    /// Write through an address definition; `false` when the bank cannot hold the word.
    pub(crate) fn write(&mut self, p: &Ptr, v: f64) -> bool {
        match *p {
            Ptr::Addr {
                fmt,
                bank,
                offset,
                bit,
                width,
            } => match fmt {
                Fmt::D => self.set_double(bank, offset, v),
                Fmt::F => self.set_word(bank, offset, (v as f32).to_bits()),
                _ => {
                    let w = u32::from(width);
                    let mask: u32 = if w == 32 {
                        u32::MAX
                    } else {
                        ((1u32 << w) - 1) << bit
                    };
                    let field = to_field(fmt, width, v) << bit;
                    let old = self.word(bank, offset);
                    self.set_word(bank, offset, (old & !mask) | (field & mask))
                }
            },
            Ptr::SelfRef { .. } => true,
        }
    }
}

/// The M-variable table of a Power card: address and self-referenced definitions with their
/// values (element definitions are kept by the caller beside it, `E` being its element type).
#[derive(Debug, Clone)]
pub(crate) struct MVars<E> {
    defs: HashMap<u32, Def<E>>,
    /// Values of self-referenced M-variables.
    values: HashMap<u32, f64>,
    /// The memory the address form reaches.
    pub(crate) mem: Memory,
}

impl<E> Default for MVars<E> {
    fn default() -> Self {
        MVars {
            defs: HashMap::new(),
            values: HashMap::new(),
            mem: Memory::default(),
        }
    }
}

/// One M-variable's definition.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Def<E> {
    /// Address or self-referenced.
    Ptr(Ptr),
    /// Element form.
    Elem(E),
}

/// The definition an M-variable has before any `->`.
pub(crate) const UNDEFINED: Ptr = Ptr::SelfRef {
    fmt: Fmt::D,
    width: 32,
};

impl<E: Clone> MVars<E> {
    /// The definition of M`n`.
    pub(crate) fn def(&self, n: u32) -> Def<E> {
        self.defs.get(&n).cloned().unwrap_or(Def::Ptr(UNDEFINED))
    }

    /// Define M`n` (a new definition starts a self-referenced variable at 0).
    pub(crate) fn define(&mut self, n: u32, d: Def<E>) {
        self.values.remove(&n);
        if matches!(d, Def::Ptr(p) if p == UNDEFINED) {
            self.defs.remove(&n);
        } else {
            self.defs.insert(n, d);
        }
    }

    /// Every M-variable defined other than `*`, in number order.
    pub(crate) fn defined(&self) -> Vec<(u32, Def<E>)> {
        let mut v: Vec<(u32, Def<E>)> = self.defs.iter().map(|(k, d)| (*k, d.clone())).collect();
        v.sort_by_key(|(k, _)| *k);
        v
    }

    /// Value of M`n` when its definition is not an element (`None`: it is one).
    pub(crate) fn read(&self, n: u32) -> Option<f64> {
        match self.def(n) {
            Def::Ptr(Ptr::SelfRef { .. }) => Some(self.values.get(&n).copied().unwrap_or(0.0)),
            Def::Ptr(p) => Some(self.mem.read(&p)),
            Def::Elem(_) => None,
        }
    }

    /// Assign M`n` when its definition is not an element: `Some(false)` when the memory
    /// cannot hold the word (the `io` window is full), `None` for an element definition.
    pub(crate) fn write(&mut self, n: u32, v: f64) -> Option<bool> {
        match self.def(n) {
            Def::Ptr(Ptr::SelfRef { fmt, width }) => {
                let x = self_value(fmt, width, v);
                if x == 0.0 {
                    self.values.remove(&n);
                } else {
                    self.values.insert(n, x);
                }
                Some(true)
            }
            Def::Ptr(p) => Some(self.mem.write(&p, v)),
            Def::Elem(_) => None,
        }
    }

    /// Self-referenced values that are not 0 (for the saved image).
    pub(crate) fn self_values(&self) -> Vec<(u32, f64)> {
        let mut v: Vec<(u32, f64)> = self.values.iter().map(|(k, x)| (*k, *x)).collect();
        v.sort_by_key(|(k, _)| *k);
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> Ptr {
        parse(s.as_bytes()).unwrap().unwrap().0
    }

    #[test]
    fn the_seed_s_definitions_parse_and_read_back_as_written() {
        for (def, back) in [
            ("u.io:$A00000.8.1", "u.io:$A00000.8.1"),
            ("s.user:0", "s.user:$0"),
            ("d.user:$100", "d.user:$100"),
            ("u.io:$A10000.8.8", "u.io:$A10000.8.8"),
            ("U.USER:$10.4", "u.user:$10.4.1"),
            ("*u", "*u"),
            ("*s.16", "*s.16"),
            ("*f", "*f"),
            ("*d", "*"),
            ("*", "*"),
        ] {
            assert_eq!(text(&p(def)), back, "{def}");
        }
        assert_eq!(
            parse(b"u.io:$A00000.8.1 M1").unwrap().map(|x| x.1),
            Some(16)
        );
    }

    #[test]
    fn bad_definitions_are_refused_with_the_seed_s_errors() {
        for (def, code) in [
            ("s.user:2", 21),              // not 4-aligned
            ("d.user:4", 21),              // not 8-aligned
            ("s.user:$100000", 21),        // past the 1 MB user buffer
            ("u.io:$1000000", 21),         // past the io window
            ("u.user:0.31.2", 21),         // bit + width > 32
            ("u.user:0.32", 21),           // bit > 31
            ("f.user:0.3", 21),            // a bit field of a float
            ("*d.16", 21),                 // a width for a float
            ("*s.33", 21),                 // width > 32
            ("*s.0", 21),                  // width 0
            ("u.user:", 20),               // no offset
            ("u.user:$", 20),              // no digits
            ("*x", 20),                    // no such format
            ("u.user:99999999999999", 20), // absurd
        ] {
            assert_eq!(
                parse(def.as_bytes()).map(|_| ()).unwrap_err().code.code(),
                code,
                "{def}"
            );
        }
        assert_eq!(parse(b"Motor[1].ActPos").unwrap(), None);
        assert_eq!(parse(b"u.other:0").unwrap(), None);
    }

    #[test]
    fn integer_formats_saturate_or_wrap_as_the_seed_says() {
        let mut m: MVars<()> = MVars::default();
        m.define(80, Def::Ptr(p("*s.16")));
        m.write(80, 40_000.0);
        assert_eq!(m.read(80), Some(32_767.0));
        m.write(80, -40_000.0);
        assert_eq!(m.read(80), Some(-32_768.0));
        m.define(81, Def::Ptr(p("*i.16")));
        m.write(81, 40_000.0);
        assert_eq!(m.read(81), Some(40_000.0 - 65_536.0));
        m.define(70, Def::Ptr(p("*u")));
        m.write(70, -1.0);
        assert_eq!(m.read(70), Some(4_294_967_295.0));
        m.define(8000, Def::Ptr(p("*f")));
        m.write(8000, 0.1);
        assert_eq!(m.read(8000), Some(f64::from(0.1f32)));
        m.write(9000, 1.0 / 3.0);
        assert_eq!(m.read(9000), Some(1.0 / 3.0));
        // A new definition starts the variable again.
        m.define(70, Def::Ptr(p("*u")));
        assert_eq!(m.read(70), Some(0.0));
    }

    #[test]
    fn address_fields_share_their_word() {
        let mut m: MVars<()> = MVars::default();
        m.define(1, Def::Ptr(p("u.user:$10.8.8")));
        m.define(2, Def::Ptr(p("u.user:$10")));
        m.define(3, Def::Ptr(p("s.user:$10.8.8")));
        m.define(4, Def::Ptr(p("u.user:$10.0.1")));
        m.write(2, f64::from(0x1234_5601u32));
        assert_eq!(m.read(1), Some(f64::from(0x56)));
        assert_eq!(m.read(4), Some(1.0));
        m.write(1, 255.0);
        assert_eq!(m.read(2), Some(f64::from(0x1234_FF01u32)));
        assert_eq!(m.read(3), Some(-1.0));
        m.write(3, 1000.0); // saturates at 127
        assert_eq!(m.read(1), Some(127.0));
        m.define(5, Def::Ptr(p("d.user:$100")));
        m.write(5, -2.5);
        assert_eq!(m.read(5), Some(-2.5));
        assert_eq!(m.mem.double(Bank::User, 0x100), -2.5);
        m.define(6, Def::Ptr(p("f.io:$A00000")));
        m.write(6, 1.5);
        assert_eq!(m.read(6), Some(1.5));
        assert_eq!(m.mem.word(Bank::Io, 0xA0_0000), 1.5f32.to_bits());
    }

    #[test]
    fn the_io_window_holds_a_bounded_number_of_words() {
        let mut mem = Memory::default();
        for k in 0..IO_WORDS as u32 {
            assert!(mem.set_word(Bank::Io, 4 * k, 1));
        }
        assert!(!mem.set_word(Bank::Io, 4 * IO_WORDS as u32, 1));
        assert!(
            mem.set_word(Bank::Io, 0, 7),
            "a word already held can change"
        );
        assert_eq!(mem.word(Bank::Io, 0), 7);
    }
}
