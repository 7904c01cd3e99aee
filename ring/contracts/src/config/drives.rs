//! `[[drives]]` (EDB step-motor drives on the EMCL bus, spec emcl.md) and `[emcl]` (the bus
//! the orchestrator serves): config keys and their structural checks. The drive model (the
//! station crate) checks the parameter overrides against its tables.
//!
//! ```toml
//! [emcl]
//! port = 0            # TCP port of the bus on 127.0.0.1 (0 = any free port)
//! pty = false         # also serve the bus on a pseudo-terminal
//!
//! [[drives]]
//! name = "drive0"
//! address = 1          # RS485 address (factory GP 66), 0-255, unique on the bus
//! station = "station0" # hosting station; omit it and the drive is a process of its own
//! node = 4             # optional: bound to this servo node of its station (step/dir input)
//! # state_file = "…"   # EEPROM image (default: <run dir>/drives/<name>.eeprom)
//! pulse_full_scale = 1000000   # bound: pps at full-scale register 2
//! axis = { "4" = 51200, "12" = 1 }   # factory values of axis parameters
//! globals = { "77" = 0 }             # factory values of bank-0 EEPROM parameters 64-87
//! [drives.motor]
//! full_steps = 200     # AP 202          run_current = 128   # AP 6
//! max_velocity = 51200 # AP 4 (pps)      max_acceleration = 51200  # AP 5 (pps²)
//! encoder_lines = 0    # AP 210          standby_current = 8       # AP 7
//! right_limit = 5120000  left_limit = -5120000   limits = true   # switch positions, µsteps
//! switches = "normally_open"   home_position = 5000  home_width = 1000  index_offset = 0
//! # hard_stop_plus = 6000000   hard_stop_minus = -6000000   load = 500
//! [drives.io]
//! inputs = [0, 0, 0]   analog = 0   loopback = false   enable_in = 1   reset_in = 0
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::validate::check_name;
use super::{ClusterConfig, ConfigError};

/// Most drives in one cluster (one bus: addresses 0-255).
pub const MAX_DRIVES: usize = 64;

/// The EMCL bus served by the orchestrator.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmclConfig {
    /// TCP port on 127.0.0.1 (0 = any free port).
    #[serde(default)]
    pub port: u16,
    /// Also serve a pseudo-terminal.
    #[serde(default)]
    pub pty: bool,
    /// Address its TCP port binds (default 127.0.0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bind: Option<String>,
}

/// Motor, encoder and mechanics of a drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DriveMotor {
    /// Full steps per revolution (factory AP 202).
    pub full_steps: u16,
    /// Run current 0-255 (factory AP 6).
    pub run_current: u8,
    /// Standby current 0-255 (factory AP 7).
    pub standby_current: u8,
    /// Maximum positioning velocity, pps (factory AP 4).
    pub max_velocity: i32,
    /// Maximum acceleration, pps² (factory AP 5).
    pub max_acceleration: i32,
    /// External encoder lines per revolution, 0 = internal encoder (factory AP 210).
    pub encoder_lines: i32,
    /// Limit switches fitted.
    pub limits: bool,
    /// Right (positive) limit switch position, µsteps.
    pub right_limit: i64,
    /// Left (negative) limit switch position, µsteps.
    pub left_limit: i64,
    /// `normally_open` (default) or `normally_closed` contacts.
    pub switches: String,
    /// Home switch window start, µsteps.
    pub home_position: i64,
    /// Home switch window width, µsteps.
    pub home_width: i64,
    /// Encoder index offset within a revolution, µsteps.
    pub index_offset: i64,
    /// Mechanical end stop, positive side, µsteps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hard_stop_plus: Option<i64>,
    /// Mechanical end stop, negative side, µsteps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hard_stop_minus: Option<i64>,
    /// stallGuard2 load reading while running freely, 0-1023.
    pub load: u16,
}

impl Default for DriveMotor {
    fn default() -> Self {
        DriveMotor {
            full_steps: 200,
            run_current: 128,
            standby_current: 8,
            max_velocity: 51_200,
            max_acceleration: 51_200,
            encoder_lines: 0,
            limits: true,
            right_limit: 5_120_000,
            left_limit: -5_120_000,
            switches: "normally_open".into(),
            home_position: 5_000,
            home_width: 1_000,
            index_offset: 0,
            hard_stop_plus: None,
            hard_stop_minus: None,
            load: 500,
        }
    }
}

/// The drive's I/O lines at start-up.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DriveIo {
    /// IN_0..IN_2 levels (0/1).
    pub inputs: Vec<u8>,
    /// Analog IN_0, 0-4095.
    pub analog: u16,
    /// Each IN_k follows OUT_k.
    pub loopback: bool,
    /// ENABLE_IN level (0/1).
    pub enable_in: u8,
    /// RESET_IN level (0/1).
    pub reset_in: u8,
}

