//! Executing one instruction, in direct mode or from the program (spec emcl.md §5, decisions
//! D2–D9, D16–D19). `Ok(value)` is the reply value (an echo of the request where the seed
//! says "don't care", D3); `Err(status)` refuses it and changes nothing.

use super::codec::{status, Instr};
use super::drive::{Ctx, Dirty, Drive, VERSION_BINARY};
use super::eeprom::{COORDS, PROGRAM_SLOTS};
use super::motion::MAX_ROTATE;
use super::paramio::Status;

/// The stand-alone-only instructions (JA, JC, COMP, CSUB, RSUB, WAIT, STOP, CLE): status 6 in
/// direct mode (D5).
pub const STAND_ALONE_ONLY: [u8; 8] = [20, 21, 22, 23, 24, 27, 28, 36];

fn motor0(i: Instr) -> Result<(), Status> {
    if i.motor == 0 {
        Ok(())
    } else {
        Err(status::INVALID_VALUE)
    }
}

impl Drive {
    /// Execute `i`. The caller has handled address, checksum, download mode, 136 type 0 and
    /// 137/1234 (which reply specially).
    pub fn exec(&mut self, i: Instr, ctx: Ctx) -> Result<i32, Status> {
        let echo = i.value;
        if ctx == Ctx::Direct && STAND_ALONE_ONLY.contains(&i.op) {
            return Err(status::NOT_AVAILABLE);
        }
        match i.op {
            1 | 2 => {
                motor0(i)?;
                if !(-MAX_ROTATE..=MAX_ROTATE).contains(&i64::from(i.value)) {
                    return Err(status::INVALID_VALUE);
                }
                self.motion_command(i)?;
                Ok(echo)
            }
            3 => {
                motor0(i)?;
                self.motion_command(i)?;
                Ok(echo)
            }
            4 => {
                if i.typ > 2 {
                    return Err(status::WRONG_TYPE);
                }
                motor0(i)?;
                if i.typ == 2 && !(0..COORDS as i32).contains(&i.value) {
                    return Err(status::INVALID_VALUE);
                }
                self.motion_command(i)?;
                Ok(echo)
            }
            5 => {
                motor0(i)?;
                self.set_ap(i.typ, i.value)?;
                Ok(echo)
            }
            6 => {
                motor0(i)?;
                let v = self.get_ap(i.typ)?;
                self.load_accu(ctx, v);
                Ok(v)
            }
            7 => {
                motor0(i)?;
                self.store_ap(i.typ)?;
                Ok(echo)
            }
            8 => {
                motor0(i)?;
                self.restore_stored_ap(i.typ)?;
                Ok(echo)
            }
            9 => {
                self.set_gp(i.typ, i.motor, i.value)?;
                Ok(echo)
            }
            10 => {
                let v = self.get_gp(i.typ, i.motor)?;
                self.load_accu(ctx, v);
                Ok(v)
            }
            11 => {
                self.store_gp(i.typ, i.motor)?;
                Ok(echo)
            }
            12 => {
                self.restore_gp(i.typ, i.motor)?;
                Ok(echo)
            }
            13 => {
                motor0(i)?;
                match i.typ {
                    0 | 1 => {
                        self.motion_command(i)?;
                        Ok(echo)
                    }
                    2 => Ok(i32::from(self.rfs.is_some())),
                    _ => Err(status::WRONG_TYPE),
                }
            }
            14 => {
                self.set_io(i.typ, i.motor, i.value)?;
                Ok(echo)
            }
            15 => {
                let v = self.get_io(i.typ, i.motor)?;
                self.load_accu(ctx, v);
                Ok(v)
            }
            19 => {
                let a = self.prog.accu;
                let v = i.value;
                let r = match i.typ {
                    0 => a.wrapping_add(v),
                    1 => a.wrapping_sub(v),
                    2 => a.wrapping_mul(v),
                    3 => a.checked_div(v).unwrap_or(a),
                    4 => a.checked_rem(v).unwrap_or(a),
                    5 => a & v,
                    6 => a | v,
                    7 => a ^ v,
                    8 => !a,
                    9 => v,
                    _ => return Err(status::WRONG_TYPE),
                };
                self.prog.load(r);
                Ok(echo)
            }
            30 => {
                self.set_coord(i)?;
                Ok(echo)
            }
            31 => self.get_coord(i, ctx),
            32 | 39 => {
                let n = Self::coord_slot(i)?;
                motor0(i)?;
                let v = if i.op == 32 {
                    self.motion.pos
                } else {
                    self.prog.accu
                };
                self.write_coord(n, v)?;
                Ok(echo)
            }
            33 => {
                let (a, x) = (self.prog.accu, self.prog.x);
                match i.typ {
                    0..=7 => {
                        let r = match i.typ {
                            0 => a.wrapping_add(x),
                            1 => a.wrapping_sub(x),
                            2 => a.wrapping_mul(x),
                            3 => a.checked_div(x).unwrap_or(a),
                            4 => a.checked_rem(x).unwrap_or(a),
                            5 => a & x,
                            6 => a | x,
                            _ => a ^ x,
                        };
                        self.prog.load(r);
                    }
                    8 => self.prog.x = !x,
                    9 => self.prog.x = a,
                    10 => {
                        self.prog.x = a;
                        self.prog.load(x);
                    }
                    _ => return Err(status::WRONG_TYPE),
                }
                Ok(echo)
            }
            34 => {
                motor0(i)?;
                self.set_ap(i.typ, self.prog.accu)?;
                Ok(echo)
            }
            35 => {
                self.set_gp(i.typ, i.motor, self.prog.accu)?;
                Ok(echo)
            }
            65 => match i.typ {
                0 => match i.value {
                    0 | 1 => {
                        self.set_power(i.value == 1);
                        Ok(echo)
                    }
                    _ => Err(status::INVALID_VALUE),
                },
                1 => Ok(i32::from(self.plant.power_on)),
                _ => Err(status::WRONG_TYPE),
            },
            128..=137 if ctx == Ctx::Program => Err(status::INVALID_INSTRUCTION),
            128 => {
                self.prog.stop();
                Ok(echo)
            }
            129 => {
                match i.typ {
                    0 => {
                        if usize::from(self.prog.pc) >= PROGRAM_SLOTS {
                            self.prog.pc = 0;
                        }
                        self.prog.state = super::program::AppState::Run;
                        self.prog.steps_pending = 0;
                    }
                    1 => match u16::try_from(i.value) {
                        Ok(a) if usize::from(a) < PROGRAM_SLOTS => self.prog.start_at(a),
                        _ => return Err(status::INVALID_VALUE),
                    },
                    _ => return Err(status::WRONG_TYPE),
                }
                Ok(echo)
            }
            // Each accepted step is one instruction; beyond the queue, status 6.
            130 if self.prog.grant_step() => Ok(echo),
            130 => Err(status::NOT_AVAILABLE),
            131 => {
                self.prog.reset();
                Ok(echo)
            }
            132 => {
                if self.gp[81] & 2 != 0 {
                    return Err(status::NOT_AVAILABLE);
                }
                match u16::try_from(i.value) {
                    Ok(a) if usize::from(a) < PROGRAM_SLOTS => {
                        self.prog.stop();
                        self.download = Some(a);
                        Ok(echo)
                    }
                    _ => Err(status::INVALID_VALUE),
                }
            }
            133 => {
                if self.download.take().is_some() {
                    self.mark_dirty(Dirty::Now);
                }
                Ok(echo)
            }
            134 => {
                if self.gp[81] & 1 != 0 {
                    return Err(status::NOT_AVAILABLE);
                }
                match usize::try_from(i.value) {
                    Ok(a) if a < PROGRAM_SLOTS => {
                        let s = self.eeprom.slot(a);
                        Ok((i32::from(s.typ) << 24)
                            | (i32::from(s.motor) << 16)
                            | (s.value & 0xFFFF))
                    }
                    _ => Err(status::INVALID_VALUE),
                }
            }
            135 => Ok(self.prog.state as i32),
            136 => match i.typ {
                1 => Ok(VERSION_BINARY),
                _ => Err(status::WRONG_TYPE),
            },
            // 137 with 1234 is handled by the frame handler (no reply).
            137 => Err(status::INVALID_VALUE),
            _ => Err(status::INVALID_INSTRUCTION),
        }
    }

