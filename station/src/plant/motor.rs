//! Rotary motor + load: inertia, viscous and Coulomb friction, an optional constant load
//! torque, integrated exactly piecewise.
//!
//! Model (SI units): `J·dω/dt = T_drive − k·ω + T_load − b·ω − T_c·sgn(ω)`, `dθ/dt = ω`, where
//! the amplifier supplies an affine torque `T_drive − k·ω` (k = 0 in torque mode, the velocity
//! loop gain in velocity mode). Between two velocity zero crossings every term is constant or
//! linear in ω, so one [`Motor::advance`] solves the ODE in closed form (exponential for
//! b + k > 0, parabola for b + k = 0): the step is exact and unconditionally stable whatever its
//! length. Coulomb friction is handled as stick–slip: when ω reaches 0 inside a step the motor
//! stops exactly there and stays stuck while |T_drive + T_load| ≤ T_c, otherwise it breaks away
//! in the direction of the net torque. No wall clock, no randomness: runs are deterministic.

/// Mechanical parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Rotor + reflected load inertia, kg·m² (> 0).
    pub inertia: f64,
    /// Viscous friction, N·m·s/rad (≥ 0).
    pub viscous: f64,
    /// Coulomb (dry) friction, N·m (≥ 0).
    pub coulomb: f64,
    /// Constant external load torque, N·m (signed; e.g. gravity on a vertical axis).
    pub load_torque: f64,
}

/// Below this `(b+k)·t/J` the viscous term is treated as zero over a step (relative error of
/// the step ≤ this value), avoiding cancellation in the exponential form.
const LINEAR_EPS: f64 = 1e-9;

/// State of one motor shaft.
#[derive(Clone, Debug)]
pub struct Motor {
    p: MotorParams,
    theta: f64,
    omega: f64,
}

impl Motor {
    /// A motor at rest at angle 0.
    pub fn new(p: MotorParams) -> Self {
        Motor {
            p,
            theta: 0.0,
            omega: 0.0,
        }
    }

    /// Parameters.
    pub fn params(&self) -> MotorParams {
        self.p
    }

    /// Change the parameters (position and speed are kept).
    pub fn set_params(&mut self, p: MotorParams) {
        self.p = p;
    }

    /// Shaft angle, rad.
    pub fn position(&self) -> f64 {
        self.theta
    }

    /// Shaft speed, rad/s.
    pub fn velocity(&self) -> f64 {
        self.omega
    }

    /// Set the state (angle rad, speed rad/s); non-finite values are ignored.
    pub fn set_state(&mut self, theta: f64, omega: f64) {
        if theta.is_finite() && omega.is_finite() {
            self.theta = theta;
            self.omega = omega;
        }
    }

    /// Move at a prescribed speed for `dt` seconds (ideal stepper drive): friction and inertia
    /// are overcome by definition.
    pub fn advance_kinematic(&mut self, dt: f64, omega: f64) {
        if dt > 0.0 && omega.is_finite() {
            self.omega = omega;
            self.theta += omega * dt;
        }
    }

    /// Advance `dt` seconds with amplifier torque `drive − damping·ω` (N·m; damping ≥ 0).
    pub fn advance(&mut self, dt: f64, drive: f64, damping: f64) {
        let valid = dt > 0.0 && drive.is_finite() && damping.is_finite() && self.p.inertia > 0.0;
        if !valid {
            return;
        }
        let j = self.p.inertia;
        let b = self.p.viscous.max(0.0) + damping.max(0.0);
        let tc = self.p.coulomb.max(0.0);
        let d = drive + self.p.load_torque;
        let mut left = dt;
        // moving → stop → break away the other way: at most 3 segments.
        for _ in 0..3 {
            if left <= 0.0 {
                break;
            }
            let s = if self.omega != 0.0 {
                self.omega.signum()
            } else if d.abs() > tc {
                d.signum()
            } else {
                return; // stuck: static friction holds
            };
            let f = d - tc * s; // constant torque of this segment
            let (w0, x) = (self.omega, b * left / j);
            // zero crossing of ω inside the segment (only while moving against the net torque)
            let t_star = if w0 != 0.0 && f * w0 < 0.0 {
                if x < LINEAR_EPS {
                    Some(-w0 * j / f)
                } else {
                    let winf = f / b;
                    Some(j / b * (-w0 / winf).ln_1p())
                }
            } else {
                None
            };
            match t_star {
                Some(ts) if ts <= left => {
                    self.segment(ts, f, b);
                    self.omega = 0.0;
                    left -= ts;
                }
                _ => {
                    self.segment(left, f, b);
                    return;
                }
            }
        }
    }