impl Default for DriveIo {
    fn default() -> Self {
        DriveIo {
            inputs: vec![0, 0, 0],
            analog: 0,
            loopback: false,
            enable_in: 1,
            reset_in: 0,
        }
    }
}

/// One EDB drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveConfig {
    /// Drive name (unique among members and drives).
    pub name: String,
    /// RS485 address (factory GP 66).
    pub address: u8,
    /// Hosting station; `None`: the drive runs as a process of its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub station: Option<String>,
    /// MACRO servo node of the station the drive is bound to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<u8>,
    /// EEPROM image file (default `<run dir>/drives/<name>.eeprom`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_file: Option<PathBuf>,
    /// Bound mode: pulse rate at full-scale register 2, pps.
    #[serde(default = "default_pulse_full_scale")]
    pub pulse_full_scale: i64,
    /// Motor and mechanics.
    #[serde(default)]
    pub motor: DriveMotor,
    /// I/O lines.
    #[serde(default)]
    pub io: DriveIo,
    /// Factory values of axis parameters, by number.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub axis: BTreeMap<String, i32>,
    /// Factory values of bank-0 EEPROM parameters (64-87), by number.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub globals: BTreeMap<String, i32>,
    /// The host a stand-alone drive runs on (clusters on several hosts; a drive on a station
    /// runs on the station's host).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
}

fn default_pulse_full_scale() -> i64 {
    1_000_000
}

impl DriveConfig {
    /// A drive with default motor and I/O.
    pub fn new(name: &str, address: u8, station: Option<&str>) -> Self {
        DriveConfig {
            name: name.to_string(),
            address,
            station: station.map(str::to_string),
            node: None,
            state_file: None,
            pulse_full_scale: default_pulse_full_scale(),
            motor: DriveMotor::default(),
            io: DriveIo::default(),
            host: None,
            axis: BTreeMap::new(),
            globals: BTreeMap::new(),
        }
    }

    /// The process that hosts it: its station, or its own name.
    pub fn host(&self) -> &str {
        self.station.as_deref().unwrap_or(&self.name)
    }

    /// Parameter overrides as (number, value); the error names the key.
    pub fn overrides(map: &BTreeMap<String, i32>) -> Result<Vec<(u8, i32)>, ParamNumberError> {
        map.iter()
            .map(|(k, v)| {
                k.trim()
                    .parse::<u8>()
                    .map(|n| (n, *v))
                    .map_err(|_| ParamNumberError(k.clone()))
            })
            .collect()
    }
}

/// A drive parameter override whose key is no parameter number 0-255 (the key).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not a parameter number 0-255")]
pub struct ParamNumberError(pub String);

impl ClusterConfig {
    /// The drive called `name`.
    pub fn drive(&self, name: &str) -> Option<&DriveConfig> {
        self.drives.iter().find(|d| d.name == name)
    }

    /// Processes hosting drives (stations with drives, stand-alone drives), each once.
    pub fn drive_hosts(&self) -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for d in &self.drives {
            let h = d.host().to_string();
            if !v.contains(&h) {
                v.push(h);
            }
        }
        v
    }

    /// Drives running as processes of their own.
    pub fn standalone_drives(&self) -> impl Iterator<Item = &DriveConfig> {
        self.drives.iter().filter(|d| d.station.is_none())
    }
}

fn bad(key: impl Into<String>, problem: impl Into<String>) -> Result<(), ConfigError> {
    Err(ConfigError::invalid(key, problem))
}

