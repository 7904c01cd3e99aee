//! Hosts for tests and benchmarks of clusters on several machines: Linux network namespaces
//! joined by veth links (needs root and iproute2's `ip`), and zenoh's router `zenohd`. Used by
//! the scenario tests (through `mcc_testing::netns`) and by `mcc bench ring`.
//!
//! [`Lab::new`] builds three namespaces in a triangle: the hub (`r`, where a router runs) has
//! a link to each host (`a`, `b`), and the hosts have a direct link too (peer to peer). Every
//! link is its own /24 of `10.213.0.0/16`; only the processes started in the namespaces use
//! them. Dropping the lab kills what runs in the namespaces and deletes them.
//!
//! | link | hub side / host side |
//! | --- | --- |
//! | r–a | `10.213.1.1` (r) / `10.213.1.2` (a) |
//! | r–b | `10.213.2.1` (r) / `10.213.2.2` (b) |
//! | a–b | `10.213.3.1` (a) / `10.213.3.2` (b) |

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Why a lab cannot be built here (the test says so and is skipped).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unavailable(pub String);

impl std::fmt::Display for Unavailable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// The three namespaces and their links.
#[derive(Debug)]
pub struct Lab {
    prefix: String,
}

/// A link of the lab: its two ends (namespace short name, device, address).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Link {
    /// One end: (namespace, device, address).
    pub left: (&'static str, &'static str, &'static str),
    /// The other end.
    pub right: (&'static str, &'static str, &'static str),
}

/// The hub–a link.
pub const RA: Link = Link {
    left: ("r", "vra", "10.213.1.1"),
    right: ("a", "var", "10.213.1.2"),
};
/// The hub–b link.
pub const RB: Link = Link {
    left: ("r", "vrb", "10.213.2.1"),
    right: ("b", "vbr", "10.213.2.2"),
};
/// The direct a–b link.
pub const AB: Link = Link {
    left: ("a", "vab", "10.213.3.1"),
    right: ("b", "vba", "10.213.3.2"),
};

fn run(cmd: &mut Command) -> Result<(), String> {
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{cmd:?}: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{cmd:?}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

fn ip(args: &[&str]) -> Result<(), String> {
    run(Command::new("ip").args(args))
}

impl Lab {
    /// Build the lab, or say why it cannot be built here (not root, no `ip`, no netns).
    pub fn new(tag: &str) -> Result<Lab, Unavailable> {
        // SAFETY: geteuid has no preconditions and cannot fail.
        #[allow(unsafe_code)]
        let euid = unsafe { libc::geteuid() };
        if euid != 0 {
            return Err(Unavailable(format!(
                "network namespaces need root (running as uid {euid})"
            )));
        }
        if Command::new("ip")
            .arg("-V")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .map(|s| !s.success())
            .unwrap_or(true)
        {
            return Err(Unavailable("iproute2's `ip` is not installed".into()));
        }
        // Short names: device names are limited to 15 bytes, namespace names are not.
        let lab = Lab {
            prefix: format!("mcc{}{tag}", std::process::id()),
        };
        lab.build()
            .map_err(|e| Unavailable(format!("cannot build the namespaces: {e}")))?;
        Ok(lab)
    }

    fn build(&self) -> Result<(), String> {
        for ns in ["r", "a", "b"] {
            ip(&["netns", "add", &self.ns(ns)])?;
            ip(&["-n", &self.ns(ns), "link", "set", "lo", "up"])?;
        }
        for l in [RA, RB, AB] {
            let (ln, ld, la) = l.left;
            let (rn, rd, ra) = l.right;
            ip(&[
                "link",
                "add",
                ld,
                "netns",
                &self.ns(ln),
                "type",
                "veth",
                "peer",
                "name",
                rd,
                "netns",
                &self.ns(rn),
            ])?;
            for (ns, dev, addr) in [(ln, ld, la), (rn, rd, ra)] {
                ip(&[
                    "-n",
                    &self.ns(ns),
                    "addr",
                    "add",
                    &format!("{addr}/24"),
                    "dev",
                    dev,
                ])?;
                ip(&["-n", &self.ns(ns), "link", "set", dev, "up"])?;
            }
        }
        Ok(())
    }

    /// The full namespace name of `short` (`r`, `a`, `b`).
    pub fn ns(&self, short: &str) -> String {
        format!("{}-{short}", self.prefix)
    }

    /// A command that runs `program` inside namespace `short`.
    pub fn command(&self, short: &str, program: impl AsRef<Path>) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", &self.ns(short)])
            .arg(program.as_ref());
        c
    }

    /// Take `link` down (both ends): packets across it are lost, nothing is closed.
    pub fn link_down(&self, link: Link) -> Result<(), String> {
        self.set(link, "down")
    }

    /// Bring `link` back up.
    pub fn link_up(&self, link: Link) -> Result<(), String> {
        self.set(link, "up")
    }

    fn set(&self, link: Link, state: &str) -> Result<(), String> {
        for (ns, dev, _) in [link.left, link.right] {
            ip(&["-n", &self.ns(ns), "link", "set", dev, state])?;
        }
        Ok(())
    }

    /// Pids of the processes in namespace `short`.
    pub fn pids(&self, short: &str) -> Vec<u32> {
        Command::new("ip")
            .args(["netns", "pids", &self.ns(short)])
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .output()
            .map(|o| {
                String::from_utf8_lossy(&o.stdout)
                    .split_whitespace()
                    .filter_map(|p| p.parse().ok())
                    .collect()
            })
            .unwrap_or_default()
    }
}

impl Drop for Lab {
    fn drop(&mut self) {
        for ns in ["r", "a", "b"] {
            for pid in self
                .pids(ns)
                .into_iter()
                .filter_map(|p| libc::pid_t::try_from(p).ok())
            {
                // SAFETY: kill(2) only sends a signal; a stale pid fails with ESRCH.
                #[allow(unsafe_code)]
                unsafe {
                    libc::kill(pid, libc::SIGKILL);
                }
            }
        }
        for ns in ["r", "a", "b"] {
            let _ = ip(&["netns", "del", &self.ns(ns)]);
        }
    }
}

/// The `zenohd` to use: `$MCC_ZENOHD`, else the one `tests/hosts/install-zenohd.sh` put in
/// `<target>/zenohd-<version>/bin` of the cargo target directory `target`.
pub fn zenohd(target: &Path) -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MCC_ZENOHD").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p)).filter(|p| p.is_file());
    }
    installed(target)
}

/// The `zenohd` installed in `<target>/zenohd-<version>/bin`, if any.
pub fn installed(target: &Path) -> Option<PathBuf> {
    std::fs::read_dir(target)
        .ok()?
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("zenohd-"))
        .map(|e| e.path().join("bin/zenohd"))
        .find(|p| p.is_file())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn installed_zenohd_is_found_under_the_target_directory() {
        let t = std::env::temp_dir().join(format!("mcc-netns-test-{}", std::process::id()));
        let bin = t.join("zenohd-1.0.0/bin");
        std::fs::create_dir_all(&bin).unwrap();
        std::fs::create_dir_all(t.join("debug")).unwrap();
        assert_eq!(installed(&t), None, "no binary yet");
        std::fs::write(bin.join("zenohd"), b"").unwrap();
        assert_eq!(installed(&t), Some(bin.join("zenohd")));
        assert_eq!(installed(&t.join("missing")), None);
        std::fs::remove_dir_all(&t).unwrap();
    }
}
