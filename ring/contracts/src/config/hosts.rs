//! Members on several hosts (issue 15): `host = "…"` on cards, stations and stand-alone drives,
//! `[hosts.NAME]` (a host's address for peer-to-peer links), `[zenoh] routers` (a `zenohd`
//! every process connects to), the config digest hosts compare at join, and the security rule:
//! a config that opens any listener to other hosts must configure zenoh access control and
//! authentication (user/password or TLS).
//!
//! ```toml
//! [zenoh]
//! routers = ["tcp/10.0.0.5:7447"]          # via a router: every process is a zenoh client of it
//! access_control = { enabled = true, default_permission = "deny", rules = [...], ... }
//! auth = { user = "mcc", password_file = "/etc/mcc/zenoh.pass" }
//!
//! [hosts.rack1]                            # peer-to-peer instead of routers:
//! address = "10.0.0.1"                     # this host's processes listen here
//! port = 7447                              # its supervisor's zenoh port (default 7447)
//!
//! [[cards]]
//! name = "card0"
//! host = "rack1"
//! ```

use std::collections::BTreeMap;
use std::net::IpAddr;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::validate::check_name;
use super::{ClusterConfig, ConfigError, MemberRef};

/// The host name of a cluster whose members name no host (the whole cluster on one machine).
pub const LOCAL_HOST: &str = "local";
/// Default zenoh port of a host's supervisor in peer-to-peer clusters.
pub const DEFAULT_HOST_PORT: u16 = 7447;

type R = Result<(), ConfigError>;

fn bad(key: impl Into<String>, problem: impl Into<String>) -> R {
    Err(ConfigError::invalid(key, problem))
}

/// `[hosts.NAME]`: how the other hosts reach this one (peer-to-peer clusters).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostConfig {
    /// The address this host's mcc processes listen on for the other hosts (an IP address of
    /// this machine). Without routers, every host needs one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub address: Option<String>,
    /// The zenoh port of this host's supervisor (the others connect to `address:port`);
    /// members listen on `address`, any port.
    #[serde(default = "default_host_port")]
    pub port: u16,
}

fn default_host_port() -> u16 {
    DEFAULT_HOST_PORT
}

/// `[zenoh.auth]`: zenoh's user/password authentication of every link.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZenohAuth {
    /// The user every mcc process authenticates as.
    pub user: String,
    /// A file holding the password (first line; never in the config itself).
    pub password_file: PathBuf,
    /// `user:password` lines of the users a listening process accepts (default: only `user`
    /// with the password above).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dictionary_file: Option<PathBuf>,
}

/// How the processes of a cluster reach each other.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Topology {
    /// One machine: every process on loopback (members name no host).
    Single,
    /// Several hosts through zenoh routers (`zenohd`): every process is a client of them.
    Routers(Vec<String>),
    /// Several hosts, peer to peer: each host's processes listen on its address, supervisors
    /// on `address:port`, and zenoh's gossip links every pair directly.
    PeerToPeer,
}

impl ClusterConfig {
    /// The host member (or stand-alone drive) `name` runs on: its `host`, a hosted drive its
    /// station's; [`LOCAL_HOST`] when the cluster names no hosts.
    pub fn member_host(&self, name: &str) -> Option<&str> {
        let host = match self.member(name) {
            Some(MemberRef::Card(c)) => c.host.as_deref(),
            Some(MemberRef::Station(s)) => s.host.as_deref(),
            None => {
                let d = self.drive(name)?;
                match &d.station {
                    Some(st) => return self.member_host(st),
                    None => d.host.as_deref(),
                }
            }
        };
        Some(host.unwrap_or(LOCAL_HOST))
    }

    /// Members name hosts.
    pub fn is_multi_host(&self) -> bool {
        self.cards.iter().any(|c| c.host.is_some())
            || self.stations.iter().any(|s| s.host.is_some())
            || self.drives.iter().any(|d| d.host.is_some())
    }

    /// The processes the supervisor of every host starts: ring members, then stand-alone drives.
    fn processes(&self) -> impl Iterator<Item = &String> {
        self.ring
            .order
            .iter()
            .chain(self.standalone_drives().map(|d| &d.name))
    }

