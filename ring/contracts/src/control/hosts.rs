//! Host shares of a cluster (issue 15): each host's supervisor holds the liveliness token
//! `mcc/<cluster>/hosts/<host>/alive` (its members leave when it goes away) and serves
//! `mcc/<cluster>/hosts/<host>/{info,down,drill}`: what it runs (config digest and text, member
//! pids), stop this share, and process drills (freeze, thaw, kill, restart) on its members.

use serde::{Deserialize, Serialize};

/// Key of `what` (`alive`, `info`, `down`, `drill`) of `host`'s share (`*` for all hosts).
pub fn host_key(cluster: &str, host: &str, what: &str) -> String {
    format!("mcc/{cluster}/hosts/{host}/{what}")
}

/// One process a share started.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct HostProc {
    /// Member (or stand-alone drive) name.
    pub name: String,
    /// OS pid on that host.
    pub pid: u32,
}

/// What a share says about itself (`hosts/<host>/info`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct HostInfo {
    /// Cluster name.
    pub cluster: String,
    /// Host name from the config ([`crate::config::LOCAL_HOST`] without hosts).
    pub host: String,
    /// The machine's own name (`/proc/sys/kernel/hostname`).
    pub machine: String,
    /// Supervisor pid.
    pub pid: u32,
    /// SHA3-256 of the resolved config it runs.
    pub digest: String,
    /// The resolved config (TOML), so a host whose config differs can name the difference.
    pub config: String,
    /// `starting`, `running` or `stopping`.
    pub phase: String,
    /// The processes it started.
    pub members: Vec<HostProc>,
    /// Its daisy chain and EMCL bus (on that host).
    pub daisy_chain: Option<String>,
    /// EMCL bus endpoint on that host.
    pub emcl_bus: Option<String>,
}

/// A drill on a member of a share (`hosts/<host>/drill`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DrillRequest {
    /// Member name.
    pub member: String,
    /// `freeze`, `thaw`, `kill` or `restart`.
    pub kind: String,
}
