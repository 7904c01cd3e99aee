//! Reading and writing axis parameters, global parameters and user variables, and copying
//! them between RAM and EEPROM (SAP/GAP/STAP/RSAP, SGP/GGP/STGP/RSGP, AAP/AGP): spec emcl.md
//! §5.2, §7, §8, decisions D6–D8, D16.

use super::codec::status;
use super::drive::{Dirty, Drive};
use super::params::{self, Access, LOCK_CODE, USER_EEPROM_VARS};

/// A status code refusing the operation.
pub type Status = u8;

impl Drive {
    /// GP 73: the configuration EEPROM is locked.
    pub fn eeprom_locked(&self) -> bool {
        self.gp[73] == 1
    }

    /// GAP: the value of axis parameter `n`.
    pub fn get_ap(&self, n: u8) -> Result<i32, Status> {
        params::axis(n).ok_or(status::WRONG_TYPE)?;
        let m = &self.motion;
        Ok(match n {
            0 => m.target_pos,
            1 => m.pos,
            2 => match m.mode {
                super::motion::Mode::Velocity => m.target_vel as i32,
                _ => m.v as i32,
            },
            3 => self.actual_velocity() as i32,
            8 => i32::from(self.target_reached()),
            10 => i32::from(self.right_limit_active()),
            11 => i32::from(self.left_limit_active()),
            133 => i32::from(self.cl_ready()),
            180 => (self.ap[6] / 8).clamp(0, 31),
            206 => self.load_value(),
            208 => i32::from(self.driver_flags()),
            209 => (self.plant.enc_offset + self.enc_scale(self.plant.shaft)) as i32,
            _ => self.ap[usize::from(n)],
        })
    }

    /// SAP (and AAP): write axis parameter `n` in RAM. Unknown or read-only → 3, out of
    /// range → 4. Writing AP 0 starts a positioning move and AP 2 a rotation, as in TMCL
    /// (the potentiometer example of \[L1362\] moves the motor through `AAP 0`).
    pub fn set_ap(&mut self, n: u8, v: i32) -> Result<(), Status> {
        let p = params::axis(n).ok_or(status::WRONG_TYPE)?;
        if p.access != Access::RW {
            return Err(status::WRONG_TYPE);
        }
        if !p.range.contains(v) {
            return Err(status::INVALID_VALUE);
        }
        match n {
            0 => self.motion_command(super::codec::Instr::new(4, 0, 0, v))?,
            2 => self.motion_command(super::codec::Instr::new(1, 0, 0, v))?,
            _ => self.restore_ap(n, v),
        }
        Ok(())
    }

    /// Put a (valid) value into RAM without motion side effects: power-up, RSAP.
    pub(crate) fn restore_ap(&mut self, n: u8, v: i32) {
        match n {
            0 => self.motion.target_pos = v,
            1 => {
                // Re-referencing: the counter is the new truth, nothing counts as lost.
                self.motion.set_position(v);
                self.plant.slip = 0;
            }
            2 => self.motion.target_vel = i64::from(v),
            209 => {
                self.plant.enc_offset = i64::from(v) - self.enc_scale(self.plant.shaft);
            }
            129 => {
                self.ap[129] = v;
                self.cl_ready_at = (v == 1).then_some(self.now_ms + CL_INIT_MS);
            }
            _ => {
                if let Some(slot) = self.ap.get_mut(usize::from(n)) {
                    *slot = v;
                }
            }
        }
    }

    /// STAP: copy RAM → EEPROM for a writable axis parameter.
    pub fn store_ap(&mut self, n: u8) -> Result<(), Status> {
        let p = params::axis(n).ok_or(status::WRONG_TYPE)?;
        if p.access != Access::RW {
            return Err(status::WRONG_TYPE);
        }
        if self.eeprom_locked() {
            return Err(status::EEPROM_LOCKED);
        }
        let v = self.get_ap(n)?;
        self.eeprom.set_axis(n, v);
        self.mark_dirty(Dirty::Now);
        Ok(())
    }

    /// RSAP: copy EEPROM → RAM for a writable axis parameter.
    pub fn restore_stored_ap(&mut self, n: u8) -> Result<(), Status> {
        let p = params::axis(n).ok_or(status::WRONG_TYPE)?;
        if p.access != Access::RW {
            return Err(status::WRONG_TYPE);
        }
        let v = self
            .eeprom
            .axis(n)
            .unwrap_or_else(|| self.spec.axis_default(n));
        self.restore_ap(n, v);
        Ok(())
    }

