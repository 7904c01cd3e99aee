//! Station plant configuration: amplifier, motor, encoder and switch parameters per servo
//! node, parsed from the station's `plant` TOML table.
//!
//! ```toml
//! [[stations]]
//! name = "station0"
//! master = 0
//! [stations.plant]            # defaults for every servo node of this station
//! mode = "torque"
//! coulomb = 0.0002
//! [stations.plant.nodes.4]    # overrides for node 4 only
//! amp_fault = true
//! plus_limit = 50000
//! ```
//!
//! Every key is optional; unknown keys are rejected with a message naming them. Units: SI
//! (N·m, kg·m², rad/s) for the mechanics, encoder counts for switch positions.
//!
//! Defaults are chosen so the PMAC default gains (Ix30 = 2000, Ix31 = Ix32 = 1280, Ix08 = Ix09
//! = 96) close a stable loop at the default 2258.7 Hz servo rate: one DAC bit gives
//! 4 N·m/32768 / 1.25e-5 kg·m² · 131072/2π counts/rev · T² ≈ 0.040 counts/cycle² of
//! acceleration, so the default PD loop has ωn ≈ 0.12 rad/cycle (≈ 43 Hz) and ζ ≈ 0.6 without
//! delay; it stays stable with up to 5 servo cycles between the encoder sample and the command
//! taking effect (the ring adds 2-3). Coulomb friction 2e-4 N·m is 1.6 DAC bits, i.e. a static
//! deadband of ≈ 4.5 counts with the default Ix30 (inside the default Ix28 = 10 counts).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::plant::amplifier::{AmpMode, AmpParams};
use crate::plant::encoder::EncoderParams;
use crate::plant::flags::Switches;
use crate::plant::motor::MotorParams;

/// Default differential travel of the limit and home switches, counts: a real switch releases
/// a little further out than it operates, so a move that ends back towards a switch it has just
/// left — a servo's undershoot, some 20 counts after a fast jog of the pmac-motorhome suite —
/// does not trip it again. 100 counts is well inside a mechanical switch's differential travel
/// at the default 131072 counts per revolution.
pub const SWITCH_HYSTERESIS: f64 = 100.0;

