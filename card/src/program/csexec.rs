//! One coordinate system's program state: the COORD trajectory ([`CoordSystem`]), the call
//! stack of the running program, synchronous M-variable assignments, run control (R, S, Q, A,
//! H, `/`, B, %, MFLUSH, PMATCH) and the per-servo-cycle output.

use std::collections::VecDeque;
use std::sync::Arc;

use super::compile::{compile, Compiled};
use super::config::{axis_defs, cs_axes, cs_config};
use crate::coord::cs::CoordSystem;
use crate::domain::ast::{AssignOp, AxisDef, PreludeCall};
use crate::model::CardModel;
use crate::model::Space;
use crate::motion::motor::Motor;

// Deepest CALL/GOSUB nesting (the top level counts as one): `Semantics::max_call_depth`; a
// 16th nested call is run-time error 5 on the classic profiles (spec §5.2 decision).

/// X:$0799: the run-time error code register.
pub(crate) const RUNTIME_ERROR_ADDR: u32 = 0x0799;

/// Run-time error codes (X:$0799, spec §5.2), plus this card's own 7-9.
pub(crate) mod rte {
    /// Program counter past program end (program missing or damaged while running).
    pub(crate) const PAST_END: u32 = 3;
    /// Unlinked conditional (structure the flattener could not link).
    pub(crate) const UNLINKED: u32 = 4;
    /// Subroutine stack overflow.
    pub(crate) const STACK: u32 = 5;
    /// GOTO label not found (also a `B` label missing at R/S).
    pub(crate) const LABEL: u32 = 6;
    /// [DECISION] a variable could not be read/written (bad number, read-only, out of range).
    pub(crate) const VARIABLE: u32 = 7;
    /// [DECISION] a move COORD refused (no motors, bad time/feedrate, impossible circle, TA=TS=0,
    /// position out of range, missing transformation matrix, singular matrix).
    pub(crate) const MOVE: u32 = 8;
    /// [DECISION] a kinematic routine ran too long or failed (Power: `Coord[x].ErrorStatus`
    /// 16, RunTimeError).
    pub(crate) const KINEMATICS: u32 = 9;
}

/// Which buffer a frame executes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgKey {
    /// `PROG n`.
    Prog(u16),
    /// The C.S.'s rotary buffer (one line compiled at a time).
    Rot,
}

/// One level of the call stack.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Buffer.
    pub key: ProgKey,
    /// Compiled code.
    pub code: Arc<Compiled>,
    /// Next instruction.
    pub pc: usize,
    /// READ arguments of the calling line not yet consumed (letter, value).
    pub args: Vec<(u8, f64)>,
    /// This frame is a PRELUDE call (no prelude fires inside it).
    pub prelude: bool,
    /// Local-variable stack slot of its `L0` (`ExtAt::base`).
    pub base: u32,
}

/// A synchronous assignment waiting for its move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyncOp {
    /// Variable family (M on the classic profiles).
    pub kind: crate::domain::ast::VarKind,
    /// Variable number.
    pub m: u32,
    /// `==`, `&=`, `|=`, `^=`.
    pub op: AssignOp,
    /// Value evaluated when the line was processed.
    pub v: f64,
}

/// Where a queued move came from.
#[derive(Debug, Clone)]
pub struct MoveAt {
    /// COORD move id.
    pub id: u64,
    /// Program number (0 = rotary).
    pub prog: u32,
    /// Word offset of its line.
    pub offset: u32,
    /// The call stack with the program counter just after the move.
    pub after: Vec<Frame>,
    /// Programmed axis positions at the end of the move.
    pub axes_end: crate::coord::axes::AxisVec,
    /// Motor positions (axis frame, C.S. motor order) at the end of the move: the target
    /// position register once the move starts executing.
    pub end: Vec<f64>,
    /// The sync line label in force when it was calculated.
    pub nsync: u32,
}

/// A change the program engine asks of a motor (applied by the servo loop, which owns the
/// motors).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotorUpdate {
    /// The target position register (`J=`, D:$080B) becomes this axis-frame position.
    Target(u16, f64),
    /// Add this to the motor's position bias (D:$0813).
    Bias(u16, f64),
}

/// Waiting states of the calculation.
#[derive(Debug, Clone, PartialEq)]
pub enum Wait {
    /// Calculating.
    None,
    /// HOME/HOMEZ issued to these motors; `ticks` background cycles seen since.
    Homing {
        /// Motors (1-based).
        motors: Vec<u16>,
        /// Cycles since the command.
        ticks: u32,
    },
    /// A DWELL was queued: no line after it is calculated until it has run (look-ahead
    /// stops at a dwell: seed 004 L10735, seed 000 L41027-41029; a DELAY does not stop it).
    Dwell,
}

