//! What a drive is built from: its RS485 address, the factory defaults of its parameters
//! (what instruction 137 restores) and the physics around it (switch positions, encoder
//! index, hard stops, I/O levels). Built from the `[[drives]]` config by the station.

use std::collections::BTreeMap;

use super::params::{self, Access};

/// Microsteps per full step (fixed on the EDB: 10 rev × 200 steps × 256 = 512 000 in the
/// seed's closed-loop example).
pub const MICROSTEPS: i64 = 256;

/// Limit-switch contact type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SwitchKind {
    /// Normally open: closes to ground when tripped (the input reads low).
    #[default]
    NormallyOpen,
    /// Normally closed: opens when tripped (the input floats, or reads high with pull-ups).
    NormallyClosed,
}

/// A drive's fixed description.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveSpec {
    /// Factory RS485 address (GP 66 default).
    pub address: u8,
    /// Factory axis parameter values (RW parameters; anything not listed is 0).
    pub axis_defaults: BTreeMap<u8, i32>,
    /// Factory bank-0 values for the EEPROM parameters 64..=87 (others per D15).
    pub global_defaults: BTreeMap<u8, i32>,
    /// Right (positive) limit switch: tripped at shaft positions ≥ this (µsteps).
    pub right_limit: Option<i64>,
    /// Left (negative) limit switch: tripped at shaft positions ≤ this (µsteps).
    pub left_limit: Option<i64>,
    /// Limit-switch contacts.
    pub switch_kind: SwitchKind,
    /// Home (reference) switch window start, µsteps.
    pub home_position: i64,
    /// Home switch window width, µsteps.
    pub home_width: i64,
    /// Encoder index (Z phase) offset within a revolution, µsteps.
    pub index_offset: i64,
    /// Mechanical end stop in the negative direction (the shaft cannot pass it), µsteps.
    pub hard_stop_minus: Option<i64>,
    /// Mechanical end stop in the positive direction, µsteps.
    pub hard_stop_plus: Option<i64>,
    /// stallGuard2 load reading while running freely (AP 206; 0 = stalled), 0..=1023.
    pub load: u16,
    /// Digital inputs IN_0..IN_2 at start-up.
    pub inputs: [bool; 3],
    /// Analog input IN_0 at start-up, 0..=4095.
    pub analog: u16,
    /// Each IN_k follows OUT_k (a test-bench loopback plug).
    pub loopback: bool,
    /// ENABLE_IN line level (high = true).
    pub enable_in: bool,
    /// RESET_IN line level (high = true; active clears POS_ERROR).
    pub reset_in: bool,
    /// Bound to a MACRO node: pulse rate at full-scale register 2, pps.
    pub pulse_full_scale: i64,
}

impl Default for DriveSpec {
    fn default() -> Self {
        DriveSpec {
            address: 1,
            axis_defaults: default_axis(),
            global_defaults: BTreeMap::new(),
            right_limit: Some(5_120_000),
            left_limit: Some(-5_120_000),
            switch_kind: SwitchKind::NormallyOpen,
            home_position: 5_000,
            home_width: 1_000,
            index_offset: 0,
            hard_stop_minus: None,
            hard_stop_plus: None,
            load: 500,
            inputs: [false; 3],
            analog: 0,
            loopback: false,
            enable_in: true,
            reset_in: false,
            pulse_full_scale: 1_000_000,
        }
    }
}

/// The project's motor-specific factory defaults (D15 leaves them to the project): a 200
/// step motor at 256 µsteps, 1 rev/s and 1 rev/s² positioning, half current, the chopper
/// on, limit switches enabled (stop on a low input), a CW index search at 0.1 rev/s.
/// Every other axis parameter defaults to 0 (D15), AP 111 to 256 and AP 214 to 200.
pub fn default_axis() -> BTreeMap<u8, i32> {
    [
        (4, 51_200),
        (5, 51_200),
        (6, 128),
        (7, 8),
        (12, 1),
        (13, 1),
        (111, 256),
        (167, 5),
        (193, 9),
        (195, 5_120),
        (202, 200),
        (214, 200),
    ]
    .into_iter()
    .collect()
}

