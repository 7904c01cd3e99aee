//! Spawning member processes (`mcc-card`, `mcc-station`, or `mcc` itself in their role) and
//! the detached supervisor, with their output captured in the run directory's log files.

use std::ffi::OsStr;
use std::fs::OpenOptions;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use anyhow::{Context, Result};
use mcc_contracts::config::{ClusterConfig, MemberRef};
use mcc_ring::transport::session;

use crate::cluster::rundir::RunDir;
use crate::cluster::sys;

/// A member binary `mcc` starts, and the hidden `mcc` subcommand that runs the same role in
/// `mcc` itself (for an install of `mcc` alone: the Python wheel).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemberRole {
    /// The binary's file name.
    pub binary: &'static str,
    /// `mcc <subcommand> ARGS...` runs as `<binary> ARGS...`.
    pub subcommand: &'static str,
}

/// Cards (`mcc-card`).
pub const CARD: MemberRole = MemberRole {
    binary: "mcc-card",
    subcommand: "run-card",
};

/// Stations and stand-alone EMCL drives (`mcc-station`).
pub const STATION: MemberRole = MemberRole {
    binary: "mcc-station",
    subcommand: "run-station",
};

/// How a member role is started: the program, then these arguments before the member's own.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemberProgram {
    /// The executable.
    pub program: PathBuf,
    /// Arguments before the member's own (the hidden subcommand when `mcc` runs the role).
    pub lead: Vec<&'static str>,
}

/// `$MCC_BIN_DIR/<name>` if set (`bin_dir`), else `<name>` next to `exe` if it is there.
fn installed_binary(name: &str, bin_dir: Option<&OsStr>, exe: Option<&Path>) -> Option<PathBuf> {
    if let Some(dir) = bin_dir.filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(dir).join(name));
    }
    let p = exe?.parent()?.join(name);
    p.is_file().then_some(p)
}

/// Where a sibling binary lives: `$MCC_BIN_DIR/<name>`, else next to the running `mcc`,
/// else the bare name (looked up in PATH).
pub fn sibling_binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().ok();
    installed_binary(
        name,
        std::env::var_os("MCC_BIN_DIR").as_deref(),
        exe.as_deref(),
    )
    .unwrap_or_else(|| PathBuf::from(name))
}

/// How to start `role`: its binary from `$MCC_BIN_DIR` or next to the running `mcc` (as
/// [`sibling_binary`]); else the running `mcc` itself with the role's hidden subcommand (an
/// install of `mcc` alone); else the bare binary name in PATH.
pub fn member_program(role: MemberRole) -> MemberProgram {
    let exe = std::env::current_exe().ok();
    member_program_in(
        role,
        std::env::var_os("MCC_BIN_DIR").as_deref(),
        exe.as_deref(),
    )
}

fn member_program_in(
    role: MemberRole,
    bin_dir: Option<&OsStr>,
    exe: Option<&Path>,
) -> MemberProgram {
    if let Some(program) = installed_binary(role.binary, bin_dir, exe) {
        return MemberProgram {
            program,
            lead: Vec::new(),
        };
    }
    match exe {
        Some(exe) => MemberProgram {
            program: exe.to_path_buf(),
            lead: vec![role.subcommand],
        },
        None => MemberProgram {
            program: PathBuf::from(role.binary),
            lead: Vec::new(),
        },
    }
}

fn log_stdio(rd: &RunDir, who: &str) -> Result<(Stdio, Stdio)> {
    let path = rd.log_path(who);
    // The logs are the user's only, as the rest of the run directory.
    let f = std::os::unix::fs::OpenOptionsExt::mode(
        OpenOptions::new().create(true).append(true),
        mcc_contracts::atomic_file::PRIVATE_MODE,
    )
    .open(&path)
    .with_context(|| format!("cannot open log {}", path.display()))?;
    let f2 = f.try_clone()?;
    Ok((Stdio::from(f), Stdio::from(f2)))
}

