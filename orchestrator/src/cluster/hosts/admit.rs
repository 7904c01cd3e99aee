//! Before a host's share starts anything, and while it waits for the ring: every other share
//! of the cluster must run the same config (digest), no other share may run this host, and
//! none of this host's members may already be running elsewhere. Errors name the problem:
//! the first keys where two configs differ, the member two hosts claim.

use std::time::Duration;

use anyhow::{bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::hosts::HostInfo;
use mcc_ring::control::alive_key;
use mcc_ring::runtime::join::{shares, short};
use zenoh::Wait;

/// How long other shares have to answer.
pub const ASK: Duration = Duration::from_millis(1500);

/// Every share found runs our config (checked again while the ring comes up: two hosts may
/// start at the same moment).
pub fn check_digests(cfg: &ClusterConfig, host: &str, found: &[HostInfo]) -> Result<()> {
    let mine = cfg.digest();
    match found.iter().find(|s| s.digest != mine) {
        Some(s) => bail!("{}", mismatch(cfg, host, s)),
        None => Ok(()),
    }
}

/// Before `host`'s share starts: every share runs our config and none runs this host.
pub fn check_shares(cfg: &ClusterConfig, host: &str, found: &[HostInfo]) -> Result<()> {
    check_digests(cfg, host, found)?;
    for s in found {
        if s.host == host {
            bail!(
                "host {host}'s share of cluster {} is already running (machine {}, supervisor pid {}): stop it there first (`mcc down --cluster {}`)",
                cfg.cluster,
                s.machine,
                s.pid,
                cfg.cluster
            );
        }
    }
    Ok(())
}

/// Refuse to start `host`'s share when the network says it would not join the same cluster.
pub fn admit(session: &zenoh::Session, cfg: &ClusterConfig, host: &str) -> Result<()> {
    check_shares(cfg, host, &shares(session, &cfg.cluster, ASK))?;
    let mine = cfg.host_processes(host);
    let alive = alive_members(session, &cfg.cluster);
    if let Some(m) = mine.iter().find(|m| alive.contains(m)) {
        bail!(
            "member {m} of cluster {} is already running on this zenoh network: two hosts claim it (this config puts it on host {host}); stop the other one first",
            cfg.cluster
        );
    }
    Ok(())
}

/// Members whose liveliness token is there (`mcc/<cluster>/alive/*`).
pub fn alive_members(session: &zenoh::Session, cluster: &str) -> Vec<String> {
    let prefix = alive_key(cluster, "");
    let Ok(replies) = session
        .liveliness()
        .get(alive_key(cluster, "*"))
        .timeout(Duration::from_millis(800))
        .wait()
    else {
        return Vec::new();
    };
    let mut out = Vec::new();
    while let Ok(r) = replies.recv() {
        if let Ok(s) = r.result() {
            if let Some(name) = s.key_expr().as_str().strip_prefix(&prefix) {
                out.push(name.to_string());
            }
        }
    }
    out
}

/// Why share `other` does not run our config: the members two hosts claim, else the first
/// keys that differ.
pub fn mismatch(cfg: &ClusterConfig, host: &str, other: &HostInfo) -> String {
    let head = format!(
        "host {} (machine {}, supervisor pid {}) runs cluster {} with another config (digest {} there, {} here)",
        other.host,
        other.machine,
        other.pid,
        cfg.cluster,
        short(&other.digest),
        short(&cfg.digest())
    );
    let theirs = ClusterConfig::from_toml_str(&other.config).ok();
    if let Some(t) = &theirs {
        for m in cfg.host_processes(host) {
            if let Some(h) = t.member_host(&m).filter(|h| *h != host) {
                return format!(
                    "{head}: two hosts claim member {m}: host {host} (this config) and host {h} (the config of host {})",
                    other.host
                );
            }
        }
    }
    let a: toml::Value = toml::from_str(&cfg.to_toml_string().unwrap_or_default())
        .unwrap_or(toml::Value::Table(Default::default()));
    let b: toml::Value =
        toml::from_str(&other.config).unwrap_or(toml::Value::Table(Default::default()));
    let mut keys = Vec::new();
    diff(&a, &b, String::new(), &mut keys);
    if keys.is_empty() {
        return head;
    }
    format!(
        "{head}: {} differ{}; start every host with the same config file and options",
        keys.iter().take(3).cloned().collect::<Vec<_>>().join(", "),
        if keys.len() == 1 { "s" } else { "" }
    )
}

/// Dotted paths (`cards[1].host`) where two TOML values differ.
pub fn diff(a: &toml::Value, b: &toml::Value, path: String, out: &mut Vec<String>) {
    use toml::Value as V;
    match (a, b) {
        (V::Table(x), V::Table(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => diff(u, v, p, out),
                    _ => out.push(p),
                }
            }
        }
        (V::Array(x), V::Array(y)) if x.len() == y.len() => {
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                diff(u, v, format!("{path}[{i}]"), out);
            }
        }
        (u, v) if u != v => out.push(path),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_hosts() -> ClusterConfig {
        let mut c = ClusterConfig::default_cluster(2, 2);
        c.zenoh.routers = vec!["tcp/127.0.0.1:7447".into()];
        for (i, h) in ["a", "a", "b", "b"].iter().enumerate() {
            let name = c.ring.order[i].clone();
            match c.cards.iter_mut().find(|x| x.name == name) {
                Some(card) => card.host = Some(h.to_string()),
                None => {
                    if let Some(s) = c.stations.iter_mut().find(|x| x.name == name) {
                        s.host = Some(h.to_string());
                    }
                }
            }
        }
        c.resolve().unwrap()
    }

    fn info(cfg: &ClusterConfig, host: &str) -> HostInfo {
        HostInfo {
            cluster: cfg.cluster.clone(),
            host: host.into(),
            machine: "m2".into(),
            pid: 42,
            digest: cfg.digest(),
            config: cfg.to_toml_string().unwrap(),
            phase: "running".into(),
            members: vec![],
            daisy_chain: None,
            emcl_bus: None,
        }
    }

    #[test]
    fn shares_must_run_the_same_config_on_other_hosts() {
        let c = two_hosts();
        assert!(check_shares(&c, "a", &[info(&c, "b")]).is_ok());
        let e = check_shares(&c, "a", &[info(&c, "a")])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "host a's share of cluster mcc is already running (machine m2, supervisor pid 42)"
            ),
            "{e}"
        );
        let mut other = c.clone();
        other.rate_hz = 1000.0;
        let e = check_shares(&c, "a", &[info(&other, "b")])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "host b (machine m2, supervisor pid 42) runs cluster mcc with another config"
            ),
            "{e}"
        );
        assert!(e.contains("rate_hz differs"), "{e}");
        // The other host's config puts one of our members on itself.
        let mut claim = c.clone();
        claim.stations[0].host = Some("b".into());
        let e = check_shares(&c, "a", &[info(&claim, "b")])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("two hosts claim member station0: host a (this config) and host b"),
            "{e}"
        );
    }

    #[test]
    fn diff_names_nested_keys() {
        let a: toml::Value = toml::from_str("x = 1\n[[c]]\nh = \"a\"\n[t]\nk = [1, 2]\n").unwrap();
        let b: toml::Value =
            toml::from_str("x = 1\ny = 2\n[[c]]\nh = \"b\"\n[t]\nk = [1, 3]\n").unwrap();
        let mut out = Vec::new();
        diff(&a, &b, String::new(), &mut out);
        assert_eq!(out, vec!["c[0].h", "t.k[1]", "y"]);
    }
}
