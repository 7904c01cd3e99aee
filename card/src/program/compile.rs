//! Flattening of stored program / PLC lines into a linear instruction list with explicit jumps
//! (pmac-commands.md §5.7, §6.4, §6.7). Block IF/ELSE/ENDIF and WHILE/ENDWHILE, one-line IF /
//! ELSE / WHILE bodies and PLC `AND (…)` / `OR (…)` continuation lines all become
//! [`Op::Branch`] / [`Op::Jump`]; every other statement is kept as [`Op::Exec`].
//!
//! Programs cannot change while a motion program runs (`OPEN PROG` is refused with ERR001), and
//! an `OPEN PLC` disables the PLC, so a compiled form stays valid while it is executed.

use crate::domain::ast::{Cond, Stmt, StmtKind};
use crate::model::ProgLine;
use crate::model::StoredLine;

/// Deepest nesting of one-line bodies (`IF (..) IF (..) X1`) accepted.
const MAX_BODY_DEPTH: u32 = 8;

/// One flat operation.
#[derive(Debug, Clone, PartialEq)]
pub enum Op {
    /// A statement executed by the executor (moves, assignments, calls, …).
    Exec(Stmt),
    /// Evaluate `cond`; when false continue at `else_to`.
    Branch {
        /// Condition.
        cond: Cond,
        /// Target when false.
        else_to: usize,
    },
    /// Unconditional jump; `back` marks loop jumps (ENDWHILE, one-line WHILE).
    Jump {
        /// Target.
        to: usize,
        /// A backward (looping) jump.
        back: bool,
    },
    /// Nothing (ENDIF, labels).
    Nop,
    /// `switch`: evaluate `value` and continue at the first case equal to it, else at
    /// `default`.
    Switch {
        /// The switch expression.
        value: crate::domain::ast::Expr,
        /// (case constant, target) in order.
        cases: Vec<(f64, usize)>,
        /// Target when no case matches (the `default:` label or the end of the block).
        default: usize,
    },
}

/// An operation with where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Instr {
    /// What to do.
    pub op: Op,
    /// Index of the source line.
    pub line: usize,
    /// First non-label statement of its line, at top level (where a PRELUDE call fires).
    pub head: bool,
}

/// A compiled program.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Compiled {
    /// Instructions; running past the end is an implicit RETURN.
    pub ops: Vec<Instr>,
    /// `N{n}` labels: (label, index of the first instruction of its line).
    pub labels: Vec<(u32, usize)>,
    /// Word offset of each source line (for `PC` / `PE`).
    pub line_offset: Vec<u32>,
}

/// A structural defect found while flattening (the run-time error "unlinked conditional").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Unlinked;

enum Open {
    If(usize),
    Else(usize),
    While(usize, usize),
    Do(usize),
    Switch(usize),
    Done,
}

/// A loop or switch being compiled: where `break` and `continue` go.
struct Breakable {
    /// `continue` target when known (a WHILE's test); `None` for a DO (patched at its end) and
    /// a switch (not a loop).
    top: Option<usize>,
    is_loop: bool,
    breaks: Vec<usize>,
    continues: Vec<usize>,
}

struct Builder {
    ops: Vec<Instr>,
    stack: Vec<Open>,
    loops: Vec<Breakable>,
    line: usize,
    plc: bool,
}

impl Builder {
    fn emit(&mut self, op: Op, head: bool) -> usize {
        self.ops.push(Instr {
            op,
            line: self.line,
            head,
        });
        self.ops.len() - 1
    }

    fn patch(&mut self, at: usize, target: usize) {
        if let Some(i) = self.ops.get_mut(at) {
            match &mut i.op {
                Op::Branch { else_to, .. } => *else_to = target,
                Op::Jump { to, .. } => *to = target,
                Op::Switch { default, .. } => *default = target,
                _ => {}
            }
        }
    }

    /// Close the innermost breakable: its breaks go to `end`, pending continues to `cont`.
    fn close_loop(&mut self, end: usize, cont: usize) -> Result<(), Unlinked> {
        let l = self.loops.pop().ok_or(Unlinked)?;
        for b in l.breaks {
            self.patch(b, end);
        }
        for c in l.continues {
            self.patch(c, cont);
        }
        Ok(())
    }

