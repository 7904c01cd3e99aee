//! The card's end of the serial daisy chain (pmac-commands §8.3). The orchestrator broadcasts
//! every byte a chain host sends to every card of the cluster through the queryable
//! `mcc/<cluster>/card/<n>/chain`; each card runs its own receiver per chain connection, as a
//! card on a real multi-drop cable does:
//!
//! - `@n` (n = hex digit) and `@@` are recognised as they arrive, whatever the addressing,
//!   and never enter the receive buffer; a lone `@` (followed by anything else) is the
//!   "report card number" command and goes into the buffer of the card(s) receiving.
//! - Line characters are collected only while this card is addressed (or under `@@`).
//! - `<CR>` makes the card execute whatever it collected (every card, at the same byte); only
//!   the addressed card (card 0 under `@@`) sends the reply.
//! - Control characters: CTRL-A/D/K/O/Q/R/S/X act on every card; CTRL-B/C/F/G/P/V/L/U/Z/N/H/I/Y
//!   only on the card(s) receiving (under `@@` the data-reporting ones are not accepted: they
//!   have no error channel, so nothing answers); CTRL-T is not allowed on a chain (ignored).
//! - Without software addressing (I1 bit 1 clear) the card assumes it is alone and takes and
//!   answers everything (`@…` then reaches the interpreter, which answers ERR003).
//!
//! Synchronized starts from the chain: before it sends a `<CR>` that may start programs, the
//! orchestrator asks every card (`?`) whether the line it collected for this connection starts
//! a program (`R`/`S`); when more than one card says so it takes those lines (`T`: the card
//! hands its buffer over and stays silent at the `<CR>`) and runs them through the cards'
//! arm/commit synchronized start (sync_start.rs), so they execute in the servo tick of one
//! ring cycle; a line that starts a program on one card only runs at the `<CR>` as usual.
//!
//! Wire format: `mcc_contracts::control::chain` (op byte, connection id, data; replies as
//! position-tagged segments the orchestrator merges in input order). `T` is answered with the
//! flags byte then the line to run (addressing prefix `#m&c` + the collected line), or nothing
//! when the collected line does not start a program.
//!
//! Refusals: the card that answers a line it refused (the talking card only) lists the
//! refusal at the line's `<CR>` position in the reply's attachment
//! (`mcc_contracts::control::chain::encode_refusals`), whatever I6 made of it in the bytes;
//! the other cards that ran the line stay silent about it, as they do about its reply.

use std::collections::HashMap;

use mcc_contracts::control::chain::{
    encode_refusals, encode_reply, Request, FLAG_STARTS, FLAG_TALKS, OP_CLOSE, OP_QUERY_START,
    OP_TAKE_START,
};
use mcc_contracts::control::CardRefusal;

use crate::domain::Refusal;
use crate::lang::{
    ctrl_n, overlong_probe, Budget, Card, Dialect, LineRun, Session, Step, MAX_LINE,
};

/// Chain connections remembered per card; the least recently used is forgotten beyond this.
pub(crate) const MAX_CONNECTIONS: usize = 64;

/// One chain connection as seen by this card.
#[derive(Debug)]
struct Conn {
    session: Session,
    buf: Vec<u8>,
    overflow: bool,
    at_pending: bool,
    last_used: u64,
    /// The collected line was taken for a synchronized start: silent at the next `<CR>`.
    synced: bool,
}

impl Conn {
    fn new(card: &mut Card, id: u64) -> Self {
        // Power-up/reset state of a chain: card 0 is addressed (§8.2).
        let session = Session {
            chain_addressed: card.card_number() == 0,
            ..Session::with_id(id)
        };
        Conn {
            session,
            buf: Vec::new(),
            overflow: false,
            at_pending: false,
            last_used: 0,
            synced: false,
        }
    }
}

/// A chain line not done yet: it waits for the ring (a MACRO auxiliary command, `@n
/// MS0,MI910`) or for its next slice of work (a long reply, `@n P0..8191`); the rest of its
/// request is fed once it is done.
#[derive(Debug)]
struct Parked {
    run: Box<LineRun>,
    session: Session,
    talking: bool,
    /// Position of the line's `<CR>` in the request.
    at: u32,
    out: Answer,
    rest: Vec<u8>,
    base: u32,
}

/// What executing a `<CR>` gave.
enum Exec {
    /// The reply this card sends (empty when silent) and the refusal it reports.
    Reply(Vec<u8>, Option<Refusal>),
    Wait(Box<LineRun>, Session, bool),
}