    /// Every host, in the order its first process appears (ring order, then drives).
    pub fn host_names(&self) -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for p in self.processes() {
            if let Some(h) = self.member_host(p) {
                if !v.iter().any(|x| x == h) {
                    v.push(h.to_string());
                }
            }
        }
        v
    }

    /// The processes of `host` (ring members in ring order, then stand-alone drives).
    pub fn host_processes(&self, host: &str) -> Vec<String> {
        self.processes()
            .filter(|p| self.member_host(p) == Some(host))
            .cloned()
            .collect()
    }

    /// How the processes reach each other.
    pub fn topology(&self) -> Topology {
        if !self.is_multi_host() {
            Topology::Single
        } else if !self.zenoh.routers.is_empty() {
            Topology::Routers(self.zenoh.routers.clone())
        } else {
            Topology::PeerToPeer
        }
    }

    /// Peer-to-peer: the endpoint of `host`'s supervisor (`tcp/ADDRESS:PORT`).
    pub fn host_endpoint(&self, host: &str) -> Option<String> {
        let h = self.hosts.get(host)?;
        let addr = h.address.as_deref()?;
        Some(tcp_endpoint(addr, h.port))
    }

    /// Peer-to-peer: what `host`'s members and clients listen on (`tcp/ADDRESS:0`).
    pub fn host_listen(&self, host: &str) -> Option<String> {
        let addr = self.hosts.get(host)?.address.as_deref()?;
        Some(tcp_endpoint(addr, 0))
    }

    /// SHA3-256 of the resolved config (hex): hosts compare it when they join, so every share
    /// of a cluster runs the same config (and options).
    pub fn digest(&self) -> String {
        use sha3::{Digest, Sha3_256};
        let text = self.to_toml_string().unwrap_or_default();
        let hash = Sha3_256::digest(text.as_bytes());
        hash.iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// `tcp/ADDR:PORT`, IPv6 addresses in brackets.
pub fn tcp_endpoint(addr: &str, port: u16) -> String {
    match addr.parse::<IpAddr>() {
        Ok(IpAddr::V6(a)) => format!("tcp/[{a}]:{port}"),
        _ => format!("tcp/{addr}:{port}"),
    }
}

/// The address part of a zenoh endpoint (`tcp/10.0.0.1:7447?x#y` → `10.0.0.1`), None for
/// endpoints that are no network address (`unixsock-stream/PATH`).
fn endpoint_host(ep: &str) -> Option<String> {
    let (proto, rest) = ep.split_once('/')?;
    if proto.starts_with("unix") {
        return None;
    }
    let addr = rest.split(['?', '#']).next().unwrap_or(rest);
    let host = match addr.strip_prefix('[') {
        Some(v6) => v6.split(']').next().unwrap_or(v6),
        None => addr.rsplit_once(':').map_or(addr, |(h, _)| h),
    };
    Some(host.to_string())
}

/// A network address only this machine reaches (127.0.0.0/8, ::1, `localhost`).
pub fn is_loopback(host: &str) -> bool {
    host.eq_ignore_ascii_case("localhost")
        || host.parse::<IpAddr>().is_ok_and(|ip| ip.is_loopback())
}

/// Whether a zenoh endpoint reaches (or is reachable from) other hosts.
pub fn endpoint_is_exposed(ep: &str) -> bool {
    endpoint_host(ep).is_some_and(|h| !is_loopback(&h))
}

/// Every setting that opens a listener (or a zenoh link) to other hosts: (key, what).
pub fn exposures(cfg: &ClusterConfig) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (list, eps) in [
        ("listen", &cfg.zenoh.listen),
        ("connect", &cfg.zenoh.connect),
        ("routers", &cfg.zenoh.routers),
    ] {
        for (i, ep) in eps.iter().enumerate() {
            if endpoint_is_exposed(ep) {
                out.push((
                    format!("zenoh.{list}[{i}]"),
                    format!("zenoh endpoint {ep:?}"),
                ));
            }
        }
    }
    for (name, h) in &cfg.hosts {
        if let Some(a) = h.address.as_deref().filter(|a| !is_loopback(a)) {
            out.push((
                format!("hosts.{name}.address"),
                format!("zenoh links of host {name} on {a}"),
            ));
        }
    }
    for (i, c) in cfg.cards.iter().enumerate() {
        if let Some(b) = c.bind.as_deref().filter(|b| !is_loopback(b)) {
            out.push((
                format!("cards[{i}].bind"),
                format!("{}'s host ports on {b}", c.name),
            ));
        }
    }
    if let Some(b) = cfg.chain.bind.as_deref().filter(|b| !is_loopback(b)) {
        out.push(("chain.bind".into(), format!("the daisy chain on {b}")));
    }
    if let Some(b) = cfg.emcl.bind.as_deref().filter(|b| !is_loopback(b)) {
        out.push(("emcl.bind".into(), format!("the EMCL bus on {b}")));
    }
    out
}

