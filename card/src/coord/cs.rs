//! One coordinate system: modal state, move queue, time base, transformation and axis map;
//! produces the motor commanded positions every servo cycle.
//!
//! Executor protocol: set modal values (`modal_mut()`), feed moves with [`CoordSystem::push_move`]
//! / [`CoordSystem::dwell`] / [`CoordSystem::delay`] while [`CoordSystem::wants_moves`], call
//! [`CoordSystem::tick`] once per servo cycle; `started` ids are where synchronous M-variable
//! assignments take effect, `finished` ids are completed moves.

use nalgebra::DVector;

use super::axes::{AxisVec, CsAxes};
use super::blend::{Kind, NewPiece, Timeline};
use super::circle::{make_arc, Centre, CircleParams};
use super::moves::{feed_time, ix16_time, ix17_accel, to_motor, CsConfig, Modal, Mode};
use super::prims::Prim;
use super::profile::{decel_stop, PtpProfile};
use super::timebase::TimeBase;
use super::transform::{Affine, TransformBank};
use super::{check_pos, CoordError};

/// The words of one move line, values already evaluated (user units).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MoveWords {
    /// Axis values X..W.
    pub pos: [Option<f64>; 9],
    /// PVT velocities `X{p}:{v}` (user units per Ix90 ms).
    pub vel: [Option<f64>; 9],
    /// Circle centre I, J, K.
    pub ijk: [Option<f64>; 3],
    /// Circle radius R.
    pub r: Option<f64>,
}

/// Result of one servo cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct TickOut {
    /// Commanded positions of the C.S. motors (counts, [`CoordSystem::motors`] order).
    pub motors: Vec<f64>,
    /// Moves whose execution began this cycle.
    pub started: Vec<u64>,
    /// Moves completed this cycle.
    pub finished: Vec<u64>,
}

#[derive(Debug, Clone, PartialEq)]
struct Abort {
    p0: Vec<f64>,
    v0: Vec<f64>,
    t: f64,
}

/// A coordinate system.
#[derive(Debug, Clone, PartialEq)]
pub struct CoordSystem {
    /// I-variable setup.
    pub cfg: CsConfig,
    /// Modal program state.
    pub modal: Modal,
    /// Time base.
    pub tb: TimeBase,
    /// Transformation matrices.
    pub xf: TransformBank,
    axes: CsAxes,
    tl: Timeline,
    tau: f64,
    pos: AxisVec,
    cmd: Vec<f64>,
    vel: Vec<f64>,
    abort: Option<Abort>,
    frozen: bool,
}

impl CoordSystem {
    /// New C.S. with axis map `axes`, PMATCHed to the present motor positions.
    pub fn new(cfg: CsConfig, axes: CsAxes, motor_pos: &[f64]) -> Self {
        let modal = Modal::new(&cfg);
        let tb = TimeBase::new(cfg.i10, cfg.ix94, cfg.ix95);
        let n = axes.motors.len();
        let mut cs = CoordSystem {
            cfg,
            modal,
            tb,
            xf: TransformBank::default(),
            axes,
            tl: Timeline::new(AxisVec::zeros()),
            tau: 0.0,
            pos: AxisVec::zeros(),
            cmd: vec![0.0; n],
            vel: vec![0.0; n],
            abort: None,
            frozen: false,
        };
        cs.pmatch(motor_pos);
        cs
    }

    /// Member motors (ascending).
    pub fn motors(&self) -> &[u16] {
        &self.axes.motors
    }

    /// Replace the axis map (after `#m->` changes) and PMATCH; refused while moving.
    pub fn set_axes(&mut self, axes: CsAxes, motor_pos: &[f64]) -> Result<(), CoordError> {
        if !self.is_idle() {
            return Err(CoordError::Stopping);
        }
        self.cmd = vec![0.0; axes.motors.len()];
        self.vel = vec![0.0; axes.motors.len()];
        self.axes = axes;
        self.pmatch(motor_pos);
        Ok(())
    }

    /// PMATCH: axis (program) positions from motor commanded positions.
    pub fn pmatch(&mut self, motor_pos: &[f64]) {
        let x = self.xf.current();
        let prev = x.to_base(&self.pos);
        let base = self.axes.pmatch(motor_pos, &prev);
        self.pos = x.to_prog(&base);
        for (r, c) in self.cmd.iter_mut().enumerate() {
            *c = motor_pos
                .get(r)
                .copied()
                .filter(|v| v.is_finite())
                .unwrap_or(0.0);
        }
        if self.tl.is_idle() {
            self.tl.clear(base);
            self.frozen = false;
        }
    }

