//! Statement dispatch of the motion-program executor ([`super::motion`]): what each program
//! statement does to the program counter, the modal state, the move queue and the card.

use super::csexec::{rte, CsExec, Frame, SyncOp};
use super::env;
use super::motion::{call_target_for, code_target_for, label_number, Flow, PassIo};
use super::motion_move::qs;
use super::stmt::{exec_common, Common, Ctx};
use crate::coord::axes::axis_index;
use crate::coord::moves::Mode;
use crate::domain::ast::{AssignOp, Axis, MoveMode, Stmt, StmtKind};
use crate::model::CardModel;
use crate::motion::motor::Motor;

impl CsExec {
    pub(super) fn exec(
        &mut self,
        card: &mut CardModel,
        motors: &[Motor],
        s: &Stmt,
        io: &mut PassIo<'_>,
    ) -> Flow {
        use StmtKind as S;
        let num = self.num;
        let pc = self.frames.last().map_or(0, |f| f.pc);
        match &s.kind {
            S::Label(_) | S::AndCond(_) | S::OrCond(_) | S::EndIf | S::EndWhile => Flow::Next,
            S::Assign {
                target,
                op:
                    op @ (AssignOp::SyncSet
                    | AssignOp::SyncAnd
                    | AssignOp::SyncOr
                    | AssignOp::SyncXor
                    | AssignOp::SyncOp(_)),
                value,
            } => {
                let (Ok(m), Ok(v)) = (
                    env::var_number(card, num, target),
                    env::value(card, num, value),
                ) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                if self.sync_pending.len() < 256 {
                    self.sync_pending.push(SyncOp {
                        kind: target.kind,
                        m,
                        op: *op,
                        v,
                    });
                }
                Flow::Next
            }
            S::Move(words) => self.move_line(card, motors, words),
            S::Mode(m) => self.modal(card, |c| {
                c.modal.mode = match m {
                    MoveMode::Linear => Mode::Linear,
                    MoveMode::Rapid => Mode::Rapid,
                    MoveMode::Circle1 => Mode::Circle1,
                    MoveMode::Circle2 => Mode::Circle2,
                    MoveMode::Spline1 | MoveMode::Spline2 => Mode::Spline1,
                };
                Ok(())
            }),
            S::Pvt(e) | S::Ta(e) | S::Td(e) | S::Spline(e) | S::Ts(e) | S::Tm(e) | S::F(e) => {
                let Ok(v) = env::value(card, num, e) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                let power = card.profile() == crate::domain::Profile::Power;
                let flow = self.modal(card, |c| match &s.kind {
                    S::Pvt(_) => c.modal.set_pvt(v),
                    S::Ta(_) if power => c.modal.set_ta_only(v),
                    S::Ta(_) => c.modal.set_ta(v),
                    S::Td(_) => c.modal.set_td(v),
                    S::Spline(_) => c.modal.set_spline(v),
                    S::Ts(_) => c.modal.set_ts(v),
                    S::Tm(_) => c.modal.set_tm(v),
                    _ => c.modal.set_f(v),
                });
                if matches!(s.kind, S::F(_) | S::Tm(_)) && !matches!(flow, Flow::Error) {
                    // Polled, Ix89 reports the most recent F or TM (seed 4541-4543). Power's
                    // `Coord[x].Tm` keeps an F as its negative (feedrate mode; seed 000
                    // L5133-5135, L41209-41210).
                    let n = env::cs_ivar(card.profile(), num, 89);
                    let kept = if power && matches!(s.kind, S::F(_)) {
                        -v
                    } else {
                        v
                    };
                    card.state.vars.force_i(n, kept);
                }
                if power && matches!(s.kind, S::Ta(_) | S::Td(_)) && !matches!(flow, Flow::Error) {
                    // Power: `ta` sets `Coord[x].Ta` and `Coord[x].Td`, `td` the latter
                    // (seed L4974-4975, L5017-5019).
                    let p = card.profile();
                    if matches!(s.kind, S::Ta(_)) {
                        card.state.vars.force_i(env::cs_ivar(p, num, 87), v);
                    }
                    card.state.vars.force_i(env::cs_ivar(p, num, 80), v);
                }
                flow
            }
            S::Abs(list) | S::Inc(list) => {
                let inc = matches!(s.kind, S::Inc(_));
                self.modal(card, |c| {
                    match list {
                        None => c.modal.inc = [inc; 9],
                        Some(l) => {
                            for a in l {
                                match axis_index(*a) {
                                    Some(k) => c.modal.inc[k] = inc,
                                    None if *a == Axis::R => c.modal.centre_abs = !inc,
                                    None => {}
                                }
                            }
                        }
                    }
                    Ok(())
                })
            }
            S::Frax(list) => self.modal(card, |c| {
                c.modal.frax = match list {
                    None => [true; 9],
                    Some(l) => {
                        let mut f = [false; 9];
                        l.iter()
                            .filter_map(|a| axis_index(*a))
                            .for_each(|k| f[k] = true);
                        f
                    }
                };
                Ok(())
            }),
            S::Dwell(e) | S::Delay(e) => {
                let Ok(v) = env::value(card, num, e) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                let dwell = matches!(s.kind, S::Dwell(_));
                let flow = self.queue(card, |c| {
                    if dwell { c.dwell(v) } else { c.delay(v) }.map(Some)
                });
                if dwell && matches!(flow, Flow::Moved) {
                    self.wait = super::csexec::Wait::Dwell;
                }
                flow
            }
            S::Home(list) | S::HomeZ(list) => self.home(card, list, matches!(s.kind, S::Home(_))),
            S::Pmatch => {
                // As the on-line `pmatch`, once the moves before it have ended.
                if self.cs.as_ref().is_some_and(|c| !c.is_idle()) {
                    return Flow::Wait;
                }
                if let Some(c) = &mut self.cs {
                    let pos = super::csexec::commanded(motors, c.motors());
                    c.pmatch(&pos);
                    if super::kin::apply_forward(card, num, c, &pos).is_err() {
                        self.runtime_error(card, rte::KINEMATICS, false);
                        return Flow::Error;
                    }
                }
                Flow::Next
            }
            S::Pstore | S::Pload => {
                // As `pset`, once the moves before it have ended.
                if self.cs.as_ref().is_some_and(|c| !c.is_idle()) {
                    return Flow::Wait;
                }
                let Some(c) = &mut self.cs else {
                    return Flow::Next;
                };
                let list = c.motors().to_vec();
                let now: Vec<(u16, f64)> = list
                    .iter()
                    .map(|&m| (m, self.bias_now(motors, m)))
                    .collect();
                if matches!(s.kind, S::Pstore) {
                    self.stored_offsets = Some(now);
                } else if let Some(kept) = self.stored_offsets.clone() {
                    for &(m, b) in &now {
                        if let Some(&(_, k)) = kept.iter().find(|(x, _)| *x == m) {
                            self.updates
                                .push(super::csexec::MotorUpdate::Bias(m, k - b));
                        }
                    }
                    // The axes follow the motors' new zero.
                    if let Some(c) = &mut self.cs {
                        let pos = super::csexec::commanded(motors, c.motors());
                        let shifted: Vec<f64> = c
                            .motors()
                            .iter()
                            .zip(&pos)
                            .map(|(m, p)| {
                                // `p` is before the bias changes not yet applied; the motor
                                // ends at its kept offset: p + (kept − applied).
                                let applied = motors
                                    .get(usize::from(*m).wrapping_sub(1))
                                    .map_or(0.0, |x| x.pos_bias);
                                let k = kept.iter().find(|(x, _)| x == m).map_or(applied, |e| e.1);
                                p + (k - applied)
                            })
                            .collect();
                        c.pmatch(&shifted);
                    }
                }
                Flow::Next
            }
            S::Pset(words) => {
                // PSET forces a stop (no blending through it), then renames the programmed
                // position through the motors' position bias (seed 11441-11452).
                if self.cs.as_ref().is_some_and(|c| !c.is_idle()) {
                    return Flow::Wait;
                }
                let mut vals = Vec::with_capacity(words.len());
                for w in words {
                    let v = match env::value(card, num, &w.value) {
                        Ok(v) if v.is_finite() => v,
                        _ => {
                            self.runtime_error(card, rte::VARIABLE, false);
                            return Flow::Error;
                        }
                    };
                    if let Some(k) = axis_index(w.axis) {
                        vals.push((k, v));
                    }
                }
                if let (None, Some(c)) = (&self.stored_offsets, &self.cs) {
                    let list = c.motors().to_vec();
                    let before = list
                        .iter()
                        .map(|&m| (m, self.bias_now(motors, m)))
                        .collect();
                    self.stored_offsets = Some(before);
                }
                if let Some(c) = &mut self.cs {
                    let delta = c.rename_axes(|p| {
                        for &(k, v) in &vals {
                            p[k] = v;
                        }
                    });
                    for (&m, d) in c.motors().iter().zip(delta) {
                        self.updates.push(super::csexec::MotorUpdate::Bias(m, d));
                    }
                }
                Flow::Next
            }
            S::CutterRadius(_) => Flow::Next,
            S::CutterComp(n) => {
                let n = *n;
                self.modal(card, |c| {
                    c.modal.cutter = n;
                    Ok(())
                })
            }
            S::Normal(words) => {
                let mut n = [0.0; 3];
                for w in words {
                    let Ok(v) = env::value(card, num, &w.value) else {
                        self.runtime_error(card, rte::VARIABLE, false);
                        return Flow::Error;
                    };
                    match w.axis {
                        Axis::I => n[0] = v,
                        Axis::J => n[1] = v,
                        _ => n[2] = v,
                    }
                }
                self.modal(card, |c| c.modal.set_normal(n))
            }
            S::Tsel(n) => {
                let tbuf = card.bufs.defines.tbuf;
                let n = *n;
                self.modal(card, |c| {
                    if c.xf.len() != tbuf as usize {
                        c.xf.define(tbuf);
                    }
                    c.tsel(n)
                })
            }
            S::Tinit => self.modal(card, |c| c.rename(|b| b.tinit())),
            S::Adis(q) | S::Idis(q) => {
                let v = qs::<3>(card, num, *q);
                let abs = matches!(s.kind, S::Adis(_));
                self.modal(card, |c| {
                    c.rename(|b| if abs { b.adis(v) } else { b.idis(v) })
                })
            }
            S::Arot(q) | S::Irot(q) => {
                let v = qs::<9>(card, num, *q);
                let abs = matches!(s.kind, S::Arot(_));
                self.modal(card, |c| {
                    c.rename(|b| if abs { b.arot(v) } else { b.irot(v) })
                })
            }
            S::Wait => Flow::Yield,
            S::Stop => Flow::Stop,
            S::Return => {
                self.do_return(card);
                Flow::Jumped
            }
            S::Goto(e) => {
                let Ok(v) = env::value(card, num, e) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                let target = self
                    .frames
                    .last()
                    .and_then(|f| f.code.label(label_number(v), pc));
                match target {
                    Some(t) => {
                        self.set_pc(t);
                        Flow::Jumped
                    }
                    None => {
                        self.runtime_error(card, rte::LABEL, false);
                        Flow::Error
                    }
                }
            }
            S::SyncLabel(n) => {
                self.nsync = *n;
                Flow::Next
            }
            S::Gosub(e, args) | S::CallSub(e, args) => {
                let (Ok(v), Ok(a)) = (env::value(card, num, e), self.args(card, args)) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                let Some(f) = self.frames.last() else {
                    return Flow::Next;
                };
                let (code, key) = (f.code.clone(), f.key);
                let Some(t) = code.label(label_number(v), pc) else {
                    return Flow::Next;
                };
                self.set_pc(pc + 1);
                let fl = self.push_frame(
                    card,
                    Frame {
                        key,
                        code,
                        pc: t,
                        args: a,
                        // `gosub` runs on the caller's locals, `callsub` on a new frame.
                        base: if matches!(s.kind, S::Gosub(..)) {
                            self.frames.last().map_or(0, |f| f.base)
                        } else {
                            self.callee_base(card)
                        },
                        prelude: false,
                    },
                );
                if matches!(fl, Flow::Error) {
                    self.set_pc(pc);
                }
                fl
            }
            S::Call(e, args) | S::Code(_, e, args) => {
                let (Ok(v), Ok(a)) = (env::value(card, num, e), self.args(card, args)) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                let (prog, label) = match &s.kind {
                    S::Code(l, ..) => code_target_for(card, num, *l, v),
                    _ => call_target_for(card, v),
                };
                self.set_pc(pc + 1);
                let fl = self.call(card, prog, label, a.clone(), false);
                match fl {
                    Flow::Jumped | Flow::Error => fl,
                    _ => {
                        // Missing target: ignored, but axis words on the line still execute.
                        if !a.is_empty() {
                            self.leftover = Some(a);
                        }
                        Flow::Jumped
                    }
                }
            }
            S::Read(letters) => {
                self.read(card, letters);
                Flow::Next
            }
            S::Prelude(p) => {
                self.prelude = p.clone();
                Flow::Next
            }
            S::Spindle(e) => {
                let Ok(v) = env::value(card, num, e) else {
                    self.runtime_error(card, rte::VARIABLE, false);
                    return Flow::Error;
                };
                let _ = card.state.vars.set_q(num, 127, v);
                Flow::Next
            }
            S::BlockStart => {
                self.in_block = true;
                Flow::Next
            }
            S::BlockStop => {
                self.in_block = false;
                if self.step {
                    Flow::Stop
                } else {
                    Flow::Next
                }
            }
            _ => {
                let mut ctx = Ctx {
                    motor: 1,
                    coord: num,
                    cmds: io.cmds,
                    out: io.out,
                    cmd: io.cmd,
                    plc: None,
                };
                match exec_common(card, &mut ctx, &s.kind) {
                    Common::BadVariable => {
                        self.runtime_error(card, rte::VARIABLE, false);
                        Flow::Error
                    }
                    _ => {
                        let _ = motors;
                        Flow::Next
                    }
                }
            }
        }
    }
}