/// Check `[[drives]]`.
pub(super) fn validate_drives(cfg: &ClusterConfig) -> Result<(), ConfigError> {
    if cfg.drives.len() > MAX_DRIVES {
        return bad(
            "drives",
            format!("{} drives; at most {MAX_DRIVES}", cfg.drives.len()),
        );
    }
    let mut names: BTreeSet<&str> = cfg.cards.iter().map(|c| c.name.as_str()).collect();
    names.extend(cfg.stations.iter().map(|s| s.name.as_str()));
    let mut addresses: BTreeMap<u8, &str> = BTreeMap::new();
    let mut bound: BTreeMap<(&str, u8), &str> = BTreeMap::new();
    let mut files: BTreeMap<&PathBuf, &str> = BTreeMap::new();
    for (i, d) in cfg.drives.iter().enumerate() {
        let key = format!("drives[{i}]");
        check_name(&format!("{key}.name"), &d.name)?;
        if d.name == "orchestrator" {
            return bad(format!("{key}.name"), "\"orchestrator\" is reserved");
        }
        if !names.insert(d.name.as_str()) {
            return bad(
                format!("{key}.name"),
                format!(
                    "duplicate name {:?} (members and drives share one namespace)",
                    d.name
                ),
            );
        }
        if let Some(other) = addresses.insert(d.address, d.name.as_str()) {
            return bad(
                format!("{key}.address"),
                format!(
                    "address {} is already used by {other:?} (two drives would answer at once)",
                    d.address
                ),
            );
        }
        match (&d.station, d.node) {
            (Some(s), node) => {
                let Some(st) = cfg.station(s) else {
                    return bad(
                        format!("{key}.station"),
                        format!("{s:?} is not a station of this config"),
                    );
                };
                if let Some(n) = node {
                    if !st.nodes.contains(&n) {
                        return bad(
                            format!("{key}.node"),
                            format!("node {n} is not one of {s:?}'s nodes {:?}", st.nodes),
                        );
                    }
                    if let Some(other) = bound.insert((s.as_str(), n), d.name.as_str()) {
                        return bad(
                            format!("{key}.node"),
                            format!("node {n} of {s:?} is already bound to {other:?}"),
                        );
                    }
                }
            }
            (None, Some(_)) => {
                return bad(
                    format!("{key}.node"),
                    "a drive bound to a MACRO node needs its station (`station = ...`)",
                )
            }
            (None, None) => {}
        }
        if let Some(f) = &d.state_file {
            if let Some(other) = files.insert(f, d.name.as_str()) {
                return bad(
                    format!("{key}.state_file"),
                    format!("{} is already the state file of {other:?}", f.display()),
                );
            }
        }
        if !(1..=16_777_216).contains(&d.pulse_full_scale) {
            return bad(
                format!("{key}.pulse_full_scale"),
                format!("{} is out of range 1-16777216", d.pulse_full_scale),
            );
        }
        validate_motor(&format!("{key}.motor"), &d.motor)?;
        validate_io(&format!("{key}.io"), &d.io)?;
        for (field, map) in [("axis", &d.axis), ("globals", &d.globals)] {
            if let Err(e) = DriveConfig::overrides(map) {
                return bad(format!("{key}.{field}"), e.to_string());
            }
        }
    }
    Ok(())
}

fn validate_motor(key: &str, m: &DriveMotor) -> Result<(), ConfigError> {
    if m.full_steps == 0 {
        return bad(format!("{key}.full_steps"), "must be 1-65535");
    }
    for (f, v) in [
        ("max_velocity", m.max_velocity),
        ("max_acceleration", m.max_acceleration),
    ] {
        if !(0..=8_388_607).contains(&v) {
            return bad(
                format!("{key}.{f}"),
                format!("{v} is out of range 0-8388607"),
            );
        }
    }
    if m.encoder_lines < 0 {
        return bad(format!("{key}.encoder_lines"), "must be ≥ 0");
    }
    if m.limits && m.left_limit >= m.right_limit {
        return bad(
            format!("{key}.left_limit"),
            format!(
                "{} must be below right_limit {}",
                m.left_limit, m.right_limit
            ),
        );
    }
    if m.switches != "normally_open" && m.switches != "normally_closed" {
        return bad(
            format!("{key}.switches"),
            format!(
                "{:?}: expected \"normally_open\" or \"normally_closed\"",
                m.switches
            ),
        );
    }
    if m.home_width < 0 {
        return bad(format!("{key}.home_width"), "must be ≥ 0");
    }
    if let (Some(lo), Some(hi)) = (m.hard_stop_minus, m.hard_stop_plus) {
        if lo >= hi {
            return bad(
                format!("{key}.hard_stop_minus"),
                format!("{lo} must be below hard_stop_plus {hi}"),
            );
        }
    }
    if m.load > 1023 {
        return bad(
            format!("{key}.load"),
            format!("{} is out of range 0-1023", m.load),
        );
    }
    Ok(())
}