    /// Rows (C.S. motor order) of the `#m->I` motors (inverse kinematics).
    pub fn inverse_rows(&self) -> Vec<usize> {
        (0..self.axes.motors.len())
            .filter(|&r| self.axes.inverse[r])
            .collect()
    }

    /// The trajectory, not an abort's deceleration or a frozen C.S., sets the motors (inverse
    /// kinematics apply).
    pub fn on_path(&self) -> bool {
        self.abort.is_none() && !self.frozen
    }

    /// The base axis position the trajectory is at now (what inverse kinematics transforms).
    pub fn base_now(&self) -> AxisVec {
        self.tl.eval(self.tau)
    }

    /// Inverse kinematics set the commanded position of row `r` (velocity follows).
    pub fn set_kin_motor(&mut self, r: usize, v: f64, first: bool) {
        let servo = self.tb.servo_ms();
        if let Some(c) = self.cmd.get_mut(r) {
            if let Some(x) = self.vel.get_mut(r) {
                *x = if first { 0.0 } else { (v - *c) / servo };
            }
            *c = v;
        }
    }

    /// Forward kinematics found base axis position `base` for the present motor positions
    /// (a PMATCH through the kinematic routine).
    pub fn set_base_position(&mut self, base: AxisVec) {
        self.pos = self.xf.current().to_prog(&base);
        if self.tl.is_idle() {
            self.tl.clear(base);
            self.frozen = false;
        }
    }

    /// Present programmed axis positions (end of the last calculated move).
    pub fn program_position(&self) -> AxisVec {
        self.pos
    }

    /// Motor positions (counts, axis frame: commanded + position bias) of the present
    /// programmed position (the end of the last calculated move), [`CoordSystem::motors`]
    /// order.
    pub fn program_motor_positions(&self) -> Vec<f64> {
        let base = self.xf.current().to_base(&self.pos);
        self.axes
            .motor_positions(&base, &self.cmd)
            .iter()
            .copied()
            .collect()
    }

    /// Rename the programmed position without moving (`Z`, `{axis}=`, `PSET`): `f` changes
    /// it; returns how much each motor's axis-frame position changes — the change of its
    /// position bias (seed 7250-7270, 10187-10202, 11441-11452).
    pub fn rename_axes(&mut self, f: impl FnOnce(&mut AxisVec)) -> Vec<f64> {
        let old = self.program_motor_positions();
        f(&mut self.pos);
        let new = self.program_motor_positions();
        let delta: Vec<f64> = new.iter().zip(&old).map(|(n, o)| n - o).collect();
        for (c, d) in self.cmd.iter_mut().zip(&delta) {
            *c += d;
        }
        if self.tl.is_idle() {
            self.tl.clear(self.xf.current().to_base(&self.pos));
        }
        delta
    }

    /// After an abort: the programmed position becomes `p` (the end of the move that was
    /// executing, where `J=` takes the motors and `R` resumes, seed 8397-8403).
    pub fn set_program_position(&mut self, p: AxisVec) {
        self.pos = p;
        if self.abort.is_some() || self.tl.is_idle() {
            self.tl.clear(self.xf.current().to_base(&self.pos));
        }
    }

    /// A RAPID move-until-trigger line (seed 10236-10262): each motor of a named axis gets its
    /// own triggered (or plain) move; returns (motor, end position in the axis frame, distance
    /// past the trigger in counts for motors of an axis with `^`). The programmed position
    /// becomes the untriggered end; the executor re-matches it when the motors have finished.
    pub fn trigger_targets(
        &mut self,
        w: &MoveWords,
        trig: &[Option<f64>; 9],
    ) -> Result<Vec<(u16, f64, Option<f64>)>, CoordError> {
        let xf = self.ready()?;
        let target = self.target(w)?;
        let old = self.program_motor_positions();
        let new = self.axes.motor_positions(&xf.to_base(&target), &self.cmd);
        let mut out = Vec::new();
        for (r, &m) in self.axes.motors.iter().enumerate() {
            let mut dist: Option<f64> = None;
            for (k, d) in trig.iter().enumerate() {
                let s = self.axes.scale[(r, k)];
                if let (Some(d), true) = (d, s != 0.0) {
                    dist = Some(dist.unwrap_or(0.0) + s * d);
                }
            }
            let to = new[r];
            if !to.is_finite() || dist.is_some_and(|d| !d.is_finite()) {
                return Err(CoordError::OutOfRange("trigger move"));
            }
            if dist.is_some() || old.get(r).is_none_or(|o| *o != to) {
                out.push((m, to, dist));
            }
        }
        self.pos = target;
        Ok(out)
    }