impl Exec {
    /// A reply without a refusal.
    fn said(r: Vec<u8>) -> Exec {
        Exec::Reply(r, None)
    }
}

/// This card's answer to a data request: reply segments `(position, bytes)` and the
/// refusals `(position, refusal)` of the lines it answered.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub(crate) struct Answer {
    /// Reply bytes by input position.
    pub segments: Vec<(u32, Vec<u8>)>,
    /// Refusals by the position of the `<CR>` that ran the line.
    pub refusals: Vec<(u32, Refusal)>,
}

/// An encoded chain reply: the payload and the refusal attachment (empty: none).
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Encoded {
    /// Reply payload.
    pub payload: Vec<u8>,
    /// Refusals attachment (`encode_refusals`).
    pub refusals: Vec<u8>,
}

impl From<Vec<u8>> for Encoded {
    fn from(payload: Vec<u8>) -> Self {
        Encoded {
            payload,
            refusals: Vec::new(),
        }
    }
}

impl Answer {
    fn encode(&self) -> Encoded {
        let refusals: Vec<(u32, CardRefusal)> = self
            .refusals
            .iter()
            .map(|&(p, r)| (p, CardRefusal::from(r)))
            .collect();
        Encoded {
            payload: encode_reply(&self.segments),
            refusals: encode_refusals(&refusals),
        }
    }

    fn push(&mut self, at: u32, bytes: Vec<u8>, refusal: Option<Refusal>) {
        if !bytes.is_empty() {
            self.segments.push((at, bytes));
        }
        if let Some(r) = refusal {
            self.refusals.push((at, r));
        }
    }
}

/// This card's receivers, one per chain connection (pure: bytes in, reply segments out).
#[derive(Debug, Default)]
pub(crate) struct ChainPort {
    conns: HashMap<u64, Conn>,
    parked: HashMap<u64, Parked>,
    clock: u64,
}

fn hex_digit(b: u8) -> Option<u8> {
    (b as char).to_digit(16).map(|d| d as u8)
}

impl ChainPort {
    /// No connections yet.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Number of connections remembered.
    #[cfg(test)]
    pub(crate) fn connections(&self) -> usize {
        self.conns.len()
    }

    /// Connection `id` is gone: close the buffer it left open, forget its state (a line
    /// waiting for the ring is dropped; its access expires unclaimed).
    pub(crate) fn close(&mut self, card: &mut Card, dialect: &mut Dialect, id: u64) {
        self.parked.remove(&id);
        if let Some(c) = self.conns.remove(&id) {
            dialect.end_chain(card, &c.session);
        }
    }

    /// A line of connection `id` is not done (it waits for the ring or for its next slice):
    /// its request is answered by
    /// [`ChainPort::resume`], and later data of the connection must wait for that.
    pub(crate) fn is_parked(&self, id: u64) -> bool {
        self.parked.contains_key(&id)
    }

    /// Connections with a parked line.
    pub(crate) fn parked(&self) -> Vec<u64> {
        self.parked.keys().copied().collect()
    }

    /// Run one request against the card; the encoded reply (`None`: a line waits for the
    /// ring, the reply comes from [`ChainPort::resume`]).
    pub(crate) fn handle(
        &mut self,
        card: &mut Card,
        dialect: &mut Dialect,
        req: &Request<'_>,
        budget: &mut Budget,
    ) -> Option<Encoded> {
        Some(match req.op {
            OP_CLOSE => {
                self.close(card, dialect, req.conn);
                Encoded::default()
            }
            OP_QUERY_START => vec![self.start_flags(card, &*dialect, req.conn)].into(),
            OP_TAKE_START => self.take_start(card, dialect, req.conn).into(),
            _ => self
                .feed(card, dialect, req.conn, req.data, budget)?
                .encode(),
        })
    }

    /// Go on with the parked line of connection `id`: the encoded reply of its request once
    /// the line (and the rest of the request) is done.
    pub(crate) fn resume(
        &mut self,
        card: &mut Card,
        dialect: &mut Dialect,
        id: u64,
        budget: &mut Budget,
    ) -> Option<Encoded> {
        let mut p = self.parked.remove(&id)?;
        let Step::Done(r) = card.step_detached(&mut p.run, &mut p.session, budget) else {
            self.parked.insert(id, p);
            return None;
        };
        let Some(conn) = self.conns.get_mut(&id) else {
            return Some(Encoded::default());
        };
        restore(conn, &p.session);
        if p.talking {
            let refusal = p.run.refusal().map(Refusal::Pmac);
            p.out.push(p.at, r, refusal);
        }
        let rest = std::mem::take(&mut p.rest);
        let out = self.feed_from(card, dialect, id, &rest, (p.base, p.out), budget)?;
        Some(out.encode())
    }

