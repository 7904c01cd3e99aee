//! `[security]` and the checks of host ports that have no authentication of their own: a
//! card's ASCII / PMAC Ethernet / `gpascii` ports, the daisy chain and the EMCL bus (as on
//! the hardware, anyone who reaches them commands the card or drive; zenoh's authentication
//! protects none of them), and a Power card's SSH login.
//!
//! ```toml
//! [security]
//! expose_unauthenticated = true   # allow cards[i].bind / chain.bind / emcl.bind off loopback
//! ```

use serde::{Deserialize, Serialize};

use super::hosts::is_loopback;
use super::{ClusterConfig, ConfigError};

/// The factory password of a Power PMAC's `root` login (the default `ssh_password`).
pub const FACTORY_SSH_PASSWORD: &str = "deltatau";

/// The key that opts in to unauthenticated ports on other hosts' reach.
pub const EXPOSE_KEY: &str = "security.expose_unauthenticated";

/// `[security]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SecurityConfig {
    /// Card host ports, the daisy chain and the EMCL bus may bind an address other hosts
    /// reach (`cards[i].bind`, `[chain] bind`, `[emcl] bind`): they have no authentication.
    #[serde(default)]
    pub expose_unauthenticated: bool,
}

impl SecurityConfig {
    pub(crate) fn is_default(&self) -> bool {
        *self == SecurityConfig::default()
    }
}

type R = Result<(), ConfigError>;

/// A Power card whose SSH other hosts reach keeps no factory password; no port without
/// authentication is reachable from other hosts unless `[security] expose_unauthenticated`.
pub(crate) fn validate_unauthenticated(cfg: &ClusterConfig) -> R {
    let exposed = |b: &Option<String>| b.as_deref().filter(|b| !is_loopback(b)).map(str::to_string);
    for (i, c) in cfg.cards.iter().enumerate() {
        let Some(b) = exposed(&c.bind) else {
            continue;
        };
        if c.profile == "power" && c.ssh_password == FACTORY_SSH_PASSWORD {
            return Err(ConfigError::invalid(
                format!("cards[{i}].ssh_password"),
                format!(
                    "cards[{i}].bind opens {}'s SSH on {b} to other hosts: set a password other than the factory default {FACTORY_SSH_PASSWORD:?}",
                    c.name
                ),
            ));
        }
    }
    if cfg.security.expose_unauthenticated {
        return Ok(());
    }
    let mut open = Vec::new();
    for (i, c) in cfg.cards.iter().enumerate() {
        let ports = if c.profile == "power" {
            "gpascii port"
        } else {
            "ASCII and PMAC Ethernet ports"
        };
        if let Some(b) = exposed(&c.bind) {
            open.push((
                format!("cards[{i}].bind"),
                format!("{}'s {ports}", c.name),
                b,
            ));
        }
    }
    if let Some(b) = exposed(&cfg.chain.bind) {
        open.push(("chain.bind".into(), "the daisy chain".into(), b));
    }
    if let Some(b) = exposed(&cfg.emcl.bind) {
        open.push(("emcl.bind".into(), "the EMCL bus".into(), b));
    }
    match open.into_iter().next() {
        Some((key, what, b)) => Err(ConfigError::invalid(
            key,
            format!(
                "opens {what} on {b} to other hosts, with no authentication (as on the hardware; zenoh's does not cover it): bind 127.0.0.1, or set [security] expose_unauthenticated = true ({EXPOSE_KEY}) to open it anyway"
            ),
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
#[path = "tests_security.rs"]
mod tests;
