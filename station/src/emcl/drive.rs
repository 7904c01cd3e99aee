//! One EDB drive: its RAM state, its EEPROM image, and how it answers a frame from the bus
//! (address filtering, checksum, download mode, the reply). Power-up and resets are in
//! `power.rs`, the instructions in `exec.rs` (coordinates in `coords.rs`), parameters in
//! `paramio.rs`, the stand-alone interpreter in `program.rs`, the 1 ms tick in `tick.rs`.
//! Pure: frames and ticks in, reply bytes out; no clock, no I/O.

use super::codec::{self, status, Instr, Reply, Request, FRAME_LEN};
use super::eeprom::{EepromError, EepromImage, COORDS};
use super::motion::Motion;
use super::program::Program;
use super::spec::DriveSpec;

/// Version string of 136 type 0 (D11, §2.4).
pub const VERSION_STRING: &[u8; 8] = b"1360V131";
/// Binary version of 136 type 1: module 1360, version 1.31 (D11).
pub const VERSION_BINARY: i32 = 0x0550_0131;

/// How the EEPROM image was found at power-up.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum EepromLoad {
    /// A valid image was loaded.
    Loaded,
    /// No image existed: factory defaults.
    Factory,
    /// The image was unreadable or corrupt: factory defaults (the reason).
    Corrupt(EepromError),
    /// GP 64 held a value other than $E4: parameters re-initialised to factory defaults.
    MagicReset,
}

/// The drive's reply to one frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Answer {
    /// The reply bytes (9), or nothing (137 factory reset sends no reply).
    pub bytes: Option<[u8; FRAME_LEN]>,
    /// GP 75 telegram pause before the reply, ms.
    pub pause_ms: u8,
}

/// EEPROM persistence request raised by a frame or a program instruction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Dirty {
    /// Nothing to write.
    #[default]
    Clean,
    /// Program memory changed during a download: write soon (no fsync needed per slot).
    Soon,
    /// A setting was stored: write it durably before answering.
    Now,
}

/// Per-drive counters shown in the status.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames addressed to this drive.
    pub frames: u64,
    /// Of them, answered with an error status.
    pub errors: u64,
    /// Of them, with a wrong checksum.
    pub checksum_errors: u64,
}

/// Physical and I/O state around the motor.
#[derive(Clone, Debug, PartialEq)]
pub struct Plant {
    /// Rotor position, µsteps (unwrapped, physical frame of the switches).
    pub shaft: i64,
    /// Encoder counter offset (AP 209 = offset + shaft scaled to encoder counts).
    pub enc_offset: i64,
    /// Steps commanded but not executed (open loop, blocked or unpowered), µsteps.
    pub slip: i64,
    /// The shaft was blocked by a hard stop during the last ms (stallGuard reads 0).
    pub stalled: bool,
    /// Shaft µsteps moved in the last ms.
    pub last_move: i64,
    /// Digital inputs IN_0..IN_2.
    pub inputs: [bool; 3],
    /// Analog IN_0.
    pub analog: u16,
    /// ENABLE_IN level.
    pub enable_in: bool,
    /// RESET_IN level.
    pub reset_in: bool,
    /// SIO bank 2 values OUT_0..OUT_2.
    pub outputs: [bool; 3],
    /// SIO 0,0: pull-ups of STOP_L/STOP_R/HOME on.
    pub pullups: bool,
    /// UF1: drive stage powered.
    pub power_on: bool,
}

/// An EDB drive.
#[derive(Clone, Debug)]
pub struct Drive {
    pub(crate) spec: DriveSpec,
    /// Axis parameters held in RAM (the motion-state ones live in `motion`).
    pub(crate) ap: [i32; 256],
    /// Bank-0 global parameters in RAM.
    pub(crate) gp: [i32; 256],
    /// Bank-2 user variables.
    pub(crate) user: [i32; 256],
    /// Coordinates 0..=20.
    pub(crate) coords: [i32; COORDS],
    /// Ramp generator.
    pub(crate) motion: Motion,
    /// Stand-alone program state and registers.
    pub(crate) prog: Program,
    /// EEPROM contents (program memory lives here: it is EEPROM).
    pub(crate) eeprom: EepromImage,
    pub(crate) dirty: Dirty,
    pub(crate) plant: Plant,
    /// POS_ERROR latched (§9.2).
    pub(crate) pos_error: bool,
    /// Stopped by stall detection (AP 208 bit 0) since the last motion command.
    pub(crate) stall_stop: bool,
    /// Driver error bits 1..6 of AP 208 (injected faults).
    pub(crate) driver_faults: u8,
    /// Closed-loop initialisation: ms at which AP 133 becomes 1.
    pub(crate) cl_ready_at: Option<u64>,
    /// A motion command deferred until closed-loop initialisation ends.
    pub(crate) deferred: Option<Instr>,
    /// Reference search in progress.
    pub(crate) rfs: Option<super::tick::Rfs>,
    /// ms of the last frame addressed to this drive (serial heartbeat).
    pub(crate) last_command_ms: u64,
    pub(crate) heartbeat_tripped: bool,
    /// The drive's clock: ms ticks run.
    pub(crate) now_ms: u64,
    /// GP 133 random generator state.
    pub(crate) rng: u64,
    /// Download mode: next program slot to write.
    pub(crate) download: Option<u16>,
    /// Bound to a MACRO node (config): follows the node's pulse command while AP 254 ≠ 0.
    pub(crate) node: Option<u8>,
    pub(crate) bound: super::bound::BoundState,
    pub(crate) load_status: EepromLoad,
    pub(crate) counters: Counters,
}