    pub(crate) fn load_accu(&mut self, ctx: Ctx, v: i32) {
        if ctx == Ctx::Program {
            self.prog.load(v);
        }
    }

    /// The drive follows its MACRO node (config `node` and AP 254 ≠ 0).
    pub fn is_bound(&self) -> bool {
        self.node.is_some() && self.ap[254] != 0
    }

    /// ROR, ROL, MST, MVP, RFS start/stop (and SAP 0 / SAP 2). Refused with status 6 while
    /// the drive is bound to a MACRO node; ignored (but OK) while POS_ERROR is latched, MST
    /// excepted; deferred while closed-loop initialisation runs.
    pub(crate) fn motion_command(&mut self, i: Instr) -> Result<(), Status> {
        if self.is_bound() {
            return Err(status::NOT_AVAILABLE);
        }
        let is_stop = i.op == 3 || (i.op == 13 && i.typ == 1);
        if self.pos_error && !is_stop {
            return Ok(());
        }
        if self.ap[129] == 1 && !self.cl_ready() && !is_stop {
            self.deferred = Some(i);
            return Ok(());
        }
        if is_stop {
            self.deferred = None;
        }
        self.apply_motion(i);
        Ok(())
    }

    /// Start a (validated) motion command now.
    pub(crate) fn apply_motion(&mut self, i: Instr) {
        self.stall_stop = false;
        match i.op {
            1 => {
                self.rfs = None;
                self.motion.rotate(i64::from(i.value));
            }
            2 => {
                self.rfs = None;
                self.motion.rotate(-i64::from(i.value));
            }
            3 => {
                self.rfs = None;
                self.motion.soft_stop();
            }
            4 => {
                self.rfs = None;
                let target = match i.typ {
                    0 => i.value,
                    1 => {
                        let base = match self.ap[127] {
                            0 => self.motion.target_pos,
                            1 => self.motion.pos,
                            _ => (self.plant.enc_offset + self.enc_scale(self.plant.shaft)) as i32,
                        };
                        base.wrapping_add(i.value)
                    }
                    _ => self
                        .coords
                        .get(usize::try_from(i.value).unwrap_or(0))
                        .copied()
                        .unwrap_or(0),
                };
                self.motion.move_to(target);
            }
            13 if i.typ == 0 => self.start_rfs(),
            13 => {
                self.rfs = None;
                self.motion.soft_stop();
            }
            _ => {}
        }
    }

    fn set_power(&mut self, on: bool) {
        self.plant.power_on = on;
    }
}
