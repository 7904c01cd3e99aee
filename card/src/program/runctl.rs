//! Run control of one coordinate system (pmac-commands.md §3.3.3, §5.10): `R`/`S` start or
//! resume at the program counter, `Q`, `A`, `/` (with the ERR017 stop point), and the `PC` /
//! `PE` texts the interpreter replies with.

use std::sync::Arc;

use super::compile::Compiled;
use super::config::cs_config;
use super::csexec::{commanded, rte, CsExec, Frame, ProgKey, Wait};
use crate::coord::cs::CoordSystem;
use crate::coord::moves::Mode;
use crate::model::CardModel;
use crate::motion::motor::Motor;

impl CsExec {
    /// `R` / `S` (the interpreter has already made its ERR010-ERR016 checks).
    pub fn start(&mut self, card: &mut CardModel, motors: &[Motor], step: bool) {
        let k = self.k();
        if let Some(f) = card.state.coords.get_mut(k) {
            f.runtime_error = false;
            f.circle_radius_error = false;
        }
        self.sync_axes(card, motors);
        let idle = self.cs.as_ref().is_some_and(CoordSystem::is_idle);
        let mut kin_failed = false;
        if let Some(c) = &mut self.cs {
            c.release();
            if idle {
                c.cfg = cs_config(card, self.num, c.motors());
                c.tb.set_slews(c.cfg.ix94, c.cfg.ix95);
                if super::env::ivar(card, 14, 1.0) != 0.0 {
                    let pos = commanded(motors, c.motors());
                    c.pmatch(&pos);
                    kin_failed = super::kin::apply_forward(card, self.num, c, &pos).is_err();
                }
            }
        }
        if kin_failed {
            self.runtime_error(card, super::csexec::rte::KINEMATICS, false);
            return;
        }
        self.step = step;
        self.step_line = None;
        self.stop_pending = false;
        self.end_hold_jog();
        if let Some(f) = card.state.coords.get_mut(k) {
            f.block_stop = false;
        }
        if let Some(r) = card.run.cs.get_mut(k) {
            r.stop_point = None;
        }
        if self.frames.is_empty() {
            self.cache.clear();
            let Some((prog, label)) = card.run.cs.get(k).and_then(|r| r.pointer) else {
                self.runtime_error(card, rte::PAST_END, false);
                return;
            };
            if prog == 0 {
                self.frames.push(Frame {
                    key: ProgKey::Rot,
                    code: Arc::new(Compiled::default()),
                    pc: 0,
                    args: Vec::new(),
                    prelude: false,
                    base: 0,
                });
            } else {
                let n = u16::try_from(prog).unwrap_or(0);
                let code = match self.program(card, n) {
                    Ok(Some(c)) => c,
                    Ok(None) => return self.runtime_error(card, rte::PAST_END, false),
                    Err(e) => return self.runtime_error(card, e, false),
                };
                let Some(pc) = code.label(label, 0) else {
                    return self.runtime_error(card, rte::LABEL, false);
                };
                self.frames.push(Frame {
                    key: ProgKey::Prog(n),
                    code,
                    pc,
                    args: Vec::new(),
                    prelude: false,
                    base: 0,
                });
            }
            self.prelude = None;
            self.prelude_fired = None;
            self.in_block = false;
        }
        self.active = true;
        self.report_pc(card);
    }

    /// `Q` (also `S` while running, CTRL-Q, `/` without segmentation): stop calculating;
    /// moves already calculated finish; R/S resume at the program counter.
    pub fn quit(&mut self) {
        self.active = false;
    }

    /// `A`, CTRL-A, CTRL-K, trips, ring fault: decelerate at Ix15, stop the program (resumable
    /// from the program counter), drop synchronous assignments.
    /// The program counter goes to just after the move that was executing and the programmed
    /// position to its end: `J=` takes the motors there and `R` resumes from it (seed
    /// 8397-8403, 6749). Any `/` or `\` stop point is dropped.
    pub fn abort(&mut self, card: &mut CardModel) {
        self.active = false;
        self.wait = Wait::None;
        self.leftover = None;
        self.stop_pending = false;
        self.end_hold_jog();
        if let Some(c) = &mut self.cs {
            let exec = c.executing();
            c.abort();
            if let Some(m) = exec.and_then(|id| self.move_at.iter().find(|m| m.id == id)) {
                self.frames = m.after.clone();
                c.set_program_position(m.axes_end);
            }
        }
        self.flush_sync();
        if let Some(r) = card.run.cs.get_mut(self.k()) {
            r.stop_point = None;
            r.apc_at = r.pc_at;
        }
        if let Some(f) = card.state.coords.get_mut(self.k()) {
            f.running = false;
            f.continuous_request = false;
            f.program_hold = false;
        }
    }

