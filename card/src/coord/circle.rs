//! CIRCLE1/CIRCLE2 geometry (pmac-commands.md §5.3.5): centre from an I/J/K vector or R,
//! NORMAL plane, full circles, spirals, helices, impossible-circle refusals.

use nalgebra::Vector3;

use super::axes::AxisVec;
use super::prims::Arc;
use super::CoordError;

/// How the centre is given on the move line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Centre {
    /// `I J K` vector: from the start point (`INC(R)`, default) or from the origin (`ABS(R)`).
    Vector {
        /// Components along X, Y, Z (missing ones 0).
        ijk: [f64; 3],
        /// `ABS(R)` in force.
        absolute: bool,
    },
    /// `R{r}`: r > 0 arc ≤ 180°, r < 0 arc ≥ 180°.
    Radius(f64),
}

/// Circle parameters that are not on the move line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CircleParams {
    /// `NORMAL` vector (direction only; default (0, 0, −1)).
    pub normal: [f64; 3],
    /// `CIRCLE1` (true: right-hand rotation about the normal = clockwise in XY with the
    /// default normal) or `CIRCLE2`.
    pub cw: bool,
    /// Ix96 circle error limit (user units; 0 = never an error).
    pub ix96: f64,
    /// Angle below which an IJK arc becomes a full circle plus that arc (rad; from I90).
    pub full_tol: f64,
}

fn v3(p: &AxisVec) -> Vector3<f64> {
    Vector3::new(p[0], p[1], p[2])
}

/// Build the arc from `p0` to `p1`. `Ok(None)` means "no arc in the plane" (R form with zero
/// chord): the caller moves linearly.
pub(crate) fn make_arc(
    p0: &AxisVec,
    p1: &AxisVec,
    centre: Centre,
    prm: &CircleParams,
) -> Result<Option<Arc>, CoordError> {
    let n = Vector3::from(prm.normal);
    let nn = n.norm();
    if !nn.is_finite() || nn < 1e-12 {
        return Err(CoordError::OutOfRange("NORMAL vector"));
    }
    let n = n / nn;
    let sigma = if prm.cw { 1.0 } else { -1.0 };
    let s = v3(p0);
    let e = v3(p1);
    let h = (e - s).dot(&n);
    let e_ip = e - n * h; // end point projected into the start plane
    let scale = s.norm().max(e.norm()).max(1.0);
    let eps = 1e-12 * scale;
    let c = match centre {
        Centre::Vector { ijk, absolute } => {
            if ijk
                .iter()
                .any(|v| !v.is_finite() || v.abs() > super::MAX_POS)
            {
                return Err(CoordError::OutOfRange("circle centre"));
            }
            let v = Vector3::from(ijk);
            let c = if absolute { v } else { s + v };
            c - n * (c - s).dot(&n)
        }
        Centre::Radius(r) => {
            if !r.is_finite() || r.abs() > super::MAX_POS {
                return Err(CoordError::OutOfRange("circle radius"));
            }
            let d = e_ip - s;
            let l = d.norm();
            if l <= eps {
                return Ok(None);
            }
            let m = s + d / 2.0;
            let excess = l - 2.0 * r.abs();
            let dist = if excess > 0.0 {
                if prm.ix96 > 0.0 && excess > prm.ix96 {
                    return Err(CoordError::CircleRadius(excess));
                }
                0.0
            } else {
                (r * r - l * l / 4.0).max(0.0).sqrt()
            };
            let side = n.cross(&(d / l));
            m + side * (sigma * r.signum() * dist)
        }
    };
    let a0 = s - c;
    let a1 = e_ip - c;
    let (r0, r1) = (a0.norm(), a1.norm());
    if r0 <= eps || r1 <= eps {
        return Err(CoordError::CircleZeroRadius);
    }
    let u0 = a0 / r0;
    let u1 = a1 / r1;
    let w0 = n.cross(&u0);
    let raw = u0.cross(&u1).dot(&n).atan2(u0.dot(&u1)); // (−π, π], positive about n
    let mut th = sigma * raw;
    let tau = std::f64::consts::TAU;
    match centre {
        Centre::Vector { .. } => {
            if th < prm.full_tol.max(1e-12) {
                th += tau;
            }
        }
        Centre::Radius(_) => {
            if th <= 0.0 {
                th += tau;
            }
        }
    }
    Ok(Some(Arc {
        c,
        u0,
        w0,
        n,
        r0,
        r1,
        theta: sigma * th,
        h,
        p0: *p0,
        p1: *p1,
    }))
}
