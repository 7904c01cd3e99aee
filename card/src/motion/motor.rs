//! One motor's servo pipeline (pmac-variables-servo-macro.md §4.2-§4.5): feedback through the
//! rollover extender, trajectory (jog/home/abort or a program setpoint), following-error and
//! limit checks, PID, output for node register 0, amplifier enable, `?` status flags.
//!
//! Safety checks (fatal/warning FE, amp fault, limits) run every servo cycle so a trip zeroes
//! the output in the cycle it is seen; in-position is evaluated on background scans.

use super::ect::PositionExtender;
use super::flags::FlagInputs;
use super::home::{TriggerAction, TriggeredMove};
use super::jog::{JogCmd, JogParams, Trajectory};
use super::params::MotorParams;
use super::pid::{PidInput, PidState};
use super::profile::{Kin, Plan, RampParams};
use crate::domain::ast::JogKind;
use crate::model::MotorFlags;

/// A command to one motor, values resolved to counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotorCommand {
    /// `K`: open the loop, zero output, amplifier off.
    Kill,
    /// `J/` on a killed motor, `$` on a non-commutated motor: close the loop where it stands.
    Enable,
    /// `O{pct}`: open-loop output at pct % of Ix69, amplifier on.
    OpenLoop(f64),
    /// A jog; `trigger` is the `^{d}` distance of a jog-until-trigger.
    Jog {
        /// The jog.
        cmd: JogCmd,
        /// Jog-until-trigger distance, counts.
        trigger: Option<f64>,
    },
    /// `J!`: round the commanded position to a whole count.
    Round,
    /// `HM`: homing search.
    Home,
    /// `HMZ`: the present commanded position becomes zero.
    HomeZero,
    /// `$*` with Ix10 = 0: kill, the actual position becomes zero, position bias 0, home
    /// complete cleared (seed 6590-6604).
    AbsRead,
    /// `A` / `<CTRL-A>`: decelerate at Ix15; killed motors close the loop where they stand.
    Abort,
}

/// Why a motor tripped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TripKind {
    /// |FE| > Ix11.
    FatalFe,
    /// Integrator saturated with Ix63 < 0.
    IntegratedFe,
    /// Amplifier fault input.
    AmpFault,
    /// Hardware or software limit in the + direction.
    PlusLimit,
    /// Hardware or software limit in the − direction.
    MinusLimit,
}

/// Who else must be stopped (Ix25 bits 22:21 for kills; programs of the C.S. always abort).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TripScope {
    /// Kill every motor of the card.
    Card,
    /// Kill every motor of this motor's C.S.
    CoordSystem,
    /// Only this motor (already killed).
    Motor,
    /// Nobody is killed (limits decelerate); abort the C.S. program.
    ProgramOnly,
}

/// A safety event raised in a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trip {
    /// What happened.
    pub kind: TripKind,
    /// What the caller must do to the other motors / C.S.
    pub scope: TripScope,
}

/// One cycle's inputs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickInput {
    /// Feedback word (24-bit, 1/32 counts): the ECT result at Ix03.
    pub feedback: u32,
    /// Flag inputs from the Ix25 image.
    pub flags: FlagInputs,
    /// Trajectory time increment, ms (present time base / 2^23).
    pub dt_ms: f64,
    /// Commanded position from a running motion program (counts), if any.
    pub program: Option<f64>,
    /// This cycle is a background scan (in-position evaluation, I7 counting).
    pub background: bool,
    /// The node's hardware position capture: low 16 bits of the encoder count latched at the
    /// last capture-flag edge (node register 1), when the station reports one (register 3
    /// bit 12).
    pub capture: Option<u16>,
}

/// One cycle's outputs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickOutput {
    /// Value for node register 0: 16-bit DAC bits left-justified, 8 fractional bits.
    pub reg0: u32,
    /// Output in DAC bits (offset Ix29 included).
    pub dac: f64,
    /// Amplifier enable.
    pub amp_enable: bool,
    /// A safety event of this cycle.
    pub trip: Option<Trip>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Killed,
    Open(f64),
    Closed,
}

