//! Fault drills on member processes (`mcc fault MEMBER freeze|thaw|kill|restart`) and the
//! per-card state `mcc status` adds from each card's `at` queryable (ring fault, killed
//! motors, program start cycle).

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::{AtReply, AtRequest};
use mcc_ring::control::{ctl_key, CtlReply};

use crate::cluster::attach::Attached;
use crate::cluster::ctl;
use crate::cluster::status::ClusterStatus;
use crate::cluster::sync_start::query_all;
use crate::cluster::sys;

/// The process-level drills.
pub const PROCESS_DRILLS: &[&str] = &["freeze", "thaw", "kill", "restart"];

/// Key of the supervisor's restart queryable (payload: member name).
pub fn restart_key(cluster: &str) -> String {
    ctl_key(cluster, "orchestrator", "restart")
}

/// Ask every card for its `info` (ring fault, killed motors, program start); in config order.
pub fn card_infos(session: &zenoh::Session, cfg: &ClusterConfig) -> Vec<Option<AtReply>> {
    card_infos_within(session, cfg, Duration::from_millis(1000))
}

/// [`card_infos`], each card given `timeout` to answer.
pub fn card_infos_within(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    timeout: Duration,
) -> Vec<Option<AtReply>> {
    let body = AtRequest::Info.to_json();
    let reqs: Vec<(u32, String)> = cfg
        .cards
        .iter()
        .map(|c| (u32::from(c.number), body.clone()))
        .collect();
    query_all(&session.clone(), &cfg.cluster, &reqs, timeout)
        .into_iter()
        .map(|(r, _)| r.ok())
        .collect()
}

/// Fill the per-card fields of the status document from [`card_infos`].
pub fn apply_card_infos(doc: &mut ClusterStatus, infos: &[Option<AtReply>]) {
    for (row, info) in doc.cards.iter_mut().zip(infos) {
        let Some(i) = info else { continue };
        row.ring_fault = Some(i.ring_fault);
        row.motors_killed = Some(i.motors_killed);
        row.killed_motors = i.killed_motors.clone();
        row.program_start_cycle = i.program_start_cycle;
        row.program_start_ns = i.program_start_ns;
    }
}

/// Add the cards' own state to a status document.
/// A card whose member answered but whose own state did not is asked once more, with a
/// longer wait: a card serves its state between servo ticks, and while its sync master is
/// frozen a follower's next tick waits up to the member timeout before its holdover clock
/// takes over (the power-ring drill saw card1's state missing while card0 was frozen). A
/// card whose member is gone is not waited for.
pub fn enrich_status(session: &zenoh::Session, cfg: &ClusterConfig, doc: &mut ClusterStatus) {
    let mut infos = card_infos(session, cfg);
    let alive = |name: &str| doc.members.iter().any(|m| m.name == name && m.alive);
    let missing: Vec<usize> = (0..infos.len())
        .filter(|&k| infos[k].is_none() && cfg.cards.get(k).is_some_and(|c| alive(&c.name)))
        .collect();
    if !missing.is_empty() {
        let again = card_infos_within(session, cfg, Duration::from_millis(3000));
        for (k, a) in again.into_iter().enumerate() {
            if missing.contains(&k) {
                infos[k] = a;
            }
        }
    }
    apply_card_infos(doc, &infos);
}

/// `mcc fault MEMBER freeze|thaw|kill|restart`.
pub fn process_drill(a: &Attached, member: &str, what: &str) -> Result<String> {
    // On several hosts the supervisor of the member's host runs the drill (every share
    // serves one restart queryable per host; this machine's record knows only its pids).
    if a.cfg.is_multi_host() {
        return crate::cluster::hosts::remote::drill(&a.session, &a.cfg, member, what);
    }
    let pid = a
        .info
        .members
        .iter()
        .find(|m| m.name == member)
        .map(|m| m.pid)
        .ok_or_else(|| anyhow!("member {member:?} has no recorded process"))?;
    let sig = match what {
        "freeze" => libc::SIGSTOP,
        "thaw" => libc::SIGCONT,
        "kill" => libc::SIGKILL,
        "restart" => {
            let r: CtlReply = ctl::query_ctl(
                &a.session,
                &restart_key(&a.cfg.cluster),
                Some(member.to_string()),
                Duration::from_secs(15),
            )?;
            if !r.ok {
                bail!("restart refused: {}", r.message);
            }
            return Ok(r.message);
        }
        other => bail!("unknown drill {other:?}"),
    };
    if !sys::pid_alive(pid) {
        bail!("{member} (pid {pid}) is not running");
    }
    sys::signal(pid, sig).map_err(|e| anyhow!("signal {sig} to {member} (pid {pid}): {e}"))?;
    Ok(format!("{what}: signal {sig} sent to pid {pid}"))
}

/// `mcc fault reset [MEMBER]`: ask members (default all) to reset their ring-fault latch
/// (`ctl/<member>/reset`; a latch stays set while the ring is unhealthy). Cards also need `$$$`.
pub fn reset_latches(a: &Attached, member: Option<&str>) -> Result<()> {
    let members: Vec<String> = match member {
        Some(m) if a.cfg.member(m).is_none() => bail!(
            "unknown member {m:?} (members: {})",
            a.cfg.ring.order.join(", ")
        ),
        Some(m) => vec![m.to_string()],
        None => a.cfg.ring.order.clone(),
    };
    let mut failed = 0;
    for m in &members {
        let key = ctl_key(&a.cfg.cluster, m, "reset");
        match ctl::query_ctl(&a.session, &key, None, Duration::from_secs(2)) {
            Ok(r) if r.ok => println!("{m}: {}", r.message),
            Ok(r) => {
                failed += 1;
                eprintln!("{m}: {}", r.message);
            }
            Err(e) => {
                failed += 1;
                eprintln!("{m}: {e:#}");
            }
        }
    }
    if failed > 0 {
        bail!(
            "{failed} of {} member(s) kept their ring fault",
            members.len()
        );
    }
    Ok(())
}
