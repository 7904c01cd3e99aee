//! The motion-program executor: one calculation pass of a coordinate system walks the flat
//! program (see [`super::compile`]) from its program counter, executing non-motion statements
//! as it goes and feeding moves to COORD while the look-ahead wants them (two moves ahead,
//! pmac-commands.md §5.2). A pass also ends at WAIT, at the second backward jump without a move
//! (the double-jump-back rule), in step mode after a move, or after [`MAX_OPS_PER_PASS`]
//! instructions, so a program looping without moves never stalls the card.

use std::sync::Arc;

use super::compile::{compile, Op};
use super::csexec::{commanded, rte, CsExec, Frame, ProgKey, Wait};
use super::env;
use super::stmt::QueuedCmd;
use crate::coord::moves::{Feed, Mode};
use crate::domain::ast::{CodeLetter, LetterArg, PreludeCall, StmtKind};
use crate::model::CardModel;
use crate::model::MoveMode as StatusMode;
use crate::model::ProgLine;
use crate::motion::motor::Motor;

/// Most instructions one calculation pass executes.
pub(crate) const MAX_OPS_PER_PASS: u32 = 1000;

/// Outcome of one statement.
pub(super) enum Flow {
    /// Continue with the next instruction.
    Next,
    /// A move (or DWELL/DELAY) was queued.
    Moved,
    /// A motion statement while the look-ahead is full: retry it next pass.
    Wait,
    /// Continue with the next instruction in a later pass.
    Yield,
    /// The statement moved the program counter itself.
    Jumped,
    /// `STOP`: halt after this statement.
    Stop,
    /// A run-time error stopped the program.
    Error,
}

/// Everything a pass needs besides the C.S. itself.
pub struct PassIo<'a> {
    /// Queued CMDs.
    pub cmds: &'a mut Vec<QueuedCmd>,
    /// Unsolicited output.
    pub out: &'a mut Vec<u8>,
    /// The command language.
    pub cmd: &'a mut dyn super::stmt::Commands,
}

fn status_mode(m: Mode) -> StatusMode {
    match m {
        Mode::Linear => StatusMode::Linear,
        Mode::Rapid => StatusMode::Rapid,
        Mode::Circle1 => StatusMode::Circle1,
        Mode::Circle2 => StatusMode::Circle2,
        Mode::Pvt => StatusMode::Pvt,
        Mode::Spline1 => StatusMode::Spline,
    }
}

/// `??` word 2 bit 2: cutter compensation on.
const CC_ON: u32 = 1 << 2;
/// `??` word 2 bit 3: cutter compensation to the left.
const CC_LEFT: u32 = 1 << 3;

/// `??` word-1 (feedrate bit, incremental bit) of axis index k (X..W).
fn axis_bits(k: usize) -> (u32, u32) {
    const F: [u32; 9] = [19, 21, 23, 7, 9, 11, 13, 15, 17];
    (1 << F[k], 1 << (F[k] - 1))
}

impl CsExec {
    pub(super) fn set_pc(&mut self, pc: usize) {
        if let Some(f) = self.frames.last_mut() {
            f.pc = pc;
        }
    }

    /// Copy on-line ABS/INC/FRAX (`??` word 1) into the modal state (at R/S).
    pub fn modal_from_flags(&mut self, card: &CardModel) {
        let (Some(c), Some(f)) = (&mut self.cs, card.state.coords.get(self.num as usize - 1))
        else {
            return;
        };
        for k in 0..9 {
            let (fb, ib) = axis_bits(k);
            c.modal.inc[k] = f.axis_bits & ib != 0;
            c.modal.frax[k] = f.axis_bits & fb != 0;
        }
        c.modal.centre_abs = !f.radius_inc;
    }

    fn flags_from_modal(&self, card: &mut CardModel) {
        let (Some(c), Some(f)) = (&self.cs, card.state.coords.get_mut(self.num as usize - 1))
        else {
            return;
        };
        let mut bits = 0;
        for k in 0..9 {
            let (fb, ib) = axis_bits(k);
            if c.modal.inc[k] {
                bits |= ib;
            }
            if c.modal.frax[k] {
                bits |= fb;
            }
        }
        f.axis_bits = bits;
        f.radius_inc = !c.modal.centre_abs;
        f.mode = status_mode(c.modal.mode);
        f.move_by_time = matches!(c.modal.feed, Feed::Time(_));
        // `??` word 2 bit 2 cutter compensation on, bit 3 to the left (seed 004 7006-7008).
        let cc = match c.modal.cutter {
            1 => CC_ON | CC_LEFT,
            2 => CC_ON,
            _ => 0,
        };
        f.other2 = (f.other2 & !(CC_ON | CC_LEFT)) | cc;
    }