/// Parameters of one servo node's plant (every field has a default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NodePlantConfig {
    /// Amplifier mode: "torque" (default), "velocity" or "pulse".
    pub mode: AmpMode,
    /// Torque at full-scale register-0 command, N·m (default 4.0).
    pub torque_full_scale: f64,
    /// Amplifier output limit, N·m (default 4.0).
    pub torque_limit: f64,
    /// Velocity mode: speed at full-scale command, rad/s (default 314.16 = 3000 rpm).
    pub velocity_full_scale: f64,
    /// Velocity mode: velocity-loop gain, N·m per rad/s (default 0.0125: a 1 ms
    /// velocity-loop time constant with the default inertia).
    pub velocity_gain: f64,
    /// Pulse mode: rate at full-scale register 2, counts/s (default 1,000,000).
    pub pulse_full_scale: f64,
    /// Configured amplifier fault: the amplifier faults whenever enabled (default false).
    pub amp_fault: bool,
    /// FAULT flag polarity: false = low-true line, 0 = fault (default, matches Ix25 bit 23 = 0).
    pub fault_high_true: bool,
    /// Rotor + load inertia, kg·m² (default 1.25e-5).
    pub inertia: f64,
    /// Viscous friction, N·m·s/rad (default 2e-5).
    pub viscous: f64,
    /// Coulomb friction, N·m (default 2e-4).
    pub coulomb: f64,
    /// Constant load torque, N·m, signed (default 0).
    pub load_torque: f64,
    /// Encoder counts per revolution after ×4 decoding (default 131072).
    pub counts_per_rev: f64,
    /// Report sub-count position in the 5 fractional bits of register 0 (default true).
    pub sub_count: bool,
    /// Home window start, counts (default 5000).
    pub home_position: f64,
    /// Home window width, counts (default 1000).
    pub home_width: f64,
    /// Positive limit switch, counts (default 1,000,000; `limits = false` removes both).
    pub plus_limit: f64,
    /// Negative limit switch, counts (default −1,000,000).
    pub minus_limit: f64,
    /// Limit switches fitted (default true).
    pub limits: bool,
    /// Differential travel of the limit and home switches, counts (default [`SWITCH_HYSTERESIS`]): a switch
    /// turns on at its configured position and off only this far back outside it.
    pub switch_hysteresis: f64,
    /// User flag level at start-up (default false).
    pub user_flag: bool,
    /// Longest integration sub-step, seconds (default 50e-6: 9 sub-steps at 2258.7 Hz).
    pub max_substep: f64,
    /// Flag capture control (MI912, the station's I9n2): which edge of the capture flag
    /// triggers the card's homing and move-until-trigger: 2/3/6/7 rising edge (the flag as
    /// it is), 10/11/14/15 falling edge (the flag inverted) (default 2). The station has no
    /// index channel: the index-only and software settings are refused.
    pub capture_control: u8,
    /// Flag capture select (MI913, the station's I9n3): 0 home switch, 1 +limit, 2 −limit,
    /// 3 user flag (default 0). The selected flag, edge applied, is reported in the HOME bit.
    pub capture_flag: u8,
    /// Output mode select (MI916, the station's I9n6): 0 PWM A/B + PWM C, 1 DAC + PWM,
    /// 2 PWM + PFM, 3 DAC + PFM (default 0). The simulated amplifier takes the node's
    /// command register whatever the output format, so the mode changes no behaviour.
    pub output_mode: u8,
    /// Mechanical end stops fitted (default false): a hard stop for hard-stop homing.
    pub hard_stops: bool,
    /// Positive end stop, counts (default 1,010,000: past the default +limit).
    pub plus_stop: f64,
    /// Negative end stop, counts (default −1,010,000).
    pub minus_stop: f64,
    /// End-stop stiffness, N·m per count of penetration (default 0.05: 80 counts at the
    /// default 4 N·m torque limit); critically damped. At most inertia/max_substep² per
    /// radian (the contact is integrated explicitly per sub-step).
    pub stop_stiffness: f64,
}

impl Default for NodePlantConfig {
    fn default() -> Self {
        NodePlantConfig {
            mode: AmpMode::Torque,
            torque_full_scale: 4.0,
            torque_limit: 4.0,
            velocity_full_scale: 314.159_265,
            velocity_gain: 0.0125,
            pulse_full_scale: 1_000_000.0,
            amp_fault: false,
            fault_high_true: false,
            inertia: 1.25e-5,
            viscous: 2e-5,
            coulomb: 2e-4,
            load_torque: 0.0,
            counts_per_rev: 131_072.0,
            sub_count: true,
            home_position: 5_000.0,
            home_width: 1_000.0,
            plus_limit: 1_000_000.0,
            minus_limit: -1_000_000.0,
            limits: true,
            switch_hysteresis: SWITCH_HYSTERESIS,
            user_flag: false,
            max_substep: 50e-6,
            capture_control: 2,
            capture_flag: 0,
            output_mode: 0,
            hard_stops: false,
            plus_stop: 1_010_000.0,
            minus_stop: -1_010_000.0,
            stop_stiffness: 0.05,
        }
    }
}

