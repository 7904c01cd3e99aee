//! The run directory of a cluster: `$MCC_RUN_DIR/<cluster>`, else
//! `$XDG_RUNTIME_DIR/mcc/<cluster>`, else `/tmp/mcc-<uid>/<cluster>`. It holds the resolved
//! `cluster.toml`, `supervisor.json` (supervisor pid, zenoh endpoint, member pids, phase) and
//! `logs/<member>.log` and `links/<member>.sock` (each member's zenoh unix-socket endpoint, with
//! zenoh's `.sock.lock` beside it). `mcc down` removes exactly these files, nothing else.
//!
//! \[DECISION\] The run directory is the user's only: created 0700 (and tightened to 0700 when
//! it exists and is ours; one owned by another user is refused), as is the default base
//! (`$XDG_RUNTIME_DIR/mcc`, `/tmp/mcc-<uid>`); a base named by `MCC_RUN_DIR` is created 0700
//! but otherwise left as the user made it. `cluster.toml` (which may hold a Power card's
//! `ssh_password`), `supervisor.json` and the logs are 0600.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

use crate::cluster::sys;
use mcc_contracts::atomic_file::PRIVATE_MODE;

/// Resolved config file name.
pub const CONFIG_FILE: &str = "cluster.toml";
/// Supervisor state file name.
pub const INFO_FILE: &str = "supervisor.json";
/// Log folder name.
pub const LOG_DIR: &str = "logs";
/// Folder of the members' unix-socket endpoints.
pub const LINK_DIR: &str = "links";
/// Longest unix-socket path the kernel takes (`sun_path` is 108 bytes with its NUL; zenoh's lock
/// file appends 5 more bytes but is an ordinary file).
const MAX_SOCKET_PATH: usize = 107;

/// One member process started by the supervisor.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MemberProc {
    /// Member name.
    pub name: String,
    /// `card`, `station` or `drive` (a stand-alone EMCL drive).
    pub kind: String,
    /// OS pid.
    pub pid: u32,
}

/// What the supervisor publishes about itself in `supervisor.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SupervisorInfo {
    /// Supervisor process id.
    pub pid: u32,
    /// Cluster name.
    pub cluster: String,
    /// `starting`, `running`, `stopping` or `failed`.
    pub phase: String,
    /// The supervisor's zenoh endpoint once listening.
    pub endpoint: Option<String>,
    /// Member processes.
    pub members: Vec<MemberProc>,
    /// Error text when `phase` is `failed`.
    pub message: Option<String>,
    /// Daisy-chain TCP endpoint (`127.0.0.1:PORT`) once serving.
    #[serde(default)]
    pub daisy_chain: Option<String>,
    /// Daisy-chain pseudo-terminal path, when one is served.
    #[serde(default)]
    pub daisy_chain_pty: Option<String>,
    /// EMCL bus TCP endpoint (`127.0.0.1:PORT`) once serving.
    #[serde(default)]
    pub emcl_bus: Option<String>,
    /// EMCL bus pseudo-terminal path, when one is served.
    #[serde(default)]
    pub emcl_bus_pty: Option<String>,
    /// The host whose share this supervisor runs (`mcc up --host`), null for a cluster on
    /// one machine.
    #[serde(default)]
    pub host: Option<String>,
}

impl SupervisorInfo {
    /// A fresh `starting` record for process `pid`.
    pub fn starting(pid: u32, cluster: &str) -> Self {
        SupervisorInfo {
            pid,
            cluster: cluster.to_string(),
            phase: "starting".into(),
            endpoint: None,
            members: Vec::new(),
            message: None,
            daisy_chain: None,
            daisy_chain_pty: None,
            emcl_bus: None,
            emcl_bus_pty: None,
            host: None,
        }
    }
}

/// A cluster's run directory.
#[derive(Debug, Clone)]
pub struct RunDir {
    /// The directory.
    pub dir: PathBuf,
    /// Cluster name.
    pub cluster: String,
    /// The host whose share runs here (`mcc up --host`): the directory is `<cluster>@<host>`.
    pub host: Option<String>,
}

/// Mode of run directories (see the module docs).
pub const DIR_MODE: u32 = 0o700;

/// The base named by `MCC_RUN_DIR`, if set.
fn chosen_base() -> Option<PathBuf> {
    std::env::var_os("MCC_RUN_DIR")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
}

/// Where run directories live.
pub fn base_dir() -> PathBuf {
    if let Some(d) = chosen_base() {
        return d;
    }
    if let Some(d) = std::env::var_os("XDG_RUNTIME_DIR").filter(|d| !d.is_empty()) {
        let d = PathBuf::from(d);
        if d.is_dir() {
            return d.join("mcc");
        }
    }
    PathBuf::from(format!("/tmp/mcc-{}", sys::uid()))
}