    /// Which axes (X..W) the motors of this C.S. use.
    pub fn axes_used(&self) -> [bool; 9] {
        self.axes.axes_used()
    }

    /// The time base has ramped to zero in a feed hold.
    pub fn hold_complete(&self) -> bool {
        self.tb.is_held() && self.tb.percent() == 0.0
    }

    /// Trajectory time (ms).
    pub fn tau(&self) -> f64 {
        self.tau
    }

    /// The clock stands in a DWELL.
    pub fn in_dwell(&self) -> bool {
        self.tl.in_dwell(self.tau)
    }

    /// Nothing queued, executing or aborting.
    pub fn is_idle(&self) -> bool {
        self.abort.is_none() && self.tl.is_idle()
    }

    /// Whether the executor should calculate the next move (look-ahead of two moves).
    pub fn wants_moves(&self) -> bool {
        self.abort.is_none() && self.tl.wants_more(self.tau)
    }

    /// Id of the executing move (PE).
    pub fn executing(&self) -> Option<u64> {
        self.tl.executing(self.tau)
    }

    fn target(&self, w: &MoveWords) -> Result<AxisVec, CoordError> {
        let mut t = self.pos;
        for k in 0..9 {
            if let Some(v) = w.pos[k] {
                let v = check_pos(v, "axis position")?;
                t[k] = check_pos(
                    if self.modal.inc[k] {
                        self.pos[k] + v
                    } else {
                        v
                    },
                    "axis position",
                )?;
            }
        }
        Ok(t)
    }

    fn ready(&mut self) -> Result<Affine, CoordError> {
        if self.abort.is_some() {
            return Err(CoordError::Stopping);
        }
        if self.axes.is_empty() {
            return Err(CoordError::NoMotors);
        }
        self.frozen = false;
        Ok(self.xf.current())
    }

    /// Calculate and queue one move line in the present mode. `Ok(None)`: nothing to do
    /// (e.g. a RAPID line that moves no motor).
    pub fn push_move(&mut self, w: &MoveWords) -> Result<Option<u64>, CoordError> {
        let xf = self.ready()?;
        let target = self.target(w)?;
        let d = target - self.pos;
        let id = match self.modal.mode {
            Mode::Rapid => self.push_rapid(&target, &xf)?,
            Mode::Pvt => Some(self.push_pvt(w, &target, &xf)?),
            Mode::Spline1 => {
                let ta = self.modal.spline_time.round();
                if ta < 1.0 {
                    return Err(CoordError::ZeroAccelTime);
                }
                Some(self.tl.push_spline(self.pos, target, ta, xf, self.tau)?)
            }
            Mode::Linear | Mode::Circle1 | Mode::Circle2 => {
                let circle = self.modal.mode != Mode::Linear
                    && self.cfg.i13 > 0.0
                    && (w.r.is_some() || w.ijk.iter().any(Option::is_some));
                let arc = if circle {
                    let centre = match w.r {
                        Some(r) => Centre::Radius(r),
                        None => Centre::Vector {
                            ijk: w.ijk.map(|v| v.unwrap_or(0.0)),
                            absolute: self.modal.centre_abs,
                        },
                    };
                    let i90 = if self.cfg.i90 > 0.0 {
                        self.cfg.i90
                    } else {
                        1.0 / 1_048_576.0
                    };
                    let prm = CircleParams {
                        normal: self.modal.normal,
                        cw: self.modal.mode == Mode::Circle1,
                        ix96: self.cfg.ix96,
                        full_tol: i90 * std::f64::consts::PI,
                    };
                    make_arc(&self.pos, &target, centre, &prm)?
                } else {
                    None
                };
                let prim = match arc {
                    Some(a) => Prim::Arc(Box::new(a)),
                    None => Prim::Line {
                        p0: self.pos,
                        p1: target,
                    },
                };
                let len = match &prim {
                    Prim::Arc(a) => Some(a.length()),
                    _ => None,
                };
                let t = feed_time(&self.modal, &self.cfg, &d, len);
                Some(self.push_blended(prim, t, &d, &xf)?)
            }
        };
        self.pos = target;
        Ok(id)
    }

