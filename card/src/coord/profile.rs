//! One-dimensional profile maths shared by blending, RAPID and abort.
//!
//! The normalised S-curve ramp: over u ∈ [0, 1] the acceleration rises linearly for the
//! fraction `s = TS/TA'`, stays constant, and falls linearly for `s` (s ∈ [0, ½]); `g(u)` is the
//! velocity fraction (0 → 1) and `G(u) = ∫g` (G(1) = ½ by symmetry).

/// Normalised S-curve ramp with S fraction `s` ∈ [0, ½].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Ramp {
    s: f64,
    ap: f64,
}

impl Ramp {
    /// Ramp with S-curve fraction `s` (clamped to [0, ½]).
    pub(crate) fn new(s: f64) -> Self {
        let s = if s.is_finite() {
            s.clamp(0.0, 0.5)
        } else {
            0.0
        };
        Ramp {
            s,
            ap: 1.0 / (1.0 - s),
        }
    }

    /// Position fraction G(u) = ∫₀ᵘ g (G(1) = ½, extended linearly beyond 1).
    pub(crate) fn big_g(&self, u: f64) -> f64 {
        if u <= 0.0 {
            0.0
        } else if u >= 1.0 {
            0.5 + (u - 1.0)
        } else if u > 0.5 {
            // ∫₀ᵘ g = ½ − (1−u) + G(1−u) by symmetry g(x) = 1 − g(1−x).
            0.5 - (1.0 - u) + self.big_g(1.0 - u)
        } else if u < self.s {
            self.ap * u * u * u / (6.0 * self.s)
        } else {
            let s = self.s;
            let d = u - s;
            self.ap * (s * s / 6.0 + s / 2.0 * d + d * d / 2.0)
        }
    }
}

/// Jog-style point-to-point profile (pmac-variables §5.2 rules), distance `d` ≥ 0 counts:
/// S-curve ramp up over `ta`, cruise at `v`, ramp down over `ta`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PtpProfile {
    /// Distance (≥ 0).
    pub d: f64,
    /// Cruise velocity (counts/ms).
    pub v: f64,
    /// Ramp time (ms).
    pub ta: f64,
    /// Cruise time (ms).
    pub tc: f64,
    ramp: Ramp,
}

impl PtpProfile {
    /// Plan distance `d` at speed `vmax` with Ix19 (`amax`, ≤ 0 none), Ix20 (`ta`), Ix21 (`ts`).
    /// Short moves get a symmetric profile with a reduced peak velocity.
    pub(crate) fn plan(d: f64, vmax: f64, amax: f64, ta: f64, ts: f64) -> Self {
        let clean = |x: f64| if x.is_finite() && x > 0.0 { x } else { 0.0 };
        let (d, vmax, amax, ts) = (clean(d), clean(vmax).max(1e-9), clean(amax), clean(ts));
        let ta0 = {
            let t = clean(ta).max(2.0 * ts);
            if t == 0.0 {
                1.0
            } else {
                t
            }
        };
        // Ramp time for cruise speed v: TA0, stretched so the peak Δv/(T−ts) ≤ amax.
        let ramp_t = |v: f64| {
            if amax > 0.0 {
                ta0.max(ts + v / amax)
            } else {
                ta0
            }
        };
        let mut v = vmax;
        let mut t = ramp_t(v);
        if v * t > d {
            // Too short to reach vmax: v·T(v) = d.
            v = d / ta0;
            t = ta0;
            if amax > 0.0 && ts + v / amax > ta0 {
                v = amax * (-ts + (ts * ts + 4.0 * d / amax).sqrt()) / 2.0;
                t = ramp_t(v);
            }
        }
        let tc = if v > 0.0 { (d / v - t).max(0.0) } else { 0.0 };
        PtpProfile {
            d,
            v,
            ta: t,
            tc,
            ramp: Ramp::new(ts / t),
        }
    }

    /// Total duration (ms).
    pub(crate) fn duration(&self) -> f64 {
        2.0 * self.ta + self.tc
    }

    /// Distance covered at time `t` ms (clamped to [0, d]).
    pub(crate) fn pos(&self, t: f64) -> f64 {
        if self.d == 0.0 || t <= 0.0 {
            return 0.0;
        }
        let (ta, tc, v) = (self.ta, self.tc, self.v);
        if t < ta {
            v * ta * self.ramp.big_g(t / ta)
        } else if t < ta + tc {
            v * ta / 2.0 + v * (t - ta)
        } else if t < 2.0 * ta + tc {
            let r = 2.0 * ta + tc - t;
            self.d - v * ta * self.ramp.big_g(r / ta)
        } else {
            self.d
        }
    }
}

/// Constant-deceleration stop from velocity `v0` at rate `a` (> 0): (position change, done)
/// after `t` ms. Used for the `A` abort at Ix15.
pub(crate) fn decel_stop(v0: f64, a: f64, t: f64) -> (f64, bool) {
    let a = if a.is_finite() && a > 0.0 { a } else { 0.25 };
    let tv = v0.abs() / a;
    let t = t.max(0.0);
    if t >= tv {
        (v0 * tv / 2.0, true)
    } else {
        (v0 * t - v0.signum() * a * t * t / 2.0, false)
    }
}
