//! Axis definitions `#m->{scale}{axis}[+offset]` (pmac-commands.md §3.3.1), C.S. membership,
//! the axis→motor matrix and its inverse for PMATCH.
//!
//! Model: for the motors of one C.S., `motor = S · base + o` with `S` an n×9 matrix (columns
//! X Y Z A B C U V W, counts per user unit) and `o` the offsets in counts. PMATCH inverts it
//! (lowest-numbered motors first, see [`CsAxes::pmatch`]).

use nalgebra::{DMatrix, DVector, SVector};

use super::{check_pos, CoordError};
use crate::domain::ast::{Axis, AxisDef};

/// Nine axis values in the order X Y Z A B C U V W.
pub(crate) type AxisVec = SVector<f64, 9>;

/// The nine motion axes in vector order.
pub(crate) const AXES: [Axis; 9] = [
    Axis::X,
    Axis::Y,
    Axis::Z,
    Axis::A,
    Axis::B,
    Axis::C,
    Axis::U,
    Axis::V,
    Axis::W,
];

/// Index of a motion axis in an [`AxisVec`]; `None` for I/J/K/R.
pub(crate) fn axis_index(a: Axis) -> Option<usize> {
    AXES.iter().position(|&x| x == a)
}

/// One motor's definition inside its coordinate system.
#[derive(Debug, Clone, PartialEq)]
pub enum MotorAxisDef {
    /// `#m->{scale}{axis}[±{scale}{axis}…][±offset]`: (axis index, counts per unit) terms.
    Linear {
        /// 1..=3 terms; more than one only within XYZ or UVW.
        terms: Vec<(usize, f64)>,
        /// Offset in counts.
        offset: f64,
    },
    /// `#m->I`: the motor belongs to the C.S. for inverse kinematics: the C.S.'s inverse
    /// routine (Power, `program::kin`) sets its position; without one it holds its commanded
    /// position during axis moves.
    Inverse,
}

impl MotorAxisDef {
    /// Validate a parsed definition (ERR003 on any defect).
    pub fn from_ast(d: &AxisDef) -> Result<Self, CoordError> {
        if d.terms.is_empty() {
            // `#m->I`: a definition without terms.
            return Ok(MotorAxisDef::Inverse);
        }
        if d.terms.len() > 3 {
            return Err(CoordError::BadAxisDef("1 to 3 axis terms"));
        }
        let mut terms = Vec::with_capacity(d.terms.len());
        for t in &d.terms {
            let k = axis_index(t.axis).ok_or(CoordError::BadAxisDef("not a motion axis"))?;
            if terms.iter().any(|&(j, _)| j == k) {
                return Err(CoordError::BadAxisDef("axis repeated"));
            }
            let s =
                check_pos(t.scale, "axis scale").map_err(|_| CoordError::BadAxisDef("scale"))?;
            terms.push((k, s));
        }
        if terms.len() > 1 {
            let xyz = terms.iter().all(|&(k, _)| k < 3);
            let uvw = terms.iter().all(|&(k, _)| (6..9).contains(&k));
            if !xyz && !uvw {
                return Err(CoordError::BadAxisDef(
                    "multi-axis terms must be from XYZ or UVW",
                ));
            }
        }
        let offset =
            check_pos(d.offset, "axis offset").map_err(|_| CoordError::BadAxisDef("offset"))?;
        Ok(MotorAxisDef::Linear { terms, offset })
    }
}

/// Card-wide table of axis definitions: which motor belongs to which C.S. and how.
#[derive(Debug, Clone, PartialEq)]
#[cfg(test)]
pub(crate) struct AxisTable {
    /// Index 0 = motor #1: (C.S. number 1-based, definition).
    motors: Vec<Option<(u16, MotorAxisDef)>>,
    coords: u16,
}

#[cfg(test)]
impl AxisTable {
    /// Empty table for `motors` motors and `coords` coordinate systems.
    pub(crate) fn new(motors: u16, coords: u16) -> Self {
        AxisTable {
            motors: vec![None; motors as usize],
            coords,
        }
    }

    fn slot(&self, motor: u16) -> Result<usize, CoordError> {
        let k = (motor as usize).wrapping_sub(1);
        if k < self.motors.len() {
            Ok(k)
        } else {
            Err(CoordError::NoSuchUnit(motor as u32))
        }
    }

    fn check_cs(&self, cs: u16) -> Result<(), CoordError> {
        if cs >= 1 && cs <= self.coords {
            Ok(())
        } else {
            Err(CoordError::NoSuchUnit(cs as u32))
        }
    }

    /// `#m->{def}` in C.S. `cs`: ERR003 if the motor is defined in another C.S. or the
    /// definition is malformed; re-definition inside the same C.S. overwrites.
    pub(crate) fn define(
        &mut self,
        cs: u16,
        motor: u16,
        def: MotorAxisDef,
    ) -> Result<(), CoordError> {
        self.check_cs(cs)?;
        let k = self.slot(motor)?;
        if let Some((c, _)) = &self.motors[k] {
            if *c != cs {
                return Err(CoordError::MotorInOtherCs(motor, *c));
            }
        }
        self.motors[k] = Some((cs, def));
        Ok(())
    }

    /// `#m->0` in C.S. `cs`: clears the definition only if it is in `cs`.
    pub(crate) fn undefine_motor(&mut self, cs: u16, motor: u16) -> Result<(), CoordError> {
        let k = self.slot(motor)?;
        if self.motors[k].as_ref().is_some_and(|(c, _)| *c == cs) {
            self.motors[k] = None;
        }
        Ok(())
    }

