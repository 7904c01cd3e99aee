//! Coordinate systems and programmed-move maths (pmac-commands.md §3.3, §5.3; pmac-variables
//! §5.1, §5.4, §5.5). Pure cores: every time is an argument (trajectory ms or servo cycles), no
//! clock, no I/O.
//!
//! Pipeline per servo cycle (driven by [`cs::CoordSystem::tick`]):
//! 1. [`timebase::TimeBase`] turns `%`/feed hold into a trajectory-time increment;
//! 2. [`blend::Timeline`] evaluates the queued moves (LINEAR/CIRCLE blended over TA at each
//!    corner, PVT, SPLINE1, RAPID, DWELL/DELAY) into program axis positions;
//! 3. [`transform::TransformBank`] (TSEL/ADIS/AROT…) maps program XYZ to base XYZ;
//! 4. [`axes::CsAxes`] (`#m->8660X-5000Y`) maps base axes to motor counts.
//!
//! The program executor feeds moves one at a time through [`cs::CoordSystem`] while
//! [`cs::CoordSystem::wants_moves`] says the look-ahead (two moves ahead) is not full.

pub(crate) mod axes;
pub(crate) mod blend;
pub(crate) mod circle;
pub(crate) mod cs;
pub(crate) mod moves;
pub(crate) mod prims;
pub(crate) mod profile;
pub(crate) mod timebase;
pub(crate) mod transform;

#[cfg(test)]
mod tests_axes;
#[cfg(test)]
mod tests_moves;
#[cfg(test)]
mod tests_paths;

use crate::domain::ErrCode;
use thiserror::Error;

/// A refused coordinate-system operation or move.
///
/// [`CoordError::err_code`] gives the `ERRnnn` for refusals of on-line commands; the others
/// are run-time errors of a running program (the executor stops the program, sets ?? word-2
/// bit 22 and, for [`CoordError::CircleRadius`], bit 21).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CoordError {
    /// `#m->…` for a motor already defined in another coordinate system (ERR003).
    #[error("motor {0} is defined in coordinate system {1}")]
    MotorInOtherCs(u16, u16),
    /// Malformed axis definition: no term, > 3 terms, mixed triples, bad scale (ERR003).
    #[error("bad axis definition: {0}")]
    BadAxisDef(&'static str),
    /// Motor or coordinate-system number outside the card (ERR003).
    #[error("no such motor or coordinate system {0}")]
    NoSuchUnit(u32),
    /// A move in a coordinate system with no motors (ERR014).
    #[error("no motors in the coordinate system")]
    NoMotors,
    /// Zero, negative or non-finite time (TA/TS/TM/PVT/DWELL/DELAY) or feedrate.
    #[error("bad time or feedrate: {0}")]
    BadTime(&'static str),
    /// TA = TS = 0: the acceleration time would be zero (PMAC divides by zero).
    #[error("acceleration time TA (or 2*TS) is zero")]
    ZeroAccelTime,
    /// Non-finite or absurdly large position / vector / matrix value.
    #[error("value out of range: {0}")]
    OutOfRange(&'static str),
    /// R-form arc whose chord exceeds 2R by more than Ix96.
    #[error("circle radius error: chord exceeds 2R by {0}")]
    CircleRadius(f64),
    /// Arc start or end point on the centre (zero radius).
    #[error("circle with zero radius")]
    CircleZeroRadius,
    /// TSEL of a matrix that does not exist, or a matrix operation with none selected.
    #[error("no transformation matrix {0}")]
    NoMatrix(u32),
    /// AROT/IROT with a singular rotation/scaling matrix.
    #[error("singular transformation matrix")]
    SingularMatrix,
    /// The look-ahead queue is full (the executor must wait for [`cs::CoordSystem::wants_moves`]).
    #[error("move queue full")]
    QueueFull,
    /// A move while the coordinate system is aborting.
    #[error("coordinate system is stopping")]
    Stopping,
}

impl CoordError {
    /// The `ERRnnn` number for refusals of on-line commands; `None` for run-time errors.
    pub fn err_code(&self) -> Option<ErrCode> {
        match self {
            CoordError::MotorInOtherCs(..)
            | CoordError::BadAxisDef(_)
            | CoordError::NoSuchUnit(_) => Some(ErrCode::Data),
            CoordError::NoMotors => Some(ErrCode::NoMotors),
            _ => None,
        }
    }
}

/// Largest accepted magnitude of a position in counts or user units (PMAC positions are 48-bit).
pub(crate) const MAX_POS: f64 = 140_737_488_355_328.0; // 2^47

/// Check a value is finite and within ±[`MAX_POS`].
pub(crate) fn check_pos(v: f64, what: &'static str) -> Result<f64, CoordError> {
    if v.is_finite() && v.abs() <= MAX_POS {
        Ok(v)
    } else {
        Err(CoordError::OutOfRange(what))
    }
}
