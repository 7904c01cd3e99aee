//! `mcc down`: stop a cluster's supervisor (which stops its members in order), make sure no
//! member process is left, remove the runtime files.

use std::time::{Duration, Instant};

use anyhow::Result;
use mcc_ring::config::ClusterConfig;

use crate::cli::DownArgs;
use crate::rundir::RunDir;
use crate::sys;

fn wait_dead(pid: u32, timeout: Duration) -> bool {
    let deadline = Instant::now() + timeout;
    while sys::pid_alive(pid) {
        if Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    true
}

/// Is `pid` still one of this cluster's member processes (guards against pid reuse)?
fn is_our_member(rd: &RunDir, pid: u32) -> bool {
    let cfg = rd.config_path().display().to_string();
    sys::cmdline(pid).is_some_and(|c| c.contains(&cfg))
}

/// Stop cluster `rd`: SIGTERM to the supervisor (it sends shutdown queries, then SIGTERM, then
/// SIGKILL to members), wait; then signal any member still running; remove the runtime files.
/// Returns how many member processes were recorded.
pub fn stop(rd: &RunDir, timeout: Duration, verbose: bool) -> Result<usize> {
    let Some(info) = rd.read_info() else {
        if rd.dir.exists() {
            rd.cleanup()?;
        }
        return Ok(0);
    };
    let me = std::process::id();
    if info.pid != me && sys::pid_alive(info.pid) {
        if verbose {
            eprintln!(
                "mcc: stopping cluster {} (supervisor pid {})",
                rd.cluster, info.pid
            );
        }
        let _ = sys::signal(info.pid, sys::SIGTERM);
        if !wait_dead(info.pid, timeout + Duration::from_secs(3)) {
            eprintln!("mcc: supervisor pid {} did not stop; killing it", info.pid);
            let _ = sys::signal(info.pid, sys::SIGKILL);
            wait_dead(info.pid, Duration::from_secs(3));
        }
    }
    // Members the supervisor could not stop (or that outlived a killed supervisor).
    for sig in [sys::SIGTERM, sys::SIGKILL] {
        let left: Vec<_> = info
            .members
            .iter()
            .filter(|m| sys::pid_alive(m.pid) && is_our_member(rd, m.pid))
            .collect();
        if left.is_empty() {
            break;
        }
        for m in &left {
            eprintln!(
                "mcc: member {} (pid {}) still running; signalling",
                m.name, m.pid
            );
            let _ = sys::signal(m.pid, sig);
        }
        for m in &left {
            wait_dead(m.pid, Duration::from_secs(3));
        }
    }
    rd.cleanup()?;
    Ok(info.members.len())
}

/// `mcc down`: this machine's share (or whole cluster), and on a cluster on several hosts
/// every other host's share first; the hosts it cannot reach are named (exit status 1).
pub fn cmd_down(cluster: &str, args: &DownArgs) -> Result<()> {
    let rd = RunDir::find(cluster)?;
    let Some(info) = rd.read_info() else {
        if rd.dir.exists() {
            rd.cleanup()?;
        }
        println!("cluster {cluster} is not running");
        return Ok(());
    };
    let timeout = Duration::from_secs(args.timeout.max(1));
    let report = remote_down(&rd, &info, timeout);
    let n = stop(&rd, timeout, true)?;
    match (&report, &info.host) {
        (Some(_), Some(h)) => println!("cluster {cluster}: host {h} stopped ({n} members)"),
        _ => println!("cluster {cluster} stopped ({n} members)"),
    }
    let Some((cfg, r)) = report else {
        return Ok(());
    };
    for h in &r.stopped {
        println!(
            "cluster {cluster}: host {h} stopped ({} members)",
            cfg.host_processes(h).len()
        );
    }
    let mut problems = Vec::new();
    for h in &r.lingering {
        problems.push(format!(
            "host {h} confirmed but had not stopped within {} s",
            timeout.as_secs()
        ));
    }
    for h in &r.unreachable {
        problems.push(format!(
            "cannot reach host {h} ({}): not running, or the network or router is down; if it runs, stop it there with `mcc down --cluster {cluster}`",
            cfg.host_processes(h).join(", ")
        ));
    }
    if problems.is_empty() {
        return Ok(());
    }
    anyhow::bail!("{}", problems.join("; "))
}

/// On a cluster on several hosts, ask every other host's share to stop (before this one's
/// supervisor, and so the session, goes away).
fn remote_down(
    rd: &RunDir,
    info: &crate::rundir::SupervisorInfo,
    timeout: Duration,
) -> Option<(ClusterConfig, crate::hosts::remote::DownReport)> {
    let cfg = ClusterConfig::from_file(&rd.config_path()).ok()?;
    if !cfg.is_multi_host() {
        return None;
    }
    let endpoint = info.endpoint.clone().unwrap_or_default();
    let session = match crate::ctl::connect(
        &cfg,
        info.host.as_deref(),
        &endpoint,
        1,
        Duration::from_millis(1500),
    ) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("mcc: cannot reach the other hosts: {e:#}");
            let r = crate::hosts::remote::DownReport {
                unreachable: cfg
                    .host_names()
                    .into_iter()
                    .filter(|h| Some(h) != info.host.as_ref())
                    .collect(),
                ..Default::default()
            };
            return Some((cfg, r));
        }
    };
    let r = crate::hosts::remote::down_others(&session, &cfg, info.host.as_deref(), timeout);
    let _ = zenoh::Wait::wait(session.close());
    Some((cfg, r))
}
