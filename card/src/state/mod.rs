//! Card state: variables, tables, register map, number printing, status words, persistence.
//!
//! [`CardState`] is the one struct INTERP holds; the submodules are its parts:
//! - [`profile`]: pmac2/turbo dimensions; [`ivars`]: I-variable tables per profile;
//! - [`vars`]: I/P/Q storage; [`mvar`]: M-variable pointers; [`memory`]/[`regmap`]: the
//!   24-bit X/Y memory with MACRO node registers and special registers; [`float48`]: 48-bit
//!   word formats;
//! - [`number`]: PMAC number printing; [`status`]: `?`/`??`/`???` words;
//! - [`persist`]: SAVE image and atomic file write; reset/`$$$***` live in `lifecycle`.

pub mod card_state;
mod card_status;
pub mod error;
pub mod float48;
pub mod ivars;
mod lifecycle;
pub mod memory;
pub mod mvar;
pub mod number;
pub mod persist;
pub mod profile;
pub mod regmap;
pub mod status;
pub mod vars;

pub use card_state::{CardState, I995_STATUS_BITS};
pub use error::StateError;
pub use lifecycle::{SAVED_REGIONS, USER_MEMORY_WORDS};
pub use memory::Space;
pub use persist::{PersistError, PersistImage};

#[cfg(test)]
mod tests;
