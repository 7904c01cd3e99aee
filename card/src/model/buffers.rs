//! Program buffers (spec §3.2.6, §5.1, §6.8): fixed motion programs, PLC programs and rotary
//! buffers, stored in parsed form, with word offsets, structural checking and a total buffer
//! space shared with the DEFINE'd buffers ([`super::defines`]). Pure and serializable.
//!
//! The stored line type is generic ([`StoredLine`]) so this module does not depend on the
//! parser's AST layout; `exec_buffers` implements the trait for the parser's line type.

use crate::domain::ErrCode;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use super::defines::Defines;

/// Structural role of one stored line (block IF/WHILE nesting).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// No effect on nesting.
    Plain,
    /// `IF (...)` opening a block.
    If,
    /// `IF (...) stmt` on one line (motion programs).
    IfOneLine,
    /// `ELSE` opening the false branch of a block.
    Else,
    /// `ELSE stmt` on one line (motion programs).
    ElseOneLine,
    /// `ENDIF`.
    EndIf,
    /// `WHILE (...)` opening a block.
    While,
    /// `ENDWHILE`.
    EndWhile,
}

/// A line as stored in a program buffer.
pub trait StoredLine: Clone {
    /// Size in buffer words (offsets of `LIST PROG n,`, `PC`, `PE`).
    fn words(&self) -> u32;
    /// Structural role.
    fn structure(&self) -> Structure;
    /// True for a lone `RETURN` line (the one `CLOSE` appends).
    fn is_return(&self) -> bool;
    /// The `RETURN` line that `CLOSE` appends.
    fn return_line() -> Self;
}

/// Which buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum BufId {
    /// Fixed motion program `PROG n`.
    Prog(u16),
    /// Interpreted PLC program `PLC n`.
    Plc(u8),
    /// The rotary buffers (all C.S.s that have one).
    Rot,
}

impl BufId {
    /// Password-protected buffers: PROG 1000-32767 and PLC 0-15.
    pub fn protected(self) -> bool {
        match self {
            BufId::Prog(n) => n >= 1000,
            BufId::Plc(n) => n <= 15,
            BufId::Rot => false,
        }
    }
}

/// One stored program (PROG or PLC).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Program<L> {
    /// Lines in order.
    pub lines: Vec<L>,
    /// False while IF/WHILE blocks are unclosed (CLOSE → ERR003, R → ERR016).
    pub valid: bool,
}

impl<L> Default for Program<L> {
    fn default() -> Self {
        Program {
            lines: Vec::new(),
            valid: true,
        }
    }
}

/// A buffer-level error, reported as `ERRnnn`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BufErr(pub ErrCode);

/// Where a nesting check stands after some lines: open blocks, and whether the last line was
/// a one-line `IF` (an `ELSE` may follow it).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct Nest {
    stack: Vec<Structure>,
    prev_one_line_if: bool,
    /// An earlier line is a closer without an opener: nothing after it is checked.
    broken: bool,
}

impl Nest {
    /// Take one more line; `false` for a closer without an opener.
    fn step(&mut self, s: Structure) -> bool {
        if self.broken {
            return true;
        }
        let stack = &mut self.stack;
        let prev_one_line_if = self.prev_one_line_if;
        match s {
            Structure::If | Structure::While => stack.push(s),
            Structure::Else | Structure::ElseOneLine => {
                let ok_block = stack.last() == Some(&Structure::If);
                if ok_block {
                    if let Some(top) = stack.last_mut() {
                        if s == Structure::Else {
                            *top = Structure::Else;
                        }
                    }
                } else if prev_one_line_if {
                    if s == Structure::Else {
                        stack.push(Structure::Else);
                    }
                } else {
                    return false;
                }
            }
            Structure::EndIf => match stack.last() {
                Some(Structure::If) | Some(Structure::Else) => {
                    stack.pop();
                }
                _ => return false,
            },
            Structure::EndWhile => match stack.last() {
                Some(Structure::While) => {
                    stack.pop();
                }
                _ => return false,
            },
            Structure::Plain | Structure::IfOneLine => {}
        }
        self.prev_one_line_if = s == Structure::IfOneLine;
        true
    }
}

/// Nesting check of a line sequence: `Err(ERR009)` for a closer without an opener at
/// `lines[i]`, `Ok(depth)` otherwise (depth > 0 means unclosed blocks).
fn nesting<'a, L: StoredLine + 'a>(lines: impl Iterator<Item = &'a L>) -> Result<usize, usize> {
    let mut n = Nest::default();
    for (i, l) in lines.enumerate() {
        if !n.step(l.structure()) {
            return Err(i);
        }
    }
    Ok(n.stack.len())
}

