//! Cluster configuration (TOML): the file `mcc up --config` reads, the resolved copy the
//! orchestrator writes into the run directory, and what every member parses at start-up.
//!
//! ```toml
//! cluster = "mcc"
//! clock = "paced"             # (default) or "lockstep" or "realtime"
//! rtf = 1.0                   # paced: real-time factor
//! rate_hz = 2258.7
//! [ring]
//! order = ["card0", "station0", "card1", "station1"]
//! sync_master = "card0"
//! [[cards]]
//! name = "card0"
//! number = 0
//! master = 0
//! [[stations]]
//! name = "station0"
//! master = 0
//! ```
//!
//! Parsing never panics: [`ClusterConfig::from_toml_str`] returns a [`ConfigError`] naming the
//! key and the problem.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

mod drives;
mod hosts;
mod security;
mod validate;

pub use drives::{DriveConfig, DriveIo, DriveMotor, EmclConfig, ParamNumberError, MAX_DRIVES};
pub use hosts::{
    endpoint_is_exposed, exposures, is_loopback, tcp_endpoint, HostConfig, Topology, ZenohAuth,
    DEFAULT_HOST_PORT, LOCAL_HOST,
};

pub use security::{SecurityConfig, EXPOSE_KEY, FACTORY_SSH_PASSWORD};
pub use validate::{check_name, MAX_MEMBERS, MAX_RTF};

#[cfg(test)]
mod tests;

/// Default MACRO servo nodes (a station's 8 servo nodes, a card's 8 motors).
pub const DEFAULT_NODES: [u8; 8] = [0, 1, 4, 5, 8, 9, 12, 13];
/// Node carrying the sync packet (I996 bits 16–19).
pub const SYNC_NODE: u8 = 15;
/// Default ring rate: the PMAC servo rate at default clock settings.
pub const DEFAULT_RATE_HZ: f64 = 2258.7;
/// Largest accepted config file, bytes.
pub const MAX_CONFIG_BYTES: usize = 1 << 20;

/// Most cycles that may be in flight around a ring (`in_flight`).
pub const MAX_IN_FLIGHT: u64 = 8;

/// Ring clock mode (architecture §3.3).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ClockMode {
    /// Lockstep semantics (a cycle starts only when the previous cycle's frame has come back
    /// around) paced by the wall clock: the sync master never starts cycle k before
    /// origin + k × period / rtf. Scheduling delays make cycles late (counted), never ring
    /// errors.
    #[default]
    Paced,
    /// Cycle k+1 starts when cycle k's frame has come back around, as fast as the ring allows.
    Lockstep,
    /// The sync master free-runs on the monotonic clock at `rate_hz`; late data is judged as
    /// hardware would judge it.
    Realtime,
}

impl ClockMode {
    /// The config / CLI word for this mode.
    pub fn as_str(self) -> &'static str {
        match self {
            ClockMode::Paced => "paced",
            ClockMode::Realtime => "realtime",
            ClockMode::Lockstep => "lockstep",
        }
    }

    /// Cycles wait for the previous cycle's frame to come back (paced and lockstep): only the
    /// ring's content makes ring errors.
    pub fn is_stepped(self) -> bool {
        matches!(self, ClockMode::Paced | ClockMode::Lockstep)
    }
}

/// The clock words, for messages.
pub const CLOCK_WORDS: &str = "paced, lockstep or realtime";

/// A clock mode name that is none of [`CLOCK_WORDS`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown clock mode {0:?} (expected paced, lockstep or realtime)")]
pub struct UnknownClockMode(pub String);

impl std::str::FromStr for ClockMode {
    type Err = UnknownClockMode;
    fn from_str(s: &str) -> Result<Self, UnknownClockMode> {
        match s {
            "paced" => Ok(ClockMode::Paced),
            "realtime" => Ok(ClockMode::Realtime),
            "lockstep" => Ok(ClockMode::Lockstep),
            other => Err(UnknownClockMode(other.to_string())),
        }
    }
}