/// Program state of one coordinate system.
#[derive(Debug)]
pub struct CsExec {
    /// C.S. number (1-based).
    pub num: u16,
    /// The trajectory (created when the C.S. first gets motors).
    pub cs: Option<CoordSystem>,
    defs: Vec<(u16, AxisDef)>,
    /// Call stack; empty = not started (R starts at the `B` pointer).
    pub frames: Vec<Frame>,
    /// Calculating (the ?? "running" bit).
    pub active: bool,
    /// Single-step (`S`): stop after the next move.
    pub step: bool,
    /// Inside BLOCKSTART..BLOCKSTOP.
    pub in_block: bool,
    /// Waiting for homing.
    pub wait: Wait,
    /// `==`-type assignments not yet bound to a move.
    pub sync_pending: Vec<SyncOp>,
    /// Assignments bound to move ids.
    pub sync_bound: VecDeque<(u64, Vec<SyncOp>)>,
    /// `PRELUDE1` call in force.
    pub prelude: Option<PreludeCall>,
    /// (frame depth, pc) where the prelude last fired (it fires once per line head).
    pub prelude_fired: Option<usize>,
    /// Axis words left over from a CALL/G-code line, executed after its RETURN.
    pub leftover: Option<Vec<(u8, f64)>>,
    /// Queued moves: id, program, word offset (`PE`), and the call stack just after the move
    /// (where a `/` stop resumes).
    pub move_at: VecDeque<MoveAt>,
    /// Compiled programs of this run.
    pub cache: Vec<(u16, Arc<Compiled>)>,
    /// A `/` stop is under way: record the stop point (ERR017) when the motion has ended.
    pub stop_pending: bool,
    /// I53 = 1 stepping: (call depth, line) of the line this `S` executes.
    pub step_line: Option<(usize, usize)>,
    /// `\` program hold (segmented LINEAR/CIRCLE): once the time base is at zero the motors
    /// leave program control and may be jogged (seed 7164-7172).
    pub hold_jog: bool,
    /// The `\` hold point has been recorded.
    hold_recorded: bool,
    /// Motor changes for the servo loop.
    pub updates: Vec<MotorUpdate>,
    /// The last sync line label passed (`N{n}` without a colon).
    pub nsync: u32,
    /// The motors' position offsets `pstore` kept (or that held before the first `pset`):
    /// what `pload` puts back.
    pub stored_offsets: Option<Vec<(u16, f64)>>,
    /// The move whose target the model's run state shows (`CsRun::target`).
    published: Option<u64>,
}

impl CsExec {
    /// Idle C.S. `num`.
    pub fn new(num: u16) -> Self {
        CsExec {
            num,
            cs: None,
            defs: Vec::new(),
            frames: Vec::new(),
            active: false,
            step: false,
            in_block: false,
            wait: Wait::None,
            sync_pending: Vec::new(),
            sync_bound: VecDeque::new(),
            prelude: None,
            prelude_fired: None,
            leftover: None,
            move_at: VecDeque::new(),
            cache: Vec::new(),
            stop_pending: false,
            step_line: None,
            hold_jog: false,
            hold_recorded: false,
            updates: Vec::new(),
            nsync: 0,
            published: None,
            stored_offsets: None,
        }
    }

    /// The target and sync label of move `exec` (the one executing) into the model's run
    /// state, when it changes.
    fn publish_target(&mut self, card: &mut CardModel, exec: Option<u64>) {
        if exec == self.published {
            return;
        }
        self.published = exec;
        let m = exec.and_then(|id| self.move_at.iter().find(|m| m.id == id));
        if let Some(r) = card.run.cs.get_mut(self.k()) {
            r.target = m.map(|m| std::array::from_fn(|k| m.axes_end[k]));
            if let Some(m) = m {
                r.nsync = m.nsync;
            }
        }
    }

    pub(super) fn k(&self) -> usize {
        self.num as usize - 1
    }

    /// Whether the trajectory still produces output (moving, aborting, or a program runs).
    pub fn busy(&self) -> bool {
        self.active || self.cs.as_ref().is_some_and(|c| !c.is_idle())
    }

    /// Follow axis-definition changes while idle (PMATCHed to the motors' commanded positions).
    pub fn sync_axes(&mut self, card: &CardModel, motors: &[Motor]) {
        if self.cs.is_some() && self.same_defs(card) {
            return;
        }
        if self.busy() {
            return;
        }
        let defs = axis_defs(card, self.num);
        let axes = cs_axes(&defs);
        let pos = commanded(motors, &axes.motors);
        let cfg = cs_config(card, self.num, &axes.motors);
        match &mut self.cs {
            Some(c) => {
                if c.set_axes(axes, &pos).is_err() {
                    return;
                }
                c.cfg = cfg;
            }
            None => self.cs = Some(CoordSystem::new(cfg, axes, &pos)),
        }
        self.defs = defs;
    }

