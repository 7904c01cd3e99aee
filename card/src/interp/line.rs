//! The command-line loop: parse item by item (the parse mode follows buffers opened/closed on
//! the same line), store program statements, execute commands left to right, frame the reply.
//! On the first error the rest of the line is dropped; data already produced is sent, then
//! the error report, no acknowledge (§2.8 [DECISION]).

use super::buffers::BufId;
use super::exec::{Flow, Out};
use super::reply::{Framing, Outcome, Reply};
use super::{Card, Session};
use crate::lang::ast::{BufferKind, CmdKind, Item, Stmt};
use crate::lang::{LineParser, Mode};

impl Card {
    /// Current I3/I4/I6.
    pub(crate) fn framing(&self) -> Framing {
        let i = |n: u32, d: f64| self.state.peek_ivar(n).unwrap_or(d) as i64;
        Framing::from_ivars(i(3, 1.0), i(4, 0.0), i(6, 3.0))
    }

    /// Keep a session's addressing inside the profile (sessions are built by host code).
    pub(crate) fn clamp_session(&self, s: &mut Session) {
        let lim = self.state.limits();
        s.motor = s.motor.clamp(1, lim.motors);
        s.coord = s.coord.clamp(1, lim.coords);
    }

    fn parse_mode(&self, s: &Session) -> Mode {
        match self.open_for(s) {
            Some(o) if !o.binary => Mode::Buffer(match o.id {
                BufId::Prog(_) => BufferKind::Prog,
                BufId::Plc(n) => BufferKind::Plc(n),
                BufId::Rot => BufferKind::Rotary,
            }),
            _ => Mode::Online,
        }
    }

    /// Execute one line; `remember` = it becomes the "last line" of CTRL-I / CTRL-Y.
    pub(crate) fn run_line(&mut self, s: &mut Session, line: &[u8], remember: bool) -> Vec<u8> {
        let mut reply = Reply::new();
        // Control characters act on arrival and never belong to the line (§1.3); LF is ignored.
        let mut clean = Vec::with_capacity(line.len());
        for &b in line {
            match b {
                b'\r' | b'\n' => {}
                0x00..=0x1F => {
                    let r = self.control(s, b);
                    reply.raw(&r);
                }
                _ => clean.push(b),
            }
        }
        if remember && !clean.is_empty() && clean.len() <= super::MAX_LINE {
            self.last_line.clone_from(&clean);
        }
        let (outcome, lines) = self.execute_line(s, &clean);
        let talk = self.chain_talking(s);
        if talk {
            let f = self.framing();
            for (fr, l) in &lines {
                reply.data_line(*fr, l.as_bytes());
            }
            reply.finish(f, outcome, &clean);
        }
        reply.into_bytes()
    }

    /// Run the items of `line`; returns the outcome and the data lines with their framing.
    pub(crate) fn execute_line(
        &mut self,
        s: &mut Session,
        line: &[u8],
    ) -> (Outcome, Vec<(Framing, String)>) {
        self.clamp_session(s);
        let mut lines = Vec::new();
        let mut parser = match LineParser::new(line) {
            Ok(p) => p,
            Err(e) => return (Outcome::Err(u16::from(e.code)), lines),
        };
        let mut pending: Vec<Stmt> = Vec::new();
        loop {
            let mode = self.parse_mode(s);
            let item = match parser.next_item(mode) {
                None => break,
                Some(Err(e)) => return (Outcome::Err(u16::from(e.code)), lines),
                Some(Ok(item)) => item,
            };
            let cmd = match item {
                Item::Stmt(st) => {
                    if self.chain_listening(s) {
                        pending.push(st);
                    }
                    continue;
                }
                Item::Cmd(c) => c.kind,
            };
            let chain_cmd = matches!(cmd, CmdKind::AddrCard(_) | CmdKind::AddrAllCards);
            if !self.chain_listening(s) && !chain_cmd {
                continue;
            }
            if !pending.is_empty() {
                if let Err(code) = self.store_line(s, std::mem::take(&mut pending)) {
                    return (Outcome::Err(code), lines);
                }
            }
            let mut out = Out::default();
            let r = self.exec_cmd(s, &cmd, &mut out);
            // Under `@@` card 0 rejects data-returning commands (§8.2 [DECISION]).
            let r = if r.is_ok()
                && s.chain_all
                && self.software_addressing()
                && !out.lines.is_empty()
                && cmd != CmdKind::ReportCard
            {
                out.lines.clear();
                Err(3)
            } else {
                r
            };
            let f = self.framing();
            lines.extend(out.lines.into_iter().map(|l| (f, l)));
            if let Err(code) = r {
                return (Outcome::Err(code), lines);
            }
            if out.flow == Flow::Reset {
                return (Outcome::Silent, lines);
            }
        }
        if !pending.is_empty() {
            if let Err(code) = self.store_line(s, pending) {
                return (Outcome::Err(code), lines);
            }
        }
        (Outcome::Ok, lines)
    }
}