/// One motor.
#[derive(Debug, Clone)]
pub struct Motor {
    mode: Mode,
    traj: Trajectory,
    pid: PidState,
    ext: PositionExtender,
    /// Home re-reference: motor position = raw position − bias, counts.
    bias: f64,
    actual: f64,
    prev_actual: f64,
    cmd: f64,
    prev_cmd: f64,
    prev_cv: f64,
    fe: f64,
    started: bool,
    trigger: Option<TriggeredMove>,
    limit_stop: bool,
    inpos_scans: u32,
    on_program: bool,
    cmd_vel: f64,
    /// The last servo cycle's length, ms (turns [`Motor::velocity`] into counts/ms).
    dt_ms: f64,
    last_out: TickOutput,
    /// Target position register (`J=`, D:$080B): the most recent programmed position, motor
    /// counts.
    pub prejog: f64,
    /// Position bias register (D:$0813), counts: reported position = actual + bias (seed
    /// 6224, 9729-9731); set by homing (the axis-definition offset), `Z`, `{axis}=`, `PSET`.
    pub pos_bias: f64,
    /// Axis-definition offset of the motor's C.S. (counts), set by the caller before a
    /// command: homing puts it into the position bias (seed 8244-8246).
    pub axis_offset: f64,
    home_bias: f64,
    /// `?` status flags.
    pub flags: MotorFlags,
}

impl Default for Motor {
    fn default() -> Self {
        Motor::new()
    }
}

/// Round a DAC value (bits) into the 24-bit register: `round(dac·256)`, two's complement.
pub(crate) fn dac_to_reg0(dac: f64) -> u32 {
    let v = (dac * 256.0).round().clamp(-8_388_608.0, 8_388_607.0) as i32;
    (v as u32) & 0xFF_FFFF
}

impl Motor {
    /// A killed motor at position 0 (power-up state).
    pub fn new() -> Self {
        Motor {
            mode: Mode::Killed,
            traj: Trajectory::new(0.0),
            pid: PidState::default(),
            ext: PositionExtender::default(),
            bias: 0.0,
            actual: 0.0,
            prev_actual: 0.0,
            cmd: 0.0,
            prev_cmd: 0.0,
            prev_cv: 0.0,
            fe: 0.0,
            started: false,
            trigger: None,
            limit_stop: false,
            inpos_scans: 0,
            on_program: false,
            cmd_vel: 0.0,
            dt_ms: 0.0,
            last_out: TickOutput::default(),
            prejog: 0.0,
            pos_bias: 0.0,
            axis_offset: 0.0,
            home_bias: 0.0,
            flags: MotorFlags::default(),
        }
    }

    /// Actual position, counts (`P`).
    pub fn actual(&self) -> f64 {
        self.actual
    }
    /// Commanded position, counts.
    pub fn commanded(&self) -> f64 {
        self.cmd
    }
    /// Reported position (`P`, `<CTRL-P>`): actual position plus position bias, counts.
    pub fn reported(&self) -> f64 {
        self.actual + self.pos_bias
    }
    /// Commanded position in the axis frame (commanded + position bias), counts: what a
    /// coordinate system matches its axes to.
    pub fn reported_commanded(&self) -> f64 {
        self.cmd + self.pos_bias
    }
    /// Following error, counts (`F`; 0 when the loop is open).
    pub fn following_error(&self) -> f64 {
        self.fe
    }
    /// Actual velocity, counts per servo cycle (`V`).
    pub fn velocity(&self) -> f64 {
        self.actual - self.prev_actual
    }
    /// True when the loop is closed.
    pub fn closed_loop(&self) -> bool {
        self.mode == Mode::Closed
    }
    /// Trajectory of the motor (jog/home/abort moves).
    pub fn trajectory(&self) -> &Trajectory {
        &self.traj
    }

