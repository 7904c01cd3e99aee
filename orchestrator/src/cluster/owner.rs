//! `mcc up --owner-pid PID`: the cluster lives only as long as the process that asked for it
//! (a test runner killed by SIGKILL, a crashed xdist worker). The supervisor checks the owner
//! every loop; a pid reused by another process does not count (the start time must match).

use crate::cluster::sys;

/// The process a cluster belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Owner {
    /// Its pid.
    pub pid: u32,
    /// Its start time (clock ticks since boot, `/proc/<pid>/stat` field 22) when first seen.
    start: Option<u64>,
}

/// Start time of `pid` (field 22 of `/proc/<pid>/stat`), if readable.
fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // "pid (comm) S ppid ..." — comm may hold spaces and ')': fields after the last ')'.
    let rest = stat.get(stat.rfind(')')? + 1..)?;
    // Field 3 (state) is the first after ')'; field 22 is the 20th.
    rest.split_whitespace().nth(19)?.parse().ok()
}

impl Owner {
    /// Remember `pid` as it is now; an error when it does not run.
    pub fn new(pid: u32) -> anyhow::Result<Self> {
        if !sys::pid_alive(pid) {
            anyhow::bail!("--owner-pid {pid}: no such process");
        }
        Ok(Owner {
            pid,
            start: start_time(pid),
        })
    }

    /// An owner known to have exited.
    pub fn gone(pid: u32) -> Self {
        Owner {
            pid,
            start: Some(u64::MAX),
        }
    }

    /// Whether the owner still runs (same pid, same start time, not a zombie).
    pub fn alive(&self) -> bool {
        sys::pid_alive(self.pid) && (self.start.is_none() || start_time(self.pid) == self.start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_owner_is_followed_by_pid_and_start_time() {
        let me = Owner::new(std::process::id()).unwrap();
        assert!(me.alive());
        assert!(me.start.is_some());
        let reused = Owner {
            pid: std::process::id(),
            start: me.start.map(|s| s + 1),
        };
        assert!(
            !reused.alive(),
            "same pid, other start time: a different process"
        );
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        assert!(Owner::new(pid).is_err() || !Owner::new(pid).unwrap().alive());
        assert!(Owner::new(u32::MAX).is_err());
    }
}