/// Hosts: either no member names one, or every process does; host names are names; drives on
/// a station follow it; several hosts need routers or every host's address.
pub(crate) fn validate_hosts(cfg: &ClusterConfig) -> R {
    let multi = cfg.is_multi_host();
    let mut first: Option<(String, String)> = None;
    let mut check = |key: String, name: &str, host: Option<&str>| -> R {
        match host {
            Some(h) => {
                check_name(&key, h)?;
                if h == LOCAL_HOST {
                    return bad(
                        key,
                        format!("\"{LOCAL_HOST}\" is reserved (a cluster without hosts)"),
                    );
                }
                if first.is_none() {
                    first = Some((name.to_string(), h.to_string()));
                }
                Ok(())
            }
            None if multi => {
                let (m, h) = first.clone().unwrap_or_default();
                let hint = if m.is_empty() {
                    String::new()
                } else {
                    format!(" ({m:?} is on host {h:?})")
                };
                bad(
                    key,
                    format!("{name:?} names no host: once one member names a host, every member and stand-alone drive must{hint}"),
                )
            }
            None => Ok(()),
        }
    };
    for (i, c) in cfg.cards.iter().enumerate() {
        check(format!("cards[{i}].host"), &c.name, c.host.as_deref())?;
    }
    for (i, s) in cfg.stations.iter().enumerate() {
        check(format!("stations[{i}].host"), &s.name, s.host.as_deref())?;
    }
    for (i, d) in cfg.drives.iter().enumerate() {
        let key = format!("drives[{i}].host");
        match (&d.station, &d.host) {
            (Some(st), Some(_)) => {
                return bad(
                    key,
                    format!(
                        "drive {:?} runs on station {st:?}, so on its host: remove the key",
                        d.name
                    ),
                )
            }
            (Some(_), None) => {}
            (None, h) => check(key, &d.name, h.as_deref())?,
        }
    }
    let used = cfg.host_names();
    for (name, h) in &cfg.hosts {
        let key = format!("hosts.{name}");
        check_name(&key, name)?;
        if !used.iter().any(|u| u == name) {
            return bad(
                key,
                format!(
                    "no member is on host {name:?} (hosts in use: {})",
                    list(&used)
                ),
            );
        }
        if let Some(a) = &h.address {
            if a.parse::<IpAddr>().is_err() {
                return bad(
                    format!("{key}.address"),
                    format!("{a:?} is not an IP address (e.g. \"10.0.0.1\")"),
                );
            }
            if h.port == 0 {
                return bad(
                    format!("{key}.port"),
                    "must be a fixed port (the other hosts connect to it)",
                );
            }
        }
    }
    if !multi {
        if !cfg.hosts.is_empty() {
            return bad(
                "hosts",
                "no member names a host (set `host = \"…\"` on the members)",
            );
        }
        return Ok(());
    }
    if cfg.zenoh.routers.is_empty() {
        for h in &used {
            if cfg.hosts.get(h).and_then(|c| c.address.as_ref()).is_none() {
                return bad(
                    format!("hosts.{h}.address"),
                    format!(
                        "members are on hosts {}: set zenoh.routers (a zenohd router) or every host's address (peer to peer)",
                        list(&used)
                    ),
                );
            }
        }
        let mut seen: BTreeMap<String, &str> = BTreeMap::new();
        for h in &used {
            if let Some(ep) = cfg.host_endpoint(h) {
                if let Some(other) = seen.insert(ep.clone(), h) {
                    return bad(
                        format!("hosts.{h}.port"),
                        format!("{ep} is already host {other:?}'s supervisor endpoint"),
                    );
                }
            }
        }
    } else if let Some((name, _)) = cfg.hosts.iter().find(|(_, h)| h.address.is_some()) {
        return bad(
            format!("hosts.{name}.address"),
            "with zenoh.routers every link goes through the router: remove the host addresses (or the routers for peer to peer)",
        );
    }
    Ok(())
}

