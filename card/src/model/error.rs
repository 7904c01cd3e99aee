//! Errors raised by the card state, each mapped to the PMAC error code it is reported as.

use crate::domain::ErrCode;
use thiserror::Error;

/// A rejected state operation. [`StateError::err_code`] gives the `ERRnnn` number to report.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum StateError {
    /// Variable number outside the profile's range (`I1024`, `P9000` on PMAC2, ...).
    #[error("variable number {0} out of range")]
    NoSuchVariable(u32),
    /// Value outside the variable's allowed range.
    #[error("value out of range for {0}")]
    ValueOutOfRange(String),
    /// Write to a read-only variable or register.
    #[error("{0} is read-only")]
    ReadOnly(String),
    /// Malformed M-variable definition (bad width/offset combination, address, ...).
    #[error("bad M-variable definition: {0}")]
    BadDefinition(String),
    /// Motor or coordinate-system number outside the profile.
    #[error("motor or coordinate system {0} out of range")]
    NoSuchUnit(u32),
}

impl StateError {
    /// The PMAC error number (`ERRnnn`) this rejection is reported as. All of these are
    /// "data error or unrecognised command" on a PMAC: ERR003.
    pub fn err_code(&self) -> ErrCode {
        ErrCode::Data
    }
}
