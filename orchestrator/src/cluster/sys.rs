//! The few OS calls the orchestrator needs that std does not offer (signals, sessions,
//! parent-death signal). Every `unsafe` block of the crate lives here, each a single libc call
//! on plain integers.
#![allow(unsafe_code)]

use std::io;

/// Signal numbers used by the orchestrator.
pub use libc::{SIGKILL, SIGTERM};

/// Send `sig` to `pid`. `Ok(false)` if no such process.
pub fn signal(pid: u32, sig: i32) -> io::Result<bool> {
    let Ok(p) = libc::pid_t::try_from(pid) else {
        return Ok(false);
    };
    if p <= 0 {
        return Ok(false);
    }
    // SAFETY: kill(2) with a positive pid and a valid signal number has no memory effects.
    let rc = unsafe { libc::kill(p, sig) };
    if rc == 0 {
        return Ok(true);
    }
    let e = io::Error::last_os_error();
    match e.raw_os_error() {
        Some(libc::ESRCH) => Ok(false),
        _ => Err(e),
    }
}

/// Whether `pid` is a live (not zombie) process.
pub fn pid_alive(pid: u32) -> bool {
    let Ok(p) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if p <= 0 {
        return false;
    }
    // SAFETY: kill(2) with signal 0 only checks existence/permission.
    let rc = unsafe { libc::kill(p, 0) };
    let exists = rc == 0 || io::Error::last_os_error().raw_os_error() == Some(libc::EPERM);
    exists && !is_zombie(pid)
}

/// A zombie still answers kill(pid, 0): look at `/proc/<pid>/stat`.
fn is_zombie(pid: u32) -> bool {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    // "pid (comm) S ..." — comm may contain spaces or parentheses: take the last ')'.
    stat.rfind(')')
        .and_then(|i| stat.get(i + 1..))
        .map(|rest| rest.trim_start().starts_with(['Z', 'X']))
        .unwrap_or(false)
}

/// The command line of `pid` (NULs turned into spaces), if readable.
pub fn cmdline(pid: u32) -> Option<String> {
    let raw = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
    Some(
        String::from_utf8_lossy(&raw)
            .replace('\0', " ")
            .trim_end()
            .to_string(),
    )
}

/// Real user id of this process.
pub fn uid() -> u32 {
    // SAFETY: getuid(2) cannot fail and touches no memory.
    unsafe { libc::getuid() }
}

/// Child side, between fork and exec: start a new session (detach from the terminal).
pub fn setsid_in_child() -> io::Result<()> {
    // SAFETY: setsid(2) is async-signal-safe and touches no memory.
    if unsafe { libc::setsid() } < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// Child side, between fork and exec: get SIGTERM when the spawning thread's process dies.
pub fn parent_death_signal_in_child() -> io::Result<()> {
    // SAFETY: prctl(PR_SET_PDEATHSIG, sig) is async-signal-safe and touches no memory.
    let rc = unsafe {
        libc::prctl(
            libc::PR_SET_PDEATHSIG,
            libc::SIGTERM as libc::c_ulong,
            0,
            0,
            0,
        )
    };
    if rc < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// Install `pre_exec` hooks on a command (the only unsafe std API we call).
pub fn pre_exec(
    cmd: &mut std::process::Command,
    hook: impl FnMut() -> io::Result<()> + Send + Sync + 'static,
) {
    use std::os::unix::process::CommandExt;
    // SAFETY: the hooks above only call async-signal-safe syscalls (setsid, prctl).
    unsafe {
        cmd.pre_exec(hook);
    }
}

/// Set a zero `SO_LINGER` on socket `fd`: its close then resets the connection (RST) at
/// once (a host-link `reset` fault).
pub fn zero_linger(fd: std::os::fd::RawFd) -> io::Result<()> {
    let l = libc::linger {
        l_onoff: 1,
        l_linger: 0,
    };
    let len = libc::socklen_t::try_from(std::mem::size_of::<libc::linger>()).unwrap_or(8);
    // SAFETY: setsockopt(2) reads `len` bytes from `&l`, a live local of exactly that size.
    let rc = unsafe {
        libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_LINGER,
            std::ptr::addr_of!(l).cast(),
            len,
        )
    };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_process_is_alive_and_nonsense_is_not() {
        assert!(pid_alive(std::process::id()));
        assert!(!pid_alive(0));
        assert!(!pid_alive(u32::MAX));
        assert!(!signal(u32::MAX, 0).unwrap());
        let me = cmdline(std::process::id()).unwrap();
        assert!(!me.is_empty());
    }

    #[test]
    fn reaped_child_is_dead_and_zombie_is_dead() {
        let mut child = std::process::Command::new("sleep")
            .arg("5")
            .spawn()
            .unwrap();
        let pid = child.id();
        assert!(pid_alive(pid));
        assert!(signal(pid, SIGKILL).unwrap());
        // Not yet reaped: a zombie, which must count as dead.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
        while pid_alive(pid) && std::time::Instant::now() < deadline {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        assert!(!pid_alive(pid));
        child.wait().unwrap();
        assert!(!pid_alive(pid));
    }
}
