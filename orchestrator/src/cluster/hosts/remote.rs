//! Acting on other hosts' shares from this one: `mcc down` stops every share it reaches and
//! names the hosts it cannot reach; process drills on a member of another host go to that
//! host's supervisor.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::hosts::{host_key, DrillRequest};
use mcc_ring::control::CtlReply;
use mcc_ring::runtime::join::shares;
use zenoh::Wait;

use crate::cluster::ctl;

/// What `down` did on the other hosts.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DownReport {
    /// Hosts whose share confirmed and stopped.
    pub stopped: Vec<String>,
    /// Hosts whose share confirmed but was still there at the deadline.
    pub lingering: Vec<String>,
    /// Hosts of the config that no share answered for.
    pub unreachable: Vec<String>,
}

/// Hosts whose share's liveliness token is there now.
pub fn live_hosts(session: &zenoh::Session, cluster: &str) -> Vec<String> {
    let Ok(replies) = session
        .liveliness()
        .get(host_key(cluster, "*", "alive"))
        .timeout(Duration::from_millis(800))
        .wait()
    else {
        return Vec::new();
    };
    let prefix = format!("mcc/{cluster}/hosts/");
    let mut out = Vec::new();
    while let Ok(r) = replies.recv() {
        if let Ok(s) = r.result() {
            let k = s.key_expr().as_str();
            if let Some(h) = k
                .strip_prefix(&prefix)
                .and_then(|r| r.strip_suffix("/alive"))
            {
                out.push(h.to_string());
            }
        }
    }
    out
}

/// Ask every share but `mine` to stop and wait (up to `timeout`) until they are gone.
pub fn down_others(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    mine: Option<&str>,
    timeout: Duration,
) -> DownReport {
    let found = shares(session, &cfg.cluster, super::admit::ASK);
    let mut report = DownReport::default();
    let mut asked = Vec::new();
    for s in found.iter().filter(|s| Some(s.host.as_str()) != mine) {
        let key = host_key(&cfg.cluster, &s.host, "down");
        match ctl::query_ctl(session, &key, None, Duration::from_secs(3)) {
            Ok(r) if r.ok => {
                eprintln!(
                    "mcc: stopping host {} (machine {}, supervisor pid {}: {})",
                    s.host,
                    s.machine,
                    s.pid,
                    s.members
                        .iter()
                        .map(|m| m.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                asked.push(s.host.clone());
            }
            _ => report.unreachable.push(s.host.clone()),
        }
    }
    let deadline = Instant::now() + timeout;
    loop {
        let live = live_hosts(session, &cfg.cluster);
        let left: Vec<&String> = asked.iter().filter(|h| live.contains(h)).collect();
        if left.is_empty() || Instant::now() >= deadline {
            for h in &asked {
                if live.contains(h) {
                    report.lingering.push(h.clone());
                } else {
                    report.stopped.push(h.clone());
                }
            }
            break;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    for h in cfg.host_names() {
        let answered = found.iter().any(|s| s.host == h);
        if Some(h.as_str()) != mine && !answered && !report.unreachable.contains(&h) {
            report.unreachable.push(h);
        }
    }
    report
}

/// A process drill (`freeze`, `thaw`, `kill`, `restart`) on `member`, run by the supervisor of
/// its host.
pub fn drill(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    member: &str,
    kind: &str,
) -> Result<String> {
    let host = cfg
        .member_host(member)
        .ok_or_else(|| anyhow!("unknown member {member:?}"))?;
    let req = DrillRequest {
        member: member.to_string(),
        kind: kind.to_string(),
    };
    let key = host_key(&cfg.cluster, host, "drill");
    let r: CtlReply = ctl::query_ctl(
        session,
        &key,
        Some(serde_json::to_string(&req)?),
        Duration::from_secs(15),
    )
    .map_err(|e| anyhow!("host {host} (which runs {member}) did not answer the drill: {e:#}"))?;
    if !r.ok {
        bail!("{kind} on {member} (host {host}) refused: {}", r.message);
    }
    Ok(format!("{} (on host {host})", r.message))
}
