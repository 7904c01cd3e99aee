//! Character-level scanning of one command line (pmac-commands.md §1): case-insensitive keyword
//! matching (longest match), numbers (`-1.5`, `.5`, `$C000`), spaces. PMAC tokenisation depends
//! on context (`P` vs `P5` vs `PC`), so the parsers drive this cursor directly instead of
//! consuming a token stream.

use super::ast::{Number, Pos};
use super::{ParseError, ERR_SYNTAX};
use crate::domain::ErrCode;

/// Maximum nesting depth of parentheses / functions / conditions in one line.
pub(super) const MAX_DEPTH: u32 = 32;

/// A scanning position over one line.
#[derive(Debug, Clone)]
pub(crate) struct Cursor<'a> {
    s: &'a [u8],
    i: usize,
    depth: u32,
}

impl<'a> Cursor<'a> {
    /// Scanner at the start of `s` (already validated by the caller).
    pub(super) fn new(s: &'a [u8]) -> Self {
        Cursor { s, i: 0, depth: 0 }
    }

    /// Current byte offset.
    pub(super) fn offset(&self) -> usize {
        self.i
    }

    /// Reset to an earlier offset (backtracking over a bounded amount).
    pub(super) fn set_offset(&mut self, i: usize) {
        self.i = i.min(self.s.len());
    }

    /// Position node for the current offset.
    pub(super) fn pos(&self) -> Pos {
        Pos(self.i as u32)
    }

