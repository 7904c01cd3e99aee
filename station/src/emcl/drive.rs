//! One EDB drive: its RAM state, its EEPROM image, and how it answers a frame from the bus
//! (address filtering, checksum, download mode, the reply). The instructions themselves are
//! in `exec.rs`, parameters in `paramio.rs`, the stand-alone interpreter in `program.rs`, the
//! 1 ms tick in `tick.rs`. Pure: frames and ticks in, reply bytes out; no clock, no I/O.

use super::codec::{self, status, Instr, Reply, Request, FRAME_LEN};
use super::eeprom::{EepromImage, COORDS};
use super::motion::Motion;
use super::params;
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
    Corrupt(String),
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
    /// A drive at power-up with factory EEPROM (no image).
    pub fn new(spec: DriveSpec) -> Self {
        Self::power_up(spec, None, None)
    }

    /// Power-up: RAM from the EEPROM image (`image`: the file's bytes, if a file exists).
    /// A corrupt image gives factory defaults and says so in [`Drive::eeprom_load`]; an
    /// image whose GP 64 is not $E4 re-initialises the parameters (program kept). `node`
    /// binds the drive to a MACRO servo node.
    pub fn power_up(spec: DriveSpec, image: Option<&[u8]>, node: Option<u8>) -> Self {
        let factory = EepromImage::factory(&spec);
        let (mut eeprom, mut load) = match image.map(EepromImage::decode) {
            None => (factory.clone(), EepromLoad::Factory),
            Some(Ok(img)) => (img, EepromLoad::Loaded),
            Some(Err(e)) => (factory.clone(), EepromLoad::Corrupt(e)),
        };
        let mut dirty = Dirty::Clean;
        if eeprom.global(64) != Some(params::EEPROM_MAGIC) {
            let program = std::mem::take(&mut eeprom.program);
            eeprom = factory;
            eeprom.program = program;
            load = EepromLoad::MagicReset;
            dirty = Dirty::Now;
        }
        let plant = Plant {
            shaft: 0,
            enc_offset: 0,
            slip: 0,
            stalled: false,
            last_move: 0,
            inputs: spec.inputs,
            analog: spec.analog,
            enable_in: spec.enable_in,
            reset_in: spec.reset_in,
            outputs: [false; 3],
            pullups: true,
            power_on: true,
        };
        let mut d = Drive {
            spec,
            ap: [0; 256],
            gp: [0; 256],
            user: [0; 256],
            coords: [0; COORDS],
            motion: Motion::default(),
            prog: Program::default(),
            eeprom,
            dirty,
            plant,
            pos_error: false,
            stall_stop: false,
            driver_faults: 0,
            cl_ready_at: None,
            deferred: None,
            rfs: None,
            last_command_ms: 0,
            heartbeat_tripped: false,
            now_ms: 0,
            rng: 0x2545_F491_4F6C_DD1D,
            download: None,
            node,
            bound: Default::default(),
            load_status: load,
            counters: Counters::default(),
        };
        d.reboot();
        d
    }

    /// RAM := EEPROM, motion stopped, program reset (autostart per GP 77). The shaft and
    /// the encoder stay where they are (it is the same motor).
    pub(crate) fn reboot(&mut self) {
        let shaft = self.plant.shaft;
        self.ap = [0; 256];
        self.gp = [0; 256];
        self.user = [0; 256];
        self.coords = [0; COORDS];
        self.motion = Motion::default();
        self.prog = Program::default();
        self.pos_error = false;
        self.stall_stop = false;
        self.cl_ready_at = None;
        self.deferred = None;
        self.rfs = None;
        self.download = None;
        self.heartbeat_tripped = false;
        self.plant.outputs = [false; 3];
        self.plant.pullups = true;
        self.plant.power_on = true;
        self.plant.slip = 0;
        // Only values the tables accept are restored (an image is CRC-checked, but it may
        // come from another firmware); anything else keeps its factory value.
        let stored: Vec<(u8, i32)> = self
            .eeprom
            .axis
            .iter()
            .copied()
            .filter(|&(n, v)| {
                params::axis(n)
                    .is_some_and(|p| p.access == params::Access::RW && p.range.contains(v))
            })
            .collect();
        for n in params::AXIS_PARAMS
            .iter()
            .filter(|p| p.access == params::Access::RW)
        {
            self.restore_ap(n.num, self.spec.axis_default(n.num));
        }
        for &(n, v) in stored.iter().filter(|(n, _)| *n != 209) {
            self.restore_ap(n, v);
        }
        // The encoder counter starts from 0 at power-up, or from a stored AP 209.
        self.plant.enc_offset = -self.enc_scale(shaft);
        if let Some(&(n, v)) = stored.iter().find(|(n, _)| *n == 209) {
            self.restore_ap(n, v);
        }
        for p in params::GLOBAL_PARAMS
            .iter()
            .filter(|p| params::global_is_eeprom(p.num))
        {
            self.gp[usize::from(p.num)] = self.spec.global_default(p.num);
        }
        for (n, v) in self.eeprom.global.clone() {
            let ok = match n {
                73 => v == 0 || v == 1,
                _ => {
                    params::global_is_eeprom(n)
                        && params::global(n).is_some_and(|p| p.range.contains(v))
                }
            };
            if ok {
                self.gp[usize::from(n)] = v;
            }
        }
        for (k, v) in self.eeprom.user.iter().enumerate() {
            if let Some(u) = self.user.get_mut(k) {
                *u = *v;
            }
        }
        if self.gp[84] == 1 {
            for k in 1..COORDS {
                self.coords[k] = self.eeprom.coords.get(k).copied().unwrap_or(0);
            }
        }
        if self.gp[77] == 1 {
            self.prog.start_at(0);
        }
    }

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

    /// 137/1234: every EEPROM setting back to the factory state (the program is kept: it is
    /// not a setting), then the drive restarts from it.
    pub(crate) fn factory_reset(&mut self) {
        let program = std::mem::take(&mut self.eeprom.program);
        self.eeprom = EepromImage::factory(&self.spec);
        self.eeprom.program = program;
        self.mark_dirty(Dirty::Now);
        self.reboot();
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
