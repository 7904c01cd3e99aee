//! Talking to a running cluster from another process: finding and attaching to it, `status`.

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use mcc_ring::config::ClusterConfig;

use crate::cli::StatusArgs;
use crate::rundir::{RunDir, SupervisorInfo};
use crate::{ctl, status};

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

/// `mcc status [--json]`.
pub fn cmd_status(cluster: &str, args: &StatusArgs) -> Result<()> {
    if let Some(ms) = args.watch {
        return crate::watch::watch(cluster, Duration::from_millis(ms));
    }
    let a = attach(cluster)?;
    let (st, slow) = ctl::query_round(
        &a.session,
        &a.cfg,
        Duration::from_millis(700),
        Duration::from_millis(1500),
    );
    let mut doc = status::build(&a.cfg, &a.info, &a.rd.dir.display().to_string(), &st, &slow);
    crate::drills::enrich_status(&a.session, &a.cfg, &mut doc);
    crate::emcl::status::enrich(&a.session, &a.cfg, &mut doc);
    crate::hosts::enrich_status(&a.session, &a.cfg, &mut doc);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        print!("{}", status::render_table(&doc));
    }
    Ok(())
}
