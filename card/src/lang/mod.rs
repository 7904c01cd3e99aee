//! The card's command languages, two dialects side by side over one executor API:
//! - [`pmac`]: the PMAC2/Turbo language (lexer, parser, listing, and the interpreter that runs
//!   lines against the card model and frames `ERRnnn` replies);
//! - [`power`]: the Power PMAC script language (gpascii threads, data-structure elements,
//!   `error #n` replies).
//!
//! [`Dialect`] is the seam: a card core holds one and reaches its language only through it;
//! no module outside `lang/` names a dialect, and neither dialect names the other (the
//! layering test holds both). The shared executor API is re-exported here: the card, a
//! connection's session, line runs, budgets, effects, and the executor's command forms
//! (`CmdKind`), onto which the Power dialect maps its motor and C.S. commands.

mod dialect;
pub(crate) mod pmac;
pub(crate) mod power;

pub(crate) use dialect::CHAIN_THREAD;
pub use dialect::{Dialect, HeldReply, Started, WholeLine};
pub(crate) use pmac::ast::CmdKind;
pub(crate) use pmac::interp::{ctrl_n, overlong_probe};
pub(crate) use power::abort_all;
/// Longest line the Power script language takes (its `gpascii` port's limit).
pub(crate) const SCRIPT_MAX_LINE: usize = power::MAX_LINE;

pub use pmac::interp::{
    Budget, Card, Effect, EffectResult, LineRun, Session, Step, Storage, MAX_LINE,
};