    /// The raw remaining bytes.
    pub(super) fn rest(&self) -> &'a [u8] {
        self.s.get(self.i..).unwrap_or(&[])
    }

    /// Upper-cased byte at the current offset.
    pub(super) fn peek(&self) -> Option<u8> {
        self.peek_at(0)
    }

    /// Upper-cased byte `k` ahead.
    pub(super) fn peek_at(&self, k: usize) -> Option<u8> {
        self.s.get(self.i + k).map(|c| c.to_ascii_uppercase())
    }

    /// Advance one byte.
    pub(super) fn bump(&mut self) {
        if self.i < self.s.len() {
            self.i += 1;
        }
    }

    /// Advance `n` bytes.
    pub(super) fn advance(&mut self, n: usize) {
        self.i = (self.i + n).min(self.s.len());
    }

    /// Skip spaces (and stray CR/LF, which hosts may leave in a line).
    pub(super) fn skip_ws(&mut self) {
        while matches!(self.s.get(self.i), Some(b' ' | b'\r' | b'\n')) {
            self.i += 1;
        }
    }

    /// At the end of the line or at a `;` comment (after spaces).
    pub(super) fn at_end(&mut self) -> bool {
        self.skip_ws();
        matches!(self.peek(), None | Some(b';'))
    }

    /// Consume byte `c` (case-insensitive) if it is next (no spaces skipped).
    pub(super) fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c.to_ascii_uppercase()) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    /// Skip spaces, then consume `c` if next.
    pub(super) fn eat_ws(&mut self, c: u8) -> bool {
        self.skip_ws();
        self.eat(c)
    }

    /// Does keyword `kw` (upper case) start at the current offset?
    pub(super) fn looking_at(&self, kw: &str) -> bool {
        let r = self.rest();
        r.len() >= kw.len()
            && r.iter()
                .zip(kw.bytes())
                .all(|(a, b)| a.to_ascii_uppercase() == b)
    }

    /// `DIS PLC` / `DISPLC` is DISABLE PLC, not DISPLAY: consume the `DIS` when `PLC` (after
    /// optional spaces) follows it (not when the word is `DISABLE`).
    pub(super) fn eat_dis_before_plc(&mut self) -> bool {
        if !self.looking_at("DIS") || self.looking_at("DISABLE") {
            return false;
        }
        let mut k = self.clone();
        k.advance(3);
        k.skip_ws();
        if k.looking_at("PLC") {
            self.advance(3);
            true
        } else {
            false
        }
    }

    /// Consume keyword `kw` (upper case, no spaces inside) if it starts here.
    pub(super) fn eat_kw(&mut self, kw: &str) -> bool {
        if self.looking_at(kw) {
            self.i += kw.len();
            true
        } else {
            false
        }
    }

    /// Longest keyword of `table` starting here; consumes it and returns its tag.
    pub(super) fn eat_longest<T: Copy>(&mut self, table: &[(&str, T)]) -> Option<T> {
        let mut best: Option<(usize, T)> = None;
        for (kw, tag) in table {
            let longer = match best {
                None => true,
                Some((l, _)) => kw.len() > l,
            };
            if longer && self.looking_at(kw) {
                best = Some((kw.len(), *tag));
            }
        }
        let (len, tag) = best?;
        self.i += len;
        Some(tag)
    }

    /// Error at the current offset.
    pub(super) fn err(&self, code: ErrCode, msg: &'static str) -> ParseError {
        ParseError {
            pos: self.i,
            code,
            msg,
        }
    }

    /// Syntax error (ERR003) at the current offset.
    pub(super) fn syntax(&self, msg: &'static str) -> ParseError {
        self.err(ERR_SYNTAX, msg)
    }

    /// Enter one nesting level (parenthesis, function, condition group).
    pub(super) fn enter(&mut self) -> Result<(), ParseError> {
        if self.depth >= MAX_DEPTH {
            return Err(self.syntax("expression nested too deeply"));
        }
        self.depth += 1;
        Ok(())
    }

    /// Leave one nesting level.
    pub(super) fn leave(&mut self) {
        self.depth = self.depth.saturating_sub(1);
    }

    /// Is a decimal digit next?
    pub(super) fn at_digit(&self) -> bool {
        self.peek().is_some_and(|c| c.is_ascii_digit())
    }

    /// Does an unsigned literal (`5`, `.5`, `$1F`) start here?
    pub(super) fn at_unsigned_number(&self) -> bool {
        match self.peek() {
            Some(c) if c.is_ascii_digit() => true,
            Some(b'.') => self.peek_at(1).is_some_and(|c| c.is_ascii_digit()),
            Some(b'$') => self.peek_at(1).is_some_and(|c| c.is_ascii_hexdigit()),
            _ => false,
        }
    }

    /// Does a (possibly negative) literal start here (spaces allowed after `-`)?
    pub(super) fn at_number(&self) -> bool {
        if self.peek() == Some(b'-') {
            let mut k = self.clone();
            k.bump();
            k.skip_ws();
            k.at_unsigned_number()
        } else {
            self.at_unsigned_number()
        }
    }

    /// Unsigned decimal integer (at most 9 digits are significant; more → ERR003).
    pub(super) fn uint(&mut self) -> Result<Option<u32>, ParseError> {
        let start = self.i;
        let mut v: u64 = 0;
        while let Some(c) = self.s.get(self.i).filter(|c| c.is_ascii_digit()) {
            v = v * 10 + u64::from(c - b'0');
            self.i += 1;
            if v > u64::from(u32::MAX) {
                return Err(ParseError {
                    pos: start,
                    code: ERR_SYNTAX,
                    msg: "number too large",
                });
            }
        }
        if self.i == start {
            Ok(None)
        } else {
            Ok(Some(v as u32))
        }
    }

    /// Unsigned integer that must be present (decimal or `$`hex).
    pub(super) fn req_uint(&mut self, what: &'static str) -> Result<u32, ParseError> {
        self.skip_ws();
        if self.peek() == Some(b'$') {
            let n = self.unsigned_number()?.ok_or_else(|| self.syntax(what))?;
            return to_u32(n.value).ok_or_else(|| self.syntax(what));
        }
        self.uint()?.ok_or_else(|| self.syntax(what))
    }

    /// Unsigned literal: `12`, `1.5`, `.5`, `12.` or `$hex`. `None` when none starts here.
    pub(super) fn unsigned_number(&mut self) -> Result<Option<Number>, ParseError> {
        let start = self.i;
        if self.peek() == Some(b'$') {
            if !self.peek_at(1).is_some_and(|c| c.is_ascii_hexdigit()) {
                return Ok(None);
            }
            self.i += 1;
            let mut v: u64 = 0;
            while let Some(d) = self.peek().and_then(|c| (c as char).to_digit(16)) {
                v = v * 16 + u64::from(d);
                self.i += 1;
                if v >= 1 << 48 {
                    return Err(ParseError {
                        pos: start,
                        code: ERR_SYNTAX,
                        msg: "hex constant too large",
                    });
                }
            }
            return Ok(Some(Number {
                value: v as f64,
                hex: true,
            }));
        }
        if !self.at_unsigned_number() {
            return Ok(None);
        }
        let mut end = self.i;
        let mut digits = 0usize;
        while self.s.get(end).is_some_and(|c| c.is_ascii_digit()) {
            end += 1;
            digits += 1;
        }
        if self.s.get(end) == Some(&b'.') {
            end += 1;
            while self.s.get(end).is_some_and(|c| c.is_ascii_digit()) {
                end += 1;
                digits += 1;
            }
        }
        if digits > 40 {
            return Err(ParseError {
                pos: start,
                code: ERR_SYNTAX,
                msg: "number too long",
            });
        }
        let text =
            std::str::from_utf8(&self.s[start..end]).map_err(|_| self.syntax("bad number"))?;
        let value: f64 = text.parse().map_err(|_| self.syntax("bad number"))?;
        self.i = end;
        Ok(Some(Number { value, hex: false }))
    }

    /// Literal with optional leading `-` (unary plus is rejected by the grammar, §1.5).
    pub(super) fn number(&mut self) -> Result<Option<Number>, ParseError> {
        let save = self.i;
        let neg = self.eat(b'-');
        if neg {
            self.skip_ws();
        }
        match self.unsigned_number()? {
            Some(n) => Ok(Some(if neg {
                Number {
                    value: -n.value,
                    hex: n.hex,
                }
            } else {
                n
            })),
            None => {
                self.i = save;
                Ok(None)
            }
        }
    }

    /// A literal that must be present.
    pub(super) fn req_number(&mut self, what: &'static str) -> Result<Number, ParseError> {
        self.skip_ws();
        self.number()?.ok_or_else(|| self.syntax(what))
    }
}