    /// `break` / `continue`.
    fn jump_out(&mut self, cont: bool, head: bool) -> Result<(), Unlinked> {
        let j = self.emit(Op::Jump { to: 0, back: cont }, head);
        let l = if cont {
            self.loops.iter_mut().rev().find(|l| l.is_loop)
        } else {
            self.loops.last_mut()
        }
        .ok_or(Unlinked)?;
        match (cont, l.top) {
            (true, Some(top)) => self.patch(j, top),
            (true, None) => l.continues.push(j),
            (false, _) => l.breaks.push(j),
        }
        Ok(())
    }

    fn here(&self) -> usize {
        self.ops.len()
    }

    /// One-line body statements (recursive for nested one-line IF / WHILE).
    fn body(&mut self, stmts: &[Stmt], depth: u32) -> Result<(), Unlinked> {
        if depth > MAX_BODY_DEPTH {
            return Err(Unlinked);
        }
        let mut k = 0;
        while k < stmts.len() {
            k = self.one(stmts, k, depth, false)?;
        }
        Ok(())
    }

    /// Compile `stmts[k]` (with look-ahead for a following ELSE); returns the next index.
    fn one(&mut self, stmts: &[Stmt], k: usize, depth: u32, head: bool) -> Result<usize, Unlinked> {
        let s = &stmts[k];
        match &s.kind {
            StmtKind::IfLine(c, body) => {
                let b = self.emit(
                    Op::Branch {
                        cond: c.clone(),
                        else_to: 0,
                    },
                    head,
                );
                self.body(body, depth + 1)?;
                match stmts.get(k + 1).map(|n| &n.kind) {
                    Some(StmtKind::Else(eb)) if !eb.is_empty() => {
                        let j = self.emit(Op::Jump { to: 0, back: false }, false);
                        let e = self.here();
                        self.patch(b, e);
                        self.body(eb, depth + 1)?;
                        let end = self.here();
                        self.patch(j, end);
                        return Ok(k + 2);
                    }
                    _ => {
                        let e = self.here();
                        self.patch(b, e);
                    }
                }
            }
            StmtKind::WhileLine(c, body) => {
                let top = self.emit(
                    Op::Branch {
                        cond: c.clone(),
                        else_to: 0,
                    },
                    head,
                );
                self.loops.push(Breakable {
                    top: Some(top),
                    is_loop: true,
                    breaks: Vec::new(),
                    continues: Vec::new(),
                });
                self.body(body, depth + 1)?;
                self.emit(
                    Op::Jump {
                        to: top,
                        back: true,
                    },
                    false,
                );
                let e = self.here();
                self.patch(top, e);
                self.close_loop(e, top)?;
            }
            StmtKind::Break => self.jump_out(false, head)?,
            StmtKind::Continue => self.jump_out(true, head)?,
            StmtKind::Label(_) => {
                self.emit(Op::Exec(s.clone()), false);
            }
            _ => {
                self.emit(Op::Exec(s.clone()), head);
            }
        }
        Ok(k + 1)
    }
}

/// Fold `AND (…)` / `OR (…)` continuation lines after line `i` into `first` (ANDs bind tighter
/// than ORs, §6.7). Returns the condition and the number of continuation lines consumed.
fn fold_conditions(first: &Cond, lines: &[ProgLine], i: usize) -> (Cond, usize) {
    let mut groups: Vec<Cond> = Vec::new();
    let mut cur = first.clone();
    let mut used = 0;
    for l in lines.iter().skip(i + 1) {
        match l.stmts.first().map(|s| &s.kind) {
            Some(StmtKind::AndCond(c)) => cur = Cond::And(Box::new(cur), Box::new(c.clone())),
            Some(StmtKind::OrCond(c)) => {
                groups.push(cur);
                cur = c.clone();
            }
            _ => break,
        }
        used += 1;
    }
    let mut out = cur;
    while let Some(g) = groups.pop() {
        out = Cond::Or(Box::new(g), Box::new(out));
    }
    (out, used)
}

