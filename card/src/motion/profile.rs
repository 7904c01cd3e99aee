//! Jog/home profile maths (pmac-variables-servo-macro.md §5.2): S-curve velocity ramps and
//! plans made of up to three segments (ramp, cruise, ramp), evaluated at any time.
//!
//! Units: counts, milliseconds. Pure functions, no allocation.
//!
//! Ramp rule: for a velocity change Δv the ramp lasts `TAj = max(Ix20, 2·Ix21)`; the
//! acceleration rises linearly for Ix21, stays constant for `TAj − 2·Ix21`, falls linearly for
//! Ix21, so the peak acceleration is `Δv/(TAj − Ix21)`. If that exceeds Ix19 the constant part is
//! lengthened (Ix21 kept): `TAj = Ix21 + |Δv|/Ix19`. Ix20 = Ix21 = 0 is treated as Ix20 = 1.

/// Acceleration parameters latched when a move command is given (Ix19, Ix20, Ix21).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RampParams {
    /// Ix20: acceleration time, ms.
    pub ta: f64,
    /// Ix21: S-curve time at each end, ms.
    pub ts: f64,
    /// Ix19: maximum acceleration, counts/ms² (≤ 0 or non-finite: no limit).
    pub amax: f64,
}

impl RampParams {
    /// Parameters from raw Ix19/Ix20/Ix21 values, sanitized (negative or NaN times become 0).
    pub fn new(ix19: f64, ix20: f64, ix21: f64) -> Self {
        let clean = |v: f64| if v.is_finite() && v > 0.0 { v } else { 0.0 };
        RampParams {
            ta: clean(ix20),
            ts: clean(ix21),
            amax: clean(ix19),
        }
    }

    /// A constant-rate ramp (no S-curve, no time floor) at `rate` counts/ms²: the Ix15 stop.
    pub fn constant_rate(rate: f64) -> Self {
        RampParams {
            ta: 0.0,
            ts: 0.0,
            amax: if rate.is_finite() && rate > 0.0 {
                rate
            } else {
                0.0
            },
        }
    }

    /// Duration in ms of a ramp changing velocity by `dv` counts/ms.
    pub fn ramp_time(&self, dv: f64) -> f64 {
        let dv = dv.abs();
        let mut t = self.ta.max(2.0 * self.ts);
        if self.ta == 0.0 && self.ts == 0.0 {
            // Constant-rate mode (Ix15 stop) when a rate is given, else the Ix20=1 floor.
            t = if self.amax > 0.0 { 0.0 } else { 1.0 };
        }
        if self.amax > 0.0 {
            t = t.max(self.ts + dv / self.amax);
        }
        t
    }
}

/// One piece of a plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Seg {
    /// S-curve ramp from `v0` to `v1` over `t` ms with S time `ts`.
    Ramp {
        /// Start velocity, counts/ms.
        v0: f64,
        /// End velocity, counts/ms.
        v1: f64,
        /// Duration, ms.
        t: f64,
        /// S-curve time at each end, ms (`2·ts ≤ t`).
        ts: f64,
    },
    /// Constant velocity `v` for `t` ms (`t` may be infinite).
    Cruise {
        /// Velocity, counts/ms.
        v: f64,
        /// Duration, ms.
        t: f64,
    },
}

/// Position, velocity and acceleration at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Kin {
    /// Position, counts.
    pub p: f64,
    /// Velocity, counts/ms.
    pub v: f64,
    /// Acceleration, counts/ms².
    pub a: f64,
}

impl Seg {
    fn duration(&self) -> f64 {
        match *self {
            Seg::Ramp { t, .. } | Seg::Cruise { t, .. } => t,
        }
    }

    fn end_velocity(&self) -> f64 {
        match *self {
            Seg::Ramp { v1, .. } => v1,
            Seg::Cruise { v, .. } => v,
        }
    }

    /// Displacement over the whole segment.
    fn distance(&self) -> f64 {
        match *self {
            Seg::Ramp { v0, v1, t, .. } => 0.5 * (v0 + v1) * t,
            Seg::Cruise { v, t } => v * t,
        }
    }

