//! Motion programs, PLCs and run control: the program engine of a card.
//!
//! Contract with the servo loop (`crate::servo`): every servo tick the loop calls
//! [`ProgramEngine::handle_action`] for each drained interpreter action (the engine takes the
//! coordinate-system / program ones and returns `false` for the rest), then
//! [`ProgramEngine::servo_tick`] (PLC 0, trajectory of every running coordinate system) which
//! returns each motor's program setpoint, then runs the motors, reports trips through
//! [`ProgramEngine::on_trip`], and finally calls [`ProgramEngine::background`] once (PLC 1-31
//! scans, program look-ahead) — one background cycle per servo tick, in ring time.
//!
//! Shared actions: `A`, `<CTRL-A>` and `<CTRL-K>` stop programs here *and* return `false`, so
//! the servo loop also applies their motor side (close killed motors / kill). Program `HOME`
//! statements queue ordinary `HM`/`HMZ` actions for the servo loop (via `Card`'s action queue).
//! Unsolicited program output (`SEND`, replies of `CMD`) is collected for the host ports:
//! [`ProgramEngine::take_output`].
//!
//! Layout: [`compile`] flattens stored lines; [`csexec`] holds one C.S.'s program state and
//! trajectory output, `runctl` its run control (R/S/Q/A, `/` and ERR017, PC/PE); [`motion`] is
//! the motion-program executor (`motion_exec`: statements, `motion_move`: moves into COORD);
//! [`plc`] runs PLCs; [`stmt`] executes statements shared by both; [`env`] / [`config`] read
//! the card's variables and setup.
//!
//! Run-time errors stop the program, abort its motion (Ix15), set `??` word-2 bit 22 (bit 21
//! too for a circle radius error) and leave a code in X:$0799: the spec's 1-6 plus 7 (a
//! variable could not be read or written) and 8 (a move COORD refused: no motors, zero or
//! negative times, TA = TS = 0, impossible circle, missing/singular matrix), see
//! [`csexec::rte`].

pub(crate) mod compile;
pub(crate) mod config;
pub(crate) mod csexec;
pub(crate) mod env;
pub(crate) mod kin;
pub(crate) mod motion;
mod motion_exec;
mod motion_move;
pub(crate) mod plc;
pub(crate) mod printf;
mod runctl;
pub(crate) mod stmt;

#[cfg(test)]
mod tests_compile;
#[cfg(test)]
mod tests_engine;
#[cfg(test)]
mod tests_flow;

use crate::model::{Action, ActionKind, CardModel};
use crate::motion::motor::{Motor, TripScope};
use csexec::CsExec;
pub(crate) use csexec::MotorUpdate;
use motion::PassIo;
use plc::PlcRunner;
use stmt::{run_cmds, QueuedCmd};
pub use stmt::{Commands, NoCommands};

/// The program engine of one card.
#[derive(Debug, Default)]
pub struct ProgramEngine {
    /// Per coordinate system (index 0 = &1), created on first use.
    cs: Vec<CsExec>,
    /// The PLC runner.
    pub plcs: PlcRunner,
    out: Vec<u8>,
    /// `Card::resets()` last seen: a `$$$` drops every program and PLC state.
    resets_seen: u64,
}

impl ProgramEngine {
    /// An engine with nothing running.
    pub fn new() -> Self {
        ProgramEngine::default()
    }

    fn ensure(&mut self, card: &CardModel) {
        if card.resets() != self.resets_seen {
            *self = ProgramEngine {
                resets_seen: card.resets(),
                out: std::mem::take(&mut self.out),
                ..ProgramEngine::default()
            };
        }
        let n = card.state.limits().coords as usize;
        while self.cs.len() < n {
            let k = self.cs.len() as u16 + 1;
            self.cs.push(CsExec::new(k));
        }
    }

    fn cs_mut(&mut self, card: &CardModel, cs: u16) -> Option<&mut CsExec> {
        self.ensure(card);
        self.cs.get_mut((cs as usize).wrapping_sub(1))
    }

    /// The program state of C.S. `cs` (1-based), if it exists.
    pub fn coord(&self, cs: u16) -> Option<&CsExec> {
        self.cs.get((cs as usize).wrapping_sub(1))
    }