impl NodePlantConfig {
    /// Check ranges; the error names the key and the problem.
    pub fn validate(&self) -> Result<(), PlantError> {
        let finite = [
            ("torque_full_scale", self.torque_full_scale),
            ("torque_limit", self.torque_limit),
            ("velocity_full_scale", self.velocity_full_scale),
            ("velocity_gain", self.velocity_gain),
            ("pulse_full_scale", self.pulse_full_scale),
            ("inertia", self.inertia),
            ("viscous", self.viscous),
            ("coulomb", self.coulomb),
            ("load_torque", self.load_torque),
            ("counts_per_rev", self.counts_per_rev),
            ("home_position", self.home_position),
            ("home_width", self.home_width),
            ("plus_limit", self.plus_limit),
            ("minus_limit", self.minus_limit),
            ("switch_hysteresis", self.switch_hysteresis),
            ("max_substep", self.max_substep),
            ("plus_stop", self.plus_stop),
            ("minus_stop", self.minus_stop),
            ("stop_stiffness", self.stop_stiffness),
        ];
        for (k, v) in finite {
            if !v.is_finite() {
                return Err(PlantError::key(
                    k,
                    format!("must be a finite number, got {v}"),
                ));
            }
        }
        let positive = [
            ("inertia", self.inertia),
            ("counts_per_rev", self.counts_per_rev),
            ("max_substep", self.max_substep),
        ];
        for (k, v) in positive {
            if v <= 0.0 {
                return Err(PlantError::key(k, format!("must be > 0, got {v}")));
            }
        }
        let non_negative = [
            ("torque_limit", self.torque_limit),
            ("velocity_gain", self.velocity_gain),
            ("viscous", self.viscous),
            ("coulomb", self.coulomb),
            ("home_width", self.home_width),
            ("switch_hysteresis", self.switch_hysteresis),
            ("stop_stiffness", self.stop_stiffness),
        ];
        for (k, v) in non_negative {
            if v < 0.0 {
                return Err(PlantError::key(k, format!("must be ≥ 0, got {v}")));
            }
        }
        if self.limits && self.minus_limit >= self.plus_limit {
            return Err(PlantError::key(
                "minus_limit",
                format!(
                    "must be below plus_limit ({} ≥ {})",
                    self.minus_limit, self.plus_limit
                ),
            ));
        }
        if self.hard_stops && self.minus_stop >= self.plus_stop {
            return Err(PlantError::key(
                "minus_stop",
                format!(
                    "must be below plus_stop ({} ≥ {})",
                    self.minus_stop, self.plus_stop
                ),
            ));
        }
        let k_rad = self.stop_stiffness * self.counts_per_rev / std::f64::consts::TAU;
        let k_max = self.inertia / (self.max_substep * self.max_substep);
        if self.hard_stops && k_rad > k_max {
            return Err(PlantError::key(
                "stop_stiffness",
                format!(
                    "at most {:.6} N·m per count with this inertia and max_substep, got {}",
                    k_max / self.counts_per_rev * std::f64::consts::TAU,
                    self.stop_stiffness
                ),
            ));
        }
        if !matches!(self.capture_control, 2 | 3 | 6 | 7 | 10 | 11 | 14 | 15) {
            return Err(PlantError::key(
                "capture_control",
                format!(
                    "one of 2, 3, 6, 7, 10, 11, 14, 15 (a flag edge), got {}",
                    self.capture_control
                ),
            ));
        }
        if self.capture_flag > 3 {
            return Err(PlantError::key(
                "capture_flag",
                format!(
                    "0 (home), 1 (+limit), 2 (-limit) or 3 (user), got {}",
                    self.capture_flag
                ),
            ));
        }
        if self.output_mode > 3 {
            return Err(PlantError::key(
                "output_mode",
                format!("0, 1, 2 or 3 (MI916), got {}", self.output_mode),
            ));
        }
        if self.max_substep > 0.01 {
            return Err(PlantError::key(
                "max_substep",
                format!("at most 0.01 s, got {}", self.max_substep),
            ));
        }
        Ok(())
    }

    /// Amplifier parameters.
    pub fn amp(&self) -> AmpParams {
        AmpParams {
            mode: self.mode,
            torque_full_scale: self.torque_full_scale,
            torque_limit: self.torque_limit,
            velocity_full_scale: self.velocity_full_scale,
            velocity_gain: self.velocity_gain,
            pulse_full_scale: self.pulse_full_scale,
            configured_fault: self.amp_fault,
        }
    }