/// Where an instruction comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ctx {
    /// A host frame (direct mode).
    Direct,
    /// The stand-alone program.
    Program,
}

impl Drive {
    /// The drive's current RS485 address (GP 66).
    pub fn address(&self) -> u8 {
        self.gp[66] as u8
    }

    /// Whether a frame for `addr` is for this drive (GP 66 or a non-zero GP 87).
    pub fn answers(&self, addr: u8) -> bool {
        addr == self.address() || (self.gp[87] != 0 && i32::from(addr) == self.gp[87])
    }

    /// How the EEPROM image was found at power-up.
    pub fn eeprom_load(&self) -> &EepromLoad {
        &self.load_status
    }

    /// The EEPROM image (what the state file holds).
    pub fn eeprom(&self) -> &EepromImage {
        &self.eeprom
    }

    /// Take the pending persistence request.
    pub fn take_dirty(&mut self) -> Dirty {
        std::mem::take(&mut self.dirty)
    }

    /// A setting was stored and must reach the disk before the drive answers.
    pub fn dirty_now(&self) -> bool {
        self.dirty == Dirty::Now
    }

    /// Download mode is on (132 … 133).
    pub fn downloading(&self) -> bool {
        self.download.is_some()
    }

    pub(crate) fn mark_dirty(&mut self, d: Dirty) {
        if d == Dirty::Now || self.dirty == Dirty::Clean {
            self.dirty = d;
        }
    }

    /// Counters.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The drive's clock (ms ticks run).
    pub fn now_ms(&self) -> u64 {
        self.now_ms
    }

    /// Handle one 9-byte frame from the bus. `None`: not addressed to this drive (RS485
    /// silence). Otherwise the reply (none for a factory reset) and the telegram pause.
    pub fn handle_frame(&mut self, frame: &[u8; FRAME_LEN]) -> Option<Answer> {
        let req = match Request::parse(frame) {
            Ok(r) => r,
            Err(r) => {
                if !self.answers(r.addr) {
                    return None;
                }
                self.counters.frames += 1;
                self.counters.errors += 1;
                self.counters.checksum_errors += 1;
                // D2: status 1, the instruction echoed, value 0.
                return Some(self.answer(Reply {
                    host: self.gp[76] as u8,
                    module: self.address(),
                    status: status::CHECKSUM,
                    op: r.instr.op,
                    value: 0,
                }));
            }
        };
        if !self.answers(req.addr) {
            return None;
        }
        self.counters.frames += 1;
        self.last_command_ms = self.now_ms;
        self.heartbeat_tripped = false;
        let i = req.instr;
        // Download mode: instructions below 128 are stored, not executed (§6.6, D10).
        if let Some(wp) = self.download {
            if i.op < 128 {
                let (st, value) = if usize::from(wp) >= super::eeprom::PROGRAM_SLOTS {
                    (status::INVALID_VALUE, 0)
                } else {
                    self.eeprom.set_slot(usize::from(wp), i);
                    self.download = Some(wp + 1);
                    self.mark_dirty(Dirty::Soon);
                    (status::STORED, i.value)
                };
                if st != status::STORED {
                    self.counters.errors += 1;
                }
                return Some(self.reply(st, i.op, value));
            }
        }
        if i.op == 136 && i.typ == 0 {
            let host = self.gp[76] as u8;
            return Some(Answer {
                bytes: Some(codec::version_string_reply(host, VERSION_STRING)),
                pause_ms: self.gp[75].clamp(0, 255) as u8,
            });
        }
        if i.op == 137 && i.value == 1234 {
            self.factory_reset();
            return Some(Answer {
                bytes: None,
                pause_ms: 0,
            });
        }
        match self.exec(i, Ctx::Direct) {
            Ok(v) => Some(self.reply(status::OK, i.op, v)),
            Err(st) => {
                self.counters.errors += 1;
                Some(self.reply(st, i.op, 0))
            }
        }
    }

    fn reply(&self, st: u8, op: u8, value: i32) -> Answer {
        self.answer(Reply {
            host: self.gp[76] as u8,
            module: self.address(),
            status: st,
            op,
            value,
        })
    }

    fn answer(&self, r: Reply) -> Answer {
        Answer {
            bytes: Some(r.to_bytes()),
            pause_ms: self.gp[75].clamp(0, 255) as u8,
        }
    }

    /// Scale a shaft position (µsteps) to encoder counts (AP 210 lines per revolution, or
    /// µsteps for the internal encoder).
    pub(crate) fn enc_scale(&self, shaft: i64) -> i64 {
        let lines = i64::from(self.ap[210]);
        if lines <= 0 {
            return shaft;
        }
        let per_rev = i64::from(self.ap[202].max(1)) * super::spec::MICROSTEPS;
        (i128::from(shaft) * i128::from(lines) / i128::from(per_rev)) as i64
    }
}