    fn push_blended(
        &mut self,
        prim: Prim,
        t: f64,
        d: &AxisVec,
        xf: &Affine,
    ) -> Result<u64, CoordError> {
        let (mut tap, s0) = self.modal.accel()?;
        let mut t = t.max(tap);
        if self.cfg.i13 <= 0.0 && prim.is_line() {
            let dm = to_motor(&self.axes.scale, &xf.vel_to_base(d));
            t = t.max(ix16_time(&self.cfg, &dm));
            let vb = xf.vel_to_base(&(d / t));
            let tail = self
                .tl
                .tail_blend_velocity(self.tau)
                .unwrap_or_else(AxisVec::zeros);
            let dv = to_motor(&self.axes.scale, &(vb - tail));
            tap = ix17_accel(&self.cfg, &dv, tap);
            t = t.max(tap);
        }
        let s = s0 * self.modal.accel()?.0 / tap;
        let (td, sd) = self.modal.decel(tap, s);
        if self.cfg.ix92 {
            self.tl.settle_tail();
        }
        self.tl.push(
            NewPiece {
                prim,
                dur: t,
                kind: Kind::Blend { ta: tap, s, td, sd },
                xf: *xf,
            },
            self.tau,
        )
    }

    fn push_rapid(&mut self, target: &AxisVec, xf: &Affine) -> Result<Option<u64>, CoordError> {
        let dm = to_motor(
            &self.axes.scale,
            &(xf.to_base(target) - xf.to_base(&self.pos)),
        );
        let mut best: Option<PtpProfile> = None;
        for (r, d) in dm.iter().enumerate() {
            let l = self.cfg.limits(r);
            let v = if self.cfg.i50 { l.ix16 } else { l.ix22 };
            let p = PtpProfile::plan(d.abs(), v, l.ix19, l.ix20, l.ix21);
            if p.d > 0.0 && !matches!(best, Some(b) if b.duration() >= p.duration()) {
                best = Some(p);
            }
        }
        let Some(prof) = best else { return Ok(None) };
        let prim = Prim::Ptp {
            p0: self.pos,
            p1: *target,
            prof,
        };
        Ok(Some(self.tl.push(
            NewPiece {
                prim,
                dur: prof.duration(),
                kind: Kind::Solo,
                xf: *xf,
            },
            self.tau,
        )?))
    }

    fn push_pvt(
        &mut self,
        w: &MoveWords,
        target: &AxisVec,
        xf: &Affine,
    ) -> Result<u64, CoordError> {
        let t = self.modal.pvt_time.round();
        if t.is_nan() || t < 1.0 {
            return Err(CoordError::BadTime("PVT time"));
        }
        let unit = if self.cfg.ix90 > 0.0 {
            self.cfg.ix90
        } else {
            1000.0
        };
        let mut v1 = AxisVec::zeros();
        for k in 0..9 {
            if let Some(v) = w.vel[k] {
                v1[k] = check_pos(v, "PVT velocity")? / unit;
            }
        }
        let v0 = self.tl.pvt_tail_velocity().unwrap_or_else(AxisVec::zeros);
        let prim = Prim::pvt(self.pos, v0, *target, v1, t);
        self.tl.push(
            NewPiece {
                prim,
                dur: t,
                kind: Kind::Pvt,
                xf: *xf,
            },
            self.tau,
        )
    }

    /// `DWELL{ms}`: stop (after the TA deceleration) and hold for `ms` real-time ms.
    pub fn dwell(&mut self, ms: f64) -> Result<u64, CoordError> {
        if !(ms.is_finite() && (0.0..=8_388_607.0).contains(&ms)) {
            return Err(CoordError::BadTime("DWELL"));
        }
        let xf = self.ready()?;
        let prim = Prim::Hold(self.pos);
        self.tl.push(
            NewPiece {
                prim,
                dur: ms.round().max(1e-6),
                kind: Kind::Dwell,
                xf,
            },
            self.tau,
        )
    }

