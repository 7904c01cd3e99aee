//! The rules a [`ClusterConfig`] must satisfy; each error names the key and the problem.

use std::collections::{BTreeMap, BTreeSet};

use super::{CardConfig, ClockMode, ClusterConfig, ConfigError, SYNC_NODE};

/// Most members one ring may hold.
pub const MAX_MEMBERS: usize = 64;
/// Highest accepted ring rate, Hz.
pub(super) const MAX_RATE_HZ: f64 = 1_000_000.0;
/// Largest real-time factor of the paced clock.
pub const MAX_RTF: f64 = 1000.0;
/// Highest I-variable number accepted in `ivars` (Turbo numbering).
pub(super) const MAX_IVAR: u32 = 8191;
const MAX_NAME: usize = 64;

type R = Result<(), ConfigError>;

fn bad(key: impl Into<String>, problem: impl Into<String>) -> R {
    Err(ConfigError::invalid(key, problem))
}

/// Names go into key expressions and file names: `[A-Za-z0-9_-]`, 1–64 chars.
pub fn check_name(key: &str, name: &str) -> R {
    if name.is_empty() {
        return bad(key, "must not be empty");
    }
    if name.len() > MAX_NAME {
        return bad(
            key,
            format!("{name:?} is longer than {MAX_NAME} characters"),
        );
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_' || *c == '-'))
    {
        return bad(
            key,
            format!("{name:?} contains {c:?} (allowed: letters, digits, '_' and '-')"),
        );
    }
    Ok(())
}

fn check_nodes(key: &str, nodes: &[u8]) -> R {
    let mut seen = BTreeSet::new();
    for (i, &n) in nodes.iter().enumerate() {
        if n > 15 {
            return bad(
                format!("{key}[{i}]"),
                format!("node {n} is out of range 0-14"),
            );
        }
        if n == SYNC_NODE {
            return bad(
                format!("{key}[{i}]"),
                "node 15 is reserved for the sync packet (allowed 0-14)",
            );
        }
        if !seen.insert(n) {
            return bad(format!("{key}[{i}]"), format!("node {n} is listed twice"));
        }
    }
    Ok(())
}

/// Check every rule of the config format.
pub(super) fn validate(cfg: &ClusterConfig) -> R {
    check_name("cluster", &cfg.cluster)?;
    check_name("ring.name", &cfg.ring.name)?;
    if !cfg.rate_hz.is_finite() || cfg.rate_hz <= 0.0 || cfg.rate_hz > MAX_RATE_HZ {
        return bad(
            "rate_hz",
            format!("{} is not a rate in (0, {MAX_RATE_HZ}] Hz", cfg.rate_hz),
        );
    }
    validate_clock(cfg)?;
    if let Some((key, problem)) = cfg.host.problem() {
        return bad(key, problem);
    }
    for (list, eps) in [
        ("listen", &cfg.zenoh.listen),
        ("connect", &cfg.zenoh.connect),
        ("routers", &cfg.zenoh.routers),
    ] {
        for (i, ep) in eps.iter().enumerate() {
            if !ep.contains('/') || ep.starts_with('/') || ep.ends_with('/') {
                return bad(
                    format!("zenoh.{list}[{i}]"),
                    format!("{ep:?} is not a zenoh endpoint like \"tcp/127.0.0.1:7447\""),
                );
            }
        }
    }
    if cfg.cards.is_empty() {
        return bad(
            "cards",
            "a ring needs at least one card (the synchronizing master)",
        );
    }
    if cfg.cards.len() + cfg.stations.len() > MAX_MEMBERS {
        return bad(
            "stations",
            format!(
                "{} members in total; at most {MAX_MEMBERS}",
                cfg.cards.len() + cfg.stations.len()
            ),
        );
    }
    validate_cards(cfg)?;
    validate_stations(cfg)?;
    validate_ring(cfg)?;
    super::drives::validate_drives(cfg)?;
    super::hosts::validate_hosts(cfg)?;
    super::hosts::validate_security(cfg)?;
    super::security::validate_unauthenticated(cfg)
}

/// `rtf` and `member_timeout_ms` (the clock keys; `clock` itself is checked by the parser).
fn validate_clock(cfg: &ClusterConfig) -> R {
    let rtf = cfg.rtf;
    if !rtf.is_finite() || rtf <= 0.0 {
        return bad(
            "rtf",
            format!("{rtf} is not a real-time factor (a number > 0, e.g. 1.0)"),
        );
    }
    if rtf > MAX_RTF {
        return bad(
            "rtf",
            format!("{rtf} is larger than the largest real-time factor {MAX_RTF}"),
        );
    }
    if rtf != 1.0 && cfg.clock != ClockMode::Paced {
        return bad(
            "rtf",
            format!(
                "{rtf}: only the paced clock runs at a real-time factor (clock is {})",
                cfg.clock.as_str()
            ),
        );
    }
    if cfg.rate_hz * rtf > MAX_RATE_HZ {
        return bad(
            "rtf",
            format!(
                "{rtf} at {} Hz asks for {} cycles per second of wall time (at most {MAX_RATE_HZ})",
                cfg.rate_hz,
                cfg.rate_hz * rtf
            ),
        );
    }
    if let Some(us) = cfg.phase_delay_us {
        let period = cfg.period_ns();
        if u64::from(us) * 1000 >= period {
            return bad(
                "phase_delay_us",
                format!(
                    "{us} µs is not shorter than one ring period ({:.1} µs at {} Hz): a member \
                     would run cycle k's tick after cycle k+1 began",
                    period as f64 / 1e3,
                    cfg.rate_hz
                ),
            );
        }
    }
    let t = cfg.member_timeout_ms;
    if t == 0 || t > 60_000 {
        return bad("member_timeout_ms", format!("{t} is out of range 1-60000"));
    }
    let wall = cfg.wall_period_ns();
    if t.saturating_mul(1_000_000) < wall {
        return bad(
            "member_timeout_ms",
            format!(
                "{t} ms is shorter than one ring period ({:.3} ms of wall time at {} Hz, rtf {rtf})",
                wall as f64 / 1e6,
                cfg.rate_hz
            ),
        );
    }
    Ok(())
}

fn validate_cards(cfg: &ClusterConfig) -> R {
    let mut names = BTreeSet::new();
    let mut numbers = BTreeMap::new();
    let mut masters = BTreeMap::new();
    let mut ports = BTreeMap::new();
    for (i, c) in cfg.cards.iter().enumerate() {
        let key = format!("cards[{i}]");
        check_name(&format!("{key}.name"), &c.name)?;
        if c.name == "orchestrator" {
            return bad(format!("{key}.name"), "\"orchestrator\" is reserved");
        }
        if !names.insert(c.name.as_str()) {
            return bad(
                format!("{key}.name"),
                format!("duplicate member name {:?}", c.name),
            );
        }
        if c.number > 15 {
            return bad(
                format!("{key}.number"),
                format!("{} is out of range 0-15", c.number),
            );
        }
        if let Some(other) = numbers.insert(c.number, c.name.as_str()) {
            return bad(
                format!("{key}.number"),
                format!("card number {} is already used by {other:?}", c.number),
            );
        }
        if c.master > 15 {
            return bad(
                format!("{key}.master"),
                format!("{} is out of range 0-15", c.master),
            );
        }
        if let Some(other) = masters.insert(c.master, c.name.as_str()) {
            return bad(
                format!("{key}.master"),
                format!("master number {} is already used by {other:?}", c.master),
            );
        }
        if !matches!(c.profile.as_str(), "pmac2" | "turbo" | "power") {
            return bad(
                format!("{key}.profile"),
                format!(
                    "unknown profile {:?} (expected pmac2, turbo or power)",
                    c.profile
                ),
            );
        }
        check_power_host(&key, c)?;
        for (field, port) in [
            ("ascii_port", c.ascii_port),
            ("pmac_eth_port", c.pmac_eth_port),
            ("gpascii_port", c.gpascii_port),
            ("ssh_port", c.ssh_port),
        ] {
            if port == 0 {
                continue;
            }
            if let Some(other) = ports.insert(port, format!("{}.{field}", c.name)) {
                return bad(
                    format!("{key}.{field}"),
                    format!("port {port} is already used by {other}"),
                );
            }
        }
        check_nodes(&format!("{key}.nodes"), &c.nodes)?;
        if let Some(p) = &c.state_file {
            let text = p.to_string_lossy();
            if text.is_empty() || text.ends_with('/') || p.ends_with(".") || p.ends_with("..") {
                return bad(
                    format!("{key}.state_file"),
                    format!("{text:?} names a directory; give the path of a file"),
                );
            }
        }
        for (name, value) in &c.ivars {
            let num = name
                .strip_prefix(['I', 'i'])
                .and_then(|n| n.parse::<u32>().ok())
                .filter(|n| *n <= MAX_IVAR);
            if num.is_none() {
                return bad(
                    format!("{key}.ivars.{name}"),
                    format!("not an I-variable name I0-I{MAX_IVAR}"),
                );
            }
            if !value.as_f64().is_finite() {
                return bad(
                    format!("{key}.ivars.{name}"),
                    "value is not a finite number",
                );
            }
        }
    }
    Ok(())
}

fn validate_stations(cfg: &ClusterConfig) -> R {
    let mut names: BTreeSet<&str> = cfg.cards.iter().map(|c| c.name.as_str()).collect();
    let mut served: BTreeMap<(u8, u8), &str> = BTreeMap::new();
    for (i, s) in cfg.stations.iter().enumerate() {
        let key = format!("stations[{i}]");
        check_name(&format!("{key}.name"), &s.name)?;
        if s.name == "orchestrator" {
            return bad(format!("{key}.name"), "\"orchestrator\" is reserved");
        }
        if !names.insert(s.name.as_str()) {
            return bad(
                format!("{key}.name"),
                format!("duplicate member name {:?}", s.name),
            );
        }
        if !cfg.cards.iter().any(|c| c.master == s.master) {
            return bad(
                format!("{key}.master"),
                format!("no card has master number {}", s.master),
            );
        }
        check_nodes(&format!("{key}.nodes"), &s.nodes)?;
        for (j, &n) in s.nodes.iter().enumerate() {
            if let Some(other) = served.insert((s.master, n), s.name.as_str()) {
                return bad(
                    format!("{key}.nodes[{j}]"),
                    format!(
                        "node {n} of master {} is already served by {other:?}",
                        s.master
                    ),
                );
            }
        }
        let ck = &s.check;
        if ck.period == 0 {
            return bad(format!("{key}.check.period"), "must be at least 1 cycle");
        }
        if ck.min_syncs > ck.period {
            return bad(
                format!("{key}.check.min_syncs"),
                format!(
                    "{} is more than the check period {} (the check would always fail)",
                    ck.min_syncs, ck.period
                ),
            );
        }
        if ck.max_errors == 0 {
            return bad(format!("{key}.check.max_errors"), "must be at least 1");
        }
    }
    Ok(())
}

fn validate_ring(cfg: &ClusterConfig) -> R {
    let mut seen = BTreeSet::new();
    for (i, m) in cfg.ring.order.iter().enumerate() {
        if cfg.member(m).is_none() && cfg.drive(m).is_some() {
            return bad(
                format!("ring.order[{i}]"),
                format!("{m:?} is a drive: drives are on the EMCL bus, not on the ring"),
            );
        }
        if cfg.member(m).is_none() {
            return bad(
                format!("ring.order[{i}]"),
                format!("{m:?} is not a card or station of this config"),
            );
        }
        if !seen.insert(m.as_str()) {
            return bad(format!("ring.order[{i}]"), format!("{m:?} is listed twice"));
        }
    }
    let all = cfg.cards.iter().map(|c| &c.name);
    if let Some(missing) = all
        .chain(cfg.stations.iter().map(|s| &s.name))
        .find(|n| !seen.contains(n.as_str()))
    {
        return bad(
            "ring.order",
            format!("member {missing:?} is missing from the ring order"),
        );
    }
    if !(1..=super::MAX_IN_FLIGHT).contains(&cfg.ring.in_flight) {
        return bad(
            "ring.in_flight",
            format!(
                "{} cycles in flight: must be 1 to {}",
                cfg.ring.in_flight,
                super::MAX_IN_FLIGHT
            ),
        );
    }
    let sm = &cfg.ring.sync_master;
    if cfg.card(sm).is_none() {
        return bad(
            "ring.sync_master",
            format!(
                "{sm:?} is not a card of this config (the synchronizing master must be a card)"
            ),
        );
    }
    Ok(())
}

/// Longest SSH user name / password a config may give.
const MAX_SSH_CREDENTIAL: usize = 128;

/// The Power card's host keys: `gpascii_port`/`ssh_port` only on a `power` card, a usable
/// SSH login (non-empty user, printable, bounded).
fn check_power_host(key: &str, c: &CardConfig) -> Result<(), ConfigError> {
    if c.profile != "power" {
        for (field, port) in [("gpascii_port", c.gpascii_port), ("ssh_port", c.ssh_port)] {
            if port != 0 {
                return bad(
                    format!("{key}.{field}"),
                    format!(
                        "only a card with profile = \"power\" has this port ({:?} has the \
                         ascii_port and pmac_eth_port)",
                        c.profile
                    ),
                );
            }
        }
    }
    for (field, v) in [("ssh_user", &c.ssh_user), ("ssh_password", &c.ssh_password)] {
        if v.is_empty() && field == "ssh_user" {
            return bad(format!("{key}.{field}"), "must not be empty".to_string());
        }
        if v.len() > MAX_SSH_CREDENTIAL {
            return bad(
                format!("{key}.{field}"),
                format!("longer than {MAX_SSH_CREDENTIAL} bytes"),
            );
        }
        if v.chars().any(char::is_control) {
            return bad(
                format!("{key}.{field}"),
                "must not contain control characters".to_string(),
            );
        }
    }
    if c.ssh_user.chars().any(char::is_whitespace) {
        return bad(
            format!("{key}.ssh_user"),
            format!("{:?} contains white space", c.ssh_user),
        );
    }
    Ok(())
}
