//! Addressing (§3.0), coordinate-system commands (§3.3), program control (§3.3.3, §5.10) and
//! motor commands (§3.4). Motion effects are queued as [`Action`]s; the interpreter keeps the
//! bookkeeping needed for its own replies and refusals (ERR001, ERR010-ERR016).

use super::exec::{Exec, Out};
use super::{Pmac, Session};
use crate::coord::axes::AXES;
use crate::domain::{CsNum, ErrCode, MotorNum};
use crate::lang::pmac::ast::{Axis, CmdKind, JogKind};
use crate::model::{axis_def_legal, axis_def_text};
use crate::model::{format_position, format_value};
use crate::model::{Action, ActionKind};

/// `??` word-1 (feedrate bit, incremental bit) of each motion axis.
fn axis_bits(a: Axis) -> Option<(u32, u32)> {
    let (f, i) = match a {
        Axis::Z => (23, 22),
        Axis::Y => (21, 20),
        Axis::X => (19, 18),
        Axis::W => (17, 16),
        Axis::V => (15, 14),
        Axis::U => (13, 12),
        Axis::C => (11, 10),
        Axis::B => (9, 8),
        Axis::A => (7, 6),
        _ => return None,
    };
    Some((1 << f, 1 << i))
}

impl Pmac<'_> {
    /// Queue the motion side of `cmd` for the servo loop.
    fn action(&mut self, s: &Session, cmd: &CmdKind) {
        use CmdKind as K;
        let kind = match cmd {
            K::Kill => ActionKind::Kill,
            K::MotorAbsRead => ActionKind::AbsRead,
            K::MotorInit => ActionKind::Enable,
            K::OpenLoop(v) => ActionKind::OpenLoop(*v),
            K::Home => ActionKind::Home,
            K::HomeZ => ActionKind::HomeZero,
            K::Jog { kind, trigger } => ActionKind::Jog {
                kind: *kind,
                trigger: *trigger,
            },
            K::Begin(_) => ActionKind::Begin,
            K::Run => ActionKind::Run,
            K::Step => ActionKind::Step,
            K::Resume => ActionKind::Resume,
            K::Quit => ActionKind::Quit,
            K::StopAtEnd => ActionKind::StopAtEnd,
            K::Abort => ActionKind::Abort,
            K::Hold => ActionKind::Hold,
            K::HoldJog => ActionKind::HoldJog,
            K::BackUp => ActionKind::BackUp,
            K::OverrideSet(v) => ActionKind::Override(*v),
            K::MFlush => ActionKind::MFlush,
            K::PMatch => ActionKind::PMatch,
            K::AxisRename(a, v) => ActionKind::AxisRename(*a, *v),
            K::ZeroAxes => ActionKind::ZeroAxes,
            _ => return,
        };
        self.model.push_action(Action {
            motor: s.motor,
            coord: s.coord,
            kind,
        });
    }

    fn motor_ok(&self, n: u32) -> Result<MotorNum, ErrCode> {
        MotorNum::new(n, &self.model.state.limits()).ok_or(ErrCode::Data)
    }

    /// Whether C.S. `cs` is running a motion program.
    pub(crate) fn cs_running(&self, cs: u16) -> bool {
        cs.checked_sub(1)
            .and_then(|k| self.model.state.coords.get(k as usize))
            .is_some_and(|c| c.running)
    }

    fn motor_busy(&self, m: u16) -> bool {
        self.model
            .run
            .cs_of(m)
            .is_some_and(|cs| self.cs_running(cs))
    }

    /// Apply the immediate servo-state effect of a motor command to motor `m` (1-based).
    fn servo(&mut self, m: u16, closed: Option<bool>, amp: Option<bool>, moving: Option<bool>) {
        let k = m as usize - 1;
        if let Some(f) = self.model.state.motors.get_mut(k) {
            if let Some(c) = closed {
                f.open_loop = !c;
                f.desired_velocity_zero = c;
            }
            if let Some(a) = amp {
                f.amp_enabled = a;
            }
        }
        if let (Some(mv), Some(r)) = (moving, self.model.run.motors.get_mut(k)) {
            r.moving = mv;
        }
    }

    pub(crate) fn exec_motion(&mut self, s: &mut Session, cmd: &CmdKind, out: &mut Out) -> Exec {
        use CmdKind as K;
        let cs = s.coord.get();
        let csk = cs as usize - 1;
        match cmd {
            K::AddrMotor(n) => s.motor = self.motor_ok(*n)?,
            K::ReportMotor => out.line(s.motor.get().to_string()),
            K::AddrCoord(n) => {
                s.coord = CsNum::new(*n, &self.model.state.limits()).ok_or(ErrCode::Data)?;
            }
            K::ReportCoord => out.line(cs.to_string()),
            K::AxisDefQuery(n) => {
                let m = self.motor_ok(*n)?;
                let text = match &self.model.run.axes[m.index()] {
                    Some((c, d)) if *c == cs => axis_def_text(d),
                    _ => "0".to_string(),
                };
                out.line(text);
            }
            K::AxisDefine(n, def) => {
                let m = self.motor_ok(*n)?;
                if !axis_def_legal(def) {
                    return Err(ErrCode::Data);
                }
                match self.model.run.cs_of(m.get()) {
                    Some(c) if c != cs => return Err(ErrCode::Data),
                    _ => {}
                }
                if self.cs_running(cs) {
                    return Err(ErrCode::Running);
                }
                self.model.run.axes[m.index()] = Some((cs, def.clone()));
                self.sync_motor_coords();
            }
            K::AxisUndefine(n) => {
                let m = self.motor_ok(*n)?;
                if self.model.run.cs_of(m.get()) == Some(cs) {
                    self.model.run.axes[m.index()] = None;
                    self.sync_motor_coords();
                }
            }
            K::Undefine => {
                for a in self.model.run.axes.iter_mut() {
                    if a.as_ref().is_some_and(|(c, _)| *c == cs) {
                        *a = None;
                    }
                }
                self.sync_motor_coords();
            }
            K::UndefineAll => {
                self.model.run.axes.iter_mut().for_each(|a| *a = None);
                self.sync_motor_coords();
            }
            K::CsStatus => out.line(self.model.state.cs_status_text(cs)),
            K::OverrideQuery => {
                let r = &self.model.run.cs[csk];
                out.line(format_value(if r.held { 0.0 } else { r.override_pct }));
            }
            K::OverrideSet(v) => {
                if *v < 0.0 || !v.is_finite() {
                    return Err(ErrCode::Data);
                }
                let i10 = self
                    .model
                    .state
                    .peek_ivar(10)
                    .unwrap_or(3_713_707.0)
                    .max(1.0);
                let max = 8_388_608.0 / i10 * 100.0;
                self.model.run.cs[csk].override_pct = v.min(max);
                // The `%` command register (X:$0806, Turbo X:$2000 …) holds it in I10 units.
                let word = (v.min(max) * i10 / 100.0).round() as i64;
                self.model.state.set_feed_word(cs, word);
                self.action(s, cmd);
            }
            K::Begin(num) => {
                if self.cs_running(cs) {
                    return Err(ErrCode::Running);
                }
                // A new program pointer drops the `/` stop point at once, so `B..R` on the
                // same line is not refused with ERR017 (seed 6749).
                self.model.run.cs[csk].stop_point = None;
                let v = num.value;
                if !(0.0..32_768.0).contains(&v) {
                    return Err(ErrCode::Data);
                }
                let prog = v.trunc() as u32;
                // N(frac × 100,000); Power: × 1,000,000 (seed 000 L39693-39697).
                let scale = self.model.state.limits().sem.call_label_scale;
                let label = ((v - v.trunc()) * scale).round() as u32;
                self.model.run.cs[csk].pointer = Some((prog, label));
                let r = &mut self.model.run.cs[csk];
                (r.pc_text, r.pe_text, r.pc_at, r.pe_at) = (None, None, None, None);
                self.action(s, cmd);
            }
            K::Run | K::Step | K::Resume => {
                self.run_checks(cs)?;
                let step = matches!(cmd, K::Step);
                let f = &mut self.model.state.coords[csk];
                f.running = true;
                f.single_step = step;
                f.continuous_request = !step;
                f.program_hold = false;
                self.model.run.cs[csk].held = false;
                self.action(s, cmd);
            }
            K::Quit | K::Abort => {
                let f = &mut self.model.state.coords[csk];
                f.running = false;
                f.continuous_request = false;
                f.single_step = matches!(cmd, K::Quit) || f.single_step;
                if matches!(cmd, K::Abort) {
                    // Seed 6749: `A` gives up resuming from the stop point.
                    self.model.run.cs[csk].stop_point = None;
                    for m in self.model.run.motors_in(cs) {
                        self.servo(m, Some(true), Some(true), Some(false));
                    }
                }
                self.action(s, cmd);
            }
            K::Hold | K::BackUp | K::HoldJog => {
                self.model.run.cs[csk].held = true;
                self.action(s, cmd);
            }
            K::StopAtEnd | K::MFlush | K::PMatch => self.action(s, cmd),
            K::AxisRename(..) | K::ZeroAxes => {
                if self.cs_running(cs) {
                    return Err(ErrCode::Running);
                }
                self.action(s, cmd)
            }
            K::Abs(list) | K::Inc(list) => {
                let inc = matches!(cmd, K::Inc(_));
                let f = &mut self.model.state.coords[csk];
                let axes: Vec<Axis> = list.clone().unwrap_or_else(|| AXES.to_vec());
                for a in axes {
                    if a == Axis::R {
                        f.radius_inc = inc;
                    } else if let Some((_, ib)) = axis_bits(a) {
                        f.axis_bits = if inc {
                            f.axis_bits | ib
                        } else {
                            f.axis_bits & !ib
                        };
                    }
                }
            }
            K::Frax(list) => {
                let f = &mut self.model.state.coords[csk];
                let axes: Vec<Axis> = list.clone().unwrap_or_else(|| AXES.to_vec());
                for a in AXES {
                    if let Some((fb, _)) = axis_bits(a) {
                        f.axis_bits = if axes.contains(&a) {
                            f.axis_bits | fb
                        } else {
                            f.axis_bits & !fb
                        };
                    }
                }
            }
            K::ProgCounter | K::ExecPointer => {
                let r = &self.model.run.cs[csk];
                let kept = if matches!(cmd, K::ProgCounter) {
                    &r.pc_text
                } else {
                    &r.pe_text
                };
                if let (Some(t), Some(_)) = (kept, r.pointer) {
                    out.line(t.clone());
                    return Ok(());
                }
                let (prog, label) = self.model.run.cs[csk].pointer.ok_or(ErrCode::Data)?;
                out.line(format!("P{prog}:{}", self.label_offset(prog, label)));
            }
            K::RotaryRemaining => {
                let n = self
                    .bufs
                    .rotary
                    .get(&(cs as u8))
                    .map_or(0, |r| r.lines.len());
                out.line(n.to_string());
            }
            K::Learn(list) => self.learn(s, list.as_deref())?,
            K::Position | K::Velocity | K::FollowingError => {
                let r = self
                    .run
                    .report
                    .get(s.motor.get() as usize - 1)
                    .copied()
                    .unwrap_or_default();
                let v = match cmd {
                    K::Position => r.0,
                    K::Velocity => r.1,
                    _ => r.2,
                };
                out.line(format_position(v));
            }
            K::MotorStatus => out.line(self.model.state.motor_status_text(s.motor.get())),
            K::MotorInit
            | K::MotorAbsRead
            | K::Home
            | K::HomeZ
            | K::Kill
            | K::OpenLoop(_)
            | K::Jog { .. } => {
                let m = s.motor.get();
                if self.motor_busy(m) {
                    return Err(ErrCode::Running);
                }
                match cmd {
                    K::MotorInit => self.servo(m, Some(true), Some(true), Some(false)),
                    K::MotorAbsRead | K::Kill => {
                        self.servo(m, Some(false), Some(false), Some(false))
                    }
                    K::OpenLoop(_) => self.servo(m, Some(false), Some(true), Some(false)),
                    K::Home => self.servo(m, Some(true), Some(true), Some(true)),
                    K::Jog {
                        kind: JogKind::Plus | JogKind::Minus,
                        ..
                    } => self.servo(m, Some(true), Some(true), Some(true)),
                    K::Jog { .. } => self.servo(m, Some(true), Some(true), Some(false)),
                    _ => {}
                }
                self.action(s, cmd);
            }
            _ => return Err(ErrCode::Data),
        }
        Ok(())
    }

    /// R/S refusal checks in the manual's order (§5.10): ERR010 … ERR016.
    fn run_checks(&self, cs: u16) -> Exec {
        let motors = self.model.run.motors_in(cs);
        let flags = |m: u16| self.model.state.motors.get(m as usize - 1);
        let ivar = |m: u16| {
            self.model
                .state
                .peek_ivar(100 * u32::from(m))
                .unwrap_or(0.0)
                != 0.0
        };
        if motors
            .iter()
            .any(|&m| flags(m).is_some_and(|f| f.neg_limit && f.pos_limit))
        {
            return Err(ErrCode::BothLimits);
        }
        let moving = |m: u16| {
            self.model
                .run
                .motors
                .get(m as usize - 1)
                .is_some_and(|r| r.moving)
        };
        if motors
            .iter()
            .any(|&m| moving(m) || flags(m).is_some_and(|f| f.home_search))
        {
            return Err(ErrCode::MoveNotDone);
        }
        if motors
            .iter()
            .any(|&m| ivar(m) && flags(m).is_some_and(|f| f.open_loop))
        {
            return Err(ErrCode::OpenLoop);
        }
        if motors.iter().any(|&m| !ivar(m)) {
            return Err(ErrCode::NotActivated);
        }
        if motors.is_empty() {
            return Err(ErrCode::NoMotors);
        }
        if matches!(
            self.mem.open.map(|o| o.id),
            Some(crate::model::BufId::Prog(_))
        ) {
            return Err(ErrCode::NoProgram);
        }
        let (prog, _) = self.model.run.cs[cs as usize - 1]
            .pointer
            .ok_or(ErrCode::NoProgram)?;
        if prog == 0 {
            if !self.model.bufs.rotary.contains_key(&(cs as u8)) {
                return Err(ErrCode::NoProgram);
            }
            return self.stop_point_check(cs);
        }
        let p = u16::try_from(prog)
            .ok()
            .and_then(|n| self.model.bufs.progs.get(&n))
            .ok_or(ErrCode::NoProgram)?;
        if !p.valid {
            return Err(ErrCode::BadProgram);
        }
        self.stop_point_check(cs)
    }

    /// ERR017: after a `/` stop every motor must be back at its stop point (within the Ix28
    /// in-position band, at least half a count) before R/S.
    fn stop_point_check(&self, cs: u16) -> Exec {
        let Some(sp) = &self.model.run.cs[cs as usize - 1].stop_point else {
            return Ok(());
        };
        for &(m, p) in sp {
            let band = (self
                .state
                .peek_ivar(100 * u32::from(m) + 28)
                .unwrap_or(160.0)
                / 16.0)
                .max(0.5);
            let at = self.model.run.report.get(m as usize - 1).map_or(p, |r| r.0);
            if (at - p).abs() > band {
                return Err(ErrCode::AwayFromStop);
            }
        }
        Ok(())
    }

    /// Word offset of label N`label` in PROG `prog` (0 for N0 or when absent).
    pub(crate) fn label_offset(&self, prog: u32, label: u32) -> u32 {
        use crate::lang::pmac::ast::StmtKind;
        use crate::model::StoredLine;
        let Some(p) = u16::try_from(prog)
            .ok()
            .and_then(|n| self.model.bufs.progs.get(&n))
        else {
            return 0;
        };
        let mut off = 0;
        for l in &p.lines {
            if l.stmts
                .first()
                .is_some_and(|st| st.kind == StmtKind::Label(label))
                && label != 0
            {
                return off;
            }
            off += l.words();
        }
        0
    }

    /// `LEARN[(axes)]`: append the present commanded axis positions to the open motion buffer.
    fn learn(&mut self, s: &Session, list: Option<&[Axis]>) -> Exec {
        use crate::lang::pmac::ast::{AxisWord, Expr, Pos, Stmt, StmtKind};
        let open = self
            .mem
            .open
            .filter(|o| o.session == s.id)
            .ok_or(ErrCode::NeedsBuffer)?;
        if matches!(open.id, crate::model::BufId::Plc(_)) {
            return Err(ErrCode::NeedsBuffer);
        }
        let axes: Vec<Axis> = list.map(<[Axis]>::to_vec).unwrap_or_else(|| AXES.to_vec());
        let words = axes
            .into_iter()
            .filter(|a| a.is_motion_axis())
            .map(|axis| AxisWord {
                axis,
                value: Expr::num(0.0),
                extra: None,
            })
            .collect();
        let st = Stmt {
            kind: StmtKind::Move(words),
            pos: Pos(0),
        };
        self.store_line(s, vec![st])
    }
}
