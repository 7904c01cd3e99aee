//! The PMAC2/Turbo command language: lexer, parser, on-line command syntax, canonical listing, and
//! the interpreter that executes lines against the card model and frames the replies.
//!
//! Entry points:
//! - [`parse_line`] / [`parse_line_prefix`]: an immediate (on-line) command line;
//! - [`parse_program_line`]: a line of statements for a buffer of a given kind (e.g. reloading);
//! - [`LineParser`]: item-by-item parsing where the mode can change within the line (a line
//!   typed while a buffer is open mixes stored statements and immediate commands, and `OPEN` /
//!   `CLOSE` in the middle of a line switch mode) — this is what INTERP uses;
//! - [`listing`]: canonical text of statements (`LIST PROG`), M-definitions, axis definitions;
//! - [`interp`]: the interpreter: executes lines against the card model, frames replies.

pub(crate) mod ast;
pub(crate) mod interp;
mod lexer;
pub(crate) mod listing;
mod parse_defs;
mod parse_expr;
mod parse_mdef;
mod parse_online;
mod parse_program;

#[cfg(test)]
mod tests_eval;
#[cfg(test)]
mod tests_online;
#[cfg(test)]
mod tests_program;

pub(crate) use parse_program::allowed;

use crate::domain::ErrCode;
use ast::{BufferKind, Command, Item, Stmt};
use lexer::Cursor;

/// ERR003: data error or unrecognised command (any syntax error).
pub(crate) const ERR_SYNTAX: ErrCode = ErrCode::Data;
/// ERR004: illegal character (byte > 127, or a control byte inside a line).
pub(crate) const ERR_ILLEGAL_CHAR: ErrCode = ErrCode::IllegalChar;
/// ERR005: the statement needs an open buffer.
pub(crate) const ERR_NEEDS_BUFFER: ErrCode = ErrCode::NeedsBuffer;

/// Longest accepted command line (bytes, without the CR). Longer lines → ERR003.
pub(crate) const MAX_LINE_LEN: usize = 1024;

/// A rejected line: byte position, PMAC error code (ERR`code`) and a short explanation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ParseError {
    /// Byte offset in the line where the problem was found.
    pub pos: usize,
    /// The PMAC refusal (ERR003, ERR004, ERR005 ...).
    pub code: ErrCode,
    /// Human-readable reason (for logs; never sent to the host).
    pub msg: &'static str,
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ERR{:03} at {}: {}", self.code, self.pos, self.msg)
    }
}

impl std::error::Error for ParseError {}

/// How the next item of a line is to be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Mode {
    /// No buffer open: everything is an immediate command; program-only statements → ERR005.
    Online,
    /// A buffer of this kind is open: statements legal for it are stored, the rest execute.
    Buffer(BufferKind),
}

/// Where a [`LineParser`] stands between two items: enough to resume it later over the same
/// line ([`LineParser::resume`]), so a long line can be executed in slices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ParserState {
    offset: usize,
    stored_any: bool,
    done: bool,
}

/// Item-by-item parser of one line. Stops after the first error.
#[derive(Debug)]
pub(crate) struct LineParser<'a> {
    cur: Cursor<'a>,
    stored_any: bool,
    done: bool,
}