    /// Resolve a parsed jog into a `JogCmd` against this motor: `J=` goes to the pre-jog
    /// position, `J==` also sets it, `J:` is relative to the commanded and `J^` to the actual
    /// position; the `*` forms take `jog_register` (Mx72). `J!` gives `None` (use
    /// [`MotorCommand::Round`]).
    pub fn resolve_jog(&mut self, kind: JogKind, jog_register: f64) -> Option<JogCmd> {
        let finite = |v: f64| if v.is_finite() { Some(v) } else { None };
        Some(match kind {
            JogKind::Plus => JogCmd::Plus,
            JogKind::Minus => JogCmd::Minus,
            JogKind::Stop => JogCmd::Stop,
            JogKind::Round => return None,
            JogKind::PreJog => JogCmd::To(self.prejog),
            JogKind::To(v) => JogCmd::To(finite(v)?),
            JogKind::ToAndSetPreJog(v) => {
                self.prejog = finite(v)?;
                JogCmd::To(self.prejog)
            }
            JogKind::RelCommanded(d) => JogCmd::To(self.cmd + finite(d)?),
            JogKind::RelActual(d) => JogCmd::To(self.actual + finite(d)?),
            JogKind::VarTo => JogCmd::To(finite(jog_register)?),
            JogKind::VarRelCommanded => JogCmd::To(self.cmd + finite(jog_register)?),
            JogKind::VarRelActual => JogCmd::To(self.actual + finite(jog_register)?),
            JogKind::Present if self.dt_ms > 0.0 => JogCmd::Velocity(self.velocity() / self.dt_ms),
            JogKind::Present => JogCmd::Velocity(0.0),
        })
    }

    /// Kill: loop open, output zero, amplifier off (trip bits are left as they are).
    pub fn kill(&mut self) {
        self.mode = Mode::Killed;
        self.trigger = None;
        self.limit_stop = false;
        self.pid.reset();
        self.traj.hold(self.actual);
        self.cmd = self.actual;
        self.flags.open_loop = true;
        self.flags.amp_enabled = false;
        self.flags.home_search = false;
        self.flags.abort_decel = false;
        self.flags.in_position = false;
        self.inpos_scans = 0;
    }

    fn enable(&mut self) {
        if self.mode == Mode::Closed {
            return;
        }
        self.mode = Mode::Closed;
        self.pid.reset();
        self.traj.hold(self.actual);
        self.cmd = self.actual;
        self.prev_cmd = self.actual;
        self.prev_cv = 0.0;
        let f = &mut self.flags;
        f.open_loop = false;
        f.amp_enabled = true;
        f.fatal_fe = false;
        f.warning_fe = false;
        f.integrated_fe = false;
        f.amp_fault = false;
        f.stopped_on_limit = false;
    }

    fn jog_params(p: &MotorParams, speed: f64) -> JogParams {
        JogParams {
            ramp: p.ramp,
            speed,
        }
    }

