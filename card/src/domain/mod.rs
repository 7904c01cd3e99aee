//! The card's domain vocabulary, shared by every layer above it and depending on none of them:
//! profiles and their dimensions, the PMAC error codes, motor / coordinate-system / node
//! numbers, and the statement and expression forms programs are stored and run in
//! ([`ast`], evaluated by [`eval`]). A command language (the PMAC dialect in `lang`, a second
//! dialect beside it) parses text into these forms; the model, the program engine and the servo
//! loop only ever see these.

pub mod ast;
mod error;
pub(crate) mod eval;
mod ids;
mod mdef_text;
pub(crate) mod profile;
pub(crate) mod words;

pub use error::{ErrCode, PowerErr, Refusal};
pub use ids::{CsNum, MotorNum, NodeNum};
pub use profile::{Limits, Profile};
