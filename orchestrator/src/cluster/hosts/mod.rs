//! A cluster on several hosts (issue 15): each host runs its share (`mcc up --host NAME`),
//! whose supervisor declares itself on the zenoh network ([`share`]), checks before starting
//! anything that it joins the same cluster ([`admit`]), and answers `down` and drills from
//! any other host ([`remote`]). The sessions of every process come from the config
//! (`mcc_ring::transport::cluster`).

pub mod admit;
pub mod remote;
pub mod share;

use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use mcc_contracts::config::{ClusterConfig, Topology};
use mcc_ring::transport::cluster::{self, Role};
use mcc_ring::transport::session::{open_session, SessionOptions};
use zenoh::Wait;

/// Open a session of `role` in a cluster on several hosts; the error names the routers or
/// peers that cannot be reached.
pub fn open(cfg: &ClusterConfig, role: Role<'_>) -> Result<zenoh::Session> {
    let opts = cluster::host_options(cfg, role)
        .map_err(|e| anyhow!("{e}"))?
        .ok_or_else(|| anyhow!("cluster {} names no hosts", cfg.cluster))?;
    open_with(cfg, &opts)
}

/// Open `opts`, naming the routers when a client cannot reach them.
pub fn open_with(cfg: &ClusterConfig, opts: &SessionOptions) -> Result<zenoh::Session> {
    open_session(opts).map_err(|e| match cfg.topology() {
        Topology::Routers(r) => anyhow!(
            "cannot reach the zenoh router {} (zenoh.routers): is zenohd running there? ({e})",
            r.join(", ")
        ),
        _ => anyhow!("{e}"),
    })
}

/// Wait up to `settle` until the session is connected: to a router (client), or to
/// `expected` peers.
pub fn settle(session: &zenoh::Session, cfg: &ClusterConfig, expected: usize, settle: Duration) {
    let deadline = Instant::now() + settle;
    let client = matches!(cfg.topology(), Topology::Routers(_));
    while Instant::now() < deadline {
        let n = if client {
            session.info().routers_zid().wait().count().min(1) * expected.max(1)
        } else {
            session.info().peers_zid().wait().count()
        };
        if n >= expected {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `--host` checked against the config: the name of a host some member is on.
pub fn check_host(cfg: &ClusterConfig, host: Option<&str>) -> Result<Option<String>> {
    let hosts = cfg.host_names();
    match host {
        None if cfg.is_multi_host() => Err(anyhow!(
            "cluster {} has members on hosts {}: start each host's share on that host with `mcc up --host NAME`",
            cfg.cluster,
            hosts.join(", ")
        )),
        None => Ok(None),
        Some(h) if !cfg.is_multi_host() => Err(anyhow!(
            "--host {h}: no member of cluster {} names a host (set `host = \"…\"` on the members)",
            cfg.cluster
        )),
        Some(h) if !hosts.iter().any(|x| x == h) => Err(anyhow!(
            "--host {h}: no member of cluster {} is on host {h:?} (hosts: {})",
            cfg.cluster,
            hosts.join(", ")
        )),
        Some(h) => Ok(Some(h.to_string())),
    }
}

/// This machine's name (for messages about shares).
pub fn machine_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "?".into())
}

/// Fill the `hosts` rows of a status document from the shares that answer.
pub fn enrich_status(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    doc: &mut crate::cluster::status::ClusterStatus,
) {
    if !cfg.is_multi_host() {
        return;
    }
    let found = mcc_ring::runtime::join::shares(session, &cfg.cluster, Duration::from_millis(800));
    let digest = cfg.digest();
    doc.hosts = cfg
        .host_names()
        .into_iter()
        .map(|h| {
            let s = found.iter().find(|s| s.host == h);
            crate::cluster::status::HostRow {
                alive: s.is_some(),
                machine: s.map(|s| s.machine.clone()),
                pid: s.map(|s| s.pid),
                phase: s.map(|s| s.phase.clone()),
                same_config: s.map(|s| s.digest == digest),
                members: cfg.host_processes(&h),
                daisy_chain: s.and_then(|s| s.daisy_chain.clone()),
                emcl_bus: s.and_then(|s| s.emcl_bus.clone()),
                name: h,
            }
        })
        .collect();
}
