//! `mcc fault CARD input KIND`: a card's hardware inputs (abort/E-stop; being built).

use anyhow::{bail, Result};

use crate::cli::FaultArgs;

/// `mcc fault CARD input KIND`.
pub fn cmd_input(_cluster: &str, member: &str, _words: &[String], _args: &FaultArgs) -> Result<()> {
    bail!("{member}: input faults are not available in this build")
}
