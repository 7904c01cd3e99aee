//! Coordinates 0..=20 (spec emcl.md §10): SCO/GCO/CCO/ACO, the 255 forms that copy between
//! RAM and EEPROM, and GP 84 write-through. Slot 0 is RAM only.

use super::codec::{status, Instr};
use super::drive::{Ctx, Dirty, Drive};
use super::eeprom::COORDS;
use super::paramio::Status;

impl Drive {
    pub(crate) fn coord_slot(i: Instr) -> Result<usize, Status> {
        let n = usize::from(i.typ);
        if n < COORDS {
            Ok(n)
        } else {
            Err(status::WRONG_TYPE)
        }
    }

    /// SCO n,0,v: set; SCO n,255: RAM → EEPROM (n = 0: all of 1..=20).
    pub(crate) fn set_coord(&mut self, i: Instr) -> Result<(), Status> {
        let n = Self::coord_slot(i)?;
        match i.motor {
            0 => self.write_coord(n, i.value),
            255 => {
                if self.eeprom_locked() {
                    return Err(status::EEPROM_LOCKED);
                }
                let range = if n == 0 { 1..COORDS } else { n..n + 1 };
                for k in range {
                    if let Some(e) = self.eeprom.coords.get_mut(k) {
                        *e = self.coords[k];
                    }
                }
                self.mark_dirty(Dirty::Now);
                Ok(())
            }
            _ => Err(status::INVALID_VALUE),
        }
    }

    /// Write coordinate `n` (through to EEPROM when GP 84 = 1; slot 0 is RAM only).
    pub(crate) fn write_coord(&mut self, n: usize, v: i32) -> Result<(), Status> {
        let through = self.gp[84] == 1 && n > 0;
        if through && self.eeprom_locked() {
            return Err(status::EEPROM_LOCKED);
        }
        if let Some(c) = self.coords.get_mut(n) {
            *c = v;
        }
        if through {
            if let Some(e) = self.eeprom.coords.get_mut(n) {
                *e = v;
            }
            self.mark_dirty(Dirty::Now);
        }
        Ok(())
    }

    /// GCO n,0: read; GCO n,255: EEPROM → RAM (n = 0: all of 1..=20), then read.
    pub(crate) fn get_coord(&mut self, i: Instr, ctx: Ctx) -> Result<i32, Status> {
        let n = Self::coord_slot(i)?;
        match i.motor {
            0 => {}
            255 => {
                let range = if n == 0 { 1..COORDS } else { n..n + 1 };
                for k in range {
                    self.coords[k] = self.eeprom.coords.get(k).copied().unwrap_or(0);
                }
            }
            _ => return Err(status::INVALID_VALUE),
        }
        let v = self.coords[n];
        self.load_accu(ctx, v);
        Ok(v)
    }
}
