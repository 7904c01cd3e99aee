//! Power-up, reboot and factory reset of a drive: RAM from the EEPROM image (spec emcl.md
//! §6.6, §7, §8, §10; GP 64 magic, GP 77 autostart, GP 84 coordinates, D9).

use super::drive::{Counters, Dirty, Drive, EepromLoad, Plant};
use super::eeprom::{EepromImage, COORDS};
use super::motion::Motion;
use super::params;
use super::program::Program;
use super::spec::DriveSpec;

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

    /// 137/1234: every EEPROM setting back to the factory state (the program is kept: it is
    /// not a setting), then the drive restarts from it.
    pub(crate) fn factory_reset(&mut self) {
        let program = std::mem::take(&mut self.eeprom.program);
        self.eeprom = EepromImage::factory(&self.spec);
        self.eeprom.program = program;
        self.mark_dirty(Dirty::Now);
        self.reboot();
    }
}