/// Caches that make entering a program line by line linear in its length: the words the
/// PROG/PLC buffers use, and the nesting state at the end of the buffer being entered. Never
/// compared, cloned empty, rebuilt from the lines when missing.
#[derive(Debug, Default)]
struct Caches {
    prog_words: Option<u64>,
    nest: Option<(BufId, usize, Nest)>,
}

impl Clone for Caches {
    fn clone(&self) -> Self {
        Caches::default()
    }
}

impl PartialEq for Caches {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Per-C.S. rotary buffer contents.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Rotary<L> {
    /// Size in words (`DEFINE ROT n`).
    pub size: u32,
    /// Lines not yet executed, oldest first.
    pub lines: Vec<L>,
}

/// All program buffers of a card plus the user-memory accounting.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Buffers<L> {
    /// Fixed motion programs.
    pub progs: BTreeMap<u16, Program<L>>,
    /// Interpreted PLC programs.
    pub plcs: BTreeMap<u8, Program<L>>,
    /// Rotary buffers by C.S. number.
    pub rotary: BTreeMap<u8, Rotary<L>>,
    /// DEFINE'd buffers other than rotary (stacking rule).
    pub defines: Defines,
    /// Total user buffer memory in words.
    pub capacity: u32,
    #[serde(skip)]
    caches: Caches,
}

/// Maximum number of resident motion programs (§5.1).
pub(super) const MAX_PROGRAMS: usize = 256;

impl<L: StoredLine> Buffers<L> {
    /// Empty buffers with `capacity` words of user memory.
    pub fn new(capacity: u32) -> Self {
        Buffers {
            progs: BTreeMap::new(),
            plcs: BTreeMap::new(),
            rotary: BTreeMap::new(),
            defines: Defines::default(),
            capacity,
            caches: Caches::default(),
        }
    }

    fn prog_words(&mut self) -> u64 {
        if let Some(w) = self.caches.prog_words {
            return w;
        }
        let w = self
            .progs
            .values()
            .chain(self.plcs.values())
            .map(prog_words)
            .sum();
        self.caches.prog_words = Some(w);
        w
    }

    /// Words used by programs, PLCs, rotary buffers and DEFINE'd buffers.
    pub fn used(&self) -> u64 {
        let p: u64 = match self.caches.prog_words {
            Some(w) => w,
            None => self
                .progs
                .values()
                .chain(self.plcs.values())
                .map(prog_words)
                .sum(),
        };
        let r: u64 = self.rotary.values().map(|r| u64::from(r.size)).sum();
        p + r + self.defines.words()
    }

    /// Free words (the magnitude `SIZE` reports).
    pub fn free(&self) -> u64 {
        u64::from(self.capacity).saturating_sub(self.used())
    }

    /// Prepare `id` for entry (OPEN): creates it if absent; removes the trailing RETURN.
    pub fn open(&mut self, id: BufId) -> Result<(), BufErr> {
        self.caches = Caches::default();
        match id {
            BufId::Prog(n) => {
                if !self.progs.contains_key(&n) && self.progs.len() >= MAX_PROGRAMS {
                    return Err(BufErr(ErrCode::NoRoom));
                }
                strip_return(self.progs.entry(n).or_default());
            }
            BufId::Plc(n) => strip_return(self.plcs.entry(n).or_default()),
            BufId::Rot => {}
        }
        Ok(())
    }

    /// Append a line to an open PROG/PLC (ERR006 when it does not fit, ERR009 for a closer
    /// without an opener). Nothing already stored changes on error.
    pub fn append(&mut self, id: BufId, line: L) -> Result<(), BufErr> {
        let words = u64::from(line.words());
        let used = self.prog_words()
            + self.rotary.values().map(|r| u64::from(r.size)).sum::<u64>()
            + self.defines.words();
        if words > u64::from(self.capacity).saturating_sub(used) {
            return Err(BufErr(ErrCode::NoRoom));
        }
        let cached = self.caches.nest.take();
        let prog = match self.program_mut(id) {
            Some(p) => p,
            None => return Err(BufErr(ErrCode::NeedsBuffer)),
        };
        // The nesting state at the end of the program: carried over from the last append to
        // the same program, rebuilt from its lines otherwise (a closer without an opener
        // earlier in the program does not refuse later lines).
        let mut nest = match cached {
            Some((cid, n, nest)) if cid == id && n == prog.lines.len() => nest,
            _ => {
                let mut nest = Nest::default();
                for l in &prog.lines {
                    if !nest.step(l.structure()) {
                        nest.broken = true;
                    }
                }
                nest
            }
        };
        let before = nest.clone();
        if !nest.step(line.structure()) {
            let len = prog.lines.len();
            self.caches.nest = Some((id, len, before));
            return Err(BufErr(ErrCode::Structure));
        }
        prog.lines.push(line);
        let len = prog.lines.len();
        self.caches.nest = Some((id, len, nest));
        if let Some(w) = self.caches.prog_words.as_mut() {
            *w += words;
        }
        Ok(())
    }