impl RunDir {
    /// The run directory of `cluster` (the name is checked: it becomes a path component).
    pub fn for_cluster(cluster: &str) -> Result<Self> {
        if let Err(mcc_contracts::config::ConfigError::Invalid { key, problem }) =
            mcc_contracts::config::check_name("--cluster", cluster)
        {
            bail!("{key}: {problem}");
        }
        Ok(RunDir {
            dir: base_dir().join(cluster),
            cluster: cluster.to_string(),
            host: None,
        })
    }

    /// The run directory of `host`'s share of `cluster` (`<cluster>@<host>`), or the whole
    /// cluster's without a host.
    pub fn for_share(cluster: &str, host: Option<&str>) -> Result<Self> {
        let mut rd = Self::for_cluster(cluster)?;
        if let Some(h) = host {
            if let Err(mcc_contracts::config::ConfigError::Invalid { key, problem }) =
                mcc_contracts::config::check_name("--host", h)
            {
                bail!("{key}: {problem}");
            }
            rd.dir = base_dir().join(format!("{cluster}@{h}"));
            rd.host = Some(h.to_string());
        }
        Ok(rd)
    }

    /// The run directory of `cluster` on this machine: the whole cluster's if it has a
    /// record, else a host share's (`<cluster>@<host>`) with a live supervisor, else the
    /// whole cluster's (which then says "not running").
    pub fn find(cluster: &str) -> Result<Self> {
        let whole = Self::for_cluster(cluster)?;
        if whole.read_info().is_some() {
            return Ok(whole);
        }
        let prefix = format!("{cluster}@");
        let mut shares: Vec<RunDir> = fs::read_dir(base_dir())
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().to_str()?.to_string();
                let host = name.strip_prefix(&prefix)?.to_string();
                Self::for_share(cluster, Some(&host)).ok()
            })
            .filter(|rd| rd.read_info().is_some())
            .collect();
        shares.sort_by_key(|rd| rd.running().is_none());
        Ok(shares.into_iter().next().unwrap_or(whole))
    }

    /// Path of the resolved config.
    pub fn config_path(&self) -> PathBuf {
        self.dir.join(CONFIG_FILE)
    }

    /// Path of `supervisor.json`.
    pub fn info_path(&self) -> PathBuf {
        self.dir.join(INFO_FILE)
    }

    /// Log file of `who` (a member or `supervisor`).
    pub fn log_path(&self, who: &str) -> PathBuf {
        self.dir.join(LOG_DIR).join(format!("{who}.log"))
    }

    /// The zenoh endpoint member `name` listens on, `unixsock-stream/<run dir>/links/<name>.sock`,
    /// when the path fits a unix socket address (else None: the member listens on TCP). Ring
    /// frames between members on one host travel over these sockets: cheaper than loopback TCP
    /// (no TCP stack, acknowledgements or Nagle to switch off).
    pub fn member_socket(&self, name: &str) -> Option<String> {
        let path = self.dir.join(LINK_DIR).join(format!("{name}.sock"));
        let text = path.to_str()?;
        (text.len() <= MAX_SOCKET_PATH && path.is_absolute())
            .then(|| format!("unixsock-stream/{text}"))
    }

    /// Create the folder of the members' sockets.
    pub fn create_link_dir(&self) -> Result<()> {
        create_dirs(&self.dir.join(LINK_DIR))
    }

    /// Make the run directory (and the default base holding it) private to this user.
    fn make_private(&self) -> Result<()> {
        let base = base_dir();
        if chosen_base().is_none() && self.dir.parent() == Some(base.as_path()) {
            private_dir(&base)?;
        }
        private_dir(&self.dir)
    }

    /// The supervisor record, if present and readable.
    pub fn read_info(&self) -> Option<SupervisorInfo> {
        let text = fs::read_to_string(self.info_path()).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// The record of a running supervisor (its pid alive), else None.
    pub fn running(&self) -> Option<SupervisorInfo> {
        self.read_info().filter(|i| sys::pid_alive(i.pid))
    }

    /// Atomically replace `supervisor.json`.
    pub fn write_info(&self, info: &SupervisorInfo) -> Result<()> {
        let text = serde_json::to_string_pretty(info)?;
        write_private(&self.info_path(), text.as_bytes())
    }

    /// Claim the run directory for a new cluster owned by process `pid`: refuses if a live
    /// supervisor owns it; a stale one (dead pid) is cleaned up first.
    pub fn claim(&self, pid: u32) -> Result<()> {
        if let Some(info) = self.running() {
            bail!(
                "cluster {:?} is already running (supervisor pid {}, run dir {}); \
                 stop it with `mcc down --cluster {}`",
                self.cluster,
                info.pid,
                self.dir.display(),
                self.cluster
            );
        }
        if self.info_path().exists() {
            self.cleanup()?;
        }
        self.make_private()?;
        create_dirs(&self.dir.join(LOG_DIR))?;
        let text = serde_json::to_string_pretty(&SupervisorInfo::starting(pid, &self.cluster))?;
        let mut f = match std::os::unix::fs::OpenOptionsExt::mode(
            fs::OpenOptions::new().write(true).create_new(true),
            PRIVATE_MODE,
        )
        .open(self.info_path())
        {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                bail!(
                    "cluster {:?} is being started by another `mcc up`",
                    self.cluster
                )
            }
            Err(e) => {
                return Err(e).context(format!("cannot write {}", self.info_path().display()))
            }
        };
        f.write_all(text.as_bytes())?;
        Ok(())
    }

    /// Write the resolved config.
    pub fn write_config(&self, text: &str) -> Result<()> {
        write_private(&self.config_path(), text.as_bytes())
    }

    /// Remove the files mcc created (config, supervisor record, logs) and the directory if it
    /// is then empty. Anything else (e.g. a user's state file placed there) stays.
    pub fn cleanup(&self) -> Result<()> {
        // (Plus the temporaries of `write_atomic`, left by a process killed while writing.)
        for f in [self.config_path(), self.info_path()] {
            mcc_contracts::atomic_file::remove_temporaries(&f);
            remove_if_exists(&f)?;
        }
        let logs = self.dir.join(LOG_DIR);
        if let Ok(entries) = fs::read_dir(&logs) {
            for e in entries.flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x == "log") {
                    remove_if_exists(&p)?;
                }
            }
        }
        let _ = fs::remove_dir(&logs);
        let links = self.dir.join(LINK_DIR);
        if let Ok(entries) = fs::read_dir(&links) {
            for e in entries.flatten() {
                let p = e.path();
                let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                if name.ends_with(".sock") || name.ends_with(".sock.lock") {
                    remove_if_exists(&p)?;
                }
            }
        }
        let _ = fs::remove_dir(&links);
        let _ = fs::remove_dir(&self.dir);
        Ok(())
    }

    /// The last `lines` lines of a log, for error messages.
    pub fn log_tail(&self, who: &str, lines: usize) -> String {
        let text = fs::read_to_string(self.log_path(who)).unwrap_or_default();
        let all: Vec<&str> = text.lines().collect();
        all[all.len().saturating_sub(lines)..].join("\n")
    }
}