/// Zenoh settings of every mcc process (peer mode, scouting off).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZenohConfig {
    /// Endpoints to listen on (e.g. `tcp/127.0.0.1:7447`).
    #[serde(default)]
    pub listen: Vec<String>,
    /// Endpoints to connect to.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Zenoh routers (`zenohd`) of a cluster on several hosts: every process is a client of
    /// them and every link goes through them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub routers: Vec<String>,
    /// User/password authentication of zenoh links.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub auth: Option<ZenohAuth>,
    /// zenoh's access control (`access_control` of zenoh's config, in TOML).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub access_control: Option<toml::Table>,
    /// TLS settings of `tls/` endpoints (`transport.link.tls` of zenoh's config, in TOML;
    /// needs mcc built with the `tls` feature).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tls: Option<toml::Table>,
}

/// `[chain]`: the daisy chain the supervisor serves.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainConfig {
    /// Address its TCP port binds (default 127.0.0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bind: Option<String>,
}

/// The ring: its name and member order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RingConfig {
    /// Ring name used in key expressions (`mcc/<cluster>/ring/<name>/link/<k>`).
    #[serde(default = "default_ring_name")]
    pub name: String,
    /// Member names in ring order; empty = the default order (see [`ClusterConfig::resolve`]).
    #[serde(default)]
    pub order: Vec<String>,
    /// The synchronizing master (a card); empty = the first card in ring order.
    #[serde(default)]
    pub sync_master: String,
    /// Paced and lockstep: ring cycles the sync master lets be in flight around the ring
    /// (1-8, default 1): cycle k starts once cycle k-N is back. More than one lets a long ring
    /// keep up with its rate at the cost of N-1 cycles of extra servo delay on every card.
    #[serde(default = "default_in_flight")]
    pub in_flight: u64,
}

impl Default for RingConfig {
    fn default() -> Self {
        RingConfig {
            name: default_ring_name(),
            order: Vec::new(),
            sync_master: String::new(),
            in_flight: default_in_flight(),
        }
    }
}

fn default_in_flight() -> u64 {
    1
}

/// A startup I-variable override value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum IVarValue {
    /// Integer value.
    Int(i64),
    /// Floating-point value.
    Float(f64),
}

impl IVarValue {
    /// The value as f64.
    pub fn as_f64(self) -> f64 {
        match self {
            IVarValue::Int(i) => i as f64,
            IVarValue::Float(f) => f,
        }
    }
}

/// One card (PMAC controller, ring master).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CardConfig {
    /// Member name (unique in the cluster).
    pub name: String,
    /// Card number on the daisy chain (I0), 0–15.
    pub number: u8,
    /// `pmac2` or `turbo`.
    #[serde(default = "default_profile")]
    pub profile: String,
    /// ASCII terminal TCP port (0 = ephemeral).
    #[serde(default)]
    pub ascii_port: u16,
    /// PMAC Ethernet protocol TCP port (0 = ephemeral).
    #[serde(default)]
    pub pmac_eth_port: u16,
    /// Power cards: raw TCP `gpascii` ("Telnet") port, one command thread per connection
    /// (0 = ephemeral).
    #[serde(default)]
    pub gpascii_port: u16,
    /// Power cards: SSH port (0 = ephemeral).
    #[serde(default)]
    pub ssh_port: u16,
    /// Power cards: the SSH login's user (default `root`, as on a Power PMAC).
    #[serde(default = "default_ssh_user")]
    pub ssh_user: String,
    /// Power cards: the SSH login's password (default `deltatau`, as on a Power PMAC).
    #[serde(default = "default_ssh_password")]
    pub ssh_password: String,
    /// MACRO master number (I996 bits 20–23), 0–15.
    pub master: u8,
    /// Activated MACRO nodes (I996 bits 0–14).
    #[serde(default = "default_nodes")]
    pub nodes: Vec<u8>,
    /// Startup I-variable overrides, e.g. `I1001 = 8`.
    #[serde(default)]
    pub ivars: BTreeMap<String, IVarValue>,
    /// Where SAVE writes and start-up reads the card's state.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_file: Option<PathBuf>,
    /// The host it runs on (clusters on several hosts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
    /// Address its ASCII and Ethernet ports bind (default 127.0.0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bind: Option<String>,
}

