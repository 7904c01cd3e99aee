//! `mcc bench ring`, section (e): the ring across three network namespaces on this machine
//! (the `mcc-netns` lab, root only): host a's share (card0, station0) in namespace `a`, host
//! b's (card1, station1) in `b`, `zenohd` in `r`, every share with a run directory of its own.
//! The same lockstep ring measured twice in one run: peer to peer over the direct a–b veth
//! link, then as zenoh clients of the router in `r` (every hop a → r → b or back), and the hop
//! cost of the router against peer to peer. Without root, `ip` or a zenohd the report says
//! SKIPPED and why.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result};
use mcc_netns::Lab;

use super::hosts::{self, Path2, Site};

/// The zenoh messages a ring's processes exchange (the access-control rule allows them).
const MESSAGES: &str = "\"put\", \"delete\", \"declare_subscriber\", \"query\", \
                        \"declare_queryable\", \"reply\", \"liveliness_token\", \
                        \"declare_liveliness_subscriber\", \"liveliness_query\"";

/// The lab and what its hosts need to link beyond loopback (the security rule: user/password
/// authentication and access control): a password made for this run, its files in a private
/// directory removed when dropped.
pub(super) struct LabHosts {
    pub(super) lab: Lab,
    secret: String,
    dir: PathBuf,
}

impl std::fmt::Debug for LabHosts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LabHosts").field("lab", &self.lab).finish()
    }
}

impl LabHosts {
    fn new(lab: Lab) -> Result<Self> {
        use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt};
        let secret = format!("{:032x}", rand::random::<u128>());
        let dir = std::env::temp_dir().join(format!("mcc-bench-lab-{}", std::process::id()));
        std::fs::DirBuilder::new()
            .mode(0o700)
            .recursive(true)
            .create(&dir)
            .with_context(|| format!("creating {}", dir.display()))?;
        for (name, text) in [
            ("pass", format!("{secret}\n")),
            ("users", format!("mcc:{secret}\n")),
        ] {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(true)
                .mode(0o600)
                .open(dir.join(name))?;
            std::io::Write::write_all(&mut f, text.as_bytes())?;
        }
        Ok(LabHosts { lab, secret, dir })
    }

    /// The `[zenoh.auth]` and `[zenoh.access_control]` tables of a lab cluster's config.
    pub(super) fn cluster_security(&self, cluster: &str) -> String {
        cluster_security(&self.dir, cluster)
    }

    /// Where the router's files go (private to this run).
    pub(super) fn dir(&self) -> &Path {
        &self.dir
    }

    /// The router's config: authenticated users only, mcc's messages only, mcc's queue depth.
    pub(super) fn router_config(&self, queues: &str) -> String {
        let (d, s) = (self.dir.display(), &self.secret);
        format!(
            "{{ mode: \"router\", transport: {{ auth: {{ usrpwd: {{ user: \"mcc\", password: \"{s}\", \
             dictionary_file: \"{d}/users\" }} }}, {queues} }}, access_control: {{ enabled: true, \
             default_permission: \"deny\", rules: [{{ id: \"mcc\", messages: [{MESSAGES}], \
             flows: [\"egress\", \"ingress\"], permission: \"allow\", key_exprs: [\"mcc/**\"] }}], \
             subjects: [{{ id: \"users\", usernames: [\"mcc\"] }}], \
             policies: [{{ rules: [\"mcc\"], subjects: [\"users\"] }}] }} }}"
        )
    }
}

impl Drop for LabHosts {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The `[zenoh.auth]` (password and users files in `dir`) and `[zenoh.access_control]`
/// tables of a lab cluster's config.
pub(super) fn cluster_security(dir: &Path, cluster: &str) -> String {
    let d = dir.display();
    format!(
            "[zenoh.auth]\nuser = \"mcc\"\npassword_file = \"{d}/pass\"\ndictionary_file = \"{d}/users\"\n\
             [zenoh.access_control]\nenabled = true\ndefault_permission = \"deny\"\n\
             [[zenoh.access_control.rules]]\nid = \"mcc\"\nmessages = [{MESSAGES}]\n\
             flows = [\"egress\", \"ingress\"]\npermission = \"allow\"\nkey_exprs = [\"mcc/{cluster}/**\"]\n\
             [[zenoh.access_control.subjects]]\nid = \"links\"\nlink_protocols = [\"tcp\"]\n\
             [[zenoh.access_control.policies]]\nrules = [\"mcc\"]\nsubjects = [\"links\"]\n"
        )
}

/// Section (e) of `mcc bench ring`.
pub fn run(window: Duration, zenohd: Option<&Path>) -> Result<()> {
    println!(
        "\n(e) across three network namespaces: 2 cards + 2 stations, lockstep, card0/station0 in \
         namespace a, card1/station1 in namespace b, zenohd in namespace r (veth links a–b, r–a, \
         r–b); {} s each",
        window.as_secs_f64()
    );
    let lab = match Lab::new("bench") {
        Ok(lab) => LabHosts::new(lab)?,
        Err(why) => {
            println!("    network namespaces: SKIPPED ({why})");
            return Ok(());
        }
    };
    let site = Site::Lab(&lab);
    hosts::header("× p2p");
    let p2p = hosts::measure(site, &Path2::PeerToPeer, "ns-p2p", window)?;
    let base = p2p.hop_us(4);
    hosts::row("namespaces, peer to peer", &p2p, 4, base);
    hosts::through_router(
        site,
        zenohd,
        "namespaces, through zenohd in r",
        window,
        (&p2p, base),
    )?;
    println!(
        "    hop µs = ring round trip / members; peer to peer the two hops between the hosts \
         cross the a–b veth, through the router every hop goes member → r → member over two \
         veths; stamped figures need a session inside the namespaces: not taken"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lab_configs_meet_the_security_rule() {
        let dir = Path::new("/tmp/mcc-bench-lab-1");
        let sec = cluster_security(dir, "bench-x");
        for (path, peers) in hosts::lab_paths() {
            let text = hosts::config_text("bench-x", &path, peers.clone(), &sec);
            let cfg = mcc_contracts::config::ClusterConfig::from_toml_str(&text)
                .unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert!(cfg.is_multi_host(), "{text}");
            // Without the tables the same config is refused, naming the key.
            let bare = hosts::config_text("bench-x", &path, peers, "");
            let e = mcc_contracts::config::ClusterConfig::from_toml_str(&bare)
                .unwrap_err()
                .to_string();
            assert!(e.contains("zenoh.auth"), "{e}");
        }
        assert!(sec.contains("password_file = \"/tmp/mcc-bench-lab-1/pass\""));
        assert!(sec.contains("key_exprs = [\"mcc/bench-x/**\"]"));
    }
}
