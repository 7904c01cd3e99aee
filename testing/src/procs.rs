//! Process bookkeeping for teardown: the pids a cluster had, each with its start time, so a
//! pid reused by another process is never signalled.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Start time of `pid` (field 22 of `/proc/<pid>/stat`); None when it does not run (or is a
/// zombie).
pub fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let rest = stat.get(stat.rfind(')')? + 1..)?;
    let mut fields = rest.split_whitespace();
    let state = fields.next()?;
    if state == "Z" || state == "X" {
        return None;
    }
    fields.nth(18)?.parse().ok()
}

/// Whether `pid` runs (not a zombie).
pub fn alive(pid: u32) -> bool {
    start_time(pid).is_some()
}

/// Send `sig` to `pid` (errors ignored).
pub fn kill(pid: u32, sig: i32) {
    if let Ok(p) = libc::pid_t::try_from(pid) {
        if p > 0 {
            // SAFETY: kill(2) only sends a signal; a stale pid fails with ESRCH.
            #[allow(unsafe_code)]
            unsafe {
                libc::kill(p, sig);
            }
        }
    }
}

/// Pids seen, with their start times.
#[derive(Debug, Default, Clone)]
pub struct Tracked {
    pids: BTreeMap<u32, Option<u64>>,
}

impl Tracked {
    /// Remember `pid` as it is now.
    pub fn add(&mut self, pid: u32) {
        self.pids.entry(pid).or_insert_with(|| start_time(pid));
    }

    /// The remembered processes still running (same pid, same start time).
    pub fn alive(&self) -> Vec<u32> {
        self.pids
            .iter()
            .filter(|(p, t)| t.is_some() && start_time(**p) == **t)
            .map(|(p, _)| *p)
            .collect()
    }

    /// SIGKILL whatever is left and wait (bounded) for it to go; the pids killed.
    pub fn kill_all(&self, wait: Duration) -> Vec<u32> {
        let left = self.alive();
        for &p in &left {
            kill(p, libc::SIGKILL);
        }
        let deadline = Instant::now() + wait;
        while !self.alive().is_empty() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        left
    }
}