/// Station-side ring check (sync-packet watchdog), in ring cycles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StationCheck {
    /// Check period, ring cycles.
    #[serde(default = "default_check_period")]
    pub period: u32,
    /// Sync packets needed per period.
    #[serde(default = "default_min_syncs")]
    pub min_syncs: u32,
    /// Errors per period that raise a fault.
    #[serde(default = "default_max_errors")]
    pub max_errors: u32,
}

impl Default for StationCheck {
    fn default() -> Self {
        StationCheck {
            period: default_check_period(),
            min_syncs: default_min_syncs(),
            max_errors: default_max_errors(),
        }
    }
}

/// One MACRO station (ring slave).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StationConfig {
    /// Member name (unique in the cluster).
    pub name: String,
    /// Master number of the card it serves.
    pub master: u8,
    /// Servo nodes it answers (I996-style activation).
    #[serde(default = "default_nodes")]
    pub nodes: Vec<u8>,
    /// Sync-packet watchdog.
    #[serde(default)]
    pub check: StationCheck,
    /// Simulated plant (amplifier, motor, encoder, switches): defaults in `[stations.plant]`,
    /// per-node overrides in `[stations.plant.nodes.N]`; parsed and checked by the station.
    #[serde(default, skip_serializing_if = "toml::Table::is_empty")]
    pub plant: toml::Table,
    /// The host it runs on (clusters on several hosts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
    /// Where `MS SAVE` writes and start-up reads the station's MI-variables (default
    /// `<run dir>/state/<name>.state`; `mcc down` never removes it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_file: Option<PathBuf>,
}

/// The whole cluster.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClusterConfig {
    /// Cluster name: key-expression namespace and run-directory name.
    #[serde(default = "default_cluster_name")]
    pub cluster: String,
    /// Clock mode.
    #[serde(default)]
    pub clock: ClockMode,
    /// Nominal ring rate, Hz.
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Paced clock: ring time advances at this multiple of wall time (1.0 = real time).
    #[serde(default = "default_rtf")]
    pub rtf: f64,
    /// Paced and lockstep: a member that has passed nothing on for this long has stopped
    /// answering (frozen): the ring is down, the sync master runs cycles on its own clock and
    /// the member downstream of the silence sees loss of light. The only wall-clock judgement
    /// of those clocks; generous (see the README for the longest stall measured under load).
    /// Formerly `lockstep_timeout_ms`.
    #[serde(default = "default_member_timeout", alias = "lockstep_timeout_ms")]
    pub member_timeout_ms: u64,
    /// Realtime: every member runs its tick of cycle k this long after the sync master started
    /// it, so all cards act at the same instant (default: half a period; 0 = tick on arrival).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_delay_us: Option<u32>,
    /// Zenoh endpoints, routers, authentication and access control.
    #[serde(default)]
    pub zenoh: ZenohConfig,
    /// Hosts of a cluster on several machines (`[hosts.NAME]`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub hosts: BTreeMap<String, HostConfig>,
    /// The daisy chain (`[chain]`).
    #[serde(default, skip_serializing_if = "ChainConfig::is_default")]
    pub chain: ChainConfig,
    /// Ring order and sync master.
    #[serde(default)]
    pub ring: RingConfig,
    /// Cards.
    #[serde(default)]
    pub cards: Vec<CardConfig>,
    /// Stations.
    #[serde(default)]
    pub stations: Vec<StationConfig>,
    /// The EMCL bus (`[emcl]`).
    #[serde(default)]
    pub emcl: EmclConfig,
    /// EDB drives on the EMCL bus (`[[drives]]`).
    #[serde(default)]
    pub drives: Vec<DriveConfig>,
    /// Host-port limits (`[host]`: connections, idle and request timeouts).
    #[serde(default)]
    pub host: crate::hostport::HostLimits,
    /// `[security]`: the opt-in to ports without authentication on other hosts' reach.
    #[serde(default, skip_serializing_if = "SecurityConfig::is_default")]
    pub security: SecurityConfig,
}

