//! `mcc fault STATION axis NODE KIND [--cycles N] [--value V]` and `mcc fault STATION
//! power-loss`: faults of a station's plant (being built).

use anyhow::{bail, Result};

use crate::cli::FaultArgs;

/// `mcc fault STATION axis NODE KIND`.
pub fn cmd_axis(_cluster: &str, member: &str, _words: &[String], _args: &FaultArgs) -> Result<()> {
    bail!("{member}: axis faults are not available in this build")
}

/// `mcc fault STATION power-loss`.
pub fn cmd_power_loss(_cluster: &str, member: &str, _args: &FaultArgs) -> Result<()> {
    bail!("{member}: power-loss is not available in this build")
}