    /// Append a line to the rotary buffer of C.S. `cs` (ERR006 when that buffer is full,
    /// ERR005 when the C.S. has none).
    pub fn append_rotary(&mut self, cs: u8, line: L) -> Result<(), BufErr> {
        let r = self
            .rotary
            .get_mut(&cs)
            .ok_or(BufErr(ErrCode::NeedsBuffer))?;
        let used: u64 = r.lines.iter().map(|l| u64::from(l.words())).sum();
        if used + u64::from(line.words()) > u64::from(r.size) {
            return Err(BufErr(ErrCode::NoRoom));
        }
        r.lines.push(line);
        Ok(())
    }

    /// Close `id`: append RETURN to a PROG/PLC and check the structure of every PROG/PLC.
    /// `Err(ERR003)` when any program is badly structured (the buffer is closed anyway).
    pub fn close(&mut self, id: BufId) -> Result<(), BufErr> {
        self.caches = Caches::default();
        if let Some(p) = self.program_mut(id) {
            p.lines.push(L::return_line());
        }
        let mut all_ok = true;
        for p in self.progs.values_mut().chain(self.plcs.values_mut()) {
            p.valid = matches!(nesting(p.lines.iter()), Ok(0));
            all_ok &= p.valid;
        }
        if all_ok {
            Ok(())
        } else {
            Err(BufErr(ErrCode::Data))
        }
    }

    /// Empty an open buffer (`CLEAR`); for rotary, the buffer of C.S. `cs`.
    pub fn clear(&mut self, id: BufId, cs: u8) {
        self.caches = Caches::default();
        match id {
            BufId::Rot => {
                if let Some(r) = self.rotary.get_mut(&cs) {
                    r.lines.clear();
                }
            }
            _ => {
                if let Some(p) = self.program_mut(id) {
                    p.lines.clear();
                    p.valid = true;
                }
            }
        }
    }

    /// Erase a PROG or PLC (`DELETE`-like). Returns whether it existed.
    pub fn remove(&mut self, id: BufId) -> bool {
        self.caches = Caches::default();
        match id {
            BufId::Prog(n) => self.progs.remove(&n).is_some(),
            BufId::Plc(n) => self.plcs.remove(&n).is_some(),
            BufId::Rot => false,
        }
    }

    /// The stored PROG/PLC.
    pub fn program(&self, id: BufId) -> Option<&Program<L>> {
        match id {
            BufId::Prog(n) => self.progs.get(&n),
            BufId::Plc(n) => self.plcs.get(&n),
            BufId::Rot => None,
        }
    }

    fn program_mut(&mut self, id: BufId) -> Option<&mut Program<L>> {
        match id {
            BufId::Prog(n) => self.progs.get_mut(&n),
            BufId::Plc(n) => self.plcs.get_mut(&n),
            BufId::Rot => None,
        }
    }
}

fn prog_words<L: StoredLine>(p: &Program<L>) -> u64 {
    p.lines.iter().map(|l| u64::from(l.words())).sum()
}

fn strip_return<L: StoredLine>(p: &mut Program<L>) {
    if p.lines.last().is_some_and(StoredLine::is_return) {
        p.lines.pop();
    }
}

/// Render `lines` for `LIST`: without `offsets`, one text per line; with `offsets`, lines whose
/// word range intersects `[start, start+len)` prefixed `{offset}:`. A `start` inside a line lists
/// from the start of that line, so offsets always restart exactly at a line.
pub(crate) fn list_lines<L: StoredLine>(
    lines: &[L],
    render: impl Fn(&L) -> String,
    offsets: Option<(u32, Option<u32>)>,
) -> Vec<String> {
    let mut out = Vec::new();
    let mut off: u64 = 0;
    for l in lines {
        let w = u64::from(l.words());
        let text = render(l);
        match offsets {
            None => out.push(text),
            Some((start, len)) => {
                let s = u64::from(start);
                let end = len.map(|n| s + u64::from(n));
                let line_end = off + w.max(1);
                let after_start = line_end > s;
                let before_end = end.is_none_or(|e| off < e);
                if after_start && before_end {
                    out.push(format!("{off}:{text}"));
                }
            }
        }
        off += w;
    }
    out
}

#[cfg(test)]
#[path = "tests_buffers.rs"]
mod tests;