/// A config that opens anything to other hosts must configure zenoh access control and
/// authentication of zenoh links (user/password, or TLS on every endpoint).
pub(crate) fn validate_security(cfg: &ClusterConfig) -> R {
    for (key, b) in cfg
        .cards
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.bind.as_ref().map(|b| (format!("cards[{i}].bind"), b)))
        .chain(cfg.chain.bind.iter().map(|b| ("chain.bind".to_string(), b)))
        .chain(cfg.emcl.bind.iter().map(|b| ("emcl.bind".to_string(), b)))
    {
        if b.parse::<IpAddr>().is_err() {
            return bad(
                key,
                format!("{b:?} is not an IP address (e.g. \"127.0.0.1\", \"0.0.0.0\")"),
            );
        }
    }
    if let Some(a) = &cfg.zenoh.auth {
        check_name("zenoh.auth.user", &a.user)?;
        if a.password_file.as_os_str().is_empty() {
            return bad("zenoh.auth.password_file", "must name a file");
        }
    }
    if let Some(acl) = &cfg.zenoh.access_control {
        if acl.get("enabled").and_then(toml::Value::as_bool) != Some(true) {
            return bad(
                "zenoh.access_control.enabled",
                "must be true when access control is configured",
            );
        }
    }
    let open = exposures(cfg);
    let Some((key, what)) = open.first() else {
        return Ok(());
    };
    let all_tls = || {
        let eps = cfg
            .zenoh
            .listen
            .iter()
            .chain(&cfg.zenoh.connect)
            .chain(&cfg.zenoh.routers);
        cfg.zenoh.tls.is_some()
            && cfg.hosts.values().all(|h| h.address.is_none())
            && eps
                .filter(|e| endpoint_is_exposed(e))
                .all(|e| e.starts_with("tls/"))
    };
    if cfg.zenoh.auth.is_none() && !all_tls() {
        return bad(
            "zenoh.auth",
            format!(
                "{key} opens {what} to other hosts: set zenoh.auth (user and password_file) or use tls/ endpoints with zenoh.tls, and zenoh.access_control"
            ),
        );
    }
    let listener = cfg
        .zenoh
        .listen
        .iter()
        .find(|e| endpoint_is_exposed(e))
        .map(|e| format!("zenoh.listen {e:?}"))
        .or_else(|| {
            cfg.hosts
                .iter()
                .find(|(_, h)| h.address.as_deref().is_some_and(|a| !is_loopback(a)))
                .map(|(n, _)| format!("hosts.{n}.address"))
        });
    if let (Some(a), Some(l)) = (&cfg.zenoh.auth, listener) {
        if a.dictionary_file.is_none() {
            return bad(
                "zenoh.auth.dictionary_file",
                format!("{l} accepts zenoh links from other hosts: name the file of the users (user:password lines) it accepts"),
            );
        }
    }
    if cfg.zenoh.access_control.is_none() {
        return bad(
            "zenoh.access_control",
            format!(
                "{key} opens {what} to other hosts: configure zenoh's access control (enabled = true, rules, subjects, policies)"
            ),
        );
    }
    Ok(())
}

fn list(v: &[String]) -> String {
    v.join(", ")
}

#[cfg(test)]
#[path = "tests_hosts.rs"]
mod tests;
