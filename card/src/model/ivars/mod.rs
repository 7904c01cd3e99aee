//! I-variable tables: factory default, allowed range, integer/float, hex printing and
//! read-only flags, per profile. Tables are computed once per card ([`IVarTable::new`]).

pub(super) mod pmac2;
pub(super) mod power;
pub(super) mod turbo;

use crate::domain::profile::{limits, Profile};

/// How a variable stores its value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IKind {
    /// Integer register: written values are rounded to the nearest integer.
    Int,
    /// Floating-point value (48-bit PMAC float).
    Float,
}

/// Description of one I-variable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IVarSpec {
    /// Factory default (`In=*`, `$$$***`).
    pub default: f64,
    /// Smallest accepted value.
    pub min: f64,
    /// Largest accepted value.
    pub max: f64,
    /// Integer or floating.
    pub kind: IKind,
    /// Address/bit-mask variable: printed `$HEX` when I9 bit 1 is set.
    pub hex: bool,
    /// Writes are refused (ERR003).
    pub read_only: bool,
}

/// Range of a 24-bit unsigned register.
pub(super) const U24: f64 = 16_777_215.0;
/// Largest positive 24-bit signed value.
pub(super) const S24MAX: f64 = 8_388_607.0;

impl IVarSpec {
    /// Integer variable with range `min..=max`.
    pub const fn int(default: f64, min: f64, max: f64) -> Self {
        IVarSpec {
            default,
            min,
            max,
            kind: IKind::Int,
            hex: false,
            read_only: false,
        }
    }
    /// Integer variable printed in hex under I9=2/3, range `0..=max`.
    pub const fn hex(default: f64, max: f64) -> Self {
        IVarSpec {
            default,
            min: 0.0,
            max,
            kind: IKind::Int,
            hex: true,
            read_only: false,
        }
    }
    /// Floating variable with range `min..=max`.
    pub const fn float(default: f64, min: f64, max: f64) -> Self {
        IVarSpec {
            default,
            min,
            max,
            kind: IKind::Float,
            hex: false,
            read_only: false,
        }
    }
    /// Unspecified/reserved variable: stores any 24-bit signed-or-unsigned integer, default 0.
    pub const fn generic() -> Self {
        IVarSpec::int(0.0, -8_388_608.0, U24)
    }
    /// Positive float with a large range (rates, speeds).
    pub const fn pos_float(default: f64) -> Self {
        IVarSpec::float(default, 0.0, 140_737_488_355_328.0)
    }
    /// Mark read-only.
    pub const fn ro(mut self) -> Self {
        self.read_only = true;
        self
    }

    /// Validate and normalise a value to be stored: integers are rounded (half away from
    /// zero); out-of-range or non-finite values return `None`.
    pub fn accept(&self, v: f64) -> Option<f64> {
        if !v.is_finite() {
            return None;
        }
        let v = match self.kind {
            IKind::Int => v.round(),
            IKind::Float => v,
        };
        if v < self.min || v > self.max {
            None
        } else {
            Some(v)
        }
    }
}

/// All I-variable specifications of one profile, indexed by number.
#[derive(Debug, Clone)]
pub struct IVarTable {
    specs: Vec<IVarSpec>,
}

impl IVarTable {
    /// Build the table for `profile`.
    pub fn new(profile: Profile) -> Self {
        let n = limits(profile).vars as usize;
        let specs = (0..n)
            .map(|i| match profile {
                Profile::Pmac2 => pmac2::spec(i as u16),
                Profile::Turbo => turbo::spec(i as u16),
                Profile::Power => power::spec(i as u16),
            })
            .collect();
        IVarTable { specs }
    }
    /// Spec of variable `n`, `None` outside the profile.
    pub fn get(&self, n: u32) -> Option<&IVarSpec> {
        self.specs.get(n as usize)
    }
    /// Number of I-variables.
    pub fn len(&self) -> usize {
        self.specs.len()
    }
    /// Always false (every profile has variables).
    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }
    /// Vector of every factory default, indexed by number.
    pub fn defaults(&self) -> Vec<f64> {
        self.specs.iter().map(|s| s.default).collect()
    }
}
