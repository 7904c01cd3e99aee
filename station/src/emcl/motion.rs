//! The drive's ramp generator (spec emcl.md §11, DECISION D14): a deterministic 1 kHz integer
//! model. Every ms the velocity `v` (pps) moves toward its goal by the acceleration of the
//! six-point ramp (with the remainder carried: `a` pps² adds `a/1000` pps per ms), and the
//! position advances by `v` milli-µsteps (a pps velocity is exactly `v` thousandths of a
//! µstep per ms), carried the same way. A positioning move computes each ms the highest
//! velocity from which it can still stop on the target, and lands on it exactly.
//!
//! Six-point ramp (AP 15–21): the motor starts at the start velocity AP 15; below the break
//! velocity AP 18 it accelerates with AP 16 and decelerates with AP 19, above it with AP 5 and
//! AP 17; a positioning move drops from the stop velocity AP 20 to 0 on the target. A zero
//! parameter falls back to the plain trapezoid (AP 5 both ways). Velocity mode (ROR/ROL/MST)
//! uses the same rates.

/// Ramp parameters, magnitudes (the sign of AP 4, 5, 15–21 is ignored).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ramp {
    /// AP 4: maximum positioning velocity, pps.
    pub vmax: i64,
    /// AP 5: maximum acceleration, pps².
    pub amax: i64,
    /// AP 15: start velocity, pps.
    pub vstart: i64,
    /// AP 16: start acceleration (below AP 18), pps².
    pub a1: i64,
    /// AP 17: maximum deceleration (above AP 18), pps².
    pub dmax: i64,
    /// AP 18: break velocity, pps.
    pub v1: i64,
    /// AP 19: final deceleration (below AP 18), pps².
    pub d1: i64,
    /// AP 20: stop velocity, pps.
    pub vstop: i64,
}

impl Ramp {
    /// Acceleration at speed `u` (≥ 0).
    pub fn accel(&self, u: i64) -> i64 {
        if self.v1 > 0 && u < self.v1 && self.a1 > 0 {
            self.a1
        } else {
            self.amax
        }
    }

    /// Deceleration at speed `u` (≥ 0).
    pub fn decel(&self, u: i64) -> i64 {
        if self.v1 > 0 && u <= self.v1 && self.d1 > 0 {
            self.d1
        } else if self.dmax > 0 {
            self.dmax
        } else {
            self.amax
        }
    }

    /// The highest speed from which the motor can still stop within `d` milli-µsteps
    /// (braking with AP 17 above the break velocity and AP 19 below it, dropping to 0 from
    /// the stop velocity). At least 1 pps so that a move always finishes.
    pub fn allowed(&self, d: i64) -> i64 {
        let d = d.max(0) as i128;
        let vs = self.vstop as i128;
        let low = self.decel(0) as i128;
        let hi = self.decel(i64::MAX) as i128;
        // v² = vs² + 2·a·d/1000 below the break velocity; above it the second segment.
        let v1 = self.v1 as i128;
        let reach_v1 = if self.v1 > 0 && low > 0 {
            (v1 * v1 - vs * vs).max(0) * 1000 / (2 * low)
        } else {
            0
        };
        // Discrete braking (a/1000 pps less every ms, the first ms still at this speed)
        // needs v²/2a + v/2000 µsteps: v = √(v_s² + 2ad + h²) − h with h = a/2000.
        let (sq, a) = if self.v1 > 0 && d >= reach_v1 && low > 0 {
            (v1 * v1 + 2 * hi * (d - reach_v1) / 1000, hi)
        } else {
            (vs * vs + 2 * low * d / 1000, low)
        };
        let h = a / 2000;
        let v = isqrt((sq + h * h).clamp(0, u64::MAX as i128) as u64) as i64 - h as i64;
        v.max(1)
    }
}

fn isqrt(n: u64) -> u64 {
    n.isqrt()
}

/// What the generator is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// At rest, nothing commanded (power-up, after a positioning move, after a hard stop).
    Idle,
    /// Velocity mode: ramping to AP 2 (ROR/ROL/MST).
    Velocity,
    /// Positioning: ramping to AP 0 (MVP).
    Position,
    /// Decelerating at a fixed rate (pps²) to standstill, then idle (limit switch, virtual
    /// stop or stall with a soft ramp).
    Stopping(i64),
}