    /// Motor parameters.
    pub fn motor(&self) -> MotorParams {
        MotorParams {
            inertia: self.inertia,
            viscous: self.viscous,
            coulomb: self.coulomb,
            load_torque: self.load_torque,
        }
    }

    /// Encoder parameters.
    pub fn encoder(&self) -> EncoderParams {
        EncoderParams {
            counts_per_rev: self.counts_per_rev,
            sub_count: self.sub_count,
        }
    }

    /// Switch positions.
    pub fn switches(&self) -> Switches {
        Switches {
            home_position: self.home_position,
            home_width: self.home_width,
            plus_limit: self.limits.then_some(self.plus_limit),
            minus_limit: self.limits.then_some(self.minus_limit),
            hysteresis: self.switch_hysteresis,
        }
    }
}

/// A station's plant: defaults plus per-node overrides (already merged and validated).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlantConfig {
    /// Parameters of nodes without an override.
    pub defaults: NodePlantConfig,
    /// Fully merged parameters of nodes with overrides, by node number.
    pub nodes: BTreeMap<u8, NodePlantConfig>,
}

impl PlantConfig {
    /// Parse a station's `plant` table (`[stations.plant]`, with `[stations.plant.nodes.N]`
    /// override tables). Errors name the offending key, prefixed with `plant.`.
    pub fn from_table(table: &toml::Table) -> Result<Self, PlantError> {
        let mut base = table.clone();
        let overrides = match base.remove("nodes") {
            None => toml::Table::new(),
            Some(toml::Value::Table(t)) => t,
            Some(other) => {
                return Err(PlantError::key(
                    "plant.nodes",
                    format!("expected a table, got {}", other.type_str()),
                ))
            }
        };
        let defaults = parse_node(&base).map_err(|e| e.within("plant"))?;
        let mut nodes = BTreeMap::new();
        for (key, v) in overrides {
            let n: u8 = key.parse().ok().filter(|n| *n < 16).ok_or_else(|| {
                PlantError::key(format!("plant.nodes.{key}"), "not a node number 0-15")
            })?;
            let t = match v {
                toml::Value::Table(t) => t,
                other => {
                    return Err(PlantError::key(
                        format!("plant.nodes.{key}"),
                        format!("expected a table, got {}", other.type_str()),
                    ))
                }
            };
            let mut merged = base.clone();
            merged.extend(t);
            let cfg = parse_node(&merged).map_err(|e| e.within(&format!("plant.nodes.{key}")))?;
            nodes.insert(n, cfg);
        }
        Ok(PlantConfig { defaults, nodes })
    }

    /// Parse from TOML text holding the plant table's contents.
    pub fn from_toml_str(s: &str) -> Result<Self, PlantError> {
        let t: toml::Table = s
            .parse()
            .map_err(|e: toml::de::Error| PlantError::Syntax(e.message().to_string()))?;
        Self::from_table(&t)
    }

    /// Parameters of `node`.
    pub fn node(&self, node: u8) -> &NodePlantConfig {
        self.nodes.get(&node).unwrap_or(&self.defaults)
    }
}

/// A plant table or node parameters that cannot be used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlantError {
    /// A key whose value is missing, malformed or out of range.
    #[error("{key}: {problem}")]
    Key {
        /// Dotted key path, e.g. `plant.nodes.4.inertia` (`(table)` when serde names none).
        key: String,
        /// What is wrong.
        problem: String,
    },
    /// The plant text is no TOML (the parser's message).
    #[error("plant: {0}")]
    Syntax(String),
}

impl PlantError {
    fn key(key: impl Into<String>, problem: impl Into<String>) -> Self {
        PlantError::Key {
            key: key.into(),
            problem: problem.into(),
        }
    }

    /// The same error with its key inside table `prefix` (`prefix.key`).
    fn within(self, prefix: &str) -> Self {
        match self {
            PlantError::Key { key, problem } => PlantError::Key {
                key: format!("{prefix}.{key}"),
                problem,
            },
            other => other,
        }
    }