    /// GGP: bank 0 parameter / bank 2 user variable. Banks 1 and 3 → 3, > 3 → 4.
    pub fn get_gp(&mut self, n: u8, bank: u8) -> Result<i32, Status> {
        match bank {
            0 => {
                params::global(n).ok_or(status::WRONG_TYPE)?;
                Ok(match n {
                    128 => self.prog.state as i32,
                    129 => i32::from(self.download.is_some()),
                    130 => i32::from(self.prog.pc),
                    133 => self.random(),
                    _ => self.gp[usize::from(n)],
                })
            }
            2 => Ok(self.user[usize::from(n)]),
            1 | 3 => Err(status::WRONG_TYPE),
            _ => Err(status::INVALID_VALUE),
        }
    }

    /// SGP (and AGP). Bank-0 parameters 64..=87 go to EEPROM at once (refused with 5 while
    /// GP 73 locks it, except GP 73 itself).
    pub fn set_gp(&mut self, n: u8, bank: u8, v: i32) -> Result<(), Status> {
        match bank {
            0 => {}
            2 => {
                self.user[usize::from(n)] = v;
                return Ok(());
            }
            1 | 3 => return Err(status::WRONG_TYPE),
            _ => return Err(status::INVALID_VALUE),
        }
        let p = params::global(n).ok_or(status::WRONG_TYPE)?;
        if p.access != Access::RW {
            return Err(status::WRONG_TYPE);
        }
        if !p.range.contains(v) {
            return Err(status::INVALID_VALUE);
        }
        match n {
            73 => {
                let locked = i32::from(v == LOCK_CODE);
                self.gp[73] = locked;
                self.eeprom.set_global(73, locked);
                self.mark_dirty(Dirty::Now);
            }
            132 => self.gp[132] = v,
            133 => self.rng = (v as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            _ => {
                if self.eeprom_locked() {
                    return Err(status::EEPROM_LOCKED);
                }
                if n == 81 && matches!(self.gp[81], 1 | 3) && matches!(v, 0 | 2) {
                    // Dropping disassembly protection erases the program (§6.6).
                    self.eeprom.program.clear();
                    self.prog.stop();
                }
                self.gp[usize::from(n)] = v;
                self.eeprom.set_global(n, v);
                self.mark_dirty(Dirty::Now);
            }
        }
        Ok(())
    }

    /// STGP: bank-0 EEPROM parameters (already stored: no-op) and user variables 0..=55.
    pub fn store_gp(&mut self, n: u8, bank: u8) -> Result<(), Status> {
        self.eeprom_target(n, bank)?;
        if self.eeprom_locked() {
            return Err(status::EEPROM_LOCKED);
        }
        if bank == 2 {
            let v = self.user[usize::from(n)];
            if let Some(slot) = self.eeprom.user.get_mut(usize::from(n)) {
                *slot = v;
            }
        } else {
            self.eeprom.set_global(n, self.gp[usize::from(n)]);
        }
        self.mark_dirty(Dirty::Now);
        Ok(())
    }

    /// RSGP: EEPROM → RAM for the same parameters.
    pub fn restore_gp(&mut self, n: u8, bank: u8) -> Result<(), Status> {
        self.eeprom_target(n, bank)?;
        if bank == 2 {
            self.user[usize::from(n)] = self.eeprom.user.get(usize::from(n)).copied().unwrap_or(0);
        } else {
            let v = self
                .eeprom
                .global(n)
                .unwrap_or_else(|| self.spec.global_default(n));
            self.gp[usize::from(n)] = v;
        }
        Ok(())
    }

    /// Whether (n, bank) has an EEPROM copy: bank 0 64..=87, bank 2 0..=55; else 3 / 4.
    fn eeprom_target(&self, n: u8, bank: u8) -> Result<(), Status> {
        match bank {
            0 if params::global_is_eeprom(n) => Ok(()),
            2 if usize::from(n) < USER_EEPROM_VARS => Ok(()),
            0..=3 => Err(status::WRONG_TYPE),
            _ => Err(status::INVALID_VALUE),
        }
    }

    /// GP 133: the next pseudo-random number, 0..=2^31−1 (xorshift64*).
    fn random(&mut self) -> i32 {
        let mut x = self.rng;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.rng = x;
        ((x.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 33) & 0x7FFF_FFFF) as i32
    }
}

/// Closed-loop initialisation time after SAP 129 := 1: 50 ticks of 10 ms (§7.3).
pub const CL_INIT_MS: u64 = 500;