    /// Waiting for homing or a dwell: `true` when calculation may go on.
    fn check_wait(&mut self, motors: &[Motor]) -> bool {
        if matches!(self.wait, Wait::Dwell) {
            // The dwell, and every move queued before it, has run.
            if self.cs.as_ref().is_some_and(|c| !c.is_idle()) {
                return false;
            }
            self.wait = Wait::None;
            return true;
        }
        let Wait::Homing {
            motors: list,
            ticks,
        } = &mut self.wait
        else {
            return true;
        };
        *ticks += 1;
        // Homing and triggered moves: wait for the search and the post-trigger move.
        let searching = list.iter().any(|&m| {
            motors.get(m as usize - 1).is_some_and(|x| {
                x.flags.home_search || (x.closed_loop() && !x.trajectory().finished())
            })
        });
        if *ticks < 3 || searching {
            return false;
        }
        self.wait = Wait::None;
        if let Some(c) = &mut self.cs {
            let pos = commanded(motors, c.motors());
            c.pmatch(&pos);
        }
        true
    }

    /// Motors homing under this program (no setpoints for them).
    pub fn homing(&self) -> &[u16] {
        match &self.wait {
            Wait::Homing { motors, .. } => motors,
            Wait::None | Wait::Dwell => &[],
        }
    }

    /// One calculation pass.
    pub fn calc(&mut self, card: &mut CardModel, motors: &[Motor], io: &mut PassIo<'_>) {
        if !self.active {
            return;
        }
        if !self.check_wait(motors) {
            // Waiting (a home search, a dwell): the moves go on, PE/PC follow them.
            self.report_pc(card);
            return;
        }
        card.exec = self.exec_at(card);
        let mut back = 0;
        let mut budget = MAX_OPS_PER_PASS;
        let line_step = self.step && env::ivar(card, 53, 0.0) != 0.0;
        while self.active && budget > 0 {
            budget -= 1;
            if let Some(words) = self.leftover.take() {
                match self.leftover_move(card, &words) {
                    Flow::Wait => {
                        self.leftover = Some(words);
                        break;
                    }
                    Flow::Error => break,
                    _ => continue,
                }
            }
            let Some(f) = self.frames.last() else {
                self.finish(card, None);
                break;
            };
            if f.key == ProgKey::Rot && f.pc >= f.code.ops.len() {
                if !self.next_rotary_line(card) {
                    break;
                }
                continue;
            }
            let (code, pc, depth, in_prelude, key) =
                (f.code.clone(), f.pc, self.frames.len(), f.prelude, f.key);
            let Some(instr) = code.ops.get(pc) else {
                self.do_return(card);
                continue;
            };
            if line_step && !self.in_block {
                // I53 = 1: one program line per S.
                let here = (depth, instr.line);
                match self.step_line {
                    Some(l) if l != here => {
                        self.active = false;
                        break;
                    }
                    None => self.step_line = Some(here),
                    _ => {}
                }
            }
            match &instr.op {
                Op::Nop => self.set_pc(pc + 1),
                Op::Jump { to, back: b } => {
                    self.set_pc(*to);
                    if *b {
                        back += 1;
                        if back >= 2 {
                            break;
                        }
                    }
                }
                Op::Branch { cond, else_to } => match env::test(card, self.num, cond) {
                    Ok(t) => self.set_pc(if t { pc + 1 } else { *else_to }),
                    Err(_) => {
                        self.runtime_error(card, rte::VARIABLE, false);
                        break;
                    }
                },
                Op::Switch {
                    value,
                    cases,
                    default,
                } => match env::value(card, self.num, value) {
                    Ok(v) => self.set_pc(super::compile::switch_target(v, cases, *default)),
                    Err(_) => {
                        self.runtime_error(card, rte::VARIABLE, false);
                        break;
                    }
                },
                Op::Exec(s) => {
                    let fire = instr.head
                        && depth == 1
                        && !in_prelude
                        && matches!(key, ProgKey::Prog(_))
                        && matches!(s.kind, StmtKind::Move(_) | StmtKind::Code(..))
                        && self.prelude_fired != Some(pc);
                    if fire {
                        if let Some(p) = self.prelude.clone() {
                            self.prelude_fired = Some(pc);
                            self.fire_prelude(card, &p);
                            continue;
                        }
                    }
                    let flow = self.exec(card, motors, s, io);
                    if depth == 1 && !matches!(flow, Flow::Wait) {
                        self.prelude_fired = None;
                    }
                    match flow {
                        Flow::Next => self.set_pc(pc + 1),
                        Flow::Moved => {
                            self.set_pc(pc + 1);
                            back = 0;
                            if self.step && !self.in_block {
                                self.active = false;
                            }
                            if matches!(self.wait, Wait::Dwell) {
                                // Nothing after a dwell is calculated before it has run.
                                break;
                            }
                        }
                        Flow::Wait | Flow::Error => break,
                        Flow::Yield => {
                            self.set_pc(pc + 1);
                            break;
                        }
                        Flow::Jumped if matches!(s.kind, StmtKind::Goto(_)) => {
                            if let Some(f) = self.frames.last() {
                                if f.pc <= pc && Arc::ptr_eq(&f.code, &code) {
                                    back += 1;
                                    if back >= 2 {
                                        break;
                                    }
                                }
                            }
                        }
                        Flow::Jumped => {}
                        Flow::Stop => {
                            self.set_pc(pc + 1);
                            self.active = false;
                        }
                    }
                }
            }
        }
        if !self.active {
            self.halted(card);
        }
        self.flags_from_modal(card);
        self.report_pc(card);
    }

