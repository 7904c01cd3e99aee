//! Waiting for a started cluster's ring to lock (`mcc up`, the benches).

use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::control::MemberStatus;

use crate::cluster::ctl;

/// Poll member status until every member is locked. Prints a progress line whenever the set
/// of locked members changes. `dead` reports a reason to give up early (a member or the
/// supervisor died).
pub fn wait_locked(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    timeout: Duration,
    dead: impl FnMut() -> Option<String>,
) -> Result<Vec<Option<MemberStatus>>> {
    wait_locked_on(session, cfg, None, timeout, dead)
}

/// [`wait_locked`] for `host`'s share of a cluster on several hosts: the ring locks once
/// every host's members are up; meanwhile every other share must run the same config, and a
/// timeout names the hosts that never started.
pub fn wait_locked_on(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    host: Option<&str>,
    timeout: Duration,
    mut dead: impl FnMut() -> Option<String>,
) -> Result<Vec<Option<MemberStatus>>> {
    let start = Instant::now();
    let mut last: Option<usize> = None;
    let mut checked = Instant::now();
    loop {
        let st = ctl::query_statuses(
            session,
            cfg,
            Duration::from_millis(300),
            Duration::from_millis(600),
        );
        let locked = st
            .iter()
            .filter(|s| s.as_ref().is_some_and(|s| s.locked))
            .count();
        if last != Some(locked) {
            let waiting: Vec<String> = cfg
                .ring
                .order
                .iter()
                .zip(&st)
                .filter(|(_, s)| !s.as_ref().is_some_and(|s| s.locked))
                .map(|(n, _)| match cfg.is_multi_host() {
                    true => format!("{n} on {}", cfg.member_host(n).unwrap_or("?")),
                    false => n.clone(),
                })
                .collect();
            eprintln!(
                "mcc: ring {}: {locked}/{} members locked{}",
                cfg.ring.name,
                st.len(),
                if waiting.is_empty() {
                    String::new()
                } else {
                    format!(" (waiting for {})", waiting.join(", "))
                }
            );
            last = Some(locked);
        }
        if locked == st.len() {
            crate::cluster::emcl::status::wait_ready(
                session,
                cfg,
                timeout.saturating_sub(start.elapsed()),
            )?;
            return Ok(st);
        }
        if let Some(why) = dead() {
            bail!("{why}");
        }
        if cfg.is_multi_host() && checked.elapsed() >= Duration::from_secs(2) {
            checked = Instant::now();
            let found =
                mcc_ring::runtime::join::shares(session, &cfg.cluster, Duration::from_millis(700));
            crate::cluster::hosts::admit::check_digests(cfg, host.unwrap_or(""), &found)?;
        }
        if start.elapsed() >= timeout {
            bail!(
                "the ring did not lock within {} s{}",
                timeout.as_secs(),
                missing_hosts(session, cfg, &st)
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// `: host b never started (card1, station1 do not answer)` for the hosts of a cluster on
/// several hosts whose members are missing (empty on one machine).
fn missing_hosts(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    st: &[Option<MemberStatus>],
) -> String {
    if !cfg.is_multi_host() {
        return String::new();
    }
    let live = crate::cluster::hosts::remote::live_hosts(session, &cfg.cluster);
    let mut parts = Vec::new();
    for h in cfg.host_names() {
        let silent: Vec<&str> = cfg
            .ring
            .order
            .iter()
            .zip(st)
            .filter(|(n, s)| s.is_none() && cfg.member_host(n) == Some(h.as_str()))
            .map(|(n, _)| n.as_str())
            .collect();
        if silent.is_empty() {
            continue;
        }
        if live.contains(&h) {
            parts.push(format!(
                "host {h} runs but {} do not answer",
                silent.join(", ")
            ));
        } else {
            parts.push(format!(
                "host {h} never started or cannot be reached ({} do not answer; start it there with `mcc up --host {h}`)",
                silent.join(", ")
            ));
        }
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!(": {}", parts.join("; "))
    }
}