impl DriveSpec {
    /// The factory value of axis parameter `n` (0 if not listed).
    pub fn axis_default(&self, n: u8) -> i32 {
        self.axis_defaults.get(&n).copied().unwrap_or(0)
    }

    /// The factory value of bank-0 parameter `n` (D15 defaults, the drive's address in 66,
    /// overridden by `global_defaults`).
    pub fn global_default(&self, n: u8) -> i32 {
        if let Some(v) = self.global_defaults.get(&n) {
            return *v;
        }
        match n {
            64 => params::EEPROM_MAGIC,
            66 => i32::from(self.address),
            72 => 7,
            76 => 2,
            _ => 0,
        }
    }

    /// Check the spec: parameter overrides must exist, be writable and in range; physics in
    /// range. The error names the parameter or key.
    pub fn validate(&self) -> Result<(), SpecError> {
        for (&n, &v) in &self.axis_defaults {
            let p = params::axis(n).ok_or(SpecError::NoAxisParam(n))?;
            if p.access != Access::RW {
                return Err(SpecError::AxisReadOnly(n));
            }
            if !p.range.contains(v) {
                return Err(SpecError::AxisRange(n, v));
            }
        }
        for (&n, &v) in &self.global_defaults {
            if !params::global_is_eeprom(n) || n == 73 {
                return Err(SpecError::GlobalNotEeprom(n));
            }
            let p = params::global(n).ok_or(SpecError::NoGlobalParam(n))?;
            if !p.range.contains(v) {
                return Err(SpecError::GlobalRange(n, v));
            }
        }
        if self.load > 1023 {
            return Err(SpecError::Load(self.load));
        }
        if self.analog > 4095 {
            return Err(SpecError::Analog(self.analog));
        }
        if self.home_width < 0 {
            return Err(SpecError::HomeWidth);
        }
        if !(1..=16_777_216).contains(&self.pulse_full_scale) {
            return Err(SpecError::PulseFullScale(self.pulse_full_scale));
        }
        if let (Some(l), Some(r)) = (self.left_limit, self.right_limit) {
            if l >= r {
                return Err(SpecError::Limits(l, r));
            }
        }
        if let (Some(l), Some(r)) = (self.hard_stop_minus, self.hard_stop_plus) {
            if l >= r {
                return Err(SpecError::HardStops(l, r));
            }
        }
        Ok(())
    }
}

/// A drive description [`DriveSpec::validate`] refuses; names the parameter or key.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SpecError {
    /// An axis parameter override for a number the drive does not have.
    #[error("axis parameter {0} does not exist")]
    NoAxisParam(u8),
    /// An axis parameter override for a read-only parameter.
    #[error("axis parameter {0} is read-only")]
    AxisReadOnly(u8),
    /// An axis parameter override out of the parameter's range (number, value).
    #[error("axis parameter {0}: {1} is out of range")]
    AxisRange(u8, i32),
    /// A global parameter override outside the EEPROM parameters 64-87 (or 73).
    #[error("global parameter {0}: only the EEPROM parameters 64-87 (not 73) have factory values")]
    GlobalNotEeprom(u8),
    /// A global parameter override for a number the drive does not have.
    #[error("global parameter {0} does not exist")]
    NoGlobalParam(u8),
    /// A global parameter override out of the parameter's range (number, value).
    #[error("global parameter {0}: {1} is out of range")]
    GlobalRange(u8, i32),
    /// `load` above 1023.
    #[error("load {0} is out of range 0-1023")]
    Load(u16),
    /// `analog` above 4095.
    #[error("analog input {0} is out of range 0-4095")]
    Analog(u16),
    /// A negative `home_width`.
    #[error("home_width must be ≥ 0")]
    HomeWidth,
    /// `pulse_full_scale` outside 1-16777216.
    #[error("pulse_full_scale {0} is out of range 1-16777216")]
    PulseFullScale(i64),
    /// `left_limit` not below `right_limit` (left, right).
    #[error("left_limit {0} must be below right_limit {1}")]
    Limits(i64, i64),
    /// `hard_stop_minus` not below `hard_stop_plus` (minus, plus).
    #[error("hard_stop_minus {0} must be below hard_stop_plus {1}")]
    HardStops(i64, i64),
}