/// Standstill is blocked in a direction: how the motor stops when it runs into it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopKind {
    /// Velocity 0 at once.
    Hard,
    /// Decelerate at this rate (pps²).
    Soft(i64),
}

/// Directions blocked this ms (limit switches, virtual stops).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Blocks {
    /// Positive motion blocked.
    pub plus: Option<StopKind>,
    /// Negative motion blocked.
    pub minus: Option<StopKind>,
}

/// The ramp generator state.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Motion {
    /// AP 1: the microstep counter (wraps modulo 2^32).
    pub pos: i32,
    /// Thousandths of a µstep beyond `pos`, 0..1000.
    sub: i64,
    /// AP 3: velocity, pps.
    pub v: i64,
    /// Carried acceleration, thousandths of a pps.
    vacc: i64,
    /// AP 0: target position.
    pub target_pos: i32,
    /// AP 2: target velocity (velocity mode), pps.
    pub target_vel: i64,
    /// Mode.
    pub mode: Mode,
}

impl Default for Motion {
    fn default() -> Self {
        Motion {
            pos: 0,
            sub: 0,
            v: 0,
            vacc: 0,
            target_pos: 0,
            target_vel: 0,
            mode: Mode::Idle,
        }
    }
}

/// Largest velocity magnitude ROR/ROL accept (erratum E4), pps.
pub const MAX_ROTATE: i64 = 16_777_216;

impl Motion {
    /// ROR/ROL: velocity mode toward `v` pps.
    pub fn rotate(&mut self, v: i64) {
        self.target_vel = v.clamp(-MAX_ROTATE, MAX_ROTATE);
        if self.mode != Mode::Velocity {
            self.vacc = 0;
        }
        self.mode = Mode::Velocity;
    }

    /// MST: target velocity 0 with the ramp; a positioning move is aborted.
    pub fn soft_stop(&mut self) {
        self.rotate(0);
    }

    /// MVP: position mode toward `target`.
    pub fn move_to(&mut self, target: i32) {
        self.target_pos = target;
        if self.mode != Mode::Position {
            self.vacc = 0;
        }
        self.mode = Mode::Position;
    }

    /// Velocity 0 at once, idle (hard stop, stall, power stage off).
    pub fn hard_stop(&mut self) {
        self.v = 0;
        self.vacc = 0;
        self.target_vel = 0;
        self.mode = Mode::Idle;
    }

    /// Decelerate at `a` pps² to standstill, then idle.
    pub fn stop_with(&mut self, a: i64) {
        if self.v == 0 {
            self.hard_stop();
        } else if !matches!(self.mode, Mode::Stopping(_)) {
            self.vacc = 0;
            self.mode = Mode::Stopping(a.max(1));
        }
    }

    /// Overwrite the position counter (SAP 1, RFS end): the sub-step remainder goes.
    pub fn set_position(&mut self, p: i32) {
        self.pos = p;
        self.sub = 0;
    }

    /// Positioning finished: on target and at rest.
    pub fn at_target(&self) -> bool {
        self.pos == self.target_pos && self.sub == 0 && self.v == 0
    }

    /// The motor stands still and nothing is commanded to move it.
    pub fn at_rest(&self) -> bool {
        self.v == 0
            && match self.mode {
                Mode::Idle | Mode::Stopping(_) => true,
                Mode::Velocity => self.target_vel == 0,
                Mode::Position => self.pos == self.target_pos && self.sub == 0,
            }
    }

    fn dv(&mut self, a: i64) -> i64 {
        self.vacc += a.max(0);
        let d = self.vacc / 1000;
        self.vacc -= d * 1000;
        d
    }

    /// The direction the generator is trying to move in (−1, 0, +1).
    fn desired_dir(&self) -> i64 {
        if self.v != 0 {
            return self.v.signum();
        }
        match self.mode {
            Mode::Idle | Mode::Stopping(_) => 0,
            Mode::Velocity => self.target_vel.signum(),
            Mode::Position => {
                let d = i64::from(self.target_pos.wrapping_sub(self.pos)) * 1000 - self.sub;
                d.signum()
            }
        }
    }