    /// The interpreter's axis definitions of this C.S. equal the ones in use (no allocation:
    /// this runs every servo tick).
    fn same_defs(&self, card: &CardModel) -> bool {
        let mut mine = self.defs.iter();
        let all = card
            .run
            .axes
            .iter()
            .enumerate()
            .filter_map(|(k, a)| {
                a.as_ref()
                    .filter(|(c, _)| *c == self.num)
                    .map(|(_, d)| (k, d))
            })
            .all(|(k, d)| {
                mine.next()
                    .is_some_and(|(m, x)| *m as usize == k + 1 && x == d)
            });
        all && mine.next().is_none()
    }

    /// Compiled `PROG n` (cached for this run); `None` when it does not exist.
    pub fn program(&mut self, card: &CardModel, n: u16) -> Result<Option<Arc<Compiled>>, u32> {
        if let Some((_, c)) = self.cache.iter().find(|(k, _)| *k == n) {
            return Ok(Some(c.clone()));
        }
        let Some(p) = card.bufs.progs.get(&n) else {
            return Ok(None);
        };
        let c = Arc::new(compile(&p.lines, false).map_err(|_| rte::UNLINKED)?);
        if self.cache.len() >= 64 {
            self.cache.remove(0);
        }
        self.cache.push((n, c.clone()));
        Ok(Some(c))
    }

    /// Stop the program with run-time error `code` (X:$0799, ?? bit 22; motion aborted).
    pub fn runtime_error(&mut self, card: &mut CardModel, code: u32, circle: bool) {
        self.active = false;
        self.wait = Wait::None;
        if let Some(c) = &mut self.cs {
            c.abort();
        }
        self.flush_sync();
        let k = self.k();
        card.state.write(Space::X, RUNTIME_ERROR_ADDR, code);
        if let Some(f) = card.state.coords.get_mut(k) {
            f.runtime_error = true;
            f.circle_radius_error |= circle;
            f.running = false;
            f.continuous_request = false;
        }
    }

    /// Leave the `\` hold state (R, abort, B).
    pub fn end_hold_jog(&mut self) {
        self.hold_jog = false;
        self.hold_recorded = false;
    }

    /// Discard pending synchronous assignments (MFLUSH, abort).
    pub fn flush_sync(&mut self) {
        self.sync_pending.clear();
        self.sync_bound.clear();
    }

    /// One servo cycle of the trajectory: motor setpoints (C.S. motor order) or `None` when
    /// the C.S. is not producing output; applies synchronous assignments of started moves.
    pub fn tick(&mut self, card: &mut CardModel) -> Option<(Vec<u16>, Vec<f64>)> {
        if !self.busy() {
            self.publish_target(card, None);
            return None;
        }
        card.exec = crate::model::ExtAt::cs(self.num, 0, crate::model::DEFAULT_STACK_OFFSET);
        let exec = self.cs.as_ref().and_then(CoordSystem::executing);
        self.publish_target(card, exec);
        let c = self.cs.as_mut()?;
        let mut out = c.tick();
        if let Err(e) = super::kin::apply_inverse(card, self.num, c, &mut out.motors) {
            let _ = e;
            self.runtime_error(card, rte::KINEMATICS, false);
            return None;
        }
        let c = self.cs.as_mut()?;
        for id in &out.started {
            if let Some(m) = self.move_at.iter().find(|m| m.id == *id) {
                for (&x, &p) in c.motors().iter().zip(&m.end) {
                    self.updates.push(MotorUpdate::Target(x, p));
                }
            }
        }
        if self.hold_jog && c.hold_complete() {
            // `\` hold complete: the hold point is the stop point R needs (ERR017) and the
            // target position `J=` returns to; the motors are free to jog.
            if !self.hold_recorded {
                self.hold_recorded = true;
                let list = c.motors().to_vec();
                for (&x, &p) in list.iter().zip(&out.motors) {
                    self.updates.push(MotorUpdate::Target(x, p));
                }
                if let Some(r) = card.run.cs.get_mut(self.k()) {
                    r.stop_point = Some(list.into_iter().zip(out.motors).collect());
                }
            }
            return None;
        }
        for id in &out.started {
            while let Some((bid, _)) = self.sync_bound.front() {
                if *bid > *id {
                    break;
                }
                if let Some((_, ops)) = self.sync_bound.pop_front() {
                    for o in ops {
                        super::env::apply_sync(card, self.num, o.kind, o.m, o.op, o.v);
                    }
                }
            }
        }
        if !self.active && c.is_idle() && !self.sync_pending.is_empty() {
            // The program ended with assignments after its last move: they take effect when
            // the motion is complete.
            for o in std::mem::take(&mut self.sync_pending) {
                super::env::apply_sync(card, self.num, o.kind, o.m, o.op, o.v);
            }
        }
        Some((c.motors().to_vec(), out.motors))
    }
}

/// Commanded positions of `list` (1-based motor numbers) in the axis frame (commanded +
/// position bias).
pub(crate) fn commanded(motors: &[Motor], list: &[u16]) -> Vec<f64> {
    list.iter()
        .map(|&m| {
            motors
                .get((m as usize).wrapping_sub(1))
                .map_or(0.0, Motor::reported_commanded)
        })
        .collect()
}
