//! The Power PMAC script dialect (seed 000, digest `power-pmac.md`): what a `power` card
//! speaks on every host connection. Each connection is a *communication thread* with its own
//! local data ([`Thread`]: `Ldata.Motor`/`Ldata.Coord`, echo mode, L/R/D/C variables, its
//! line count for error reports). [`Power::line`] takes one command line (bytes, without its
//! terminator) and returns the thread's output for it, as `gpascii` writes it: each reply line
//! ends with CR LF, errors read `stdin:{line}:{col}: error #{n}: {TEXT}: {the line}`, and
//! every line is acknowledged with ACK CR LF (host tools wait for it).
//!
//! The dialect runs against the same card as the PMAC dialect (`lang::Card`): the
//! model's P/Q/M variables, its I-variables (Power numbering mapped onto the model's Turbo
//! numbering: Power motor `x` is model motor `x+1`, C.S. `x` model C.S. `x+1`, `I8000+n` the
//! model's global `In`), and the PMAC executors for motor and C.S. commands (jogs, homing,
//! kills, run control), whose requests become `model::Action`s. Data-structure elements come
//! from the seed's catalogue (`catalog`); elements without a model equivalent keep their
//! values here.

pub(crate) mod abort_all;
mod backup;
mod catalog;
mod direct;
mod elements;
mod exec;
mod host_effect;
mod kinematics;
mod listing;
mod macro_ic;
mod moves;
mod mptr;
mod mvars;
mod oneline;
mod parse;
mod preproc;
mod program;
pub(crate) mod progvars;
mod rotary;
pub(crate) mod saved;
mod status_elems;
mod units;