    /// The key path the error names (none for a syntax error).
    pub fn key_path(&self) -> Option<&str> {
        match self {
            PlantError::Key { key, .. } => Some(key),
            PlantError::Syntax(_) => None,
        }
    }
}

/// Deserialize and validate one node's merged table; errors start with the key name.
fn parse_node(t: &toml::Table) -> Result<NodePlantConfig, PlantError> {
    let cfg: NodePlantConfig =
        toml::Value::Table(t.clone())
            .try_into()
            .map_err(|e: toml::de::Error| {
                let msg = e.message().to_string();
                // serde names unknown fields in its message; otherwise blame the table
                match t.keys().find(|k| msg.contains(&format!("`{k}`"))) {
                    Some(k) => PlantError::key(k.as_str(), msg),
                    None => PlantError::key("(table)", msg),
                }
            })?;
    cfg.validate()?;
    Ok(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_table_gives_defaults() {
        let p = PlantConfig::from_toml_str("").unwrap();
        assert_eq!(p.defaults, NodePlantConfig::default());
        assert_eq!(p.node(3), &NodePlantConfig::default());
        assert!(NodePlantConfig::default().validate().is_ok());
    }

    #[test]
    fn node_overrides_merge_over_station_defaults() {
        let p = PlantConfig::from_toml_str(
            "mode = \"velocity\"\ncoulomb = 0.001\n[nodes.4]\namp_fault = true\nplus_limit = 5e4\n",
        )
        .unwrap();
        assert_eq!(p.defaults.mode, AmpMode::Velocity);
        assert_eq!(p.defaults.coulomb, 0.001);
        let n4 = p.node(4);
        assert!(n4.amp_fault);
        assert_eq!(
            (n4.mode, n4.coulomb, n4.plus_limit),
            (AmpMode::Velocity, 0.001, 50_000.0)
        );
        assert!(!p.node(5).amp_fault);
        assert_eq!(p.node(4).switches().plus_limit, Some(50_000.0));
    }

    #[test]
    fn errors_name_the_key() {
        let e = |s: &str| PlantConfig::from_toml_str(s).unwrap_err().to_string();
        assert!(
            e("inertia = 0").starts_with("plant.inertia: must be > 0"),
            "{}",
            e("inertia = 0")
        );
        assert!(e("coulomb = -1").starts_with("plant.coulomb: must be ≥ 0"));
        assert!(
            e("warp = 9").starts_with("plant.warp: unknown field"),
            "{}",
            e("warp = 9")
        );
        assert!(e("[nodes.16]\ninertia = 1").starts_with("plant.nodes.16: not a node number"));
        assert!(e("[nodes.x]").starts_with("plant.nodes.x: not a node number"));
        assert!(e("nodes = 3").starts_with("plant.nodes: expected a table"));
        assert!(e("[nodes.2]\ninertia = -1").starts_with("plant.nodes.2.inertia: must be > 0"));
        assert!(
            e("mode = \"warp\"").starts_with("plant."),
            "{}",
            e("mode = \"warp\"")
        );
        assert!(e("minus_limit = 2e6").starts_with("plant.minus_limit: must be below"));
        assert!(e("max_substep = 1.0").starts_with("plant.max_substep"));
        assert!(e("switch_hysteresis = -1").starts_with("plant.switch_hysteresis: must be ≥ 0"));
        let p = PlantConfig::from_toml_str("[nodes.3]\nswitch_hysteresis = 0").unwrap();
        assert_eq!(p.node(3).switches().hysteresis, 0.0);
        assert_eq!(p.node(2).switches().hysteresis, SWITCH_HYSTERESIS);
        assert!(
            e("inertia = nan").contains("finite"),
            "{}",
            e("inertia = nan")
        );
        assert!(e("this is not toml").starts_with("plant: "));
        // limits may be removed altogether, then their ordering does not matter
        let p = PlantConfig::from_toml_str("limits = false\nminus_limit = 2e6").unwrap();
        assert_eq!(p.defaults.switches().plus_limit, None);
    }
}