    /// Apply a command (the caller has already refused it with ERR001 if a program runs).
    pub fn command(&mut self, c: MotorCommand, p: &MotorParams) {
        match c {
            MotorCommand::Kill => self.kill(),
            MotorCommand::Enable => self.enable(),
            MotorCommand::OpenLoop(pct) => {
                let pct = if pct.is_finite() {
                    pct.clamp(-100.0, 100.0)
                } else {
                    0.0
                };
                self.kill();
                self.mode = Mode::Open(pct / 100.0 * p.gains.out_limit.abs());
                self.flags.amp_enabled = true;
            }
            MotorCommand::Jog {
                cmd: JogCmd::Velocity(v),
                ..
            } => {
                // Power `jog`: no effect on a motor already jogging (or moving in closed
                // loop); otherwise the loop closes on the move as it is and keeps its velocity.
                if self.mode == Mode::Closed && !self.traj.finished() {
                    return;
                }
                self.enable();
                if self.blocked(JogCmd::Velocity(v).direction(0.0)) {
                    return;
                }
                self.trigger = None;
                self.flags.trigger_move = false;
                self.flags.home_search = false;
                self.limit_stop = false;
                self.flags.abort_decel = false;
                self.traj.replace(super::profile::Plan::to_velocity(
                    self.actual,
                    v,
                    v,
                    &p.ramp,
                ));
            }
            MotorCommand::Jog { cmd, trigger } => {
                self.enable();
                if self.blocked(cmd.direction(self.cmd)) {
                    return;
                }
                self.trigger = trigger.map(|d| TriggeredMove::jog(d, p.fe_trigger));
                self.flags.trigger_move = trigger.is_some();
                // Seed 6811: "home search in progress" is set for a jog-until-trigger too.
                self.flags.home_search = trigger.is_some();
                let jp = Self::jog_params(p, p.jog_speed);
                self.limit_stop = false;
                self.flags.abort_decel = false;
                self.traj.command(p.i12, |k| cmd.plan(k, &jp));
            }
            MotorCommand::Round => {
                if self.mode == Mode::Closed && self.traj.finished() {
                    self.traj.hold(self.cmd.round());
                }
            }
            MotorCommand::Home => {
                if p.home_speed == 0.0 || !p.home_speed.is_finite() {
                    return;
                }
                self.enable();
                self.trigger = Some(TriggeredMove::home(p.home_offset, p.fe_trigger));
                self.flags.home_complete = false;
                self.flags.home_search = true;
                self.home_bias = self.axis_offset;
                self.limit_stop = false;
                self.flags.abort_decel = false;
                let jp = Self::jog_params(p, p.home_speed.abs());
                let cmd = if p.home_speed > 0.0 {
                    JogCmd::Plus
                } else {
                    JogCmd::Minus
                };
                self.traj.command(p.i12, |k| cmd.plan(k, &jp));
            }
            MotorCommand::HomeZero => {
                let z = self.cmd;
                self.rebase(z);
                self.pos_bias = self.axis_offset;
                self.flags.home_complete = true;
            }
            MotorCommand::AbsRead => {
                self.kill();
                if !p.abs_read {
                    // Ix10 = 0: no absolute sensor read, the actual position becomes zero.
                    let z = self.actual;
                    self.rebase(z);
                    self.cmd = self.actual;
                    self.traj.hold(self.actual);
                }
                self.pos_bias = 0.0;
                self.flags.home_complete = false;
            }
            MotorCommand::Abort => {
                if self.mode != Mode::Closed {
                    self.enable();
                    return;
                }
                self.trigger = None;
                self.flags.home_search = false;
                self.flags.abort_decel = true;
                self.stop_at_ix15(p);
            }
        }
    }

    /// Decelerate from the present commanded state at Ix15 (no planning delay).
    fn stop_at_ix15(&mut self, p: &MotorParams) {
        let v = if self.on_program {
            self.cmd_vel
        } else {
            self.traj.now().v
        };
        let k = Kin {
            p: self.cmd,
            v,
            a: 0.0,
        };
        let rp = RampParams::constant_rate(p.abort_decel);
        self.traj.replace(Plan::to_velocity(k.p, k.v, 0.0, &rp));
    }

    /// Motion in direction `dir` is blocked by a limit that is set.
    fn blocked(&self, dir: f64) -> bool {
        (dir > 0.0 && self.flags.pos_limit) || (dir < 0.0 && self.flags.neg_limit)
    }

    /// Shift the motor frame so the old position `zero` becomes 0.
    fn rebase(&mut self, zero: f64) {
        self.bias += zero;
        self.actual -= zero;
        self.prev_actual -= zero;
        self.cmd -= zero;
        self.prev_cmd -= zero;
        self.traj.shift(-zero);
    }

    fn trip(&mut self, kind: TripKind, p: &MotorParams) -> Trip {
        let kill_scope = match (p.ix25 >> 21) & 3 {
            0 => TripScope::Card,
            1 => TripScope::CoordSystem,
            _ => TripScope::Motor,
        };
        match kind {
            TripKind::FatalFe => {
                self.flags.fatal_fe = true;
                self.flags.warning_fe = true;
            }
            TripKind::IntegratedFe => {
                self.flags.fatal_fe = true;
                self.flags.integrated_fe = true;
            }
            TripKind::AmpFault => self.flags.amp_fault = true,
            TripKind::PlusLimit | TripKind::MinusLimit => {
                self.flags.stopped_on_limit = true;
                self.flags.abort_decel = true;
                self.limit_stop = true;
                self.trigger = None;
                self.flags.home_search = false;
                self.stop_at_ix15(p);
                return Trip {
                    kind,
                    scope: TripScope::ProgramOnly,
                };
            }
        }
        self.kill();
        Trip {
            kind,
            scope: kill_scope,
        }
    }