    /// `UNDEFINE` in C.S. `cs`.
    pub(crate) fn undefine(&mut self, cs: u16) {
        for m in self.motors.iter_mut() {
            if m.as_ref().is_some_and(|(c, _)| *c == cs) {
                *m = None;
            }
        }
    }

    /// `UNDEFINE ALL`.
    pub(crate) fn undefine_all(&mut self) {
        self.motors.iter_mut().for_each(|m| *m = None);
    }

    /// `#m->` in C.S. `cs`: the definition if it is in `cs` (reply `0` otherwise).
    pub(crate) fn query(&self, cs: u16, motor: u16) -> Option<&MotorAxisDef> {
        let k = self.slot(motor).ok()?;
        self.motors[k]
            .as_ref()
            .filter(|(c, _)| *c == cs)
            .map(|(_, d)| d)
    }

    /// The C.S. motor `motor` belongs to.
    pub(crate) fn cs_of(&self, motor: u16) -> Option<u16> {
        let k = self.slot(motor).ok()?;
        self.motors[k].as_ref().map(|(c, _)| *c)
    }

    /// The matrix view of C.S. `cs` (motors in ascending number).
    pub(crate) fn cs_axes(&self, cs: u16) -> CsAxes {
        let defs: Vec<(u16, &MotorAxisDef)> = self
            .motors
            .iter()
            .enumerate()
            .filter_map(|(k, m)| {
                m.as_ref()
                    .filter(|(c, _)| *c == cs)
                    .map(|(_, d)| (k as u16 + 1, d))
            })
            .collect();
        CsAxes::build(&defs)
    }
}

/// The axis→motor map of one coordinate system.
#[derive(Debug, Clone, PartialEq)]
pub struct CsAxes {
    /// Member motors, ascending (1-based numbers).
    pub motors: Vec<u16>,
    /// n×9 scale matrix, counts per user unit (zero row for `#m->I` motors).
    pub scale: DMatrix<f64>,
    /// Offsets in counts.
    pub offset: DVector<f64>,
    /// Which motors are `#m->I` (they keep their position).
    pub inverse: Vec<bool>,
}

impl CsAxes {
    /// Build from (motor, definition) pairs in ascending motor order.
    pub fn build(defs: &[(u16, &MotorAxisDef)]) -> Self {
        let n = defs.len();
        let mut scale = DMatrix::zeros(n, 9);
        let mut offset = DVector::zeros(n);
        let mut inverse = vec![false; n];
        for (r, (_, d)) in defs.iter().enumerate() {
            match d {
                MotorAxisDef::Linear { terms, offset: o } => {
                    for &(k, s) in terms {
                        scale[(r, k)] = s;
                    }
                    offset[r] = *o;
                }
                MotorAxisDef::Inverse => inverse[r] = true,
            }
        }
        CsAxes {
            motors: defs.iter().map(|(m, _)| *m).collect(),
            scale,
            offset,
            inverse,
        }
    }

    /// No motors at all.
    pub fn is_empty(&self) -> bool {
        self.motors.is_empty()
    }

    /// Which axes drive at least one motor.
    pub fn axes_used(&self) -> [bool; 9] {
        let mut u = [false; 9];
        for (k, used) in u.iter_mut().enumerate() {
            *used = self.scale.column(k).iter().any(|&s| s != 0.0);
        }
        u
    }

    /// Motor commanded positions (counts) for base axis positions. `#m->I` motors take their
    /// value from `hold` (same order as [`CsAxes::motors`]).
    pub fn motor_positions(&self, base: &AxisVec, hold: &[f64]) -> DVector<f64> {
        let mut m = &self.scale * base + &self.offset;
        for (r, inv) in self.inverse.iter().enumerate() {
            if *inv {
                m[r] = hold.get(r).copied().unwrap_or(0.0);
            }
        }
        m
    }

    /// PMATCH: base axis positions from motor positions (same order as [`CsAxes::motors`]).
    ///
    /// Motors are taken in ascending number and a motor is used only if its row adds a new
    /// direction (so with several motors on one axis the lowest-numbered one wins). The
    /// selected rows are solved in the least-squares, minimum-change sense around `prev`:
    /// axes no selected motor determines (phantom axes, under-determined combinations) keep
    /// their `prev` value; square regular systems are solved exactly.
    pub fn pmatch(&self, motor_pos: &[f64], prev: &AxisVec) -> AxisVec {
        let tol = 1e-9 * self.scale.amax().max(1e-300);
        let mut rows: Vec<usize> = Vec::new();
        let mut rank = 0;
        for r in 0..self.motors.len() {
            if self.inverse[r] || !matches!(motor_pos.get(r), Some(p) if p.is_finite()) {
                continue;
            }
            let mut trial = rows.clone();
            trial.push(r);
            let sub = self.scale.select_rows(trial.iter());
            let rk = sub.svd(false, false).rank(tol);
            if rk > rank {
                rows = trial;
                rank = rk;
            }
            if rank == 9 {
                break;
            }
        }
        if rows.is_empty() {
            return *prev;
        }
        let sub = self.scale.select_rows(rows.iter());
        let rhs = DVector::from_iterator(
            rows.len(),
            rows.iter()
                .map(|&r| motor_pos[r] - self.offset[r] - (self.scale.row(r) * prev)[0]),
        );
        match sub.svd(true, true).solve(&rhs, tol) {
            Ok(delta) => {
                let mut out = *prev;
                for k in 0..9 {
                    out[k] += delta[k];
                }
                out
            }
            Err(_) => *prev,
        }
    }
}