impl<'a> LineParser<'a> {
    /// Validate the line (length, character set) and start parsing it.
    pub(crate) fn new(line: &'a [u8]) -> Result<LineParser<'a>, ParseError> {
        if line.len() > MAX_LINE_LEN {
            return Err(ParseError {
                pos: MAX_LINE_LEN,
                code: ERR_SYNTAX,
                msg: "line too long",
            });
        }
        if let Some(pos) = line
            .iter()
            .position(|&b| b > 126 || (b < 32 && b != b'\r' && b != b'\n'))
        {
            return Err(ParseError {
                pos,
                code: ERR_ILLEGAL_CHAR,
                msg: "illegal character",
            });
        }
        Ok(LineParser {
            cur: Cursor::new(line),
            stored_any: false,
            done: false,
        })
    }

    /// Where the parser stands (between items).
    pub(crate) fn state(&self) -> ParserState {
        ParserState {
            offset: self.cur.offset(),
            stored_any: self.stored_any,
            done: self.done,
        }
    }

    /// A parser over `line` (validated by [`LineParser::new`] before) continuing at `state`.
    pub(crate) fn resume(line: &'a [u8], state: ParserState) -> LineParser<'a> {
        let mut cur = Cursor::new(line);
        cur.set_offset(state.offset);
        LineParser {
            cur,
            stored_any: state.stored_any,
            done: state.done,
        }
    }

    /// The next command or statement, `None` at the end of the line (or after an error).
    pub(crate) fn next_item(&mut self, mode: Mode) -> Option<Result<Item, ParseError>> {
        if self.done || self.cur.at_end() {
            self.done = true;
            return None;
        }
        let r = match mode {
            Mode::Online => self.online(),
            Mode::Buffer(kind) => self.buffered(kind),
        };
        if r.is_err() {
            self.done = true;
        }
        Some(r)
    }

    fn online(&mut self) -> Result<Item, ParseError> {
        let start = self.cur.offset();
        if let Some(cmd) = parse_online::command(&mut self.cur)? {
            return Ok(Item::Cmd(cmd));
        }
        self.cur.set_offset(start);
        let mut k = self.cur.clone();
        match parse_program::statement(&mut k, BufferKind::Prog, !self.stored_any) {
            Ok(Some(_)) => Err(ParseError {
                pos: start,
                code: ERR_NEEDS_BUFFER,
                msg: "statement needs an open buffer",
            }),
            Ok(None) => Err(self.cur.syntax("unrecognised command")),
            Err(e) => Err(e),
        }
    }

    fn buffered(&mut self, kind: BufferKind) -> Result<Item, ParseError> {
        let start = self.cur.offset();
        let mut k = self.cur.clone();
        let stmt = parse_program::statement(&mut k, kind, !self.stored_any);
        let label = matches!(self.cur.peek(), Some(b'N' | b'O'))
            && self.cur.peek_at(1).is_some_and(|d| d.is_ascii_digit());
        if label {
            // never fall back to the on-line `O{n}` (open-loop output) for a label
            let s = stmt?.ok_or_else(|| self.cur.syntax("label expected"))?;
            if !allowed(&s.kind, kind) {
                return Err(ParseError {
                    pos: start,
                    code: ERR_SYNTAX,
                    msg: "labels are not allowed in this buffer",
                });
            }
            self.cur = k;
            self.stored_any = true;
            return Ok(Item::Stmt(s));
        }
        if let Ok(Some(s)) = &stmt {
            if allowed(&s.kind, kind) {
                self.cur = k;
                self.stored_any = true;
                return Ok(Item::Stmt(s.clone()));
            }
        }
        let mut o = self.cur.clone();
        match parse_online::command(&mut o) {
            Ok(Some(cmd)) => {
                self.cur = o;
                Ok(Item::Cmd(cmd))
            }
            other => Err(match (stmt, other) {
                (Ok(Some(s)), _) => ParseError {
                    pos: s.pos.0 as usize,
                    code: ERR_SYNTAX,
                    msg: "statement not allowed in this buffer",
                },
                (Err(e), _) => e,
                (Ok(None), Err(e)) => e,
                (Ok(None), _) => ParseError {
                    pos: start,
                    code: ERR_SYNTAX,
                    msg: "unrecognised command",
                },
            }),
        }
    }
}

/// Parse a whole immediate command line. Any error rejects the whole line.
pub(crate) fn parse_line(line: &[u8]) -> Result<Vec<Command>, ParseError> {
    match parse_line_prefix(line) {
        (cmds, None) => Ok(cmds),
        (_, Some(e)) => Err(e),
    }
}

/// Parse an immediate command line up to the first error: the commands before it (to be
/// executed left to right, pmac-commands.md §2.8) and the error, if any.
pub(crate) fn parse_line_prefix(line: &[u8]) -> (Vec<Command>, Option<ParseError>) {
    let mut p = match LineParser::new(line) {
        Ok(p) => p,
        Err(e) => return (Vec::new(), Some(e)),
    };
    let mut out = Vec::new();
    while let Some(item) = p.next_item(Mode::Online) {
        match item {
            Ok(Item::Cmd(c)) => out.push(c),
            Ok(Item::Stmt(_)) => {}
            Err(e) => return (out, Some(e)),
        }
    }
    (out, None)
}

/// Parse a line entered into an open buffer of `kind`, requiring that every item is a storable
/// statement (an immediate command → ERR003). Used for stored/reloaded program text.
pub(crate) fn parse_program_line(line: &[u8], kind: BufferKind) -> Result<Vec<Stmt>, ParseError> {
    let mut p = LineParser::new(line)?;
    let mut out = Vec::new();
    while let Some(item) = p.next_item(Mode::Buffer(kind)) {
        match item? {
            Item::Stmt(s) => out.push(s),
            Item::Cmd(c) => {
                return Err(ParseError {
                    pos: c.pos.0 as usize,
                    code: ERR_SYNTAX,
                    msg: "not a program statement",
                })
            }
        }
    }
    Ok(out)
}