/// Start member `name` connected to `endpoint`. Its stdout/stderr go to `logs/<name>.log`; it
/// runs in its own process group (a terminal Ctrl-C reaches only `mcc`, which then stops the
/// members in order) and gets SIGTERM if the spawning process dies. Must be called from a
/// thread that lives as long as the supervisor (the parent-death signal follows the thread).
pub fn spawn_member(rd: &RunDir, cfg: &ClusterConfig, name: &str, endpoint: &str) -> Result<Child> {
    let role = match cfg.member(name) {
        Some(MemberRef::Card(_)) => CARD,
        Some(MemberRef::Station(_)) => STATION,
        // A stand-alone EMCL drive runs as the station binary in drive mode.
        None if cfg.drive(name).is_some() => STATION,
        None => anyhow::bail!("member {name:?} is not in the config"),
    };
    let bin = member_program(role);
    let (out, err) = log_stdio(rd, name)?;
    let mut cmd = Command::new(&bin.program);
    cmd.args(&bin.lead)
        .arg("--config")
        .arg(rd.config_path())
        .arg("--name")
        .arg(name)
        .arg("--connect")
        .arg(endpoint);
    // Members on this host reach each other over unix sockets (gossip hands the locators
    // around); the CLI and the supervisor keep their TCP endpoints. On several hosts every
    // link is a zenoh TCP link from the config (a unix-socket locator handed to another host
    // by gossip would be meaningless there; see `mcc_ring::transport::cluster`).
    if let Some(sock) = rd.member_socket(name).filter(|_| !cfg.is_multi_host()) {
        rd.create_link_dir()?;
        cmd.arg("--listen").arg(sock);
    }
    // zenoh's thread pools sized for a ring member (unless the user chose their own).
    if std::env::var_os(session::RUNTIME_ENV).is_none() {
        cmd.env(session::RUNTIME_ENV, session::MEMBER_RUNTIME);
    }
    cmd.stdin(Stdio::null()).stdout(out).stderr(err);
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    sys::pre_exec(&mut cmd, sys::parent_death_signal_in_child);
    cmd.spawn()
        .with_context(|| format!("cannot start {name} ({})", bin.program.display()))
}

/// Re-execute `mcc supervise --cluster <name> [--owner-pid PID]` as a daemon: new session (no
/// terminal), stdin null, output to `logs/supervisor.log`. Returns its pid.
pub fn spawn_supervisor(rd: &RunDir, owner_pid: Option<u32>) -> Result<u32> {
    let host = rd.host.as_ref().map(|h| format!("--host={h}"));
    let exe = std::env::current_exe().context("cannot find the mcc executable")?;
    let (out, err) = log_stdio(rd, "supervisor")?;
    let mut cmd = Command::new(&exe);
    cmd.arg("--cluster")
        .arg(&rd.cluster)
        .arg("supervise")
        .args(owner_pid.map(|p| format!("--owner-pid={p}")))
        .args(host)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err);
    sys::pre_exec(&mut cmd, sys::setsid_in_child);
    let child = cmd.spawn().context("cannot start the supervisor")?;
    // The daemon is not waited for: once we exit it is re-parented and reaped by init.
    Ok(child.id())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("mcc-launch-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_member_binary_next_to_mcc_is_started_directly() {
        let d = tmp_dir("sibling");
        std::fs::write(d.join("mcc-card"), "").unwrap();
        let p = member_program_in(CARD, None, Some(&d.join("mcc")));
        assert_eq!(p.program, d.join("mcc-card"));
        assert!(p.lead.is_empty());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn mcc_alone_runs_the_member_role_itself() {
        // The Python wheel installs `mcc` only: no `mcc-station` beside it.
        let d = tmp_dir("alone");
        std::fs::write(d.join("mcc-card"), "").unwrap();
        let exe = d.join("mcc");
        let p = member_program_in(STATION, None, Some(&exe));
        assert_eq!(p.program, exe);
        assert_eq!(p.lead, vec!["run-station"]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn mcc_bin_dir_wins_as_before() {
        let p = member_program_in(CARD, Some(OsStr::new("/opt/x")), Some(Path::new("/u/mcc")));
        assert_eq!(p.program, PathBuf::from("/opt/x/mcc-card"));
        assert!(p.lead.is_empty());
        // Empty means unset.
        let p = member_program_in(CARD, Some(OsStr::new("")), None);
        assert_eq!(p.program, PathBuf::from("mcc-card"));
    }
}
