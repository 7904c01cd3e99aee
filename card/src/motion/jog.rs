//! Per-motor trajectory for jog, home and abort moves (pmac-variables-servo-macro.md §5.2).
//!
//! A [`Trajectory`] is a short chain of [`Plan`]s with start times on the motor's trajectory
//! clock (ms, advanced by the time-base increment each servo cycle). A new move command is
//! planned to start I12 ms later from the state the present course would have then ("the motor
//! keeps its current course meanwhile", seed L 1684-1696); a command arriving before an earlier
//! one took effect supersedes it from its own start time on.

use super::profile::{Kin, Plan, RampParams};

/// Most plans kept at once (one running plus pending ones inside the I12 window).
const MAX_PLANS: usize = 8;

/// A jog request with every value resolved to counts (the `*` forms read the jog register,
/// `J^` is made relative to the actual position, by the caller).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JogCmd {
    /// `J+`: jog positive indefinitely.
    Plus,
    /// `J-`: jog negative indefinitely.
    Minus,
    /// `J/`: ramp to a stop.
    Stop,
    /// Go to an absolute position in counts (`J=`, `J={c}`, `J:{c}`, `J^{c}` once resolved).
    To(f64),
    /// Jog on indefinitely at this velocity, counts/ms (Power `jog`: the present velocity).
    Velocity(f64),
}

/// Latched move parameters for one jog (Ix19-Ix22 when the command was given).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JogParams {
    /// Accel parameters.
    pub ramp: RampParams,
    /// Ix22 jog speed, counts/ms.
    pub speed: f64,
}

impl JogCmd {
    /// The plan for this jog from the state `k`.
    pub fn plan(&self, k: Kin, jp: &JogParams) -> Plan {
        let speed = if jp.speed.is_finite() {
            jp.speed.abs()
        } else {
            0.0
        };
        match *self {
            JogCmd::Plus => Plan::to_velocity(k.p, k.v, speed, &jp.ramp),
            JogCmd::Minus => Plan::to_velocity(k.p, k.v, -speed, &jp.ramp),
            JogCmd::Stop => Plan::to_velocity(k.p, k.v, 0.0, &jp.ramp),
            JogCmd::To(target) => Plan::to_position(k.p, k.v, target, speed, &jp.ramp),
            JogCmd::Velocity(v) => Plan::to_velocity(k.p, k.v, v, &jp.ramp),
        }
    }

    /// Direction of motion asked for, relative to the commanded position `cmd` (+1, -1, 0).
    pub fn direction(&self, cmd: f64) -> f64 {
        match *self {
            JogCmd::Plus => 1.0,
            JogCmd::Minus => -1.0,
            JogCmd::Stop => 0.0,
            JogCmd::Velocity(v) => v.signum() * f64::from(u8::from(v != 0.0)),
            JogCmd::To(t) => {
                if t > cmd {
                    1.0
                } else if t < cmd {
                    -1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// The commanded-position generator of one motor.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    t: f64,
    plans: Vec<(f64, Plan)>,
}

impl Trajectory {
    /// Stand still at `p`.
    pub fn new(p: f64) -> Self {
        Trajectory {
            t: 0.0,
            plans: vec![(0.0, Plan::hold(p))],
        }
    }

    /// Present trajectory time, ms.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// State of the chain at time `t` (≥ the present time).
    pub fn state_at(&self, t: f64) -> Kin {
        let mut cur = None;
        for (start, plan) in &self.plans {
            if *start <= t || cur.is_none() {
                cur = Some((*start, plan));
            }
        }
        match cur {
            Some((start, plan)) => plan.eval(t - start),
            None => Kin::default(),
        }
    }

    /// Advance by `dt` ms; returns the new commanded state.
    pub fn advance(&mut self, dt: f64) -> Kin {
        if dt.is_finite() && dt > 0.0 {
            self.t += dt;
        }
        while self.plans.len() > 1 && self.plans[1].0 <= self.t {
            self.plans.remove(0);
        }
        self.state_at(self.t)
    }

    /// The present commanded state.
    pub fn now(&self) -> Kin {
        self.state_at(self.t)
    }

    /// Start a new plan `delay` ms from now, built from the state at that time.
    pub fn command(&mut self, delay: f64, make: impl FnOnce(Kin) -> Plan) {
        let delay = if delay.is_finite() && delay > 0.0 {
            delay
        } else {
            0.0
        };
        let at = self.t + delay;
        self.plans.retain(|(s, _)| *s < at);
        if self.plans.len() >= MAX_PLANS {
            self.plans.truncate(MAX_PLANS - 1);
        }
        let k = self.state_at(at);
        let plan = make(k);
        if self.plans.len() == 1
            && self.finished()
            && k.v == 0.0
            && k.a == 0.0
            && plan.end_position() == Some(k.p)
        {
            // A motor at rest asked to stay where it is (`J/`, `J=` to the present
            // position): no move is scheduled, so none is in progress (issue 14 item 16).
            return;
        }
        self.plans.push((at, plan));
    }

    /// Replace everything by standing still at `p` now (killed, open loop, enable).
    pub fn hold(&mut self, p: f64) {
        self.plans.clear();
        self.plans.push((self.t, Plan::hold(p)));
    }

    /// Replace everything by `plan` starting now.
    pub fn replace(&mut self, plan: Plan) {
        self.plans.clear();
        self.plans.push((self.t, plan));
    }

    /// True when no plan is pending and the running one has finished (at rest or endless).
    pub fn finished(&self) -> bool {
        match self.plans.as_slice() {
            [(s, p)] => p.done_at(self.t - s),
            _ => false,
        }
    }

    /// The end position of the last plan (`None` for an endless jog).
    pub fn target(&self) -> Option<f64> {
        self.plans.last().and_then(|(_, p)| p.end_position())
    }

    /// Shift every plan by `dp` counts (home re-referencing).
    pub fn shift(&mut self, dp: f64) {
        for (_, p) in &mut self.plans {
            p.shift(dp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jp() -> JogParams {
        JogParams {
            ramp: RampParams::new(0.0, 100.0, 0.0),
            speed: 10.0,
        }
    }

    #[test]
    fn command_waits_i12_then_moves() {
        let mut tr = Trajectory::new(5.0);
        tr.command(10.0, |k| JogCmd::Plus.plan(k, &jp()));
        assert_eq!(tr.advance(10.0).p, 5.0);
        // 10 ms into a linear 100 ms ramp to 10 counts/ms: a = 0.1, p = 5 + 0.1·10²/2.
        let k = tr.advance(10.0);
        assert!((k.p - 10.0).abs() < 1e-12 && (k.v - 1.0).abs() < 1e-12);
    }

    #[test]
    fn later_command_supersedes_pending_one() {
        let mut tr = Trajectory::new(0.0);
        tr.command(10.0, |k| JogCmd::Plus.plan(k, &jp()));
        tr.advance(5.0);
        tr.command(10.0, |k| JogCmd::To(k.p).plan(k, &jp()));
        // Plus started at 10 ms and runs until 15 ms, then the move back to 0 from there.
        let k = tr.state_at(15.0);
        assert!((k.p - 1.25).abs() < 1e-12);
        for _ in 0..100 {
            tr.advance(5.0);
        }
        assert!(tr.finished());
        assert_eq!(tr.now().p, 1.25);
    }
}
