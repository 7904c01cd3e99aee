//! The Power card's global abort input set-up (seed 000 L3095-3134, L19423-19470,
//! L20029-20055): `Sys.pAbortAll` (0 = no global abort input), `Sys.AbortAllBit`,
//! `Sys.AbortAllLimit` and each C.S.'s `Coord[x].AbortAllMode`, read from the dialect's store
//! (their defaults when never set). The input itself is the card core's
//! (`core::inputs`).

use super::catalog::{self, St, DEFS};
use super::progvars::ProgVars;
use crate::model::CardModel;

/// What the global abort input is wired to and how each C.S. answers it.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct AbortAllSetup {
    /// `Sys.pAbortAll` ≠ 0: the card watches an input register.
    pub enabled: bool,
    /// `Sys.AbortAllBit`.
    pub bit: u32,
    /// `Sys.AbortAllLimit`: scans the bit must be seen (more than) before the card acts.
    pub limit: u32,
    /// `Coord[x].AbortAllMode` for x = 0..16 (0 abort, 1 kill, 2 abort then kill, 3 ignore).
    pub modes: Vec<u8>,
}

fn value(model: &CardModel, st: St, idx: u32, name: &str) -> f64 {
    match model.ext::<ProgVars>() {
        Some(pv) => super::elements::kept_or_default(&pv.store, st, idx, name),
        None => catalog::find(st, name).map_or(0.0, |d| DEFS[d].default),
    }
}

/// The set-up as the card holds it now.
pub(crate) fn setup(model: &CardModel) -> AbortAllSetup {
    let n = St::Coord.count().unwrap_or(16);
    AbortAllSetup {
        enabled: value(model, St::Sys, 0, "pAbortAll") != 0.0,
        bit: value(model, St::Sys, 0, "AbortAllBit").clamp(0.0, 31.0) as u32,
        limit: value(model, St::Sys, 0, "AbortAllLimit").clamp(0.0, 255.0) as u32,
        modes: (0..n)
            .map(|x| value(model, St::Coord, x, "AbortAllMode").clamp(0.0, 3.0) as u8)
            .collect(),
    }
}