    /// Calculation stopped (STOP, step done, Q): the ?? running bit drops.
    pub(super) fn halted(&mut self, card: &mut CardModel) {
        if let Some(f) = card.state.coords.get_mut(self.num as usize - 1) {
            f.running = false;
            f.continuous_request = false;
            if self.step {
                f.single_step = true;
            }
        }
    }

    /// End of the top-level program: stop; the next R starts at the top of `prog`.
    pub(super) fn finish(&mut self, card: &mut CardModel, prog: Option<u16>) {
        self.active = false;
        self.frames.clear();
        let k = self.num as usize - 1;
        if let (Some(n), Some(r)) = (prog, card.run.cs.get_mut(k)) {
            r.pointer = Some((u32::from(n), 0));
        }
        self.halted(card);
    }

    fn next_rotary_line(&mut self, card: &mut CardModel) -> bool {
        let line = card
            .bufs
            .rotary
            .get_mut(&(self.num as u8))
            .filter(|r| !r.lines.is_empty())
            .map(|r| r.lines.remove(0));
        let Some(line) = line else { return false };
        match compile(std::slice::from_ref::<ProgLine>(&line), false) {
            Ok(c) => {
                if let Some(f) = self.frames.last_mut() {
                    f.code = Arc::new(c);
                    f.pc = 0;
                }
                true
            }
            Err(_) => {
                self.runtime_error(card, rte::UNLINKED, false);
                false
            }
        }
    }

    pub(super) fn do_return(&mut self, card: &mut CardModel) {
        let Some(f) = self.frames.pop() else { return };
        card.exec = self.exec_at(card);
        if self.frames.is_empty() {
            let prog = match f.key {
                ProgKey::Prog(n) => Some(n),
                ProgKey::Rot => None,
            };
            self.finish(card, prog);
            return;
        }
        if !f.args.is_empty() {
            self.leftover = Some(f.args);
        }
    }

    pub(super) fn push_frame(&mut self, card: &mut CardModel, f: Frame) -> Flow {
        if self.frames.len() >= usize::from(card.state.limits().sem.max_call_depth) {
            self.runtime_error(card, rte::STACK, false);
            return Flow::Error;
        }
        self.frames.push(f);
        card.exec = self.exec_at(card);
        Flow::Jumped
    }

    /// Where the running program's variables are: its frame's stack base and its buffer's
    /// stack offset.
    pub(super) fn exec_at(&self, card: &CardModel) -> crate::model::ExtAt {
        let (base, offset) = self
            .frames
            .last()
            .map_or((0, crate::model::DEFAULT_STACK_OFFSET), |f| {
                (f.base, frame_offset(card, f.key))
            });
        crate::model::ExtAt::cs(self.num, base, offset)
    }

    /// Motor `m`'s position bias with the changes this C.S. has asked and the servo loop has
    /// not applied yet.
    pub(super) fn bias_now(&self, motors: &[Motor], m: u16) -> f64 {
        let applied = motors
            .get(usize::from(m).wrapping_sub(1))
            .map_or(0.0, |x| x.pos_bias);
        let pending: f64 = self
            .updates
            .iter()
            .filter_map(|u| match u {
                super::csexec::MotorUpdate::Bias(x, d) if *x == m => Some(*d),
                _ => None,
            })
            .sum();
        applied + pending
    }

    /// The stack base of a subroutine the running program calls with a new frame of locals
    /// (`call`, `callsub`; `gosub` keeps the caller's).
    pub(super) fn callee_base(&self, card: &CardModel) -> u32 {
        self.frames
            .last()
            .map_or(0, |f| f.base.saturating_add(frame_offset(card, f.key)))
    }

    pub(super) fn args(
        &mut self,
        card: &mut CardModel,
        args: &[LetterArg],
    ) -> Result<Vec<(u8, f64)>, ()> {
        let mut v = Vec::with_capacity(args.len());
        for a in args {
            v.push((
                a.letter,
                env::value(card, self.num, &a.value).map_err(|_| ())?,
            ));
        }
        Ok(v)
    }

