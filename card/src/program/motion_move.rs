//! Moves and modal changes of the motion-program executor: feeding COORD (with look-ahead,
//! synchronous M-variable binding and `PE` bookkeeping), program HOME, READ.

use super::csexec::{rte, CsExec, MoveAt, ProgKey, Wait};
use super::env;
use super::motion::Flow;
use crate::coord::axes::axis_index;
use crate::coord::cs::{CoordSystem, MoveWords};
use crate::coord::moves::Mode;
use crate::coord::CoordError;
use crate::domain::ast::{Axis, AxisExtra, AxisWord, JogKind, NumRange};
use crate::domain::{CsNum, MotorNum};
use crate::model::{Action, ActionKind, CardModel};
use crate::motion::motor::Motor;

impl CsExec {
    /// Apply a modal change to the trajectory (created on demand).
    pub(super) fn modal(
        &mut self,
        card: &mut CardModel,
        f: impl FnOnce(&mut CoordSystem) -> Result<(), CoordError>,
    ) -> Flow {
        let Some(c) = &mut self.cs else {
            self.runtime_error(card, rte::MOVE, false);
            return Flow::Error;
        };
        match f(c) {
            Ok(()) => Flow::Next,
            Err(e) => {
                let circle = matches!(e, CoordError::CircleRadius(_));
                self.runtime_error(card, rte::MOVE, circle);
                Flow::Error
            }
        }
    }

    /// Queue a move-like item when the look-ahead wants one.
    pub(super) fn queue(
        &mut self,
        card: &mut CardModel,
        f: impl FnOnce(&mut CoordSystem) -> Result<Option<u64>, CoordError>,
    ) -> Flow {
        let Some(c) = &mut self.cs else {
            self.runtime_error(card, rte::MOVE, false);
            return Flow::Error;
        };
        if !c.wants_moves() {
            return Flow::Wait;
        }
        match f(c) {
            Ok(Some(id)) => {
                if !self.sync_pending.is_empty() {
                    let ops = std::mem::take(&mut self.sync_pending);
                    self.sync_bound.push_back((id, ops));
                }
                let (p, o) = self.frames.last().map_or((0, 0), |f| {
                    let n = match f.key {
                        ProgKey::Prog(n) => u32::from(n),
                        ProgKey::Rot => 0,
                    };
                    (n, f.code.offset_of(f.pc))
                });
                let mut after = self.frames.clone();
                if let Some(f) = after.last_mut() {
                    f.pc += 1;
                }
                let mut end = c.program_motor_positions();
                // The `#n->I` motors' targets: the inverse routine at the move's end point.
                let kin_ok = super::kin::end_targets(card, self.num, c, &mut end).is_ok();
                self.move_at.push_back(MoveAt {
                    id,
                    prog: p,
                    offset: o,
                    after,
                    axes_end: c.program_position(),
                    end,
                    nsync: self.nsync,
                });
                if self.move_at.len() > 32 {
                    self.move_at.pop_front();
                }
                if !kin_ok {
                    self.runtime_error(card, rte::KINEMATICS, false);
                    return Flow::Error;
                }
                Flow::Moved
            }
            Ok(None) => Flow::Next,
            Err(CoordError::QueueFull) => Flow::Wait,
            Err(e) => {
                let circle = matches!(e, CoordError::CircleRadius(_));
                self.runtime_error(card, rte::MOVE, circle);
                Flow::Error
            }
        }
    }

    pub(super) fn move_line(
        &mut self,
        card: &mut CardModel,
        motors: &[Motor],
        words: &[AxisWord],
    ) -> Flow {
        let mut w = MoveWords::default();
        let mut trig = [None; 9];
        for aw in words {
            let Ok(v) = env::value(card, self.num, &aw.value) else {
                self.runtime_error(card, rte::VARIABLE, false);
                return Flow::Error;
            };
            let mut extra = None;
            match &aw.extra {
                Some(AxisExtra::Velocity(e)) | Some(AxisExtra::Trigger(e)) => {
                    let Ok(x) = env::value(card, self.num, e) else {
                        self.runtime_error(card, rte::VARIABLE, false);
                        return Flow::Error;
                    };
                    if matches!(aw.extra, Some(AxisExtra::Trigger(_))) {
                        if let Some(k) = axis_index(aw.axis) {
                            trig[k] = Some(x);
                        }
                    } else {
                        extra = Some(x);
                    }
                }
                None => {}
            }
            put_word(&mut w, aw.axis, v, extra);
        }
        let rapid = self
            .cs
            .as_ref()
            .is_some_and(|c| c.modal.mode == Mode::Rapid);
        if rapid && trig.iter().any(Option::is_some) {
            return self.trigger_move(card, motors, &w, &trig);
        }
        self.queue(card, |c| c.push_move(&w))
    }