    /// Displacement, velocity and acceleration `tau` ms into the segment.
    fn eval(&self, tau: f64) -> Kin {
        match *self {
            Seg::Cruise { v, .. } => Kin {
                p: v * tau,
                v,
                a: 0.0,
            },
            Seg::Ramp { v0, v1, t, ts } => {
                if t <= 0.0 {
                    return Kin {
                        p: 0.0,
                        v: v1,
                        a: 0.0,
                    };
                }
                let tau = tau.clamp(0.0, t);
                let ap = (v1 - v0) / (t - ts);
                if tau < ts {
                    Kin {
                        p: v0 * tau + ap * tau * tau * tau / (6.0 * ts),
                        v: v0 + ap * tau * tau / (2.0 * ts),
                        a: ap * tau / ts,
                    }
                } else if tau <= t - ts {
                    let u = tau - ts;
                    let p1 = v0 * ts + ap * ts * ts / 6.0;
                    let vs = v0 + ap * ts / 2.0;
                    Kin {
                        p: p1 + vs * u + ap * u * u / 2.0,
                        v: vs + ap * u,
                        a: ap,
                    }
                } else {
                    let w = t - tau;
                    Kin {
                        p: 0.5 * (v0 + v1) * t - (v1 * w - ap * w * w * w / (6.0 * ts)),
                        v: v1 - ap * w * w / (2.0 * ts),
                        a: ap * w / ts,
                    }
                }
            }
        }
    }
}

/// A motion plan starting at position `p0`, velocity `v0`: up to three segments, then rest at
/// the end position (or an endless cruise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    p0: f64,
    segs: [Seg; 3],
    n: usize,
    /// Exact end position for finite plans (avoids accumulated rounding).
    end: Option<f64>,
}

const NONE: Seg = Seg::Cruise { v: 0.0, t: 0.0 };

impl Plan {
    /// Stand still at `p`.
    pub fn hold(p: f64) -> Self {
        Plan {
            p0: p,
            segs: [NONE; 3],
            n: 0,
            end: Some(p),
        }
    }

    fn ramp(v0: f64, v1: f64, rp: &RampParams) -> Seg {
        let t = rp.ramp_time(v1 - v0);
        Seg::Ramp {
            v0,
            v1,
            t,
            ts: rp.ts.min(t / 2.0),
        }
    }

    /// Change velocity from `v0` to `vt` and keep it (J+ / J- / J/ when `vt` = 0).
    pub fn to_velocity(p0: f64, v0: f64, vt: f64, rp: &RampParams) -> Self {
        let r = Plan::ramp(v0, vt, rp);
        if vt == 0.0 {
            let end = p0 + r.distance();
            return Plan {
                p0,
                segs: [r, NONE, NONE],
                n: 1,
                end: Some(end),
            };
        }
        Plan {
            p0,
            segs: [
                r,
                Seg::Cruise {
                    v: vt,
                    t: f64::INFINITY,
                },
                NONE,
            ],
            n: 2,
            end: None,
        }
    }