impl ChainConfig {
    fn is_default(&self) -> bool {
        *self == ChainConfig::default()
    }
}

/// I995/I996 values a member derives from the config (spec §6.2, §6.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RingSettings {
    /// I995: ring configuration bits.
    pub i995: u16,
    /// I996: node activation, sync node, master number.
    pub i996: u32,
}

/// Kind and index of a member in the config lists.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MemberRef<'a> {
    /// A card.
    Card(&'a CardConfig),
    /// A station.
    Station(&'a StationConfig),
}

/// A config that failed to parse or validate.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// TOML syntax or type error (the message carries line, column and key).
    #[error("config: {0}")]
    Parse(String),
    /// A value that parsed but is not acceptable.
    #[error("config: {key}: {problem}")]
    Invalid {
        /// Dotted key path, e.g. `cards[1].nodes`.
        key: String,
        /// What is wrong.
        problem: String,
    },
    /// The file could not be read.
    #[error("config: cannot read {path}: {problem}")]
    Io {
        /// File path.
        path: String,
        /// OS error text.
        problem: String,
    },
}

impl ConfigError {
    pub(crate) fn invalid(key: impl Into<String>, problem: impl Into<String>) -> Self {
        ConfigError::Invalid {
            key: key.into(),
            problem: problem.into(),
        }
    }
}

impl ClusterConfig {
    /// The embedded default: `cards` cards and `stations` stations in one ring, and one EDB
    /// drive `drive0` at address 1 hosted by station0 (standing alone without stations). Card c has
    /// number c and master number c; station s serves card `s % cards` (stations sharing a card
    /// split its nodes 0,1,4,5,8,9,12,13 between them); ring order is each card followed by the
    /// stations it serves; card0 is the synchronizing master.
    pub fn default_cluster(cards: usize, stations: usize) -> Self {
        let cards_n = cards.max(1);
        let card_list: Vec<CardConfig> = (0..cards)
            .map(|c| CardConfig {
                name: format!("card{c}"),
                number: (c % 256) as u8,
                profile: default_profile(),
                ascii_port: 0,
                pmac_eth_port: 0,
                gpascii_port: 0,
                ssh_port: 0,
                ssh_user: default_ssh_user(),
                ssh_password: default_ssh_password(),
                master: (c % 256) as u8,
                nodes: default_nodes(),
                ivars: default_card_ivars(),
                state_file: None,
                host: None,
                bind: None,
            })
            .collect();
        let station_list: Vec<StationConfig> = (0..stations)
            .map(|s| {
                let c = s % cards_n;
                // Stations sharing a card split its 8 servo nodes between them.
                let (j, k) = (s / cards_n, (stations - c).div_ceil(cards_n));
                let n = DEFAULT_NODES.len();
                let nodes = DEFAULT_NODES[(j * n / k).min(n)..((j + 1) * n / k).min(n)].to_vec();
                StationConfig {
                    name: format!("station{s}"),
                    master: (c % 256) as u8,
                    nodes,
                    check: StationCheck::default(),
                    plant: toml::Table::new(),
                    host: None,
                    state_file: None,
                }
            })
            .collect();
        let mut cfg = ClusterConfig {
            cluster: default_cluster_name(),
            clock: ClockMode::default(),
            rate_hz: DEFAULT_RATE_HZ,
            rtf: default_rtf(),
            member_timeout_ms: default_member_timeout(),
            phase_delay_us: None,
            zenoh: ZenohConfig::default(),
            hosts: BTreeMap::new(),
            chain: ChainConfig::default(),
            ring: RingConfig::default(),
            cards: card_list,
            drives: vec![DriveConfig::new(
                "drive0",
                1,
                station_list.first().map(|s| s.name.as_str()),
            )],
            stations: station_list,
            emcl: EmclConfig::default(),
            host: crate::hostport::HostLimits::default(),
            security: SecurityConfig::default(),
        };
        cfg.fill_defaults();
        cfg
    }

