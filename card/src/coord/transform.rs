//! Axis transformation matrices (pmac-commands.md §5.3.10): `DEFINE TBUF n`, `TSEL`, `TINIT`,
//! `ADIS`, `IDIS`, `AROT`, `IROT`.
//!
//! Model (spec decision): programmed XYZ = R · baseXYZ + D, R row-major from Q(q+3r+c).
//! None of these move anything: the C.S. keeps the present *base* position and renames it.

use nalgebra::{Matrix3, Vector3};

use super::axes::AxisVec;
use super::CoordError;

/// One affine XYZ transformation: programmed = `r · base + d`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// Rotation/scaling.
    pub r: Matrix3<f64>,
    /// Displacement.
    pub d: Vector3<f64>,
    /// Cached inverse of `r`.
    pub r_inv: Matrix3<f64>,
}

impl Default for Affine {
    fn default() -> Self {
        Affine {
            r: Matrix3::identity(),
            d: Vector3::zeros(),
            r_inv: Matrix3::identity(),
        }
    }
}

impl Affine {
    /// Programmed axis vector → base axis vector (only X, Y, Z change).
    pub fn to_base(self, prog: &AxisVec) -> AxisVec {
        let p = Vector3::new(prog[0], prog[1], prog[2]);
        let b = self.r_inv * (p - self.d);
        let mut out = *prog;
        out[0] = b[0];
        out[1] = b[1];
        out[2] = b[2];
        out
    }

    /// A velocity (or any difference) vector, programmed → base.
    pub fn vel_to_base(&self, v: &AxisVec) -> AxisVec {
        let b = self.r_inv * Vector3::new(v[0], v[1], v[2]);
        let mut out = *v;
        out[0] = b[0];
        out[1] = b[1];
        out[2] = b[2];
        out
    }

    /// Base axis vector → programmed axis vector.
    pub fn to_prog(self, base: &AxisVec) -> AxisVec {
        let p = self.r * Vector3::new(base[0], base[1], base[2]) + self.d;
        let mut out = *base;
        out[0] = p[0];
        out[1] = p[1];
        out[2] = p[2];
        out
    }

    fn set_r(&mut self, r: Matrix3<f64>) -> Result<(), CoordError> {
        if r.iter().any(|v| !v.is_finite() || v.abs() > 1e12) {
            return Err(CoordError::OutOfRange("rotation matrix"));
        }
        let inv = r.try_inverse().ok_or(CoordError::SingularMatrix)?;
        if inv.iter().any(|v| !v.is_finite()) || r.determinant().abs() < 1e-12 {
            return Err(CoordError::SingularMatrix);
        }
        self.r = r;
        self.r_inv = inv;
        Ok(())
    }
}

/// The matrices of `DEFINE TBUF` and the selection of one coordinate system.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TransformBank {
    mats: Vec<Affine>,
    selected: usize,
}

fn vec3(q: [f64; 3]) -> Result<Vector3<f64>, CoordError> {
    if q.iter().any(|v| !v.is_finite() || v.abs() > super::MAX_POS) {
        return Err(CoordError::OutOfRange("displacement"));
    }
    Ok(Vector3::new(q[0], q[1], q[2]))
}

impl TransformBank {
    /// `DEFINE TBUF n`: n identity matrices (selection cleared).
    pub fn define(&mut self, n: u32) {
        self.mats = vec![Affine::default(); n.min(256) as usize];
        self.selected = 0;
    }

    /// `DELETE TBUF`.
    pub fn delete(&mut self) {
        self.mats.clear();
        self.selected = 0;
    }

    /// Number of defined matrices.
    pub fn len(&self) -> usize {
        self.mats.len()
    }

    /// No matrices defined.
    pub fn is_empty(&self) -> bool {
        self.mats.is_empty()
    }

    /// `TSEL n` (0 = off). The matrix must exist.
    pub fn tsel(&mut self, n: u32) -> Result<(), CoordError> {
        if n as usize > self.mats.len() {
            return Err(CoordError::NoMatrix(n));
        }
        self.selected = n as usize;
        Ok(())
    }

    /// Selected matrix number (0 = none).
    pub fn selected(&self) -> u32 {
        self.selected as u32
    }

    /// The transformation in force (identity when none selected).
    pub fn current(&self) -> Affine {
        self.selected
            .checked_sub(1)
            .and_then(|k| self.mats.get(k))
            .copied()
            .unwrap_or_default()
    }

    fn cur_mut(&mut self) -> Result<&mut Affine, CoordError> {
        let k = self.selected;
        k.checked_sub(1)
            .and_then(|k| self.mats.get_mut(k))
            .ok_or(CoordError::NoMatrix(k as u32))
    }

    /// `TINIT`: identity rotation, zero displacement.
    pub fn tinit(&mut self) -> Result<(), CoordError> {
        *self.cur_mut()? = Affine::default();
        Ok(())
    }

    /// `ADIS q`: displacement := (Q(q), Q(q+1), Q(q+2)).
    pub fn adis(&mut self, q: [f64; 3]) -> Result<(), CoordError> {
        let d = vec3(q)?;
        self.cur_mut()?.d = d;
        Ok(())
    }

    /// `IDIS q`: displacement += (Q(q), Q(q+1), Q(q+2)).
    pub fn idis(&mut self, q: [f64; 3]) -> Result<(), CoordError> {
        let d = vec3(q)?;
        let m = self.cur_mut()?;
        m.d += d;
        Ok(())
    }

    /// `AROT q`: R := Q(q..q+8) row-major. Singular matrices are refused (R unchanged).
    pub fn arot(&mut self, q: [f64; 9]) -> Result<(), CoordError> {
        let r = Matrix3::from_row_slice(&q);
        self.cur_mut()?.set_r(r)
    }

    /// `IROT q`: R := R · Q(q..q+8).
    pub fn irot(&mut self, q: [f64; 9]) -> Result<(), CoordError> {
        let inc = Matrix3::from_row_slice(&q);
        let m = self.cur_mut()?;
        let r = m.r * inc;
        m.set_r(r)
    }
}