    /// CALL of `PROG prog` at label `label` (missing program or label: ignored).
    pub(super) fn call(
        &mut self,
        card: &mut CardModel,
        prog: u32,
        label: u32,
        args: Vec<(u8, f64)>,
        prelude: bool,
    ) -> Flow {
        let strict = card.state.limits().sem.strict_calls;
        let missing = |me: &mut Self, card: &mut CardModel| {
            if strict {
                me.runtime_error(card, rte::LABEL, false);
                Flow::Error
            } else {
                Flow::Next
            }
        };
        let Ok(n) = u16::try_from(prog) else {
            return missing(self, card);
        };
        let code = match self.program(card, n) {
            Ok(Some(c)) => c,
            Ok(None) => return missing(self, card),
            Err(e) => {
                self.runtime_error(card, e, false);
                return Flow::Error;
            }
        };
        let Some(pc) = code.label(label, 0).or(strict.then_some(0)) else {
            return Flow::Next;
        };
        self.push_frame(
            card,
            Frame {
                key: ProgKey::Prog(n),
                code,
                pc,
                args,
                prelude,
                base: self.callee_base(card),
            },
        )
    }

    pub(super) fn fire_prelude(&mut self, card: &mut CardModel, p: &PreludeCall) {
        let (prog, label) = match p {
            PreludeCall::Call(n) => call_target_for(card, n.value),
            PreludeCall::Code(l, n) => code_target_for(card, self.num, *l, n.value),
        };
        let f = self.call(card, prog, label, Vec::new(), true);
        if matches!(f, Flow::Jumped) {
            // Return lands on the line head again (prelude_fired stops a second firing).
        }
    }
}

pub(super) fn label_number(v: f64) -> u32 {
    if v.is_finite() && v >= 0.0 {
        v.round().min(f64::from(u32::MAX)) as u32
    } else {
        u32::MAX
    }
}

/// `CALL{v}`: program int(v) at label N(frac × 100000).
pub(crate) fn call_target(v: f64) -> (u32, u32) {
    if !(0.0..4_294_967_296.0).contains(&v) {
        return (0, 0);
    }
    let p = v.trunc();
    (p as u32, ((v - p) * 100_000.0).round() as u32)
}

/// `CALL{v}` with the card's semantics: buffer and label.
pub(crate) fn call_target_for(card: &CardModel, v: f64) -> (u32, u32) {
    let sem = card.state.limits().sem;
    if sem.subprog_base == 0 && sem.call_label_scale == 100_000.0 {
        return call_target(v);
    }
    if !(0.0..32_768.0).contains(&v) {
        return (u32::MAX, 0);
    }
    let p = v.trunc();
    (
        u32::from(sem.subprog_base) + p as u32,
        ((v - p) * sem.call_label_scale).round() as u32,
    )
}

/// G/M/T/D{c} with the card's semantics (C.S. `cs`): buffer and label.
pub(crate) fn code_target_for(card: &CardModel, cs: u16, l: CodeLetter, c: f64) -> (u32, u32) {
    let sem = card.state.limits().sem;
    let Some(base) = sem.code_prog_ivar else {
        return code_target(l, c);
    };
    let k = match l {
        CodeLetter::G => 0,
        CodeLetter::M => 1,
        CodeLetter::T => 2,
        CodeLetter::D => 3,
    };
    let n = super::env::cs_ivar(card.profile(), cs, u32::from(base) + k);
    let prog = super::env::ivar(card, n, f64::from(1000 + k));
    if !(c.is_finite() && c >= 0.0 && (0.0..32_768.0).contains(&prog)) {
        return (u32::MAX, 0);
    }
    (
        u32::from(sem.subprog_base) + prog as u32,
        (c * 1000.0).round().min(f64::from(u32::MAX)) as u32,
    )
}

/// G/M/T/D{c}: PROG 1000 + 10·hundreds + k at label N(rest × 1000).
pub(crate) fn code_target(l: CodeLetter, c: f64) -> (u32, u32) {
    if !(c.is_finite() && (0.0..1000.0).contains(&c)) {
        return (0, 0);
    }
    let h = (c / 100.0).floor();
    let r = c - 100.0 * h;
    let k = match l {
        CodeLetter::G => 0,
        CodeLetter::M => 1,
        CodeLetter::T => 2,
        CodeLetter::D => 3,
    };
    (1000 + 10 * h as u32 + k, (r * 1000.0).round() as u32)
}

/// The stack offset of the buffer a frame runs.
fn frame_offset(card: &CardModel, key: ProgKey) -> u32 {
    match key {
        ProgKey::Prog(n) => card.stack_offset(crate::model::StackOf::Prog(n)),
        _ => crate::model::DEFAULT_STACK_OFFSET,
    }
}
