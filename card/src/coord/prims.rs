//! Path primitives of single moves, in program axis units, evaluated at absolute trajectory
//! time τ (ms). Lines and arcs extrapolate beyond their interval (needed by blending).

use nalgebra::Vector3;

use super::axes::AxisVec;
use super::profile::PtpProfile;

/// Circular / helical / spiral arc in the XYZ part; the other axes move linearly.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Arc {
    /// Centre (in the plane of the start point).
    pub c: Vector3<f64>,
    /// Unit vector centre → start.
    pub u0: Vector3<f64>,
    /// `n × u0` (the positive-rotation direction).
    pub w0: Vector3<f64>,
    /// Unit plane normal.
    pub n: Vector3<f64>,
    /// Start and end radius.
    pub r0: f64,
    /// End radius (≠ r0: spiral).
    pub r1: f64,
    /// Signed swept angle (rad), positive = right-hand about `n`.
    pub theta: f64,
    /// Displacement along `n` (helix).
    pub h: f64,
    /// Start point (all nine axes).
    pub p0: AxisVec,
    /// End point (all nine axes).
    pub p1: AxisVec,
}

impl Arc {
    /// Position and d/ds (s = fraction of the move, may be outside [0, 1]).
    pub(crate) fn at(&self, s: f64) -> (AxisVec, AxisVec) {
        let mut p = self.p0 + (self.p1 - self.p0) * s;
        let mut dp = self.p1 - self.p0;
        let phi = self.theta * s;
        let (sn, cs) = phi.sin_cos();
        let r = self.r0 + (self.r1 - self.r0) * s;
        let dir = self.u0 * cs + self.w0 * sn;
        let xyz = self.c + dir * r + self.n * (self.h * s);
        let dxyz = dir * (self.r1 - self.r0)
            + (self.w0 * cs - self.u0 * sn) * (r * self.theta)
            + self.n * self.h;
        for k in 0..3 {
            p[k] = xyz[k];
            dp[k] = dxyz[k];
        }
        (p, dp)
    }

    /// Arc length of the XYZ part (mean radius × angle, with the helix).
    pub(crate) fn length(&self) -> f64 {
        let a = self.theta.abs() * (self.r0 + self.r1) / 2.0;
        (a * a + self.h * self.h).sqrt()
    }
}

/// One move's path as a function of τ.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Prim {
    /// Stand still.
    Hold(AxisVec),
    /// Constant velocity from `p0` at `t0` to `p1` at `t0 + dur`.
    Line {
        /// Start.
        p0: AxisVec,
        /// End.
        p1: AxisVec,
    },
    /// Arc from `t0` to `t0 + dur`.
    Arc(Box<Arc>),
    /// PVT cubic: p0 + v0·τ + a·τ²/2 + j·τ³/6 (τ from the segment start, ms).
    Cubic {
        /// Start position.
        p0: AxisVec,
        /// Start velocity (units/ms).
        v0: AxisVec,
        /// Start acceleration.
        a: AxisVec,
        /// Jerk.
        j: AxisVec,
    },
    /// Straight line with a point-to-point (RAPID) scalar profile.
    Ptp {
        /// Start.
        p0: AxisVec,
        /// End.
        p1: AxisVec,
        /// Profile of the limiting motor (distance normalised by `prof.d`).
        prof: PtpProfile,
    },
    /// Uniform cubic B-spline segment with control points `q` (SPLINE1).
    Spline([AxisVec; 4]),
}

impl Prim {
    /// Hermite PVT cubic from (p0, v0) to (p1, v1) over `t` ms.
    pub(crate) fn pvt(p0: AxisVec, v0: AxisVec, p1: AxisVec, v1: AxisVec, t: f64) -> Prim {
        let dp = p1 - p0;
        let a = (dp * 6.0 - (v0 * 2.0 + v1) * (2.0 * t)) / (t * t);
        let j = ((v0 + v1) * (6.0 * t) - dp * 12.0) / (t * t * t);
        Prim::Cubic { p0, v0, a, j }
    }

    /// Position and velocity (units/ms) at absolute τ for a move starting at `t0` lasting `dur`.
    pub(crate) fn eval(&self, t0: f64, dur: f64, tau: f64) -> (AxisVec, AxisVec) {
        let dur = dur.max(1e-9);
        match self {
            Prim::Hold(p) => (*p, AxisVec::zeros()),
            Prim::Line { p0, p1 } => {
                let v = (p1 - p0) / dur;
                (p0 + v * (tau - t0), v)
            }
            Prim::Arc(a) => {
                let (p, dp) = a.at((tau - t0) / dur);
                (p, dp / dur)
            }
            Prim::Cubic { p0, v0, a, j } => {
                let t = (tau - t0).clamp(0.0, dur);
                let p = p0 + v0 * t + a * (t * t / 2.0) + j * (t * t * t / 6.0);
                let v = v0 + a * t + j * (t * t / 2.0);
                (p, v)
            }
            Prim::Ptp { p0, p1, prof } => {
                let t = tau - t0;
                if prof.d <= 0.0 {
                    return (*p1, AxisVec::zeros());
                }
                let f = prof.pos(t) / prof.d;
                let h = 1e-3;
                let fv = (prof.pos(t + h) - prof.pos(t - h)) / (2.0 * h * prof.d);
                (p0 + (p1 - p0) * f, (p1 - p0) * fv)
            }
            Prim::Spline(q) => {
                let u = ((tau - t0) / dur).clamp(0.0, 1.0);
                let (u2, u3) = (u * u, u * u * u);
                let b = [
                    (1.0 - u).powi(3) / 6.0,
                    (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
                    (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
                    u3 / 6.0,
                ];
                let db = [
                    -(1.0 - u).powi(2) / 2.0,
                    (9.0 * u2 - 12.0 * u) / 6.0,
                    (-9.0 * u2 + 6.0 * u + 3.0) / 6.0,
                    u2 / 2.0,
                ];
                let mut p = AxisVec::zeros();
                let mut v = AxisVec::zeros();
                for k in 0..4 {
                    p += q[k] * b[k];
                    v += q[k] * (db[k] / dur);
                }
                (p, v)
            }
        }
    }

    /// End position of a move lasting `dur`.
    pub(crate) fn end(&self, dur: f64) -> AxisVec {
        self.eval(0.0, dur, dur).0
    }

    /// Whether the velocity difference to another primitive is best computed analytically
    /// (both straight lines) in blend windows.
    pub(crate) fn is_line(&self) -> bool {
        matches!(self, Prim::Line { .. } | Prim::Hold(_))
    }
}
