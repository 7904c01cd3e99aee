//! Spawning member processes (`mcc-card`, `mcc-station`) and the detached supervisor, with
//! their output captured in the run directory's log files.

use std::fs::OpenOptions;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

use anyhow::{Context, Result};
use mcc_ring::config::{ClusterConfig, MemberRef};
use mcc_ring::transport::session;

use crate::cluster::rundir::RunDir;
use crate::cluster::sys;

/// Where a sibling binary lives: `$MCC_BIN_DIR/<name>`, else next to the running `mcc`,
/// else the bare name (looked up in PATH).
pub fn sibling_binary(name: &str) -> PathBuf {
    if let Some(dir) = std::env::var_os("MCC_BIN_DIR").filter(|d| !d.is_empty()) {
        return PathBuf::from(dir).join(name);
    }
    if let Some(dir) = std::env::current_exe()
        .ok()
        .and_then(|p| p.parent().map(PathBuf::from))
    {
        let p = dir.join(name);
        if p.is_file() {
            return p;
        }
    }
    PathBuf::from(name)
}

fn log_stdio(rd: &RunDir, who: &str) -> Result<(Stdio, Stdio)> {
    let path = rd.log_path(who);
    // The logs are the user's only, as the rest of the run directory.
    let f = std::os::unix::fs::OpenOptionsExt::mode(
        OpenOptions::new().create(true).append(true),
        mcc_ring::runtime::atomic_file::PRIVATE_MODE,
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
    let bin = match cfg.member(name) {
        Some(MemberRef::Card(_)) => sibling_binary("mcc-card"),
        Some(MemberRef::Station(_)) => sibling_binary("mcc-station"),
        // A stand-alone EMCL drive runs as the station binary in drive mode.
        None if cfg.drive(name).is_some() => sibling_binary("mcc-station"),
        None => anyhow::bail!("member {name:?} is not in the config"),
    };
    let (out, err) = log_stdio(rd, name)?;
    let mut cmd = Command::new(&bin);
    cmd.arg("--config")
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
        .with_context(|| format!("cannot start {name} ({})", bin.display()))
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