    /// One servo cycle.
    pub fn tick(&mut self, p: &MotorParams, inp: &TickInput) -> TickOutput {
        if !p.active {
            // Ix00 = 0: no position, servo or trajectory work; outputs stay as they were.
            return self.last_out;
        }
        if inp.dt_ms.is_finite() && inp.dt_ms > 0.0 {
            self.dt_ms = inp.dt_ms;
        }
        let raw = self.ext.update(inp.feedback & 0xFF_FFFF) as f64 / 32.0 - self.bias;
        self.prev_actual = if self.started { self.actual } else { raw };
        self.actual = raw;
        self.started = true;
        let mut trip = None;
        if self.mode != Mode::Killed && inp.flags.amp_fault && !p.ignore_fault() {
            trip = Some(self.trip(TripKind::AmpFault, p));
        }
        let dac = match self.mode {
            Mode::Killed | Mode::Open(_) => {
                self.cmd = self.actual;
                self.prev_cmd = self.actual;
                self.prev_cv = 0.0;
                self.fe = 0.0;
                self.traj.hold(self.actual);
                self.update_limit_bits(p, &inp.flags);
                match self.mode {
                    Mode::Open(v) => v,
                    _ => 0.0,
                }
            }
            Mode::Closed => self.closed_cycle(p, inp, &mut trip),
        };
        self.update_status(p, inp);
        let out = dac + p.dac_offset;
        self.last_out = TickOutput {
            reg0: dac_to_reg0(out),
            dac: out,
            amp_enable: self.mode != Mode::Killed,
            trip: None,
        };
        TickOutput {
            trip,
            ..self.last_out
        }
    }

    fn update_limit_bits(&mut self, p: &MotorParams, f: &FlagInputs) {
        let hw = !p.ignore_limits();
        let searching = self.trigger.is_some_and(|t| t.is_home_search());
        let soft_plus = !searching && p.soft_plus != 0.0 && self.cmd > p.soft_plus;
        let soft_minus = !searching && p.soft_minus != 0.0 && self.cmd < p.soft_minus;
        self.flags.pos_limit = (hw && f.plus_limit) || soft_plus;
        self.flags.neg_limit = (hw && f.minus_limit) || soft_minus;
    }

    fn closed_cycle(&mut self, p: &MotorParams, inp: &TickInput, trip: &mut Option<Trip>) -> f64 {
        let k = self.traj.advance(inp.dt_ms);
        self.on_program = false;
        self.cmd = match inp.program {
            Some(sp) if !self.limit_stop && sp.is_finite() => {
                self.traj.hold(sp);
                self.on_program = true;
                sp
            }
            _ => k.p,
        };
        let cv = self.cmd - self.prev_cmd;
        if inp.dt_ms > 0.0 {
            self.cmd_vel = cv / inp.dt_ms;
        }
        self.update_limit_bits(p, &inp.flags);
        if !self.limit_stop && cv != 0.0 {
            // Seed 6837: 0 "even when into a limit but moving out of it".
            self.flags.stopped_on_limit = false;
        }
        if trip.is_none() && !self.limit_stop {
            if self.flags.pos_limit && cv > 0.0 {
                *trip = Some(self.trip(TripKind::PlusLimit, p));
            } else if self.flags.neg_limit && cv < 0.0 {
                *trip = Some(self.trip(TripKind::MinusLimit, p));
            }
        }
        if let Some(mut t) = self.trigger {
            let warn = p.warn_fe != 0.0 && (self.cmd - self.actual).abs() * 16.0 > p.warn_fe;
            let at = self.capture_position(p, &t, inp);
            if let Some(a) = t.on_cycle(inp.flags.home, warn, at) {
                self.on_trigger(p, &t, a);
            }
            if self.trigger.is_some() {
                self.trigger = Some(t);
            }
            if self.traj.finished() {
                // Post-trigger move done, or a triggered move ended without a trigger: the
                // trigger-move bit stays set then (seed 6847).
                self.trigger = None;
                self.flags.home_search = false;
            }
        }
        self.fe = self.cmd - self.actual;
        if trip.is_none() && p.fatal_fe != 0.0 && self.fe.abs() * 16.0 > p.fatal_fe {
            *trip = Some(self.trip(TripKind::FatalFe, p));
            return 0.0;
        }
        self.flags.warning_fe = p.warn_fe != 0.0 && self.fe.abs() * 16.0 > p.warn_fe;
        let cv = self.cmd - self.prev_cmd;
        let ca = cv - self.prev_cv;
        self.prev_cmd = self.cmd;
        self.prev_cv = cv;
        let out = self.pid.step(
            &p.gains,
            &PidInput {
                fe: self.fe,
                cv,
                ca,
                av: self.actual - self.prev_actual,
            },
        );
        if out.integrated_fault && trip.is_none() {
            *trip = Some(self.trip(TripKind::IntegratedFe, p));
            return 0.0;
        }
        // The loop stays closed on a limit: the motor is servoed to where the Ix15
        // deceleration ended (a limit blocks commanded motion into it, not the drive), so it
        // comes in position there, as the DLS homing PLCs expect after a limit stop.
        let dac = out.dac;
        if self.limit_stop && self.traj.finished() {
            self.limit_stop = false;
            self.flags.abort_decel = false;
        }
        // A C.S. abort decelerates the program's own path: the motor follows its setpoints
        // (its trajectory holds each one), and the bit stays until they stop (seed 6805:
        // "until the commanded deceleration to zero velocity finishes").
        let program_moving = self.on_program && self.cmd_vel != 0.0;
        if self.flags.abort_decel && self.traj.finished() && !program_moving {
            self.flags.abort_decel = false;
        }
        dac
    }

