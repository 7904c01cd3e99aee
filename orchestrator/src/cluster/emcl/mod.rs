//! The EMCL bus (issue 12, spec emcl.md, architecture §5): one multi-drop RS485-style bus per
//! cluster, served by the supervisor on a TCP port and optionally a pseudo-terminal
//! ([`server`]); every 9-byte frame goes to every process hosting drives and the addressed
//! drive's reply comes back, one frame at a time as on a half-duplex line ([`bus`]). Drive
//! rows for `mcc status` ([`status`]); the `mcc emcl` verb is `verbs/emcl.rs`.

pub mod bus;
pub mod server;
pub mod status;

use anyhow::{anyhow, Result};
use mcc_contracts::config::ClusterConfig;

/// Check the drives of a config against the drive model before anything starts.
pub fn validate(cfg: &ClusterConfig) -> Result<()> {
    mcc_station::emcl_rt::check_drives(cfg).map_err(|e| anyhow!(e))
}
