//! `mcc down`: stop a cluster's supervisor (which stops its members in order), make sure no
//! member process is left, remove the runtime files.

use std::time::Duration;

use anyhow::Result;
use mcc_contracts::config::ClusterConfig;

use crate::cli::DownArgs;
use crate::cluster::rundir::RunDir;

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
    let n = crate::cluster::stop::stop(&rd, timeout, true)?;
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
    info: &crate::cluster::rundir::SupervisorInfo,
    timeout: Duration,
) -> Option<(ClusterConfig, crate::cluster::hosts::remote::DownReport)> {
    let cfg = ClusterConfig::from_file(&rd.config_path()).ok()?;
    if !cfg.is_multi_host() {
        return None;
    }
    let endpoint = info.endpoint.clone().unwrap_or_default();
    let session = match crate::cluster::ctl::connect(
        &cfg,
        info.host.as_deref(),
        &endpoint,
        1,
        Duration::from_millis(1500),
    ) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("mcc: cannot reach the other hosts: {e:#}");
            let r = crate::cluster::hosts::remote::DownReport {
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
    let r =
        crate::cluster::hosts::remote::down_others(&session, &cfg, info.host.as_deref(), timeout);
    let _ = zenoh::Wait::wait(session.close());
    Some((cfg, r))
}
