//! Talking to a running cluster from another process: finding and attaching to it.

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::ClusterConfig;

use crate::cluster::ctl;
use crate::cluster::rundir::{RunDir, SupervisorInfo};

/// A running cluster found through its run directory, with a connected session.
pub struct Attached {
    /// Run directory.
    pub rd: RunDir,
    /// Supervisor record.
    pub info: SupervisorInfo,
    /// Resolved config.
    pub cfg: ClusterConfig,
    /// Session connected to the cluster.
    pub session: zenoh::Session,
}

impl std::fmt::Debug for Attached {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Attached")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

/// Find cluster `name` and connect to it.
pub fn attach(name: &str) -> Result<Attached> {
    let rd = RunDir::find(name)?;
    let Some(info) = rd.running() else {
        bail!(
            "cluster {name:?} is not running (no live supervisor in {})",
            rd.dir.display()
        );
    };
    let cfg = ClusterConfig::from_file(&rd.config_path())?;
    let endpoint = info
        .endpoint
        .clone()
        .ok_or_else(|| anyhow!("cluster {name:?} is still starting (no endpoint yet)"))?;
    let session = ctl::connect(
        &cfg,
        info.host.as_deref(),
        &endpoint,
        cfg.ring.order.len() + 1 + cfg.standalone_drives().count(),
        Duration::from_millis(1500),
    )?;
    // A fresh session may not route queries to every member yet, and a query nobody serves
    // comes back empty at once (a start-sync or gather then blames a card): ask every member
    // until each answered (bounded; a dead member only costs the budget).
    let _ = ctl::query_statuses(
        &session,
        &cfg,
        Duration::from_millis(300),
        Duration::from_millis(1500),
    );
    Ok(Attached {
        rd,
        info,
        cfg,
        session,
    })
}

impl Attached {
    /// A new host connection on the cluster's daisy chain, replies awaited `timeout_ms`.
    pub fn chain_link(&self, timeout_ms: u64) -> crate::cluster::chain::link::ChainLink {
        crate::cluster::chain::link::ChainLink::new(
            self.session.clone(),
            &self.cfg,
            Duration::from_millis(timeout_ms.max(1)),
        )
    }
}