    /// Parse, fill implicit defaults (ring order, sync master) and validate.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        if text.len() > MAX_CONFIG_BYTES {
            return Err(ConfigError::Parse(format!(
                "file too large ({} bytes, limit {MAX_CONFIG_BYTES})",
                text.len()
            )));
        }
        let cfg: ClusterConfig =
            toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        cfg.resolve()
    }

    /// Read and parse a file (see [`ClusterConfig::from_toml_str`]); a card `state_file` that
    /// is an existing directory is refused (SAVE could never write it).
    #[allow(clippy::disallowed_methods)] // reading the config file is this function's job
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let io_err = |e: std::io::Error| ConfigError::Io {
            path: path.display().to_string(),
            problem: e.to_string(),
        };
        let meta = std::fs::metadata(path).map_err(io_err)?;
        if meta.len() > MAX_CONFIG_BYTES as u64 {
            return Err(ConfigError::Parse(format!(
                "{}: file too large ({} bytes, limit {MAX_CONFIG_BYTES})",
                path.display(),
                meta.len()
            )));
        }
        let text = std::fs::read_to_string(path).map_err(io_err)?;
        let cfg = Self::from_toml_str(&text).map_err(|e| match e {
            ConfigError::Parse(m) => ConfigError::Parse(format!("{}: {m}", path.display())),
            other => other,
        })?;
        for (i, c) in cfg.cards.iter().enumerate() {
            if let Some(p) = c.state_file.as_ref().filter(|p| p.is_dir()) {
                return Err(ConfigError::invalid(
                    format!("cards[{i}].state_file"),
                    format!("{} is a directory; give the path of a file", p.display()),
                ));
            }
        }
        Ok(cfg)
    }

    /// Fill the implicit defaults, then validate.
    pub fn resolve(mut self) -> Result<Self, ConfigError> {
        self.fill_defaults();
        self.validate()?;
        Ok(self)
    }

    /// The resolved config as TOML (what the orchestrator hands to members).
    pub fn to_toml_string(&self) -> Result<String, ConfigError> {
        toml::to_string(self).map_err(|e| ConfigError::Parse(e.to_string()))
    }

    /// Empty ring order → default order; empty sync master → first card in ring order; a
    /// card's unset ring-check keys → [`DEFAULT_RING_CHECK`] in its profile's keys.
    fn fill_defaults(&mut self) {
        for c in &mut self.cards {
            c.fill_ring_check();
        }
        if self.ring.order.is_empty() {
            let n = self.cards.len().max(1);
            let mut order = Vec::new();
            for (c, card) in self.cards.iter().enumerate() {
                order.push(card.name.clone());
                let served = self.stations.iter().enumerate();
                for (_, st) in served.filter(|(s, _)| s % n == c) {
                    order.push(st.name.clone());
                }
            }
            if self.cards.is_empty() {
                order.extend(self.stations.iter().map(|s| s.name.clone()));
            }
            self.ring.order = order;
        }
        if self.ring.sync_master.is_empty() {
            let first = self.ring.order.iter().find(|m| self.card(m).is_some());
            if let Some(first) = first {
                self.ring.sync_master = first.clone();
            }
        }
    }

    /// Check every rule; the error names the key and the problem.
    pub fn validate(&self) -> Result<(), ConfigError> {
        validate::validate(self)
    }

    /// Realtime phase alignment delay in ns: `phase_delay_us` if set, else half a period.
    pub fn phase_delay_ns(&self) -> u64 {
        match self.phase_delay_us {
            Some(us) => u64::from(us) * 1000,
            None => self.period_ns() / 2,
        }
    }

    /// Wall-clock length of one ring cycle in ns: the nominal period divided by the real-time
    /// factor on the paced clock, the nominal period otherwise.
    pub fn wall_period_ns(&self) -> u64 {
        let p = self.period_ns();
        match self.clock {
            ClockMode::Paced if self.rtf.is_finite() && self.rtf > 0.0 => {
                (p as f64 / self.rtf).round().max(1.0) as u64
            }
            _ => p,
        }
    }

    /// The frozen-member wait ([`ClusterConfig::member_timeout_ms`]).
    pub fn member_timeout(&self) -> std::time::Duration {
        std::time::Duration::from_millis(self.member_timeout_ms.max(1))
    }

    /// How long a card's servo tick may wait for the commit of a synchronized start due in
    /// it. Paced and lockstep: a quarter of the frozen-member wait (the ring waits for the
    /// card, so the wait only makes cycles late; on a loaded machine the orchestrator's commit
    /// can take far longer than a few ms, and giving up would split the start). Realtime: at
    /// most 25 ms, since a longer stall of the tick breaks the free-running ring.
    pub fn sync_start_stall(&self) -> std::time::Duration {
        let ms = if self.clock.is_stepped() {
            (self.member_timeout_ms / 4).max(1)
        } else {
            (self.member_timeout_ms / 2).clamp(1, 25)
        };
        std::time::Duration::from_millis(ms)
    }

    /// Nominal ring period in nanoseconds.
    pub fn period_ns(&self) -> u64 {
        if self.rate_hz > 0.0 && self.rate_hz.is_finite() {
            (1e9 / self.rate_hz).round() as u64
        } else {
            0
        }
    }

    /// The card called `name`.
    pub fn card(&self, name: &str) -> Option<&CardConfig> {
        self.cards.iter().find(|c| c.name == name)
    }

    /// The station called `name`.
    pub fn station(&self, name: &str) -> Option<&StationConfig> {
        self.stations.iter().find(|s| s.name == name)
    }

    /// The member called `name`.
    pub fn member(&self, name: &str) -> Option<MemberRef<'_>> {
        self.card(name)
            .map(MemberRef::Card)
            .or_else(|| self.station(name).map(MemberRef::Station))
    }

    /// Position of `name` in the ring order.
    pub fn position(&self, name: &str) -> Option<usize> {
        self.ring.order.iter().position(|m| m == name)
    }

    /// The member upstream of `name` (the one whose link it subscribes to).
    pub fn upstream(&self, name: &str) -> Option<&str> {
        let n = self.ring.order.len();
        let k = self.position(name)?;
        self.ring.order.get((k + n - 1) % n).map(String::as_str)
    }

    /// Master number of the synchronizing master (the only master whose node-15 packet is the
    /// ring's sync packet; see `mcc_ring::core::CoreConfig::sync_source`).
    pub fn sync_source(&self) -> Option<u8> {
        self.card(&self.ring.sync_master).map(|c| c.master & 0x0F)
    }

    /// I995/I996 for a member (spec §6.2–§6.3): sync master $30; other cards $8090 (master,
    /// phase lock, no master check on node 15); stations $8080. I996 = master<<20 | 15<<16 |
    /// node bits | node 15 on every member but the sync master.
    pub fn ring_settings(&self, name: &str) -> Option<RingSettings> {
        let is_sync = self.ring.sync_master == name;
        let (i995, master, nodes): (u16, u8, &[u8]) = match self.member(name)? {
            MemberRef::Card(c) if is_sync => (0x0030, c.master, &c.nodes),
            MemberRef::Card(c) => (0x8090, c.master, &c.nodes),
            MemberRef::Station(s) => (0x8080, s.master, &s.nodes),
        };
        let mut i996 = (u32::from(master & 0xF) << 20) | (u32::from(SYNC_NODE) << 16);
        for &n in nodes.iter().filter(|&&n| n < 16) {
            i996 |= 1 << n;
        }
        if !is_sync {
            i996 |= 1 << SYNC_NODE;
        }
        Some(RingSettings { i995, i996 })
    }
}