    /// One ms: update the velocity, then the position. Returns the whole µsteps moved
    /// (signed). A blocked direction (limit switch, virtual stop) stops the motor as its
    /// [`StopKind`] says and keeps it from starting that way; a positioning move that runs
    /// into one is abandoned, velocity mode keeps its target.
    pub fn step(&mut self, r: &Ramp, blocks: Blocks) -> i64 {
        let dir = self.desired_dir();
        let block = match dir {
            1 => blocks.plus,
            -1 => blocks.minus,
            _ => None,
        };
        match block {
            Some(StopKind::Hard) => self.blocked_stop(),
            Some(StopKind::Soft(a)) => {
                let d = self.dv(a.max(1));
                self.v = toward_zero(self.v, d);
                if self.v == 0 {
                    self.blocked_stop();
                }
            }
            None => match self.mode {
                Mode::Idle => self.v = 0,
                Mode::Velocity => self.step_velocity(r),
                Mode::Position => self.step_position(r),
                Mode::Stopping(a) => {
                    let d = self.dv(a);
                    self.v = toward_zero(self.v, d);
                    if self.v == 0 {
                        self.mode = Mode::Idle;
                    }
                }
            },
        }
        self.advance()
    }

    fn blocked_stop(&mut self) {
        self.v = 0;
        self.vacc = 0;
        if self.mode != Mode::Velocity {
            self.mode = Mode::Idle;
        }
    }

    fn advance(&mut self) -> i64 {
        let total = self.sub + self.v;
        let steps = total.div_euclid(1000);
        self.sub = total.rem_euclid(1000);
        self.pos = self.pos.wrapping_add(steps as i32);
        steps
    }

    fn step_velocity(&mut self, r: &Ramp) {
        let goal = self.target_vel;
        let v = self.v;
        if v == goal {
            return;
        }
        // Slow down first if the goal is slower or the other way.
        let same_dir = (v >= 0 && goal > 0) || (v <= 0 && goal < 0);
        if v != 0 && (!same_dir || goal.abs() < v.abs()) {
            let u = v.abs();
            let d = self.dv(r.decel(u));
            let floor = if same_dir { goal.abs() } else { 0 };
            let mut nu = (u - d).max(floor);
            if !same_dir && r.vstop > 0 && nu <= r.vstop {
                nu = 0;
            }
            self.v = nu * v.signum();
            return;
        }
        // Speed up toward the goal (from standstill: the start velocity at once).
        let s = goal.signum();
        let u = v.abs();
        let mut nu = u + self.dv(r.accel(u));
        if r.vstart > 0 && nu < r.vstart {
            nu = r.vstart;
        }
        self.v = nu.min(goal.abs()) * s;
    }

    fn step_position(&mut self, r: &Ramp) {
        let dpos = i64::from(self.target_pos.wrapping_sub(self.pos));
        let d = dpos * 1000 - self.sub;
        if d == 0 {
            self.v = 0;
            self.vacc = 0;
            return;
        }
        let s = d.signum();
        let dist = d.abs();
        let u = self.v * s;
        if u < 0 {
            // Moving away from the target: brake first.
            let dd = self.dv(r.decel(-u));
            self.v = toward_zero(self.v, dd);
            return;
        }
        let cap = r.vmax.min(r.allowed(dist));
        let mut nu = if u < cap {
            let mut n = (u + self.dv(r.accel(u))).min(cap);
            if r.vstart > 0 && n < r.vstart {
                n = r.vstart.min(cap);
            }
            n
        } else {
            (u - self.dv(r.decel(u))).max(cap)
        };
        if nu >= dist {
            // Land exactly on the target this ms.
            nu = dist;
        }
        self.v = nu * s;
    }
}

fn toward_zero(v: i64, d: i64) -> i64 {
    if v > 0 {
        (v - d).max(0)
    } else {
        (v + d).min(0)
    }
}

#[cfg(test)]
#[path = "motion_tests.rs"]
mod tests;
