//! `mcc fault CARD|chain|bus link KIND [--probability P --seed S --cycles N]`: host-link
//! faults (being built).

use anyhow::{bail, Result};

use crate::cli::FaultArgs;

/// `mcc fault TARGET link KIND`.
pub fn cmd_link(_cluster: &str, target: &str, _words: &[String], _args: &FaultArgs) -> Result<()> {
    bail!("{target}: host-link faults are not available in this build")
}