    /// `\` (pmac-commands; seed 6962-6964, 7164-7172): with I13 > 0 in LINEAR or CIRCLE mode a
    /// program hold — the time base ramps to zero, the `??` program-hold bit is set, the
    /// program stops calculating and, once stopped, the motors may be jogged; `R` resumes
    /// once they are back at the hold point (ERR017 otherwise). Otherwise it acts as `H`.
    pub fn hold_jog(&mut self, card: &mut CardModel) {
        let i13 = super::env::ivar(card, 13, 0.0);
        let i52 = super::env::ivar(card, 52, 37_137.0);
        let busy = self.busy();
        let Some(c) = &mut self.cs else { return };
        let mode = c.modal.mode;
        if i13 <= 0.0 || !busy || !matches!(mode, Mode::Linear | Mode::Circle1 | Mode::Circle2) {
            c.hold();
            return;
        }
        // I52 is in I10 units per segmentation period (I13 ms).
        c.program_hold(i52 * c.tb.servo_ms() / i13);
        self.active = false;
        self.hold_jog = true;
        if let Some(f) = card.state.coords.get_mut(self.k()) {
            f.running = false;
            f.continuous_request = false;
            f.program_hold = true;
        }
    }

    /// `/` (segmented moves): finish the executing move, drop the moves calculated after it
    /// and put the program counter just after it.
    pub fn stop_at_end(&mut self, card: &mut CardModel) {
        if let Some(f) = card.state.coords.get_mut(self.k()) {
            f.running = false;
            f.continuous_request = false;
            f.block_stop = true;
        }
        let Some(c) = &mut self.cs else { return };
        let exec = c.executing();
        c.stop_at_end();
        if let Some(m) = exec.and_then(|id| self.move_at.iter().find(|m| m.id == id)) {
            self.frames = m.after.clone();
        }
        self.flush_sync();
        self.leftover = None;
        self.stop_pending = true;
        self.active = false;
    }

    /// After a `/` stop: once the motion has ended, keep the motors' stop point for ERR017.
    pub fn record_stop_point(&mut self, card: &mut CardModel, motors: &[Motor]) {
        let Some(c) = &self.cs else { return };
        if !self.stop_pending || !c.is_idle() {
            return;
        }
        self.stop_pending = false;
        let list = c.motors().to_vec();
        let pos = commanded(motors, &list);
        if let Some(r) = card.run.cs.get_mut(self.k()) {
            r.stop_point = Some(list.into_iter().zip(pos).collect());
        }
    }

    /// `PC` / `PE` texts into the interpreter's run state.
    pub fn report_pc(&self, card: &mut CardModel) {
        let k = self.k();
        let pc = if self.frames.is_empty() {
            None
        } else {
            let parts: Vec<String> = self
                .frames
                .iter()
                .rev()
                .map(|f| {
                    let n = match f.key {
                        ProgKey::Prog(n) => u32::from(n),
                        ProgKey::Rot => 0,
                    };
                    format!("P{n}:{}", f.code.offset_of(f.pc))
                })
                .collect();
            Some(parts.join(">"))
        };
        let pc_at = self.frames.last().map(|f| {
            let n = match f.key {
                ProgKey::Prog(n) => u32::from(n),
                ProgKey::Rot => 0,
            };
            (n, f.code.offset_of(f.pc))
        });
        let exec = self.cs.as_ref().and_then(CoordSystem::executing);
        let pe_at = exec
            .and_then(|id| self.move_at.iter().find(|m| m.id == id))
            .map(|m| (m.prog, m.offset));
        let pe = pe_at.map(|(p, o)| format!("P{p}:{o}"));
        if let Some(r) = card.run.cs.get_mut(k) {
            r.pc_text = pc.clone();
            r.pe_text = pe.or(pc);
            r.pc_at = pc_at;
            r.pe_at = pe_at.or(pc_at);
        }
    }
}
