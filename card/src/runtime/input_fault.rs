//! `mcc fault CARD input KIND`: the card's application-fault request for its hardware stop
//! inputs (the JSON of [`mcc_ring::control::FaultRequest::App`]), applied to the card core
//! ([`crate::core::inputs`]).

use serde::{Deserialize, Serialize};

use crate::core::inputs::InputKind;
use crate::core::CardCore;

/// `{"family": "input", "kind": "abort", "select": 1, "cycles": 100}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputFaultRequest {
    /// Always `input`.
    pub family: String,
    /// `abort` or `feed-hold` ([`InputKind::WORDS`]).
    pub kind: String,
    /// PMAC2/Turbo: the C.S. the FPD lines select (0: none; default 1).
    #[serde(default)]
    pub select: Option<u16>,
    /// Held for this many cycles (default: until `mcc fault clear`).
    #[serde(default)]
    pub cycles: Option<u64>,
}

/// The family word of this request type.
pub(crate) const FAMILY: &str = "input";

/// Apply the input request `fault` to `core` at ring cycle `cycle` (the next tick's).
pub(crate) fn apply(
    core: &mut CardCore,
    fault: &serde_json::Value,
    cycle: u64,
) -> Result<String, String> {
    let req: InputFaultRequest = serde_json::from_value(fault.clone()).map_err(|e| {
        format!("bad input fault request: {e} (fields: family, kind, select, cycles)")
    })?;
    let kind = InputKind::parse(&req.kind)?;
    core.press_input(kind, req.select.unwrap_or(1), cycle, req.cycles)
}