/// The default ring check of every card profile: period 16 servo cycles ≈ 7 ms, 2 errors,
/// 4 sync packets (with the default I8 = 2 that is 6 checks per period, so the sync minimum
/// ≤ period/(I8+1) holds as the spec requires).
pub const DEFAULT_RING_CHECK: [i64; 3] = [16, 2, 4];

/// The config keys of a card's ring check (period, maximum errors, required syncs) for its
/// `profile`: PMAC2 I1001/I1004/I1005 (seed 004); Turbo I80/I81/I82 (the Turbo numbering; seed
/// 000's Turbo-to-Power table maps them to `Macro.TestPeriod`/`TestMaxErrors`/
/// `TestReqdSynchs`); Power the PMAC2 keys, which the card's start-up layer takes as those
/// `Macro` elements (Power `I1001` itself is `Motor[10].PhaseCtrl`).
pub fn ring_check_keys(profile: &str) -> [&'static str; 3] {
    if profile.eq_ignore_ascii_case("turbo") {
        ["I80", "I81", "I82"]
    } else {
        ["I1001", "I1004", "I1005"]
    }
}

impl CardConfig {
    /// The value of start-up I-variable `key` (case-insensitive), if the config sets it.
    pub fn ivar(&self, key: &str) -> Option<f64> {
        self.ivars
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_f64())
    }

    /// The ring check's (period, maximum errors, required syncs) as the config sets them in
    /// the card's profile's keys ([`ring_check_keys`]); unset ones are `None`.
    pub fn ring_check(&self) -> [Option<f64>; 3] {
        ring_check_keys(&self.profile).map(|k| self.ivar(k))
    }

    /// Fill the ring-check keys the config leaves unset with [`DEFAULT_RING_CHECK`] (every
    /// profile starts with its ring check armed).
    fn fill_ring_check(&mut self) {
        for (k, v) in ring_check_keys(&self.profile)
            .into_iter()
            .zip(DEFAULT_RING_CHECK)
        {
            if self.ivar(k).is_none() {
                self.ivars.insert(k.to_string(), IVarValue::Int(v));
            }
        }
    }
}

