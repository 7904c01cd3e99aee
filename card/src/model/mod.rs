//! The card data model: everything a card remembers, with the operations that keep it
//! consistent. Pure (no I/O, no clock). Built on [`crate::domain`] only; the command language,
//! the program engine and the servo loop are all above it.
//!
//! - [`CardModel`]: the aggregate (state, buffers, run state, motion requests, gather, output);
//! - [`CardState`]: variables, I-variable tables per profile, the 24-bit X/Y memory with its
//!   MACRO node registers and special registers, M-variable pointers, status flags, password;
//! - program storage (`Buffers`, `ProgLine`, DEFINE'd buffers), run state (`RunState`), motion
//!   requests (`Action`), data gathering (`GatherBuffer`), the unsolicited-output log;
//! - number printing and status words, the SAVE image (`PersistImage`) and its byte format.

mod actions;
mod buffers;
mod card;
mod card_state;
mod card_status;
mod defines;
mod error;
mod ext;
mod float48;
mod gather;
mod image_part;
mod ivars;
mod lifecycle;
pub(crate) mod macro_aux;
mod memory;
mod mvar;
mod number;
pub(crate) mod persist;
mod persist_v3;
mod progline;
mod regmap;
mod runstate;
mod status;
mod unsolicited;
mod vars;

#[cfg(test)]
pub(crate) use actions::MAX_ACTIONS;
pub use actions::{Action, ActionKind};
pub(crate) use buffers::{list_lines, BufErr, BufId, Buffers, Program, Rotary, StoredLine};
pub use card::CardModel;
pub(crate) use card::{user_memory_words, PLCS};
pub use card_state::CardState;
pub(crate) use card_state::I995_STATUS_BITS;
pub(crate) use defines::{CompTable, Defines, Layer, TableKind, TBUF_WORDS};
pub(crate) use ext::{ExtAt, ExtError, ExtVars, KinRoutine, StackOf, Thread, DEFAULT_STACK_OFFSET};
pub use float48::*;
pub(crate) use gather::gather_tick;
pub(crate) use image_part::{ImageHooks, ImagePart, PartLoad};
pub(crate) use ivars::turbo::MACRO_IC0_BASE;
pub use memory::*;
pub(crate) use mvar::long;
pub(crate) use number::*;
pub(crate) use progline::ProgLine;
pub(crate) use regmap::{Addr, SERVO_COUNTER};
pub(crate) use runstate::{axis_def_legal, axis_def_text, PlcRun, RunState};
pub(crate) use status::*;
pub(crate) use unsolicited::Unsolicited;

#[cfg(test)]
#[path = "tests_state.rs"]
mod tests;
