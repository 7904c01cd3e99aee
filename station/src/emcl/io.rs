//! The drive's I/O (spec emcl.md §9) and switches: SIO/GIO, the dedicated outputs selected
//! by GP 72, ENABLE_IN (GP 80), RESET_IN, the limit and home switches, and the inputs a test
//! bench (or `mcc`) can set from outside.
//!
//! Decisions: ALARM_OUT = OUT_0, POS_REACHED = OUT_1, POS_ERROR = OUT_2 (§9.2); SIO on a line
//! claimed by a dedicated function answers 100 and has no effect. A limit-switch input reads
//! low while its contact is closed, high while open with the pull-ups on (SIO 0,0,1, the
//! power-up state) and low while open with them off (a floating input reads low). AP 10/11
//! report the switch as active for the polarity AP 12/13 select (AP 12 = 3: high = active;
//! otherwise low = active).

use super::codec::status;
use super::drive::Drive;
use super::paramio::Status;
use super::spec::SwitchKind;

impl Drive {
    /// SIO: bank 2 outputs OUT_0..OUT_2 (0/1); bank 0 port 0 switches the STOP_L/STOP_R/HOME
    /// pull-ups.
    pub(crate) fn set_io(&mut self, port: u8, bank: u8, v: i32) -> Result<(), Status> {
        match bank {
            2 => {
                let slot = self
                    .plant
                    .outputs
                    .get_mut(usize::from(port))
                    .ok_or(status::WRONG_TYPE)?;
                match v {
                    0 | 1 => *slot = v == 1,
                    _ => return Err(status::INVALID_VALUE),
                }
            }
            0 => {
                if port != 0 {
                    return Err(status::WRONG_TYPE);
                }
                match v {
                    0 | 1 => self.plant.pullups = v == 1,
                    _ => return Err(status::INVALID_VALUE),
                }
            }
            _ => return Err(status::INVALID_VALUE),
        }
        Ok(())
    }

    /// GIO: bank 0 digital inputs IN_0..IN_2, bank 1 analog IN_0 (0..4095), bank 2 the
    /// state of OUT_0..OUT_2.
    pub(crate) fn get_io(&self, port: u8, bank: u8) -> Result<i32, Status> {
        match bank {
            0 if port <= 2 => Ok(i32::from(self.input_level(usize::from(port)))),
            1 if port == 0 => Ok(i32::from(self.plant.analog)),
            2 if port <= 2 => Ok(i32::from(self.output_line(usize::from(port)))),
            0..=2 => Err(status::WRONG_TYPE),
            _ => Err(status::INVALID_VALUE),
        }
    }

    /// Level of IN_k (with the loopback plug: OUT_k's line).
    pub fn input_level(&self, k: usize) -> bool {
        if self.spec.loopback {
            self.output_line(k)
        } else {
            self.plant.inputs.get(k).copied().unwrap_or(false)
        }
    }

    /// Level of OUT_k: the dedicated function when GP 72 claims the line, else the SIO value.
    pub fn output_line(&self, k: usize) -> bool {
        if self.gp[72] & (1 << k) != 0 {
            match k {
                0 => self.driver_faults != 0,
                1 => self.target_reached(),
                _ => self.pos_error,
            }
        } else {
            self.plant.outputs.get(k).copied().unwrap_or(false)
        }
    }

    /// Input level of a limit switch whose contact is tripped or not (`None`: not fitted).
    fn limit_level(&self, tripped: Option<bool>) -> bool {
        let closed = match (self.spec.switch_kind, tripped) {
            (_, None) => false,
            (SwitchKind::NormallyOpen, Some(t)) => t,
            (SwitchKind::NormallyClosed, Some(t)) => !t,
        };
        !closed && self.plant.pullups
    }

    fn limit_active(level: bool, polarity: i32) -> bool {
        if polarity == 3 {
            level
        } else {
            !level
        }
    }

    /// AP 10: the right (positive) limit switch is active.
    pub fn right_limit_active(&self) -> bool {
        let tripped = self.spec.right_limit.map(|r| self.plant.shaft >= r);
        Self::limit_active(self.limit_level(tripped), self.ap[12])
    }

    /// AP 11: the left (negative) limit switch is active.
    pub fn left_limit_active(&self) -> bool {
        let tripped = self.spec.left_limit.map(|l| self.plant.shaft <= l);
        Self::limit_active(self.limit_level(tripped), self.ap[13])
    }

    /// The reference (home) switch is active: the shaft is inside the home window.
    pub fn home_active(&self) -> bool {
        let s = self.plant.shaft;
        s >= self.spec.home_position && s <= self.spec.home_position + self.spec.home_width
    }

    /// ENABLE_IN allows the driver (GP 80: 0 ignored, 1 low-active, 2 high-active).
    pub fn enable_ok(&self) -> bool {
        match self.gp[80] {
            1 => !self.plant.enable_in,
            2 => self.plant.enable_in,
            _ => true,
        }
    }

    /// The driver stage drives the motor: powered (UF1), enabled, chopper on (AP 167 ≠ 0),
    /// a run current set, no driver error.
    pub fn driver_on(&self) -> bool {
        self.plant.power_on
            && self.enable_ok()
            && self.ap[167] != 0
            && self.ap[6] > 0
            && self.driver_faults == 0
    }

    /// Set an input line or inject a driver fault from outside (the test bench): `in0`..`in2`
    /// (0/1), `analog` (0..4095), `enable_in`, `reset_in` (0/1), `overtemp`, `short` (0/1,
    /// AP 208 bits 1 and 3: the driver shuts off and ALARM_OUT rises).
    pub fn set_input(&mut self, name: &str, v: i64) -> Result<(), InputError> {
        let bit = |v: i64| match v {
            0 | 1 => Ok(v == 1),
            _ => Err(InputError::NotBit(name.to_string(), v)),
        };
        match name {
            "in0" | "in1" | "in2" => {
                let k = usize::from(name.as_bytes()[2] - b'0');
                let b = bit(v)?;
                if let Some(slot) = self.plant.inputs.get_mut(k) {
                    *slot = b;
                }
            }
            "analog" => {
                if !(0..=4095).contains(&v) {
                    return Err(InputError::Analog(v));
                }
                self.plant.analog = v as u16;
            }
            "enable_in" => self.plant.enable_in = bit(v)?,
            "reset_in" => {
                self.plant.reset_in = bit(v)?;
                if self.plant.reset_in {
                    self.clear_pos_error();
                }
            }
            "overtemp" => self.set_fault_bit(1, bit(v)?),
            "short" => self.set_fault_bit(3, bit(v)?),
            _ => return Err(InputError::Unknown(name.to_string())),
        }
        Ok(())
    }

    fn set_fault_bit(&mut self, b: u8, on: bool) {
        if on {
            self.driver_faults |= 1 << b;
        } else {
            self.driver_faults &= !(1 << b);
        }
    }
}

/// An input [`Drive::set_input`] refuses.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// A digital line set to something other than 0 or 1 (line, value).
    #[error("{0}: {1} is not 0 or 1")]
    NotBit(String, i64),
    /// The analog input outside 0-4095 (value).
    #[error("analog: {0} is out of range 0-4095")]
    Analog(i64),
    /// No input of that name.
    #[error("unknown input {0:?} (in0, in1, in2, analog, enable_in, reset_in, overtemp, short)")]
    Unknown(String),
}