fn validate_io(key: &str, io: &DriveIo) -> Result<(), ConfigError> {
    if io.inputs.len() > 3 {
        return bad(format!("{key}.inputs"), "at most 3 inputs (IN_0..IN_2)");
    }
    if let Some((k, v)) = io.inputs.iter().enumerate().find(|(_, v)| **v > 1) {
        return bad(format!("{key}.inputs[{k}]"), format!("{v} is not 0 or 1"));
    }
    if io.analog > 4095 {
        return bad(
            format!("{key}.analog"),
            format!("{} is out of range 0-4095", io.analog),
        );
    }
    for (f, v) in [("enable_in", io.enable_in), ("reset_in", io.reset_in)] {
        if v > 1 {
            return bad(format!("{key}.{f}"), format!("{v} is not 0 or 1"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(extra: &str) -> Result<ClusterConfig, ConfigError> {
        let base = r#"
[[cards]]
name = "card0"
number = 0
master = 0
[[stations]]
name = "station0"
master = 0
"#;
        ClusterConfig::from_toml_str(&format!("{base}{extra}"))
    }

    fn err(extra: &str) -> String {
        parse(extra).unwrap_err().to_string()
    }

    #[test]
    fn default_cluster_has_drive0_on_station0() {
        let c = ClusterConfig::default_cluster(2, 2);
        assert_eq!(c.drives.len(), 1);
        let d = &c.drives[0];
        assert_eq!((d.name.as_str(), d.address), ("drive0", 1));
        assert_eq!(d.station.as_deref(), Some("station0"));
        assert_eq!(c.drive_hosts(), vec!["station0".to_string()]);
        let c0 = ClusterConfig::default_cluster(1, 0);
        assert_eq!(
            c0.drives[0].station, None,
            "no station: drive0 stands alone"
        );
        assert_eq!(c0.standalone_drives().count(), 1);
        // The resolved config survives the trip through the run directory.
        let text = c.to_toml_string().unwrap();
        assert_eq!(ClusterConfig::from_toml_str(&text).unwrap(), c);
    }

    #[test]
    fn drives_parse_with_motor_io_and_overrides() {
        let c = parse(
            r#"
[emcl]
port = 4711
pty = true
[[drives]]
name = "x"
address = 7
station = "station0"
node = 4
axis = { "4" = 1000, "12" = 3 }
globals = { "77" = 1 }
[drives.motor]
full_steps = 400
hard_stop_plus = 100
[drives.io]
inputs = [1, 0, 1]
analog = 4095
[[drives]]
name = "solo"
address = 8
"#,
        )
        .unwrap();
        assert_eq!(
            c.emcl,
            EmclConfig {
                port: 4711,
                pty: true,
                bind: None
            }
        );
        let x = c.drive("x").unwrap();
        assert_eq!(x.node, Some(4));
        assert_eq!(x.motor.full_steps, 400);
        assert_eq!(x.motor.hard_stop_plus, Some(100));
        assert_eq!(x.io.inputs, vec![1, 0, 1]);
        assert_eq!(
            DriveConfig::overrides(&x.axis).unwrap(),
            vec![(12, 3), (4, 1000)]
        );
        assert_eq!(
            c.drive_hosts(),
            vec!["station0".to_string(), "solo".to_string()]
        );
    }

    #[test]
    fn bad_drives_are_refused_naming_the_key() {
        let cases = [
            ("[[drives]]\nname = \"d\"\naddress = 1\nstation = \"nope\"", "drives[0].station"),
            ("[[drives]]\nname = \"station0\"\naddress = 1", "duplicate name"),
            (
                "[[drives]]\nname = \"a\"\naddress = 3\n[[drives]]\nname = \"b\"\naddress = 3",
                "drives[1].address: address 3 is already used by \"a\"",
            ),
            ("[[drives]]\nname = \"a\"\naddress = 1\nnode = 0", "needs its station"),
            (
                "[[drives]]\nname = \"a\"\naddress = 1\nstation = \"station0\"\nnode = 2",
                "node 2 is not one of",
            ),
            (
                "[[drives]]\nname = \"a\"\naddress = 1\nstation = \"station0\"\nnode = 0\n[[drives]]\nname = \"b\"\naddress = 2\nstation = \"station0\"\nnode = 0",
                "already bound to \"a\"",
            ),
            ("[[drives]]\nname = \"a\"\naddress = 300", "address"),
            ("[[drives]]\nname = \"a\"\naddress = 1\naxis = { x = 1 }", "drives[0].axis"),
            ("[[drives]]\nname = \"a\"\naddress = 1\n[drives.motor]\nswitches = \"nc\"", "switches"),
            ("[[drives]]\nname = \"a\"\naddress = 1\n[drives.io]\ninputs = [2]", "inputs[0]"),
            ("[[drives]]\nname = \"a\"\naddress = 1\n[drives.motor]\nspeed = 2", "unknown field"),
            ("[[drives]]\nname = \"a\"\naddress = 1\npulse_full_scale = 0", "pulse_full_scale"),
            ("[ring]\norder = [\"card0\", \"station0\", \"a\"]\n[[drives]]\nname = \"a\"\naddress = 1", "is a drive"),
        ];
        for (toml, want) in cases {
            let e = err(toml);
            assert!(e.contains(want), "{toml}\n→ {e}");
        }
    }
}