    /// RAPID move-until-trigger (seed 10236-10262, 6847, 6811): waits for the C.S. to stop
    /// (no blending), then every motor of a named axis runs its own jog-style move at Ix22 with
    /// Ix19-Ix21 — a jog-until-trigger for the axes with `^` (trigger per Ix03/Ix25 and the
    /// capture flag, end point the trigger + the `^` distance), a plain one for the others;
    /// the next line runs when every motor has finished, after a PMATCH.
    fn trigger_move(
        &mut self,
        card: &mut CardModel,
        motors: &[Motor],
        w: &MoveWords,
        trig: &[Option<f64>; 9],
    ) -> Flow {
        let Some(c) = &mut self.cs else {
            self.runtime_error(card, rte::MOVE, false);
            return Flow::Error;
        };
        if !c.is_idle() {
            return Flow::Wait;
        }
        let plan = match c.trigger_targets(w, trig) {
            Ok(p) => p,
            Err(_) => {
                self.runtime_error(card, rte::MOVE, false);
                return Flow::Error;
            }
        };
        let mut list = Vec::with_capacity(plan.len());
        for (m, to, dist) in plan {
            let bias = motors.get(usize::from(m) - 1).map_or(0.0, |x| x.pos_bias);
            card.push_action(Action {
                motor: MotorNum::of(m),
                coord: CsNum::of(self.num),
                kind: ActionKind::Jog {
                    kind: JogKind::To(to - bias),
                    trigger: dist,
                },
            });
            list.push(m);
        }
        if list.is_empty() {
            return Flow::Next;
        }
        self.wait = Wait::Homing {
            motors: list,
            ticks: 0,
        };
        Flow::Yield
    }

    /// Axis words (and F) left on a CALL / G-code line after READ: a move after the RETURN.
    pub(super) fn leftover_move(&mut self, card: &mut CardModel, args: &[(u8, f64)]) -> Flow {
        let mut w = MoveWords::default();
        let mut any = false;
        for &(l, v) in args {
            if l == b'F' {
                if let Some(c) = &mut self.cs {
                    if c.modal.set_f(v).is_err() {
                        self.runtime_error(card, rte::MOVE, false);
                        return Flow::Error;
                    }
                }
            } else if let Some(a) = Axis::from_letter(l) {
                put_word(&mut w, a, v, None);
                any = true;
            }
        }
        if !any {
            return Flow::Next;
        }
        self.queue(card, |c| c.push_move(&w))
    }

    pub(super) fn home(&mut self, card: &mut CardModel, list: &[NumRange], search: bool) -> Flow {
        let Some(c) = &self.cs else {
            return Flow::Next;
        };
        if !c.is_idle() {
            return Flow::Wait;
        }
        let mine: Vec<u16> = NumRange::expand(list)
            .into_iter()
            .filter_map(|m| u16::try_from(m).ok())
            .filter(|m| c.motors().contains(m))
            .collect();
        if mine.is_empty() {
            return Flow::Next;
        }
        for &m in &mine {
            card.push_action(Action {
                motor: MotorNum::of(m),
                coord: CsNum::of(self.num),
                kind: if search {
                    ActionKind::Home
                } else {
                    ActionKind::HomeZero
                },
            });
        }
        self.wait = Wait::Homing {
            motors: mine,
            ticks: 0,
        };
        Flow::Yield
    }

    /// `READ(...)`: consume the calling line's arguments into Q101..Q126 / Q100.
    pub(super) fn read(&mut self, card: &mut CardModel, letters: &[u8]) {
        let num = self.num;
        let Some(f) = self.frames.last_mut() else {
            return;
        };
        read_args(card, num, &mut f.args, letters);
    }
}

/// `READ(...)` of a program of C.S. `cs` (or a PLC addressing it): consume the leading
/// arguments of the calling line whose letters are listed into Q101..Q126 and the mask of
/// letters read into Q100 (classic), or into the language's extension family
/// (`Semantics::read_ext`, evaluated for `card.exec`).
pub(crate) fn read_args(card: &mut CardModel, cs: u16, args: &mut Vec<(u8, f64)>, letters: &[u8]) {
    let ext = card.state.limits().sem.read_ext;
    let at = card.exec;
    let mut mask = 0u64;
    let mut used = 0;
    for &(l, v) in args.iter() {
        // A..Z are 1..26; with an extension family the double letters AA..ZZ (stored as
        // a..z) are 27..52 (Power PMAC D27-D52).
        let k = match l {
            b'A'..=b'Z' => u32::from(l - b'A') + 1,
            b'a'..=b'z' if ext.is_some() => u32::from(l - b'a') + 27,
            _ => break,
        };
        if !letters.contains(&l) || mask & (1 << (k - 1)) != 0 {
            break;
        }
        mask |= 1 << (k - 1);
        match ext {
            Some(fam) => {
                let _ = card.ext_write(&at, fam, k, v);
            }
            None => {
                let _ = card.state.vars.set_q(cs, 100 + k, v);
            }
        }
        used += 1;
    }
    args.drain(..used);
    match ext {
        Some(fam) => {
            for n in [0, 54] {
                let _ = card.ext_write(&at, fam, n, mask as f64);
            }
        }
        None => {
            let _ = card.state.vars.set_q(cs, 100, mask as f64);
        }
    }
}

fn put_word(w: &mut MoveWords, a: Axis, v: f64, vel: Option<f64>) {
    match a {
        Axis::I => w.ijk[0] = Some(v),
        Axis::J => w.ijk[1] = Some(v),
        Axis::K => w.ijk[2] = Some(v),
        Axis::R => w.r = Some(v),
        _ => {
            if let Some(k) = axis_index(a) {
                w.pos[k] = Some(v);
                w.vel[k] = vel;
            }
        }
    }
}

/// Q(q)..Q(q+N-1) of C.S. `cs` (missing ones 0).
pub(super) fn qs<const N: usize>(card: &CardModel, cs: u16, q: u32) -> [f64; N] {
    let mut v = [0.0; N];
    for (i, x) in v.iter_mut().enumerate() {
        *x = card.state.vars.q(cs, q + i as u32).unwrap_or(0.0);
    }
    v
}