    /// Move from (`p0`, `v0`) to rest at `target` with speed at most `vmax` (the S-curve
    /// trapezoid; short moves use a symmetric profile with a reduced peak velocity, reversal if
    /// the present velocity carries the motor past the target).
    pub fn to_position(p0: f64, v0: f64, target: f64, vmax: f64, rp: &RampParams) -> Self {
        let vmax = if vmax.is_finite() { vmax.abs() } else { 0.0 };
        if vmax == 0.0 {
            return Plan::to_velocity(p0, v0, 0.0, rp);
        }
        let dist = target - p0;
        let d = |vc: f64| 0.5 * (v0 + vc) * rp.ramp_time(vc - v0) + 0.5 * vc * rp.ramp_time(vc);
        let (dp, dn) = (d(vmax), d(-vmax));
        let (vc, tc) = if dist >= dp {
            (vmax, (dist - dp) / vmax)
        } else if dist <= dn {
            (-vmax, (dn - dist) / vmax)
        } else {
            let (mut lo, mut hi) = (-vmax, vmax);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if d(mid) < dist {
                    lo = mid;
                } else {
                    hi = mid;
                }
                if hi - lo <= 1e-15 * vmax {
                    break;
                }
            }
            (0.5 * (lo + hi), 0.0)
        };
        Plan {
            p0,
            segs: [
                Plan::ramp(v0, vc, rp),
                Seg::Cruise { v: vc, t: tc },
                Plan::ramp(vc, 0.0, rp),
            ],
            n: 3,
            end: Some(target),
        }
    }

    /// Total duration in ms (infinite for an endless cruise).
    pub fn duration(&self) -> f64 {
        self.segs[..self.n].iter().map(Seg::duration).sum()
    }

    /// Final position of a finite plan.
    pub fn end_position(&self) -> Option<f64> {
        self.end
    }

    /// Velocity at the end (the endless cruise velocity, or 0).
    pub fn final_velocity(&self) -> f64 {
        match self.n {
            0 => 0.0,
            n => self.segs[n - 1].end_velocity(),
        }
    }

    /// Position, velocity, acceleration `t` ms after the plan's start (`t` ≥ 0).
    pub fn eval(&self, t: f64) -> Kin {
        let mut p = self.p0;
        let mut left = t.max(0.0);
        for s in &self.segs[..self.n] {
            let dur = s.duration();
            if left < dur {
                let k = s.eval(left);
                return Kin {
                    p: p + k.p,
                    v: k.v,
                    a: k.a,
                };
            }
            left -= dur;
            p += s.distance();
        }
        Kin {
            p: self.end.unwrap_or(p),
            v: self.final_velocity(),
            a: 0.0,
        }
    }

    /// True when `t` is at or past the end of a finite plan.
    pub fn done_at(&self, t: f64) -> bool {
        self.end.is_some() && t >= self.duration()
    }

    /// Shift the whole plan by `dp` counts (re-referencing after homing).
    pub fn shift(&mut self, dp: f64) {
        self.p0 += dp;
        if let Some(e) = self.end.as_mut() {
            *e += dp;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_examples_of_ix19_stretch() {
        // Ix20=100, Ix21=0, Ix22=50, Ix19=0.25 → 200 ms; reversal ±50 → 400 ms (seed L 3166-3170).
        let rp = RampParams::new(0.25, 100.0, 0.0);
        assert_eq!(rp.ramp_time(50.0), 200.0);
        assert_eq!(rp.ramp_time(100.0), 400.0);
        // Unlimited: Ix20 governs; Ix21 > Ix20/2: 2·Ix21.
        assert_eq!(RampParams::new(10.0, 100.0, 0.0).ramp_time(50.0), 100.0);
        assert_eq!(RampParams::new(10.0, 60.0, 50.0).ramp_time(5.0), 100.0);
        // Ix20 = Ix21 = 0: the 1 ms floor.
        assert_eq!(RampParams::new(0.0, 0.0, 0.0).ramp_time(5.0), 1.0);
    }

    #[test]
    fn pure_s_ramp_reaches_speed_with_half_distance() {
        let rp = RampParams::new(0.0, 0.0, 50.0);
        let plan = Plan::to_velocity(0.0, 0.0, 10.0, &rp);
        // Peak accel Δv/(T−ts) = 10/50 = 0.2 at t = 50 ms.
        let k = plan.eval(50.0);
        assert!((k.a - 0.2).abs() < 1e-12);
        assert!((k.v - 5.0).abs() < 1e-12);
        let k = plan.eval(100.0);
        assert!((k.p - 500.0).abs() < 1e-9 && (k.v - 10.0).abs() < 1e-12);
        let k = plan.eval(200.0);
        assert!((k.p - 1500.0).abs() < 1e-9);
    }

    #[test]
    fn to_position_ends_on_target_and_reverses_when_needed() {
        let rp = RampParams::new(0.0, 100.0, 20.0);
        let plan = Plan::to_position(0.0, 0.0, 1000.0, 32.0, &rp);
        assert_eq!(plan.eval(plan.duration() + 5.0).p, 1000.0);
        // Moving fast toward a target too close: overshoot then come back.
        let plan = Plan::to_position(0.0, 10.0, 10.0, 32.0, &rp);
        let mut minv = f64::MAX;
        let mut t = 0.0;
        while t < plan.duration() {
            minv = minv.min(plan.eval(t).v);
            t += 0.5;
        }
        assert!(minv < 0.0, "expected a reversal");
        assert!((plan.eval(plan.duration()).p - 10.0).abs() < 1e-9);
    }
}