/// Exact conversion of a non-negative integral float to `u32`.
pub(crate) fn to_u32(v: f64) -> Option<u32> {
    if v >= 0.0 && v <= f64::from(u32::MAX) && v.fract() == 0.0 {
        Some(v as u32)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_decimal_hex_negative() {
        let mut c = Cursor::new(b"-1.5 $C000 .25 12. 7");
        assert_eq!(
            c.number().unwrap(),
            Some(Number {
                value: -1.5,
                hex: false
            })
        );
        c.skip_ws();
        assert_eq!(
            c.number().unwrap(),
            Some(Number {
                value: 49152.0,
                hex: true
            })
        );
        c.skip_ws();
        assert_eq!(
            c.number().unwrap(),
            Some(Number {
                value: 0.25,
                hex: false
            })
        );
        c.skip_ws();
        assert_eq!(
            c.number().unwrap(),
            Some(Number {
                value: 12.0,
                hex: false
            })
        );
        c.skip_ws();
        assert_eq!(c.uint().unwrap(), Some(7));
        assert!(c.at_end());
    }

    #[test]
    fn longest_keyword_wins_case_insensitive() {
        let table = [("DEL", 1), ("DELETE", 2), ("DELAY", 3)];
        let mut c = Cursor::new(b"deleteX");
        assert_eq!(c.eat_longest(&table), Some(2));
        assert_eq!(c.offset(), 6);
        let mut c = Cursor::new(b"DEL GAT");
        assert_eq!(c.eat_longest(&table), Some(1));
        let mut c = Cursor::new(b"Dly");
        assert_eq!(c.eat_longest(&table), None);
    }

    #[test]
    fn overlong_numbers_are_errors() {
        let mut c = Cursor::new(b"99999999999");
        assert_eq!(c.uint().unwrap_err().code, ERR_SYNTAX);
        let mut c = Cursor::new(b"$1000000000000");
        assert_eq!(c.unsigned_number().unwrap_err().pos, 0);
        let mut c = Cursor::new(b"-x");
        assert_eq!(c.number().unwrap(), None);
        assert_eq!(c.offset(), 0);
    }
}
