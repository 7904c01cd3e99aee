//! Rotary motion-program buffers of a Power card (seed L34322-34360, L37756-37780):
//! `define rotary {bytes}[,[{lookahead}]][,{stack}]` and `delete rotary` for the addressed
//! C.S., `open rotary` (also `open rot`, `open prog 0`) to enter lines into it, `close`.
//! Lines entered go into the C.S.'s rotary queue, which its program 0 (`b0 r`) runs as they
//! arrive (the model's rotary buffers, shared with the PMAC dialect's engine).
//!
//! [DECISION] The buffer's size in the model's words is its bytes / 8 (the seed's single-axis
//! move takes 9 bytes, one or two model words); a line that does not fit is refused (#21)
//! and closes the buffer, the lines already queued stay. A rotary line is executed alone, so
//! it cannot open a block another line closes (`if (…) {` alone: #20). The stack offset
//! argument is accepted when it is 256 (the default): the program engine uses one stack
//! offset for every program.

use super::parse::SyntaxError;
use super::{exec, listing, program, progvars, Power, Thread};
use crate::domain::PowerErr;
use crate::lang::Card;
use crate::model::{ProgLine, Rotary};

/// The rotary buffer a thread has open.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RotOpen {
    /// The connection that opened it.
    pub conn: u64,
    /// Its C.S. (model numbering).
    pub cs: u8,
}

fn bad(code: PowerErr) -> SyntaxError {
    SyntaxError { at: 0, code }
}

/// Smallest rotary buffer (bytes).
const MIN_BYTES: u64 = 2048;

impl Power {
    /// `define rotary …`, `delete rotary`, `open rotary`, and lines entered into an open
    /// rotary buffer; `None` when `line` is none of these.
    pub(crate) fn rotary_command(
        &mut self,
        card: &mut Card,
        conn: u64,
        th: &mut Thread,
        line: &[u8],
    ) -> Option<Vec<u8>> {
        let text = String::from_utf8_lossy(line).to_ascii_lowercase();
        let all: Vec<&str> = text.split_whitespace().collect();
        let mine = self.rot.is_some_and(|r| r.conn == conn);
        // `&n define rotary …`: the C.S. may be addressed on the line itself.
        let (cs, words) = match all.split_first() {
            Some((w, rest)) if !mine && w.len() > 1 && w.starts_with('&') => {
                match w[1..].parse::<u16>() {
                    Ok(n) if n < card.model.state.limits().coords => (Some(n), rest),
                    _ => (None, all.as_slice()),
                }
            }
            _ => (None, all.as_slice()),
        };
        let rotary = matches!(
            words,
            ["define", "rotary", ..]
                | ["delete", "rotary"]
                | ["open", "rotary" | "rot"]
                | ["open", "prog", "0"]
        );
        if let (Some(n), true) = (cs, rotary) {
            th.coord = n;
        }
        let r = match words {
            ["define", "rotary", args @ ..] => define(card, th, &args.concat()),
            ["delete", "rotary"] => delete(card, th, self.rot),
            ["open", "rotary" | "rot"] | ["open", "prog", "0"] => self.open_rotary(card, conn, th),
            // Another buffer cannot be opened while this one is (the rotary stays open).
            ["open", ..] if mine => Err(bad(PowerErr::IllegalParameter)),
            ["close"] | ["close", "all", "buffers"] if mine => {
                self.rot = None;
                Ok(())
            }
            _ if mine => self.enter(card, line),
            _ => return None,
        };
        th.lines += 1;
        Some(exec::frame(th, line, r.err()))
    }

    fn open_rotary(&mut self, card: &mut Card, conn: u64, th: &Thread) -> Result<(), SyntaxError> {
        if self.rot.is_some() || self.open.is_some() {
            return Err(bad(PowerErr::IllegalParameter));
        }
        let cs = u8::try_from(th.coord + 1).map_err(|_| bad(PowerErr::IllegalParameter))?;
        if !card.model.bufs.rotary.contains_key(&cs) {
            return Err(bad(PowerErr::IllegalParameter));
        }
        self.rot = Some(RotOpen { conn, cs });
        Ok(())
    }

    /// One line into the open rotary buffer.
    fn enter(&mut self, card: &mut Card, line: &[u8]) -> Result<(), SyntaxError> {
        let Some(r) = self.rot else {
            return Ok(());
        };
        if listing::text_of(line).is_none() {
            return Ok(());
        }
        let parsed = progvars::with(card, |_, pv| {
            let mut blocks = Vec::new();
            let s = program::parse_program_line(line, &mut blocks, &mut pv.elems)?;
            if blocks.is_empty() {
                Ok(s)
            } else {
                Err(bad(PowerErr::IllegalCmd))
            }
        });
        let stored = parsed.and_then(|stmts| {
            program::stored_lines(stmts).into_iter().try_for_each(|p| {
                card.model
                    .bufs
                    .append_rotary(r.cs, ProgLine::new(p))
                    .map_err(|_| bad(PowerErr::IllegalParameter))
            })
        });
        if stored.is_err() {
            // Seed §2.9: a line that cannot be entered closes the buffer.
            self.rot = None;
        }
        stored
    }
}

/// `define rotary {bytes}[,[{lookahead}]][,{stack}]` (`args` without white space).
fn define(card: &mut Card, th: &Thread, args: &str) -> Result<(), SyntaxError> {
    let parts: Vec<&str> = args.split(',').collect();
    if parts.is_empty() || parts.len() > 3 {
        return Err(bad(PowerErr::IllegalCmd));
    }
    let num = |s: &str, dflt: u64| -> Result<u64, SyntaxError> {
        if s.is_empty() {
            return Ok(dflt);
        }
        s.parse::<u64>().map_err(|_| bad(PowerErr::IllegalCmd))
    };
    let bytes = num(parts[0], 0)?;
    let look = num(parts.get(1).copied().unwrap_or(""), 1024)?;
    let stack = num(parts.get(2).copied().unwrap_or(""), 256)?;
    if !(MIN_BYTES..=u64::from(u32::MAX)).contains(&bytes)
        || look < 1024
        || look > bytes / 2
        || stack != 256
    {
        return Err(bad(PowerErr::IllegalParameter));
    }
    let cs = u8::try_from(th.coord + 1).map_err(|_| bad(PowerErr::IllegalParameter))?;
    if card.model.cs_running(u16::from(cs)) {
        return Err(bad(PowerErr::ProgramRunning));
    }
    card.model.bufs.rotary.insert(
        cs,
        Rotary {
            size: (bytes / 8) as u32,
            lines: Vec::new(),
        },
    );
    Ok(())
}

/// `delete rotary`: the addressed C.S.'s buffer is gone (not while it runs or is open).
fn delete(card: &mut Card, th: &Thread, open: Option<RotOpen>) -> Result<(), SyntaxError> {
    let cs = u8::try_from(th.coord + 1).map_err(|_| bad(PowerErr::IllegalParameter))?;
    if card.model.cs_running(u16::from(cs)) {
        return Err(bad(PowerErr::ProgramRunning));
    }
    if open.is_some_and(|r| r.cs == cs) {
        return Err(bad(PowerErr::IllegalParameter));
    }
    card.model.bufs.rotary.remove(&cs);
    Ok(())
}
