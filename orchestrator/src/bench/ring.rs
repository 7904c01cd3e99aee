//! `mcc bench ring` (in progress).

use anyhow::{bail, Result};

use crate::cli::BenchRingArgs;

/// Run the ring benchmark.
pub fn run(_args: &BenchRingArgs) -> Result<()> {
    bail!("mcc bench ring is not available yet")
}