    /// [`FLAG_STARTS`]/[`FLAG_TALKS`] of the line connection `id` has collected (0: none).
    pub(crate) fn start_flags(&self, card: &mut Card, dialect: &Dialect, id: u64) -> u8 {
        match self.conns.get(&id) {
            Some(c) if starts_program(card, dialect, c) => {
                FLAG_STARTS | (u8::from(card.chain_talking(&c.session)) * FLAG_TALKS)
            }
            _ => 0,
        }
    }

    /// Take the collected line of connection `id` for a synchronized start: the flags byte,
    /// then the line prefixed with the connection's addressing (`#m&c`); empty (and nothing
    /// taken) when the line does not start a program. The card then stays silent at the
    /// `<CR>` that would have executed it, and the connection's motor/C.S. follow the line's
    /// `#n`/`&n` as if it had run here.
    pub(crate) fn take_start(
        &mut self,
        card: &mut Card,
        dialect: &mut Dialect,
        id: u64,
    ) -> Vec<u8> {
        let flags = self.start_flags(card, &*dialect, id);
        let Some(c) = self.conns.get_mut(&id) else {
            return Vec::new();
        };
        if flags & FLAG_STARTS == 0 {
            return Vec::new();
        }
        let line = std::mem::take(&mut c.buf);
        c.synced = true;
        let mut out = vec![flags];
        out.extend_from_slice(&dialect.take_line(card, &mut c.session, &line));
        out
    }

    /// Feed chain input of connection `id`; returns the reply segments and refusals (`None`:
    /// a line waits for the ring, see [`ChainPort::resume`]).
    pub(crate) fn feed(
        &mut self,
        card: &mut Card,
        dialect: &mut Dialect,
        id: u64,
        data: &[u8],
        budget: &mut Budget,
    ) -> Option<Answer> {
        self.clock += 1;
        if !self.conns.contains_key(&id) && self.conns.len() >= MAX_CONNECTIONS {
            let oldest = self.conns.iter().min_by_key(|(_, c)| c.last_used);
            if let Some(&old) = oldest.map(|(k, _)| k) {
                self.close(card, &mut *dialect, old);
            }
        }
        self.feed_from(card, dialect, id, data, (0, Answer::default()), budget)
    }

    fn feed_from(
        &mut self,
        card: &mut Card,
        dialect: &mut Dialect,
        id: u64,
        data: &[u8],
        (base, mut out): (u32, Answer),
        budget: &mut Budget,
    ) -> Option<Answer> {
        let clock = self.clock;
        let conn = self.conns.entry(id).or_insert_with(|| Conn::new(card, id));
        conn.last_used = clock;
        for (i, &b) in data.iter().enumerate() {
            let at = base + i as u32;
            match byte(card, &mut *dialect, conn, b, budget) {
                Exec::Reply(r, refusal) => out.push(at, r, refusal),
                Exec::Wait(run, session, talking) => {
                    self.parked.insert(
                        id,
                        Parked {
                            run,
                            session,
                            talking,
                            at,
                            out,
                            rest: data[i + 1..].to_vec(),
                            base: at + 1,
                        },
                    );
                    return None;
                }
            }
        }
        Some(out)
    }
}

/// Prefix `#m&c` may add to a taken line (the synchronized start refuses longer lines).
const PREFIX_ROOM: usize = 16;

/// The collected line would start a program (`R`/`S`) if executed now.
fn starts_program(card: &Card, dialect: &Dialect, c: &Conn) -> bool {
    if c.overflow || c.buf.is_empty() || c.buf.len() + PREFIX_ROOM > MAX_LINE {
        return false;
    }
    dialect.starts_program(card, &c.session, &c.buf)
}

