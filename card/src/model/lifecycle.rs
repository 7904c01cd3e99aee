//! Reset (`$$$`), re-initialisation (`$$$***`), SAVE images, and status-word texts for
//! [`CardState`]. Pure functions on the state (pmac-variables §1.4).

use super::card_state::CardState;
use super::memory::{Memory, Space};
use super::persist::{PersistError, PersistImage};
use super::status::{CsFlags, GlobalFlags, MotorFlags};
use crate::domain::profile;

/// Memory regions SAVE keeps besides variables: ECT setup, analog table, VME/DPRAM setup.
pub(super) const SAVED_REGIONS: [(Space, u16, usize); 3] = [
    (Space::Y, 0x0720, 0x20),
    (Space::X, 0x0708, 8),
    (Space::X, 0x0783, 10),
];

/// Top of user buffer memory (UBUFFER grows down from here).
pub(super) const UBUFFER_TOP: u16 = 0x9FFF;
/// Size of user buffer memory in words ($1800-$9FFF).
pub(super) const USER_MEMORY_WORDS: u32 = 0x8800;

impl CardState {
    /// The image `SAVE` writes. `programs` is INTERP's serialized buffer data.
    pub fn to_image(&self, programs: Vec<u8>) -> PersistImage {
        let n = self.limits().vars as u32;
        let ivars = (0..n).map(|k| self.peek_ivar(k).unwrap_or(0.0)).collect();
        let (mdefs, mself) = self.mdefs_all();
        let mut regions: Vec<(Space, u16, Vec<u32>)> = SAVED_REGIONS
            .iter()
            .map(|&(s, a, c)| (s, a, self.memory.snapshot(s, a.into(), c)))
            .collect();
        let ub = self.ubuffer_words.min(USER_MEMORY_WORDS) as usize;
        if ub > 0 {
            let start = UBUFFER_TOP + 1 - ub as u16;
            let a = start.into();
            regions.push((Space::X, start, self.memory.snapshot(Space::X, a, ub)));
            regions.push((Space::Y, start, self.memory.snapshot(Space::Y, a, ub)));
        }
        PersistImage {
            profile: profile::name(self.profile()).into(),
            ivars,
            pvars: self.vars.p_all().to_vec(),
            qvars: self.vars.q_all().to_vec(),
            mdefs: mdefs.to_vec(),
            mself: mself.to_vec(),
            regions,
            ubuffer_words: self.ubuffer_words,
            password: self.password.clone(),
            programs,
            format: super::persist::VERSION,
        }
    }

    /// `$$$`: the state after a power cycle. With a saved image, everything it holds is
    /// reloaded (unsaved changes are lost); without one, factory defaults. Then the reset-time
    /// rules apply (see [`CardState::power_on`]). Returns the programs blob for INTERP (empty
    /// without an image). An image for another profile is refused.
    pub fn reset(&mut self, image: Option<&PersistImage>) -> Result<Vec<u8>, PersistError> {
        if let Some(img) = image {
            if img.profile != profile::name(self.profile()) {
                return Err(PersistError::Profile(img.profile.clone()));
            }
        }
        let mut fresh = CardState::new(self.profile());
        let programs = match image {
            Some(img) => {
                fresh.vars.load(&img.ivars, &img.pvars, &img.qvars);
                fresh.load_mdefs(&img.mdefs, &img.mself);
                for (space, start, words) in &img.regions {
                    fresh.memory.restore(*space, (*start).into(), words);
                }
                fresh.ubuffer_words = img.ubuffer_words.min(USER_MEMORY_WORDS);
                fresh.password = img.password.clone();
                let (rv, map) = (fresh.ring_ivars(), *fresh.map());
                for (n, addr) in [(rv.cfg, map.ring_cfg_addr), (rv.nodes, map.ring_nodes_addr)] {
                    let v = fresh.vars.i(n).unwrap_or(0.0);
                    fresh.write(Space::Y, addr, v as u32);
                }
                img.programs.clone()
            }
            None => Vec::new(),
        };
        *self = fresh;
        self.power_on();
        Ok(programs)
    }

    /// Reset-time rules (Turbo numbers in brackets): I1004/I1005 (I81/I82) = 0 become 2;
    /// I1003 (I78) > 0 forces I1000 (I70) bit 15 to 0;
    /// I58 = 1 forces I3 1→0 and 3→2; node command registers cleared; motors killed; the
    /// password must be matched again (a null password counts as matched).
    pub fn power_on(&mut self) {
        let rv = self.ring_ivars();
        for n in [rv.error_limit, rv.sync_min] {
            if self.vars.i(n) == Ok(0.0) {
                self.vars.force_i(n, 2.0);
            }
        }
        if self.vars.i(rv.aux_timeout).unwrap_or(0.0) > 0.0 {
            let v = self.peek_ivar(rv.aux_enable).unwrap_or(0.0) as u32 & !0x8000;
            self.vars.force_i(rv.aux_enable, v as f64);
        }
        if self.vars.i(58) == Ok(1.0) {
            match self.vars.i(3) {
                Ok(1.0) => self.vars.force_i(3, 0.0),
                Ok(3.0) => self.vars.force_i(3, 2.0),
                _ => {}
            }
        }
        self.memory.clear_node_commands();
        let lim = self.limits();
        self.motors = vec![MotorFlags::default(); lim.motors as usize];
        self.coords = vec![CsFlags::default(); lim.coords as usize];
        self.global = GlobalFlags::default();
        self.password_matched = self.password.is_empty();
        self.reset_feed_words();
    }

    /// `$$$***`: I-variables to factory defaults, ECT and VME/DPRAM setup to defaults,
    /// password cleared, motors killed. M-definitions, P and Q values are not touched; INTERP
    /// erases programs and buffers. The saved image on disk is not touched either.
    pub fn factory(&mut self) {
        let fresh = CardState::new(self.profile());
        self.vars.reset_i();
        for (space, start, count) in SAVED_REGIONS {
            let words = fresh.memory.snapshot(space, start.into(), count);
            self.memory.restore(space, start.into(), &words);
        }
        let map = *self.map();
        for a in [map.ring_cfg_addr, map.ring_nodes_addr] {
            let w = fresh.memory.read(Space::Y, a);
            self.memory.write(Space::Y, a, w);
        }
        self.ubuffer_words = 0;
        self.password.clear();
        self.password_matched = true;
        for m in self.motors.iter_mut() {
            *m = MotorFlags {
                coord: m.coord,
                home_complete: m.home_complete,
                ..MotorFlags::default()
            };
        }
        for c in self.coords.iter_mut() {
            c.running = false;
        }
    }

    /// Fresh raw memory (for tests and tools that need a blank image).
    pub fn blank_memory() -> Memory {
        Memory::default()
    }
}
