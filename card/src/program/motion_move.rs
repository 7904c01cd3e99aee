//! Moves and modal changes of the motion-program executor: feeding COORD (with look-ahead,
//! synchronous M-variable binding and `PE` bookkeeping), program HOME, READ.

use super::csexec::{rte, CsExec, MoveAt, ProgKey, Wait};
use super::env;
use super::motion::Flow;
use crate::coord::axes::axis_index;
use crate::coord::cs::{CoordSystem, MoveWords};
use crate::coord::CoordError;
use crate::domain::ast::{Axis, AxisExtra, AxisWord, NumRange};
use crate::model::{Action, ActionKind, CardModel};

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
                self.move_at.push_back(MoveAt {
                    id,
                    prog: p,
                    offset: o,
                    after,
                    axes_end: c.program_position(),
                    end: c.program_motor_positions(),
                });
                if self.move_at.len() > 32 {
                    self.move_at.pop_front();
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

    pub(super) fn move_line(&mut self, card: &mut CardModel, words: &[AxisWord]) -> Flow {
        let mut w = MoveWords::default();
        for aw in words {
            let Ok(v) = env::value(card, self.num, &aw.value) else {
                self.runtime_error(card, rte::VARIABLE, false);
                return Flow::Error;
            };
            let extra = match &aw.extra {
                Some(AxisExtra::Velocity(e)) => match env::value(card, self.num, e) {
                    Ok(x) => Some(x),
                    Err(_) => {
                        self.runtime_error(card, rte::VARIABLE, false);
                        return Flow::Error;
                    }
                },
                _ => None,
            };
            put_word(&mut w, aw.axis, v, extra);
        }
        self.queue(card, |c| c.push_move(&w))
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
                motor: m,
                coord: self.num,
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
        let mut mask = 0u32;
        let mut used = 0;
        for &(l, v) in &f.args {
            let k = u32::from(l.wrapping_sub(b'A')) + 1;
            if !letters.contains(&l) || !(1..=26).contains(&k) || mask & (1 << (k - 1)) != 0 {
                break;
            }
            mask |= 1 << (k - 1);
            let _ = card.state.vars.set_q(num, 100 + k, v);
            used += 1;
        }
        f.args.drain(..used);
        let _ = card.state.vars.set_q(num, 100, f64::from(mask));
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