/// Process one received byte; the reply this card sends because of it.
fn byte(card: &mut Card, dialect: &mut Dialect, c: &mut Conn, b: u8, budget: &mut Budget) -> Exec {
    if b == b'\r' {
        let sa = card.software_addressing();
        if std::mem::take(&mut c.at_pending) && sa {
            // `@` then <CR>: the report-card command.
            collect(card, c, b'@');
        }
        return match execute_whole(card, dialect, c) {
            Some(r) => r,
            None => execute(card, c, budget),
        };
    }
    if b == 0x09 && dialect.has_control_commands() {
        return repeat_last(card, c, budget);
    }
    if !dialect.has_control_commands() && b < 0x20 {
        return Exec::said(line_edit_control(card, c, b));
    }
    byte_other(card, c, b)
}

/// [DECISION] A control character on a Power card: a `gpascii` thread has no PMAC
/// control-character commands (no reports, no CTRL-A/K/Q/R/S motion commands), so none of
/// them acts on the card and none is answered — as on its raw `gpascii` port, which ignores
/// them. Only line editing, as the controller's terminal does it: `<BS>` erases the last
/// character collected, `<CTRL-U>` and `<CTRL-X>` the whole line (for this card when it
/// listens). A broadcast CTRL-A/K on a mixed chain therefore stops the PMAC cards only.
fn line_edit_control(card: &mut Card, c: &mut Conn, b: u8) -> Vec<u8> {
    if std::mem::take(&mut c.at_pending) && card.software_addressing() {
        // A lone `@` before it: the report-card command, collected like any line character.
        collect(card, c, b'@');
    }
    if card.chain_listening(&c.session) {
        match b {
            0x08 if !c.overflow => {
                c.buf.pop();
            }
            0x15 | 0x18 => {
                c.buf.clear();
                c.overflow = false;
            }
            _ => {}
        }
    }
    Vec::new()
}

/// A received byte other than `<CR>`.
fn byte_other(card: &mut Card, c: &mut Conn, b: u8) -> Exec {
    let sa = card.software_addressing();
    if std::mem::take(&mut c.at_pending) && sa {
        if let Some(n) = hex_digit(b) {
            let _ = card.chain_select(&mut c.session, Some(n));
            return Exec::said(Vec::new());
        }
        if b == b'@' {
            let _ = card.chain_select(&mut c.session, None);
            return Exec::said(Vec::new());
        }
        // A lone `@`: the report-card command, collected like any line character.
        collect(card, c, b'@');
    }
    if b == b'@' && sa {
        c.at_pending = true;
        return Exec::said(Vec::new());
    }
    let listening = card.chain_listening(&c.session);
    let talking = card.chain_talking(&c.session);
    let all = sa && c.session.chain_all;
    let said = |r: Vec<u8>| if talking { r } else { Vec::new() };
    Exec::said(match b {
        // CTRL-A/D/K/O/Q/R/S: every card, whatever the addressing.
        0x01 | 0x04 | 0x0B | 0x0F | 0x11 | 0x12 | 0x13 => {
            let r = card.control_char(&mut c.session, b);
            said(r)
        }
        0x18 => {
            c.buf.clear();
            c.overflow = false;
            let r = card.control_char(&mut c.session, b);
            said(r)
        }
        // Reports: the addressed card only; not accepted under `@@`.
        0x02 | 0x03 | 0x06 | 0x07 | 0x10 | 0x16 if listening && !all => {
            let r = card.control_char(&mut c.session, b);
            said(r)
        }
        0x0C | 0x15 | 0x1A if listening => {
            let r = card.control_char(&mut c.session, b);
            said(r)
        }
        0x08 if listening => {
            if !c.overflow {
                c.buf.pop();
            }
            Vec::new()
        }
        0x0E => said(ctrl_n(&c.buf)),
        0x19 if listening => {
            c.overflow = false;
            c.buf = card.last_line().to_vec();
            said(c.buf.clone())
        }
        0x00..=0x1F => Vec::new(),
        _ => {
            collect(card, c, b);
            Vec::new()
        }
    })
}

/// A line character: into the buffer while this card is receiving; over-long lines are
/// dropped and answered ERR003 at their `<CR>`.
fn collect(card: &mut Card, c: &mut Conn, b: u8) {
    if !card.chain_listening(&c.session) || c.overflow {
        return;
    }
    if c.buf.len() >= MAX_LINE {
        c.overflow = true;
        c.buf.clear();
    } else {
        c.buf.push(b);
    }
}

/// Keep what the line changed in the session (motor/C.S.), not the chain addressing, which
/// belongs to the connection.
fn restore(c: &mut Conn, s: &Session) {
    c.session.motor = s.motor;
    c.session.coord = s.coord;
}