/// Create `dir` and its missing parents, each 0700.
fn create_dirs(dir: &Path) -> Result<()> {
    use std::os::unix::fs::DirBuilderExt;
    fs::DirBuilder::new()
        .recursive(true)
        .mode(DIR_MODE)
        .create(dir)
        .with_context(|| format!("cannot create {}", dir.display()))
}

/// `dir` as a directory only this user may enter: created 0700, tightened to 0700 when it
/// exists and is ours, refused when another user owns it.
pub fn private_dir(dir: &Path) -> Result<()> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    create_dirs(dir)?;
    let md = fs::metadata(dir).with_context(|| format!("cannot read {}", dir.display()))?;
    if md.uid() != sys::uid() {
        bail!(
            "run dir {} belongs to uid {}, not to this user (uid {}): refusing to use it \
             (remove it, or set MCC_RUN_DIR)",
            dir.display(),
            md.uid(),
            sys::uid()
        );
    }
    if md.permissions().mode() & 0o077 != 0 {
        fs::set_permissions(dir, fs::Permissions::from_mode(DIR_MODE))
            .with_context(|| format!("cannot make {} private (0700)", dir.display()))?;
    }
    Ok(())
}

fn remove_if_exists(p: &Path) -> Result<()> {
    match fs::remove_file(p) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e).context(format!("cannot remove {}", p.display())),
    }
}