    /// Unsolicited output for the host (`SEND` text, replies and errors of program `CMD`s),
    /// drained.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Take a coordinate-system or program action (R, S, Q, A, H, B, /, \, PC, PE, CTRL-R/S/Q/
    /// O/A, ...). Returns `false` when the action is not the engine's (motor actions) — and
    /// for `A`, CTRL-A and CTRL-K, whose motor side the servo loop also applies.
    pub fn handle_action(
        &mut self,
        card: &mut CardModel,
        motors: &[Motor],
        action: &Action,
    ) -> bool {
        self.ensure(card);
        match &action.kind {
            ActionKind::AbortAll | ActionKind::KillAll => {
                for x in &mut self.cs {
                    x.abort(card);
                }
                false
            }
            ActionKind::HoldAll => {
                for x in &mut self.cs {
                    if let Some(c) = &mut x.cs {
                        c.hold();
                    }
                }
                true
            }
            ActionKind::QuitAll => {
                for x in &mut self.cs {
                    x.quit();
                }
                true
            }
            kind => {
                let Some(x) = self.cs_mut(card, action.coord.get()) else {
                    return false;
                };
                self::run_control(x, card, motors, kind)
            }
        }
    }

    /// One servo tick at ring cycle `cycle`, `dt_ms` of (time-base scaled) time: PLC 0 and every
    /// running coordinate system. Returns, per motor (index 0 = motor 1), the program's
    /// commanded position in counts, or `None` when the motor is not under program control.
    /// (Each C.S. advances its own trajectory clock from I10 and its `%` time base.)
    pub fn servo_tick(
        &mut self,
        card: &mut CardModel,
        cmd: &mut dyn Commands,
        motors: &[Motor],
        _cycle: u64,
        _dt_ms: f64,
    ) -> Vec<Option<f64>> {
        self.ensure(card);
        self.plcs.foreground(card, cmd, &mut self.out);
        let mut res = vec![None; motors.len()];
        for x in &mut self.cs {
            x.sync_axes(card, motors);
            if let Some(c) = &mut x.cs {
                let killed = |m: &u16| {
                    motors
                        .get(usize::from(*m).wrapping_sub(1))
                        .is_none_or(|mo| !mo.closed_loop())
                };
                if !c.motors().is_empty() && c.motors().iter().all(killed) {
                    c.end_abort_of_killed();
                }
            }
            let ticked = x.tick(card);
            // `?` word 1 bit 15 "dwell in progress" on every motor of the C.S. (seed 6820).
            if let Some(c) = &x.cs {
                let dwell = c.in_dwell();
                for &m in c.motors() {
                    if let Some(f) = card.state.motors.get_mut(usize::from(m).wrapping_sub(1)) {
                        f.dwell = dwell;
                    }
                }
            }
            let Some((list, pos)) = ticked else {
                continue;
            };
            let homing = x.homing().to_vec();
            for (m, p) in list.iter().zip(pos) {
                if homing.contains(m) {
                    continue;
                }
                let k = (*m as usize).wrapping_sub(1);
                let bias = motors.get(k).map_or(0.0, |x| x.pos_bias);
                if let Some(r) = res.get_mut(k) {
                    *r = Some(p - bias);
                }
            }
        }
        res
    }

    /// Motor changes asked by the coordinate systems (target positions of started moves and
    /// `\` holds, position-bias changes of `Z`, `{axis}=`, `PSET`), drained.
    pub(crate) fn take_motor_updates(&mut self) -> Vec<MotorUpdate> {
        let mut out = Vec::new();
        for x in &mut self.cs {
            out.append(&mut x.updates);
        }
        out
    }

    /// A motor tripped (following error, amp fault, limit): abort the programs per `scope`.
    /// `motor` is the index into the servo loop's motor slice (0 = motor #1). Whatever the
    /// scope, the program of the motor's C.S. is aborted; `TripScope::Card` aborts all.
    pub fn on_trip(&mut self, card: &mut CardModel, motor: usize, scope: TripScope) {
        self.ensure(card);
        let m = u16::try_from(motor + 1).unwrap_or(0);
        let mine = card.run.cs_of(m);
        for x in &mut self.cs {
            if scope == TripScope::Card || Some(x.num) == mine {
                x.abort(card);
            }
        }
    }

    /// The ring failed: abort every program (the servo loop kills the motors).
    pub fn on_ring_fault(&mut self, card: &mut CardModel) {
        self.ensure(card);
        for x in &mut self.cs {
            x.abort(card);
        }
    }

    /// One background cycle: PLC 1-31 scans (I5 gating), program look-ahead.
    pub fn background(&mut self, card: &mut CardModel, cmd: &mut dyn Commands, motors: &[Motor]) {
        self.ensure(card);
        self.plcs.background(card, cmd, &mut self.out);
        let mut cmds: Vec<QueuedCmd> = Vec::new();
        for x in &mut self.cs {
            if x.active {
                x.calc(
                    card,
                    motors,
                    &mut PassIo {
                        cmds: &mut cmds,
                        out: &mut self.out,
                        cmd: &mut *cmd,
                    },
                );
            } else if x.busy() {
                x.report_pc(card);
            }
            x.record_stop_point(card, motors);
            cs_status(x, card, motors);
        }
        run_cmds(card, cmd, &mut cmds, &mut self.out);
    }
}