/// CTRL-I: the card(s) receiving execute the last line again (not remembered anew), within
/// `budget` as a `<CR>` does; the talking card reports its refusal.
fn repeat_last(card: &mut Card, c: &mut Conn, budget: &mut Budget) -> Exec {
    if std::mem::take(&mut c.at_pending) && card.software_addressing() {
        // A lone `@` before it: the report-card command, collected like any line character.
        collect(card, c, b'@');
    }
    if !card.chain_listening(&c.session) {
        return Exec::said(Vec::new());
    }
    let talking = card.chain_talking(&c.session);
    let line = card.last_line().to_vec();
    let mut s = Session {
        chain_addressed: true,
        ..c.session.clone()
    };
    let run = card.start_line(&mut s, &line, false);
    step(card, c, run, s, talking, budget)
}

/// Run `run` within `budget`: its reply and refusal when done (if talking), else handed
/// back to be parked.
fn step(
    card: &mut Card,
    c: &mut Conn,
    mut run: LineRun,
    mut s: Session,
    talking: bool,
    budget: &mut Budget,
) -> Exec {
    let Step::Done(r) = card.step_detached(&mut run, &mut s, budget) else {
        return Exec::Wait(Box::new(run), s, talking);
    };
    restore(c, &s);
    if !talking {
        return Exec::said(Vec::new());
    }
    Exec::Reply(r, run.refusal().map(Refusal::Pmac))
}

/// `<CR>`: execute the collected line (every card that has one) within `budget`, reply if
/// talking. A line not done (its MACRO auxiliary command waits for the ring, or its slice is
/// used) is handed back to be parked.
fn execute(card: &mut Card, c: &mut Conn, budget: &mut Budget) -> Exec {
    let talking = card.chain_talking(&c.session);
    if std::mem::take(&mut c.synced) && c.buf.is_empty() && !c.overflow {
        // The line was taken for a synchronized start: it runs (and answers) there.
        return Exec::said(Vec::new());
    }
    let line = std::mem::take(&mut c.buf);
    if std::mem::take(&mut c.overflow) {
        if !talking {
            return Exec::said(Vec::new());
        }
        let (r, e) = card.run_detached_refused(&mut c.session.clone(), &overlong_probe());
        return Exec::Reply(r, e.map(Refusal::Pmac));
    }
    if line.is_empty() && !talking {
        return Exec::said(Vec::new());
    }
    // The line was collected while addressed: it runs even if another card is addressed now.
    let mut s = Session {
        chain_addressed: true,
        ..c.session.clone()
    };
    let run = card.start_detached(&mut s, &line);
    step(card, c, run, s, talking, budget)
}

/// `<CR>` on a card whose language answers lines whole (Power): the collected line runs on
/// the connection's own communication thread, and the reply is what `gpascii` writes (each
/// line ended by CR LF, then ACK CR LF; errors as `stdin:L:C: error #n: …`). `None`: the
/// PMAC chain runs it ([`execute`]).
fn execute_whole(card: &mut Card, dialect: &mut Dialect, c: &mut Conn) -> Option<Exec> {
    if !dialect.answers_whole_lines() {
        return None;
    }
    let talking = card.chain_talking(&c.session);
    if std::mem::take(&mut c.synced) && c.buf.is_empty() && !c.overflow {
        return Some(Exec::said(Vec::new()));
    }
    let line = std::mem::take(&mut c.buf);
    // Longer than the dialect takes: it answers its own error for it.
    let overflow = std::mem::take(&mut c.overflow);
    if line.is_empty() && !overflow && !talking {
        return Some(Exec::said(Vec::new()));
    }
    let (r, e) = dialect.chain_line(card, &c.session, &line, overflow)?;
    if !talking {
        return Some(Exec::said(Vec::new()));
    }
    Some(Exec::Reply(r, e))
}

/// Start-up: the card's chain number (I0) from the config and software addressing on (I1 bit
/// 1), so the cluster's chain works out of the box. Config `ivars` applied later still win.
pub(crate) fn apply_chain_defaults(card: &mut Card, number: u8) {
    let mut s = Session::default();
    let i1 = card.state.peek_ivar(1).unwrap_or(0.0) as u32 | 2;
    let line = format!("I0={} I1={i1}", number & 0xF);
    let _ = card.command_line(&mut s, line.as_bytes());
}

#[cfg(test)]
#[path = "tests_chain.rs"]
mod tests;