    /// `DELAY{ms}`: a blended zero-distance move of at least TA' (scales with `%`).
    pub fn delay(&mut self, ms: f64) -> Result<u64, CoordError> {
        if !(ms.is_finite() && (0.0..=8_388_607.0).contains(&ms)) {
            return Err(CoordError::BadTime("DELAY"));
        }
        let xf = self.ready()?;
        let prim = Prim::Line {
            p0: self.pos,
            p1: self.pos,
        };
        let (tap, s) = self.modal.accel()?;
        let (td, sd) = self.modal.decel(tap, s);
        self.tl.push(
            NewPiece {
                prim,
                dur: ms.max(tap),
                kind: Kind::Blend { ta: tap, s, td, sd },
                xf,
            },
            self.tau,
        )
    }

    /// `/`: stop at the end of the executing move.
    pub fn stop_at_end(&mut self) {
        let end = self.tl.stop_after_current(self.tau);
        self.pos = self.xf.current().to_prog(&end);
    }

    /// `A` / `<CTRL-A>`: every motor decelerates at its Ix15 (path not kept); queued moves
    /// are dropped. The program position stays the old target (PMATCH to use the stop point).
    pub fn abort(&mut self) {
        if self.abort.is_none() && !self.tl.is_idle() {
            self.abort = Some(Abort {
                p0: self.cmd.clone(),
                v0: self.vel.clone(),
                t: 0.0,
            });
        }
        let rest = self.xf.current().to_base(&self.pos);
        self.tl.clear(rest);
        self.frozen = true;
    }

    /// The abort deceleration ends at once: every motor it was stopping has been killed (no
    /// motor follows it any more, so the C.S. has no motion pending).
    pub fn end_abort_of_killed(&mut self) {
        if self.abort.is_some() {
            self.abort = None;
            self.vel.iter_mut().for_each(|v| *v = 0.0);
        }
    }

    /// `H` feed hold.
    pub fn hold(&mut self) {
        self.tb.hold();
    }

    /// `\` program hold at `slew` (2^-23 ms per servo cycle per servo cycle).
    pub fn program_hold(&mut self, slew: f64) {
        self.tb.program_hold(slew);
    }

    /// `R`/`S` release of a feed hold.
    pub fn release(&mut self) {
        self.tb.release();
    }

    /// One servo cycle.
    pub fn tick(&mut self) -> TickOut {
        let servo = self.tb.servo_ms();
        if let Some(a) = &mut self.abort {
            a.t += servo;
            let mut all = true;
            for (r, c) in self.cmd.iter_mut().enumerate() {
                let (dp, done) = decel_stop(
                    a.v0.get(r).copied().unwrap_or(0.0),
                    self.cfg.limits(r).ix15,
                    a.t,
                );
                *c = a.p0.get(r).copied().unwrap_or(*c) + dp;
                all &= done;
            }
            if all {
                self.abort = None;
            }
            self.vel.iter_mut().for_each(|v| *v = 0.0);
            return TickOut {
                motors: self.cmd.clone(),
                started: Vec::new(),
                finished: Vec::new(),
            };
        }
        let dt = self.tb.tick();
        self.tau += if self.tl.in_dwell(self.tau) {
            servo
        } else {
            dt
        };
        let (started, finished) = self.tl.advance(self.tau);
        if !self.frozen {
            let base = self.tl.eval(self.tau);
            let m: DVector<f64> = self.axes.motor_positions(&base, &self.cmd);
            for (r, c) in self.cmd.iter_mut().enumerate() {
                let new = m[r];
                self.vel[r] = (new - *c) / servo;
                *c = new;
            }
        }
        TickOut {
            motors: self.cmd.clone(),
            started,
            finished,
        }
    }

    /// `TSEL n` (renames the present position into the new frame).
    pub fn tsel(&mut self, n: u32) -> Result<(), CoordError> {
        self.rename(|b| b.tsel(n))
    }

    /// Apply a matrix operation (`TINIT`, `ADIS`, `AROT`…): the base position is kept and
    /// the programmed position renamed.
    pub fn rename(
        &mut self,
        f: impl FnOnce(&mut TransformBank) -> Result<(), CoordError>,
    ) -> Result<(), CoordError> {
        let base = self.xf.current().to_base(&self.pos);
        f(&mut self.xf)?;
        self.pos = self.xf.current().to_prog(&base);
        Ok(())
    }
}