/// Motion program `n` is running or suspended in some C.S.: that C.S. points at it (or
/// calculates or executes in it) and is `Coord[x].ProgActive` (running, its moves
/// executing, a hold, or a stop it can resume from; `a` ends it).
fn prog_in_use(card: &Card, n: u32) -> bool {
    let m = &card.model;
    m.run.cs.iter().enumerate().any(|(k, r)| {
        let here = r.pointer.is_some_and(|(p, _)| p == n)
            || r.pc_at.is_some_and(|(p, _)| p == n)
            || r.pe_at.is_some_and(|(p, _)| p == n);
        let active = m
            .state
            .coords
            .get(k)
            .is_some_and(|c| c.running || c.moves_pending)
            || r.stop_point.is_some();
        here && active
    })
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_forms;
#[cfg(test)]
mod tests_fuzz;
#[cfg(test)]
mod tests_kin;
#[cfg(test)]
mod tests_moves;
#[cfg(test)]
mod tests_mvars;
#[cfg(test)]
mod tests_preproc;
#[cfg(test)]
mod tests_programs;
#[cfg(test)]
mod tests_rotary;
#[cfg(test)]
mod tests_status;
#[cfg(test)]
mod tests_stops;
#[cfg(test)]
mod tests_units;

use crate::domain::PowerErr;
use std::collections::HashMap;

use crate::lang::Card;
use crate::model::{BufId, ProgLine};
pub(crate) use host_effect::PowerWait;

/// Longest command line accepted (bytes before the terminator).
pub(crate) const MAX_LINE: usize = 1024;

/// Connections the dialect keeps threads for; the least recently used is forgotten beyond.
const MAX_THREADS: usize = 512;

/// L- and R-variables per thread (L0-L8191, R0-R8191: seed §2.2).
pub(crate) const LOCALS: usize = 8192;
/// D-variables per thread (D0-D54).
pub(crate) const DVARS: usize = 55;
/// C-variables per thread (C0-C63).
pub(crate) const CVARS: usize = 64;

/// One communication thread's local data (`Ldata`).
#[derive(Debug, Clone)]
pub struct Thread {
    /// Addressed motor (`Ldata.Motor`, Power numbering: 0 at power-up).
    pub motor: u16,
    /// Addressed coordinate system (`Ldata.Coord`, 0 at power-up).
    pub coord: u16,
    /// Echo mode (`echo{n}`, bits 0-6).
    pub echo: u32,
    /// Lines received so far (error reports name the line).
    pub lines: u64,
    /// `Ldata.CmdStatus`: 0 once a `cmd` text of this thread ran, minus its error number
    /// when it failed (the thread may set it beforehand to watch for the change).
    pub(crate) cmd_status: f64,
    /// `Ldata.CmdCount`: `cmd` texts of this thread run so far (the thread may reset it).
    pub(crate) cmd_count: f64,
    /// The first refusal framed for the line running now (see [`exec::frame`]).
    pub(crate) refusal: std::cell::Cell<Option<PowerErr>>,
    l: Vec<f64>,
    r: Vec<f64>,
    d: [f64; DVARS],
    c: [f64; CVARS],
}

impl Default for Thread {
    fn default() -> Self {
        Thread {
            motor: 0,
            coord: 0,
            echo: 0,
            lines: 0,
            cmd_status: 0.0,
            cmd_count: 0.0,
            refusal: std::cell::Cell::new(None),
            l: Vec::new(),
            r: Vec::new(),
            d: [0.0; DVARS],
            c: [0.0; CVARS],
        }
    }
}

impl Thread {
    /// Record `e` as the line's refusal unless an earlier one is recorded.
    pub(crate) fn refuse(&self, e: PowerErr) {
        if self.refusal.get().is_none() {
            self.refusal.set(Some(e));
        }
    }

    /// Thread-local variable `n` of family `f` (`None`: out of range).
    pub(crate) fn local(&self, f: u16, n: u32) -> Option<f64> {
        let n = n as usize;
        match f {
            parse::EXT_L if n < LOCALS => Some(self.l.get(n).copied().unwrap_or(0.0)),
            parse::EXT_R if n < LOCALS => Some(self.r.get(n).copied().unwrap_or(0.0)),
            parse::EXT_D => self.d.get(n).copied(),
            parse::EXT_C => self.c.get(n).copied(),
            _ => None,
        }
    }

    /// Store thread-local variable `n` of family `f`; `false` when out of range.
    pub(crate) fn set_local(&mut self, f: u16, n: u32, v: f64) -> bool {
        let n = n as usize;
        let slot = match f {
            parse::EXT_L | parse::EXT_R if n < LOCALS => {
                let vec = if f == parse::EXT_L {
                    &mut self.l
                } else {
                    &mut self.r
                };
                if vec.len() <= n {
                    vec.resize(n + 1, 0.0);
                }
                &mut vec[n]
            }
            parse::EXT_D => match self.d.get_mut(n) {
                Some(s) => s,
                None => return false,
            },
            parse::EXT_C => match self.c.get_mut(n) {
                Some(s) => s,
                None => return false,
            },
            _ => return false,
        };
        *slot = v;
        true
    }
}

/// The connection id of the thread that runs `cmd"…"` strings of programs and PLCs (seed
/// §2.13: a dedicated internal thread).
pub(crate) const CMD_THREAD: u64 = 1 << 62;

/// The program engine's command path on a Power card: `cmd"…"` lines are kept during the
/// servo tick and run through the dialect after it ([`Power::program_commands`]), on
/// [`CMD_THREAD`]; their replies go nowhere (the seed's `cmd` has no reply channel).
#[derive(Debug, Default)]
pub struct CmdQueue {
    /// Each text with the program thread that issued it (its `Ldata.CmdStatus`/`CmdCount`
    /// report the outcome).
    lines: Vec<(crate::model::Thread, Vec<u8>)>,
}

impl crate::program::Commands for CmdQueue {
    fn line(
        &mut self,
        card: &mut crate::model::CardModel,
        motor: u16,
        coord: u16,
        line: &[u8],
    ) -> Vec<u8> {
        if self.lines.len() < 256 {
            // A direct command without a list acts on the issuing thread's addressed motor or
            // C.S. (its `Ldata`, Power numbers; the engine's are the model's, one more).
            let t = card.exec.thread;
            let (m, c) = card
                .ext::<progvars::ProgVars>()
                .and_then(|pv| pv.addressing(t))
                .unwrap_or((motor.saturating_sub(1), coord.saturating_sub(1)));
            self.lines.push((t, direct::resolve(line, m, c)));
        }
        Vec::new()
    }

    fn control(&mut self, _: &mut crate::model::CardModel, _: u16, _: u16, _: u8) -> Vec<u8> {
        Vec::new()
    }
}

/// The dialect's state on one card: the communication threads and the values of elements the
/// model does not keep.
#[derive(Debug, Default)]
pub struct Power {
    threads: HashMap<u64, (Thread, u64)>,
    clock: u64,
    open: Option<OpenBuf>,
    /// The rotary buffer open for entry (`rotary`), if any.
    rot: Option<rotary::RotOpen>,
    /// A host line is running ([`Power::host_line`]): its `save` or `$$$` waits for the
    /// effect.
    host: bool,
    /// The effect of the host line running, for its caller to perform.
    wait: Option<PowerWait>,
}

/// The one buffer open on the card (seed §2.9: one at a time across all threads).
#[derive(Debug)]
struct OpenBuf {
    conn: u64,
    id: BufId,
    blocks: program::Blocks,
    lines: usize,
    /// Its text so far (the lines `list` will show).
    text: Vec<String>,
    /// How many stored lines each text line became.
    stored: Vec<usize>,
    /// A kinematic routine (model C.S., inverse) instead of the buffer `id`.
    kin: Option<(u16, bool)>,
    /// The kinematic routine's stored lines.
    kin_lines: Vec<ProgLine>,
    /// The stack offset `open` gave (`open prog n,{offset}`).
    stack: u32,
}

impl Power {
    /// A dialect with no threads yet and every element at its default.
    pub fn new() -> Self {
        Power::default()
    }

    /// Execute one command line of connection `conn` on `card`: the bytes to send back.
    pub fn line(&mut self, card: &mut Card, conn: u64, line: &[u8]) -> Vec<u8> {
        self.line_refused(card, conn, line).0
    }

    /// [`Power::line`], with the line's first refusal (the `error #n` it reported first).
    pub(crate) fn line_refused(
        &mut self,
        card: &mut Card,
        conn: u64,
        line: &[u8],
    ) -> (Vec<u8>, Option<PowerErr>) {
        let expanded;
        let pre = progvars::with(card, |card, pv| {
            let plcs = &card.model.bufs.plcs;
            pv.pre.line(line, &|n| plcs.contains_key(&(n as u8)))
        });
        let line = match pre {
            preproc::Pre::Same => line,
            preproc::Pre::Text(t) => {
                expanded = t;
                &expanded[..]
            }
            done => {
                // A directive is taken (ACK); a bad one is refused in Power's terms.
                let mut th = self.take_thread(conn);
                th.lines += 1;
                let (e, refusal) = match done {
                    preproc::Pre::Error(code) => {
                        (Some(parse::SyntaxError { at: 0, code }), Some(code))
                    }
                    _ => (None, None),
                };
                let out = exec::frame(&th, line, e);
                th.refusal.set(None);
                self.threads.insert(conn, (th, self.clock));
                return (out, refusal);
            }
        };
        let mut th = self.take_thread(conn);
        th.refusal.set(None);
        let mut cmds = Vec::new();
        let mut kin = Vec::new();
        let out = if let Some(out) = self.rotary_command(card, conn, &mut th, line) {
            out
        } else if let Some(out) = self.buffer_command(card, conn, &mut th, line) {
            out
        } else if let Some(out) = (line.len() <= MAX_LINE)
            .then(|| oneline::command(card, conn, &mut th, line, &mut cmds))
            .flatten()
        {
            out
        } else if let Some(out) = self.reset_command(card, conn, &mut th, line) {
            out
        } else {
            progvars::with(card, |card, pv| {
                if let Some(out) = backup::command(&mut card.model, &pv.store, &mut th, line) {
                    return out;
                }
                match listing::command(card, &pv.sources, &pv.kin, &mut th, line) {
                    Some(out) => out,
                    None => {
                        let (store, others) = pv.split_threads();
                        exec::run_line(card, store, others, &mut th, line, &mut kin)
                    }
                }
            })
        };
        // `&x p|d|f|v` of a kinematic C.S.: the forward routine, now that the dialect's
        // variables are back in the model.
        let out = if kin.is_empty() {
            out
        } else {
            kinematics::fill_reports(&mut card.model, out, &kin)
        };
        let refusal = th.refusal.take();
        self.threads.insert(conn, (th, self.clock));
        if conn != CMD_THREAD {
            // `cx cmd"…"`: the text runs on the command thread (a `cmd` text cannot hold
            // another quoted text, so this does not nest further).
            for c in cmds {
                let _ = self.line(card, CMD_THREAD, &c);
            }
        }
        (out, refusal)
    }

    /// Run the `cmd"…"` lines programs issued during a servo tick (see [`CmdQueue`]).
    pub fn program_commands(&mut self, card: &mut Card, q: CmdQueue) {
        for (t, l) in q.lines {
            let (_, refusal) = self.line_refused(card, CMD_THREAD, &l);
            let status = refusal.map_or(0.0, |e| -f64::from(e.code()));
            progvars::with(card, |_, pv| pv.command_done(t, status));
        }
    }

    /// Install the dialect's variables in `card`'s model: programs and PLCs reach I-, L-,
    /// R-, D-, C-variables and data-structure elements through it (`model::ExtVars`).
    pub fn attach(card: &mut Card) {
        progvars::install(&mut card.model);
    }

    /// Connection `conn` closed: forget its thread, close a buffer it left open.
    pub fn end(&mut self, card: &mut Card, conn: u64) {
        self.threads.remove(&conn);
        if self.rot.is_some_and(|r| r.conn == conn) {
            self.rot = None;
        }
        if self.open.as_ref().is_some_and(|o| o.conn == conn) {
            // A buffer left open by a vanished connection is closed (its errors have no one to
            // go to).
            let _ = self.close(card);
        }
    }

    /// `$$$`, `$$$***` and `save`, alone on their line: the model's reset, factory
    /// re-initialisation and save (effects the card's runtime performs, as for the PMAC
    /// dialect). `$$$` and `$$$***` send no reply at all (seed §2.7); `save` its ACK. A host
    /// line's `save` and `$$$` are handed to the caller of [`Power::host_line`], which answers
    /// once the image is written (an error when it is not) or loaded, before the host's next
    /// line; others (programs' `cmd`, the chain) are detached.
    fn reset_command(
        &mut self,
        card: &mut Card,
        conn: u64,
        th: &mut Thread,
        line: &[u8],
    ) -> Option<Vec<u8>> {
        let text = String::from_utf8_lossy(line).trim().to_ascii_lowercase();
        let pmac: &[u8] = match text.as_str() {
            "$$$" => b"$$$",
            "$$$***" => b"$$$***",
            "save" => b"SAVE",
            _ => return None,
        };
        th.lines += 1;
        if self.host && conn != CMD_THREAD && text != "$$$***" {
            let wait = match text.as_str() {
                "save" => PowerWait::save(card, th, line),
                _ => PowerWait::reset(),
            };
            let out = wait.ok.clone();
            self.wait = Some(wait);
            return Some(out);
        }
        let mut s = crate::lang::Session::with_id(0);
        let _ = card.run_detached(&mut s, pmac);
        Some(if text == "save" {
            exec::frame(th, line, None)
        } else {
            Vec::new()
        })
    }

    /// `open prog|plc n`, `close`, and the lines entered into an open buffer.
    fn buffer_command(
        &mut self,
        card: &mut Card,
        conn: u64,
        th: &mut Thread,
        line: &[u8],
    ) -> Option<Vec<u8>> {
        let text = String::from_utf8_lossy(line).to_ascii_lowercase();
        let words: Vec<&str> = text.split_whitespace().collect();
        let mine = self.open.as_ref().is_some_and(|o| o.conn == conn);
        if let Some(target) = kinematics::open_words(&text, th) {
            th.lines += 1;
            let r = self.open_kin(card, conn, target);
            return Some(exec::frame(th, line, r.err()));
        }
        match words.as_slice() {
            ["open", kind, n @ ..]
                if !n.is_empty() && n.concat().bytes().all(|b| b.is_ascii_digit() || b == b',') =>
            {
                th.lines += 1;
                let r = self.open_buffer(card, conn, kind, &n.concat());
                return Some(exec::frame(th, line, r.err()));
            }
            // `clear prog|plc|subprog n` (seed L33625-33656): `open … close`, which deletes
            // the buffer; refused as `open` is (a running program, an enabled PLC: #26).
            ["clear", kind @ ("prog" | "plc" | "subprog"), n]
                if n.bytes().all(|b| b.is_ascii_digit()) =>
            {
                th.lines += 1;
                let r = self
                    .open_buffer(card, conn, kind, n)
                    .and_then(|()| self.close(card));
                return Some(exec::frame(th, line, r.err()));
            }
            ["clear", "all", "buffers"] => {
                th.lines += 1;
                let r = self.clear_all(card);
                return Some(exec::frame(th, line, r.err()));
            }
            ["close"] | ["close", "all", "buffers"] => {
                th.lines += 1;
                let r = if self.open.is_some() {
                    self.close(card)
                } else {
                    Ok(())
                };
                return Some(exec::frame(th, line, r.err()));
            }
            _ if mine => {}
            _ => return None,
        }
        th.lines += 1;
        let o = self.open.as_mut()?;
        let depth = (o.blocks.len(), o.blocks.last().copied());
        let parsed = progvars::with(card, |_, pv| {
            program::parse_program_line(line, &mut o.blocks, &mut pv.elems)
        });
        let r = match parsed {
            // A `}` whose `while` is on the next line stores nothing but is listed (its text
            // is what a saved image rebuilds the buffer from).
            Ok(stmts)
                if stmts.is_empty() && (o.blocks.len(), o.blocks.last().copied()) != depth =>
            {
                o.text.extend(listing::text_of(line));
                o.stored.push(0);
                Ok(())
            }
            // A line with nothing to store (blank, a comment, `sendall`) is not listed either:
            // the listing has one line per stored line (`list pc` relies on it).
            Ok(stmts) if stmts.is_empty() => Ok(()),
            Ok(stmts) => {
                o.text.extend(listing::text_of(line));
                let parts = program::stored_lines(stmts);
                o.lines += 1;
                o.stored.push(parts.len());
                if o.kin.is_some() {
                    o.kin_lines.extend(parts.into_iter().map(ProgLine::new));
                    return Some(exec::frame(th, line, None));
                }
                parts.into_iter().try_for_each(|p| {
                    card.model
                        .bufs
                        .append(o.id, ProgLine::new(p))
                        .map_err(|_| parse::SyntaxError {
                            at: 0,
                            code: PowerErr::IllegalParameter,
                        })
                })
            }
            Err(e) => Err(e),
        };
        Some(match r {
            Ok(()) => exec::frame(th, line, None),
            Err(e) => {
                // Seed §2.9: a line that is not a valid buffer command erases and closes the
                // open buffer.
                let (id, kin) = (o.id, o.kin.is_some());
                self.open = None;
                if !kin {
                    card.model.bufs.remove(id);
                }
                exec::frame(th, line, Some(e))
            }
        })
    }

    /// `clear all buffers` (seed L33605-33623): every motion program, subprogram, PLC and
    /// kinematic routine deleted and every rotary buffer emptied (its structure kept). Every
    /// program must be stopped, no buffer open, no PLC enabled (#26 / #21 otherwise).
    fn clear_all(&mut self, card: &mut Card) -> Result<(), parse::SyntaxError> {
        let bad = |code| parse::SyntaxError { at: 0, code };
        if self.open.is_some() || self.rot.is_some() {
            return Err(bad(PowerErr::IllegalParameter));
        }
        let m = &card.model;
        let busy = m
            .state
            .coords
            .iter()
            .zip(&m.run.cs)
            .any(|(c, r)| c.running || c.moves_pending || r.stop_point.is_some());
        let plc_on = m.bufs.plcs.keys().any(|&k| {
            m.run
                .plc
                .get(usize::from(k))
                .is_some_and(|r| r.enabled || r.paused)
        });
        if busy || plc_on {
            return Err(bad(PowerErr::ProgramRunning));
        }
        let ids: Vec<BufId> = m
            .bufs
            .progs
            .keys()
            .map(|&n| BufId::Prog(n))
            .chain(m.bufs.plcs.keys().map(|&n| BufId::Plc(n)))
            .collect();
        let rotaries: Vec<u8> = m.bufs.rotary.keys().copied().collect();
        for id in ids {
            card.model.bufs.remove(id);
            progvars::with(card, |_, pv| pv.sources.remove(&id));
        }
        for cs in rotaries {
            card.model.bufs.clear(BufId::Rot, cs);
        }
        progvars::with(card, |_, pv| pv.kin.clear());
        Ok(())
    }

    fn open_buffer(
        &mut self,
        card: &mut Card,
        conn: u64,
        kind: &str,
        n: &str,
    ) -> Result<(), parse::SyntaxError> {
        let bad = |code| parse::SyntaxError { at: 0, code };
        if self.open.is_some() || self.rot.is_some() {
            return Err(bad(PowerErr::IllegalParameter));
        }
        // `n[,[stack]][,labels]` (seed L37686-37752): the stack offset is where the `R`
        // variables of the program start (the `L` of a subroutine it calls), 1..8191 of the
        // thread's 8,192-slot stack; the label count is accepted (the engine has no label
        // table to size).
        let mut args = n.split(',');
        let n: u32 = args
            .next()
            .unwrap_or("")
            .parse()
            .map_err(|_| bad(PowerErr::IllegalParameter))?;
        let opt: Vec<&str> = args.collect();
        if opt.len() > 2 {
            return Err(bad(PowerErr::IllegalCmd));
        }
        let mut stack = crate::model::DEFAULT_STACK_OFFSET;
        for (k, a) in opt.iter().enumerate() {
            if a.is_empty() {
                continue;
            }
            match a.parse::<u32>() {
                Ok(v) if k == 0 && (1..LOCALS as u32).contains(&v) => stack = v,
                Ok(v) if k == 1 && v > 0 => {}
                Ok(_) => return Err(bad(PowerErr::IllegalParameter)),
                Err(_) => return Err(bad(PowerErr::IllegalCmd)),
            }
        }
        let id = match kind {
            "prog" if (1..=32_767).contains(&n) => BufId::Prog(n as u16),
            "plc" if n <= 31 => BufId::Plc(n as u8),
            // Subprograms have their own numbers (the model's buffers from 32768 on).
            "subprog" if n <= 32_767 => {
                BufId::Prog(crate::domain::profile::POWER_SUBPROG_BASE + n as u16)
            }
            "prog" | "plc" | "subprog" => return Err(bad(PowerErr::IllegalParameter)),
            _ => return Err(bad(PowerErr::IllegalCmd)),
        };
        // Seed L37656-37661: a PLC is opened only when disabled (not paused, not stepping);
        // L37737-37741: a motion program only while no C.S. runs it or holds it suspended
        // (hold, stop, step: `a` ends it); other programs may be opened meanwhile.
        match id {
            BufId::Plc(k) => {
                // Only a PLC that exists can be enabled in fact (the flags of an empty
                // buffer are the power-on defaults).
                let r = card.model.run.plc[usize::from(k)];
                if (r.enabled || r.paused) && card.model.bufs.plcs.contains_key(&k) {
                    return Err(bad(PowerErr::ProgramRunning));
                }
            }
            BufId::Prog(p) if prog_in_use(card, u32::from(p)) => {
                return Err(bad(PowerErr::ProgramRunning))
            }
            _ => {}
        }
        // Seed §2.9: `open` clears the buffer.
        card.model.bufs.remove(id);
        progvars::with(card, |_, pv| pv.sources.remove(&id));
        card.model
            .bufs
            .open(id)
            .map_err(|_| bad(PowerErr::IllegalParameter))?;
        match id {
            BufId::Prog(p) => {
                // The C.S. pointing at it (none runs it) point at nothing any more.
                for c in card.model.run.cs.iter_mut() {
                    if c.pointer.is_some_and(|(n, _)| n == u32::from(p)) {
                        c.pointer = None;
                    }
                }
            }
            // A new PLC runs once enabled (seed L37630-37634).
            BufId::Plc(k) => card.model.run.plc[usize::from(k)].enabled = false,
            BufId::Rot => {}
        }
        self.open = Some(OpenBuf {
            conn,
            id,
            blocks: Vec::new(),
            lines: 0,
            text: Vec::new(),
            stored: Vec::new(),
            kin: None,
            kin_lines: Vec::new(),
            stack,
        });
        Ok(())
    }

    /// Close the open buffer: an empty one is deleted (seed: `open` then `close`), an
    /// unbalanced one is erased with an error.
    fn close(&mut self, card: &mut Card) -> Result<(), parse::SyntaxError> {
        let Some(o) = self.open.take() else {
            return Ok(());
        };
        if o.kin.is_some() {
            return self.close_kin(card, o);
        }
        if o.lines == 0 {
            card.model.bufs.remove(o.id);
            return Ok(());
        }
        if !o.blocks.is_empty() {
            card.model.bufs.remove(o.id);
            return Err(parse::SyntaxError {
                at: 0,
                code: PowerErr::IllegalCmd,
            });
        }
        card.model
            .bufs
            .close(o.id)
            .map_err(|_| parse::SyntaxError {
                at: 0,
                code: PowerErr::IllegalParameter,
            })?;
        progvars::with(card, |_, pv| {
            pv.sources.insert(o.id, o.text, o.stored, o.stack);
        });
        Ok(())
    }

    /// The line `line` of connection `conn` would start a motion program (`r`/`s`, also
    /// after `b{n}`) if it ran now (not while `conn` has a buffer open, not with a syntax
    /// error): the daisy chain's synchronized start asks this.
    pub fn starts_program(&self, card: &Card, conn: u64, line: &[u8]) -> bool {
        if self.open.as_ref().is_some_and(|o| o.conn == conn) || line.len() > MAX_LINE {
            return false;
        }
        let lim = card.model.state.limits();
        let p = parse::parse_line(line, lim.motors, lim.coords);
        p.error.is_none()
            && p.items.iter().any(|it| {
                matches!(
                    it.cmd,
                    parse::Cmd::Cs(parse::CsCmd::Run | parse::CsCmd::Step | parse::CsCmd::Start(_))
                )
            })
    }

    /// The addressed motor and C.S. (`Ldata.Motor`, `Ldata.Coord`) of connection `conn`.
    pub fn addressing(&self, conn: u64) -> (u16, u16) {
        self.thread(conn).map_or((0, 0), |t| (t.motor, t.coord))
    }

    /// Connection `conn` takes the modal `#n`/`&n` of `line` as if it had run (the line was
    /// taken to run elsewhere: a synchronized start).
    pub fn adopt_addressing(&mut self, card: &Card, conn: u64, line: &[u8]) {
        let lim = card.model.state.limits();
        let p = parse::parse_line(line, lim.motors, lim.coords);
        let mut th = self.take_thread(conn);
        for it in &p.items {
            match &it.cmd {
                parse::Cmd::Motors(v, false) if v.len() == 1 => th.motor = v[0],
                parse::Cmd::Coords(v, false) if v.len() == 1 => th.coord = v[0],
                _ => {}
            }
        }
        self.threads.insert(conn, (th, self.clock));
    }

    /// The thread of `conn` (a fresh one for a new connection).
    pub fn thread(&self, conn: u64) -> Option<&Thread> {
        self.threads.get(&conn).map(|(t, _)| t)
    }

    fn take_thread(&mut self, conn: u64) -> Thread {
        self.clock += 1;
        if let Some((t, _)) = self.threads.remove(&conn) {
            return t;
        }
        if self.threads.len() >= MAX_THREADS {
            let oldest = self
                .threads
                .iter()
                .min_by_key(|(_, (_, t))| *t)
                .map(|(k, _)| *k);
            if let Some(k) = oldest {
                self.threads.remove(&k);
            }
        }
        Thread::default()
    }
}