/// On-line program control for one C.S.
fn run_control(x: &mut CsExec, card: &mut CardModel, motors: &[Motor], cmd: &ActionKind) -> bool {
    match cmd {
        ActionKind::Begin => {
            x.frames.clear();
            x.flush_sync();
            x.stop_pending = false;
            x.end_hold_jog();
            if let Some(r) = card.run.cs.get_mut(x.num as usize - 1) {
                r.stop_point = None;
            }
            true
        }
        ActionKind::Run | ActionKind::Resume | ActionKind::Step => {
            let running = card.cs_running(x.num);
            if !running {
                // The interpreter refused it (ERR010-ERR016): nothing to do.
                return true;
            }
            x.start(card, motors, matches!(cmd, ActionKind::Step));
            x.modal_from_flags(card);
            true
        }
        ActionKind::Quit => {
            x.quit();
            true
        }
        ActionKind::StopAtEnd => {
            // [DECISION] with I13 = 0 (no segmentation) `/` is `Q`, as the spec says; the
            // segmented form (stop inside the executing move) is COORD's `stop_at_end`.
            if env::ivar(card, 13, 0.0) > 0.0 {
                x.stop_at_end(card);
            } else {
                x.quit();
            }
            true
        }
        ActionKind::Abort => {
            x.abort(card);
            false
        }
        ActionKind::HoldJog => {
            x.hold_jog(card);
            true
        }
        ActionKind::AxisRename(..) | ActionKind::ZeroAxes => {
            x.sync_axes(card, motors);
            if x.busy() {
                return true;
            }
            if let Some(c) = &mut x.cs {
                // Re-label the present commanded positions (seed 7264, 10187).
                c.pmatch(&csexec::commanded(motors, c.motors()));
                let delta = match cmd {
                    ActionKind::AxisRename(a, v) => match crate::coord::axes::axis_index(*a) {
                        Some(k) if v.is_finite() => c.rename_axes(|p| p[k] = *v),
                        _ => return true,
                    },
                    _ => {
                        let used = c.axes_used();
                        c.rename_axes(|p| {
                            for (k, u) in used.iter().enumerate() {
                                if *u {
                                    p[k] = 0.0;
                                }
                            }
                        })
                    }
                };
                for (&m, d) in c.motors().iter().zip(delta) {
                    x.updates.push(MotorUpdate::Bias(m, d));
                }
            }
            true
        }
        ActionKind::Hold | ActionKind::BackUp => {
            if let Some(c) = &mut x.cs {
                c.hold();
            }
            true
        }
        ActionKind::Override(v) => {
            x.sync_axes(card, motors);
            let profile = card.profile();
            let slew = |nn| env::ivar(card, env::cs_ivar(profile, x.num, nn), f64::NAN);
            let (ix94, ix95) = (slew(94), slew(95));
            if let Some(c) = &mut x.cs {
                c.tb.set_slews(ix94, ix95);
                c.tb.set_percent(*v);
            }
            true
        }
        ActionKind::MFlush => {
            x.flush_sync();
            true
        }
        ActionKind::PMatch => {
            if let Some(c) = &mut x.cs {
                if c.is_idle() {
                    let pos = csexec::commanded(motors, c.motors());
                    c.pmatch(&pos);
                    if kin::apply_forward(card, x.num, c, &pos).is_err() {
                        // [DECISION] a failed forward routine leaves the PMATCH of the
                        // linear axes in place (an on-line command has no run-time error).
                    }
                }
            }
            true
        }
        _ => false,
    }
}

/// `??` bits the engine owns: running (calculation), in position (all motors, no move), and
/// the OR of the motors' amp-fault / fatal / warning following-error bits.
fn cs_status(x: &CsExec, card: &mut CardModel, motors: &[Motor]) {
    let k = x.num as usize - 1;
    let idle = !x.busy();
    let (mut inpos, mut amp, mut fatal, mut warn) = (true, false, false, false);
    for (i, a) in card.run.axes.iter().enumerate() {
        if a.as_ref().is_none_or(|(c, _)| *c != x.num) {
            continue;
        }
        if let Some(m) = motors.get(i) {
            inpos &= m.flags.in_position;
            amp |= m.flags.amp_fault;
            fatal |= m.flags.fatal_fe;
            warn |= m.flags.warning_fe;
        }
    }
    if let Some(f) = card.state.coords.get_mut(k) {
        if x.active {
            f.running = true;
        }
        f.in_position = idle && inpos;
        f.moves_pending = !idle;
        f.amp_fault = amp;
        f.fatal_fe = fatal;
        f.warning_fe = warn;
    }
}