/// Start-up I-variables of the embedded default cluster's (PMAC2) cards: the ring check armed
/// ([`DEFAULT_RING_CHECK`] in I1001/I1004/I1005).
fn default_card_ivars() -> BTreeMap<String, IVarValue> {
    ring_check_keys("pmac2")
        .into_iter()
        .zip(DEFAULT_RING_CHECK)
        .map(|(k, v)| (k.to_string(), IVarValue::Int(v)))
        .collect()
}

fn default_cluster_name() -> String {
    "mcc".to_string()
}
fn default_ring_name() -> String {
    "0".to_string()
}
fn default_rate() -> f64 {
    DEFAULT_RATE_HZ
}
fn default_rtf() -> f64 {
    1.0
}
/// Default frozen-member wait, ms (see `member_timeout_ms`).
pub const DEFAULT_MEMBER_TIMEOUT_MS: u64 = 10_000;
fn default_member_timeout() -> u64 {
    DEFAULT_MEMBER_TIMEOUT_MS
}
fn default_profile() -> String {
    "pmac2".to_string()
}
fn default_ssh_user() -> String {
    "root".to_string()
}
fn default_ssh_password() -> String {
    FACTORY_SSH_PASSWORD.to_string()
}
fn default_nodes() -> Vec<u8> {
    DEFAULT_NODES.to_vec()
}
fn default_check_period() -> u32 {
    8
}
fn default_min_syncs() -> u32 {
    4
}
fn default_max_errors() -> u32 {
    4
}
