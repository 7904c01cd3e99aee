//! Stopping a cluster: its supervisor first (which stops its members in order), then any
//! member process left; the runtime files removed.

use std::time::{Duration, Instant};

use anyhow::Result;

use crate::cluster::rundir::RunDir;
use crate::cluster::sys;

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