/// Write atomically (`mcc_contracts::atomic_file`: temporary sibling, fsync, rename,
/// fsync the directory), the file 0600 (the run directory's files may hold secrets).
pub fn write_private(path: &Path, bytes: &[u8]) -> Result<()> {
    mcc_contracts::atomic_file::write_private(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_run_dir(tag: &str) -> RunDir {
        let dir =
            std::env::temp_dir().join(format!("mcc-rundir-test-{}-{tag}", std::process::id()));
        RunDir {
            dir,
            cluster: tag.into(),
            host: None,
        }
    }

    #[test]
    fn claim_refuses_a_live_owner_and_reclaims_a_stale_one() {
        let rd = temp_run_dir("claim");
        rd.claim(std::process::id()).unwrap();
        let err = rd.claim(std::process::id()).unwrap_err().to_string();
        assert!(err.contains("already running"), "{err}");
        // A dead owner: stale, reclaimed.
        let mut info = rd.read_info().unwrap();
        info.pid = u32::MAX;
        rd.write_info(&info).unwrap();
        rd.claim(std::process::id()).unwrap();
        assert_eq!(rd.read_info().unwrap().pid, std::process::id());
        rd.cleanup().unwrap();
        assert!(!rd.dir.exists());
    }

    #[test]
    fn the_run_dir_and_its_files_are_the_users_only() {
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: &Path| fs::metadata(p).unwrap().permissions().mode() & 0o777;
        let rd = temp_run_dir("private");
        // A run dir left world-readable (by an older mcc) is tightened.
        fs::create_dir_all(&rd.dir).unwrap();
        fs::set_permissions(&rd.dir, fs::Permissions::from_mode(0o755)).unwrap();
        rd.claim(std::process::id()).unwrap();
        rd.write_config("[[cards]]\nssh_password = \"secret\"\n")
            .unwrap();
        rd.create_link_dir().unwrap();
        assert_eq!(mode(&rd.dir), 0o700);
        assert_eq!(mode(&rd.dir.join(LOG_DIR)), 0o700);
        assert_eq!(mode(&rd.dir.join(LINK_DIR)), 0o700);
        assert_eq!(mode(&rd.config_path()), 0o600);
        assert_eq!(mode(&rd.info_path()), 0o600);
        let mut info = rd.read_info().unwrap();
        info.phase = "running".into();
        rd.write_info(&info).unwrap();
        assert_eq!(mode(&rd.info_path()), 0o600);
        rd.cleanup().unwrap();
        // A fresh one is created private.
        rd.claim(std::process::id()).unwrap();
        assert_eq!(mode(&rd.dir), 0o700);
        rd.cleanup().unwrap();
    }

    #[test]
    fn cleanup_keeps_foreign_files() {
        let rd = temp_run_dir("foreign");
        rd.claim(std::process::id()).unwrap();
        rd.write_config("cluster = \"x\"\n").unwrap();
        fs::write(rd.log_path("card0"), "hello\nworld\n").unwrap();
        assert_eq!(rd.log_tail("card0", 1), "world");
        fs::write(rd.dir.join("card0.state"), "saved").unwrap();
        rd.create_link_dir().unwrap();
        let sock = rd.member_socket("card0").unwrap();
        let path = sock.strip_prefix("unixsock-stream/").unwrap();
        fs::write(path, "").unwrap();
        fs::write(format!("{path}.lock"), "").unwrap();
        fs::write(rd.dir.join(LINK_DIR).join("notes.txt"), "mine").unwrap();
        // A temporary left by a supervisor killed while writing its record is ours.
        fs::write(mcc_contracts::atomic_file::temp_path(&rd.info_path()), "{").unwrap();
        rd.cleanup().unwrap();
        assert!(!mcc_contracts::atomic_file::temp_path(&rd.info_path()).exists());
        assert!(!std::path::Path::new(path).exists());
        assert!(rd.dir.join(LINK_DIR).join("notes.txt").exists());
        assert!(rd.dir.join("card0.state").exists());
        assert!(!rd.config_path().exists() && !rd.info_path().exists());
        fs::remove_dir_all(&rd.dir).unwrap();
    }

    #[test]
    fn member_sockets_live_in_the_run_dir_and_fit_a_socket_address() {
        let rd = RunDir {
            dir: PathBuf::from("/run/user/1000/mcc/lab"),
            cluster: "lab".into(),
            host: None,
        };
        assert_eq!(
            rd.member_socket("card0").as_deref(),
            Some("unixsock-stream//run/user/1000/mcc/lab/links/card0.sock")
        );
        let long = RunDir {
            dir: PathBuf::from(format!("/tmp/{}", "x".repeat(100))),
            cluster: "x".into(),
            host: None,
        };
        assert_eq!(long.member_socket("card0"), None);
    }

    #[test]
    fn cluster_names_are_checked() {
        assert!(RunDir::for_cluster("../etc").is_err());
        assert!(RunDir::for_cluster("").is_err());
        assert!(RunDir::for_cluster("ok-name_1").is_ok());
    }
}