    /// The trigger position if the trigger fires this cycle: the station's hardware capture
    /// (the count at which the flag changed) when the trigger is the capture flag, software
    /// capture is off (PMAC2 Ix03 bit 16, Turbo Ixx97 bit 0) and the latched count belongs to
    /// the motion just seen (within 8 cycles of travel + 4 counts of the actual position);
    /// otherwise the actual position of this cycle (software capture).
    fn capture_position(&self, p: &MotorParams, t: &TriggeredMove, inp: &TickInput) -> f64 {
        let (Some(c16), false, super::home::TriggerSource::HomeFlag) =
            (inp.capture, p.software_capture, t.source)
        else {
            return self.actual;
        };
        let raw = self.actual + self.bias;
        let d = (i64::from(c16) - raw.floor() as i64).rem_euclid(0x1_0000);
        let d = if d >= 0x8000 { d - 0x1_0000 } else { d } as f64;
        let cap = raw.floor() + d;
        let window = 8.0 * self.velocity().abs() + 4.0;
        if (cap - raw).abs() <= window {
            cap - self.bias
        } else {
            self.actual
        }
    }

    fn on_trigger(&mut self, p: &MotorParams, t: &TriggeredMove, a: TriggerAction) {
        let speed = match t.kind {
            super::home::TriggerKind::Home { .. } => p.home_speed.abs(),
            super::home::TriggerKind::Jog { .. } => p.jog_speed,
        };
        if let Some(z) = a.new_zero {
            self.rebase(z);
            self.pos_bias = self.home_bias;
            self.flags.home_complete = true;
            self.flags.home_search = false;
        }
        self.flags.trigger_move = false;
        self.flags.home_search = false;
        let jp = Self::jog_params(p, speed);
        let target = a.target;
        self.traj
            .command(p.i12, |k| JogCmd::To(target).plan(k, &jp));
    }

    fn update_status(&mut self, p: &MotorParams, inp: &TickInput) {
        let closed = self.mode == Mode::Closed;
        let moving = !self.traj.finished() || inp.program.is_some();
        self.flags.desired_velocity_zero = self.prev_cv == 0.0 && self.traj.now().v == 0.0;
        self.flags.move_timer = closed && moving;
        self.flags.open_loop = !closed;
        self.flags.amp_enabled = self.mode != Mode::Killed;
        if inp.background {
            let ok = closed
                && self.flags.desired_velocity_zero
                && !self.flags.move_timer
                && self.fe.abs() * 16.0 < p.inpos_band;
            self.inpos_scans = if ok {
                self.inpos_scans.saturating_add(1)
            } else {
                0
            };
            self.flags.in_position = self.inpos_scans > p.i7;
        }
        if !closed {
            self.flags.in_position = false;
            self.inpos_scans = 0;
        }
    }
}