    /// Closed-form solution of `J·ω' = f − b·ω` over `t` seconds.
    fn segment(&mut self, t: f64, f: f64, b: f64) {
        let j = self.p.inertia;
        let x = b * t / j;
        let w0 = self.omega;
        if x < LINEAR_EPS {
            let a = f / j;
            self.theta += w0 * t + 0.5 * a * t * t;
            self.omega = w0 + a * t;
        } else {
            let tau = j / b;
            let winf = f / b;
            let one_minus_e = -(-x).exp_m1();
            self.theta += winf * t + (w0 - winf) * tau * one_minus_e;
            self.omega = winf + (w0 - winf) * (1.0 - one_minus_e);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn motor(viscous: f64, coulomb: f64, load: f64) -> Motor {
        Motor::new(MotorParams {
            inertia: 1e-5,
            viscous,
            coulomb,
            load_torque: load,
        })
    }

    #[test]
    fn constant_torque_no_friction_is_a_parabola() {
        // θ = ½·(T/J)·t², ω = (T/J)·t, independent of how time is cut into steps.
        let mut m = motor(0.0, 0.0, 0.0);
        let (t, j, dt) = (0.01, 1e-5, 1.0 / 2258.7);
        let n = 200;
        for _ in 0..n {
            m.advance(dt, t, 0.0);
        }
        let tt = n as f64 * dt;
        let a = t / j;
        assert!((m.velocity() - a * tt).abs() < 1e-9 * a * tt);
        assert!((m.position() - 0.5 * a * tt * tt).abs() < 1e-9 * 0.5 * a * tt * tt);
    }

    #[test]
    fn viscous_drag_gives_first_order_step_response() {
        // ω(t) = T/b·(1 − e^{−bt/J}); θ(t) = T/b·(t − J/b·(1 − e^{−bt/J}))
        let (tq, b, j) = (0.02, 1e-3, 1e-5);
        let mut m = motor(b, 0.0, 0.0);
        let dt = 1.0 / 2258.7;
        for _ in 0..100 {
            m.advance(dt, tq, 0.0);
        }
        let t = 100.0 * dt;
        let w = tq / b * (1.0 - (-b * t / j).exp());
        let th = tq / b * (t - j / b * (1.0 - (-b * t / j).exp()));
        assert!(
            (m.velocity() - w).abs() < 1e-9 * w,
            "{} vs {w}",
            m.velocity()
        );
        assert!((m.position() - th).abs() < 1e-9 * th);
    }

    #[test]
    fn coulomb_friction_stops_the_motor_exactly() {
        // Coasting from ω0 with only Coulomb friction: stops after J·ω0/Tc at J·ω0²/(2Tc).
        let (j, tc, w0) = (1e-5, 2e-3, 50.0);
        let mut m = motor(0.0, tc, 0.0);
        m.set_state(0.0, w0);
        let dt = 1.0 / 2258.7;
        let t_stop = j * w0 / tc; // 0.25 s
        let k_stop = (t_stop / dt).ceil() as usize;
        for _ in 0..k_stop - 1 {
            m.advance(dt, 0.0, 0.0);
        }
        assert!(m.velocity() > 0.0);
        m.advance(dt, 0.0, 0.0);
        assert_eq!(m.velocity(), 0.0);
        let dist = j * w0 * w0 / (2.0 * tc);
        assert!((m.position() - dist).abs() < 1e-9 * dist);
        // and it stays at rest, no creep or chatter
        for _ in 0..1000 {
            m.advance(dt, 0.0, 0.0);
        }
        assert_eq!(m.velocity(), 0.0);
        assert!((m.position() - dist).abs() < 1e-9 * dist);
    }

    #[test]
    fn static_friction_holds_below_breakaway_and_slips_above() {
        let mut m = motor(0.0, 2e-3, 0.0);
        m.advance(0.1, 1.9e-3, 0.0);
        assert_eq!((m.position(), m.velocity()), (0.0, 0.0));
        // above breakaway: a = (T − Tc)/J in the torque's direction
        m.advance(0.1, -3e-3, 0.0);
        assert!((m.velocity() - (-1e-3 / 1e-5 * 0.1)).abs() < 1e-9);
        // a load torque adds to the drive: 1.9e-3 + 0.5e-3 breaks away
        let mut l = motor(0.0, 2e-3, 0.5e-3);
        l.advance(0.1, 1.9e-3, 0.0);
        assert!((l.velocity() - 0.4e-3 / 1e-5 * 0.1).abs() < 1e-9);
    }

    #[test]
    fn reversing_torque_stops_then_reverses_within_one_step() {
        // ω0 = 10 rad/s, T = −0.01 N·m, Tc = 0.002: decel (T−Tc)/J = −1200 to stop at
        // t1 = 10/1200, then accelerate at (T+Tc)/J = −800 for the rest.
        let mut m = motor(0.0, 2e-3, 0.0);
        m.set_state(0.0, 10.0);
        m.advance(0.02, -0.01, 0.0);
        let t1 = 10.0 / 1200.0;
        let t2 = 0.02 - t1;
        let w = -800.0 * t2;
        let th = 10.0 * t1 - 0.5 * 1200.0 * t1 * t1 - 0.5 * 800.0 * t2 * t2;
        assert!((m.velocity() - w).abs() < 1e-9, "{}", m.velocity());
        assert!((m.position() - th).abs() < 1e-9);
    }

    #[test]
    fn bad_inputs_leave_state_untouched() {
        let mut m = motor(0.0, 0.0, 0.0);
        m.advance(f64::NAN, 1.0, 0.0);
        m.advance(-1.0, 1.0, 0.0);
        m.advance(1.0, f64::INFINITY, 0.0);
        m.set_state(f64::NAN, 1.0);
        assert_eq!((m.position(), m.velocity()), (0.0, 0.0));
    }
}