/// Flatten `lines`. `plc` enables AND/OR continuation lines.
pub(crate) fn compile(lines: &[ProgLine], plc: bool) -> Result<Compiled, Unlinked> {
    let mut b = Builder {
        ops: Vec::new(),
        stack: Vec::new(),
        loops: Vec::new(),
        line: 0,
        plc,
    };
    let mut labels = Vec::new();
    let mut line_offset = Vec::with_capacity(lines.len());
    let mut off = 0u32;
    for l in lines {
        line_offset.push(off);
        off = off.saturating_add(l.words());
    }
    // Whether the previous line was a one-line IF whose jump-over-ELSE must be patched.
    let mut after_if_line: Option<(usize, usize)> = None;
    let mut i = 0;
    while i < lines.len() {
        b.line = i;
        let stmts = &lines[i].stmts;
        let first_op = b.here();
        let mut k = 0;
        let mut head = true;
        let pending_if = after_if_line.take();
        while k < stmts.len() {
            let s = &stmts[k];
            if let StmtKind::Label(n) = s.kind {
                labels.push((n, first_op));
                b.emit(Op::Nop, false);
                k += 1;
                continue;
            }
            let h = std::mem::replace(&mut head, false);
            match &s.kind {
                StmtKind::If(c) => {
                    let (cond, used) = if b.plc {
                        fold_conditions(c, lines, i)
                    } else {
                        (c.clone(), 0)
                    };
                    let at = b.emit(Op::Branch { cond, else_to: 0 }, h);
                    b.stack.push(Open::If(at));
                    i += used;
                }
                StmtKind::While(c) => {
                    let (cond, used) = if b.plc {
                        fold_conditions(c, lines, i)
                    } else {
                        (c.clone(), 0)
                    };
                    let at = b.emit(Op::Branch { cond, else_to: 0 }, h);
                    b.stack.push(Open::While(at, at));
                    b.loops.push(Breakable {
                        top: Some(at),
                        is_loop: true,
                        breaks: Vec::new(),
                        continues: Vec::new(),
                    });
                    i += used;
                }
                StmtKind::Do => {
                    let at = b.emit(Op::Nop, h);
                    b.stack.push(Open::Do(at));
                    b.loops.push(Breakable {
                        top: None,
                        is_loop: true,
                        breaks: Vec::new(),
                        continues: Vec::new(),
                    });
                }
                StmtKind::DoWhile(c) => match b.stack.pop() {
                    Some(Open::Do(top)) => {
                        let test = b.here();
                        let br = b.emit(
                            Op::Branch {
                                cond: c.clone(),
                                else_to: 0,
                            },
                            h,
                        );
                        b.emit(
                            Op::Jump {
                                to: top,
                                back: true,
                            },
                            false,
                        );
                        let e = b.here();
                        b.patch(br, e);
                        b.close_loop(e, test)?;
                    }
                    _ => return Err(Unlinked),
                },
                StmtKind::Switch(e) => {
                    let at = b.emit(
                        Op::Switch {
                            value: e.clone(),
                            cases: Vec::new(),
                            default: usize::MAX,
                        },
                        h,
                    );
                    b.stack.push(Open::Switch(at));
                    b.loops.push(Breakable {
                        top: None,
                        is_loop: false,
                        breaks: Vec::new(),
                        continues: Vec::new(),
                    });
                }
                StmtKind::Case(_) | StmtKind::Default => {
                    let Some(Open::Switch(at)) = b.stack.last() else {
                        return Err(Unlinked);
                    };
                    let (at, here) = (*at, b.here());
                    if let Some(Op::Switch { cases, default, .. }) =
                        b.ops.get_mut(at).map(|i| &mut i.op)
                    {
                        match &s.kind {
                            StmtKind::Case(v) => cases.push((*v, here)),
                            _ => *default = here,
                        }
                    }
                    b.emit(Op::Nop, false);
                }
                StmtKind::EndSwitch => match b.stack.pop() {
                    Some(Open::Switch(at)) => {
                        let e = b.here();
                        if let Some(Op::Switch { default, .. }) =
                            b.ops.get_mut(at).map(|i| &mut i.op)
                        {
                            if *default == usize::MAX {
                                *default = e;
                            }
                        }
                        b.emit(Op::Nop, false);
                        b.close_loop(e, e)?;
                    }
                    _ => return Err(Unlinked),
                },
                StmtKind::Else(body) => {
                    if k == 0
                        || stmts[..k]
                            .iter()
                            .all(|s| matches!(s.kind, StmtKind::Label(_)))
                    {
                        if let Some((branch, jump)) = pending_if {
                            // ELSE line belonging to the one-line IF of the previous line.
                            let _ = branch;
                            if body.is_empty() {
                                b.stack.push(Open::Else(jump));
                                let e = b.here();
                                b.patch(branch, e);
                            } else {
                                let e = b.here();
                                b.patch(branch, e);
                                b.body(body, 1)?;
                                let end = b.here();
                                b.patch(jump, end);
                            }
                            k += 1;
                            continue;
                        }
                    }
                    match b.stack.pop() {
                        Some(Open::If(br)) => {
                            let j = b.emit(Op::Jump { to: 0, back: false }, h);
                            let e = b.here();
                            b.patch(br, e);
                            if body.is_empty() {
                                b.stack.push(Open::Else(j));
                            } else {
                                b.body(body, 1)?;
                                let end = b.here();
                                b.patch(j, end);
                                b.stack.push(Open::Done);
                            }
                        }
                        _ => return Err(Unlinked),
                    }
                }
                StmtKind::EndIf => {
                    match b.stack.pop() {
                        Some(Open::If(at)) | Some(Open::Else(at)) => {
                            let e = b.here();
                            b.patch(at, e);
                        }
                        Some(Open::Done) => {}
                        _ => return Err(Unlinked),
                    }
                    b.emit(Op::Nop, false);
                }
                StmtKind::EndWhile => match b.stack.pop() {
                    Some(Open::While(top, br)) => {
                        b.emit(
                            Op::Jump {
                                to: top,
                                back: true,
                            },
                            h,
                        );
                        let e = b.here();
                        b.patch(br, e);
                        b.close_loop(e, top)?;
                    }
                    _ => return Err(Unlinked),
                },
                StmtKind::IfLine(..) if k + 1 == stmts.len() => {
                    // A one-line IF ending its line: an ELSE on the next line belongs to it.
                    let br = b.here();
                    k = b.one(stmts, k, 0, h)?;
                    let next_else = lines.get(i + 1).is_some_and(|n| {
                        n.stmts
                            .iter()
                            .find(|s| !matches!(s.kind, StmtKind::Label(_)))
                            .is_some_and(|s| matches!(s.kind, StmtKind::Else(_)))
                    });
                    if next_else {
                        let j = b.emit(Op::Jump { to: 0, back: false }, false);
                        let e = b.here();
                        b.patch(br, e);
                        after_if_line = Some((br, j));
                    }
                    continue;
                }
                StmtKind::AndCond(_) | StmtKind::OrCond(_) => return Err(Unlinked),
                _ => {
                    k = b.one(stmts, k, 0, h)?;
                    continue;
                }
            }
            k += 1;
        }
        i += 1;
    }
    if !b.stack.is_empty() {
        return Err(Unlinked);
    }
    Ok(Compiled {
        ops: b.ops,
        labels,
        line_offset,
    })
}

/// Where a `switch` on `v` continues: the first case equal to `v`, else `default`.
pub(crate) fn switch_target(v: f64, cases: &[(f64, usize)], default: usize) -> usize {
    cases
        .iter()
        .find(|(c, _)| *c == v)
        .map_or(default, |(_, t)| *t)
}

impl Compiled {
    /// Instruction index of label `n` (N0 = the top); for duplicates the first at or after
    /// `from`, else the first from the top.
    pub fn label(&self, n: u32, from: usize) -> Option<usize> {
        if n == 0 {
            return Some(0);
        }
        let mut first = None;
        for &(l, at) in &self.labels {
            if l == n {
                if at >= from {
                    return Some(at);
                }
                first = first.or(Some(at));
            }
        }
        first
    }

    /// Word offset of the line of instruction `at` (end of program: total words).
    pub fn offset_of(&self, at: usize) -> u32 {
        match self.ops.get(at) {
            Some(i) => self.line_offset.get(i.line).copied().unwrap_or(0),
            None => self.line_offset.last().copied().unwrap_or(0),
        }
    }
}
