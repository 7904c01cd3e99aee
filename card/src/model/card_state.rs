//! [`CardState`]: everything a card remembers — profile, I/P/Q variables, M-definitions,
//! memory, status flags, password — with the operations INTERP calls. Pure: no I/O.

use super::error::StateError;
use super::float48::{decode_float, encode_float};
use super::ivars::{IVarSpec, IVarTable};
use super::memory::{Memory, Space};
use super::mvar::{self, WordAccess};
use super::number::{format_hex, format_value};
use super::regmap::{Addr, MemMap, Special};
use super::status::{CsFlags, GlobalFlags, MotorFlags};
use super::vars::VarStore;
use crate::domain::ast::MDef;
use crate::domain::profile::{limits, ring_ivars, Limits, Profile, RingIvars};

/// I995 bits that are status (cleared when read): 0-3 and 6.
pub(crate) const I995_STATUS_BITS: u32 = 0x4F;
/// I995 bit 5: synchronizing master station enable.
const I995_SYNC_MASTER: u32 = 0x20;
/// I995 bit 6: sync node packet received (status).
const I995_SYNC_RECEIVED: u32 = 0x40;

/// One controller card's state.
#[derive(Debug, Clone)]
pub struct CardState {
    profile: Profile,
    limits: Limits,
    map: MemMap,
    ring: RingIvars,
    /// I, P, Q storage (direct access for INTERP; I995/I996 go through [`CardState::read_ivar`]).
    pub vars: VarStore,
    mdefs: Vec<MDef>,
    mself: Vec<i32>,
    /// Raw memory (special registers are applied by [`CardState::read`]/[`CardState::write`]).
    pub memory: Memory,
    /// Per-motor dynamic flags, index 0 = motor 1.
    pub motors: Vec<MotorFlags>,
    /// Per-C.S. flags, index 0 = C.S. 1.
    pub coords: Vec<CsFlags>,
    /// Global status flags.
    pub global: GlobalFlags,
    /// Password (empty = none). Persistent; cleared by `$$$***`.
    pub password: String,
    /// Password matched since the last reset (a null password always counts as matched).
    pub password_matched: bool,
    /// Words reserved by `DEFINE UBUFFER` (saved from $9FFF downward).
    pub ubuffer_words: u32,
    /// Per C.S.: its `%` command register was written through memory (an M-variable, `W`)
    /// since the servo loop last looked ([`CardState::take_feed_write`]).
    feed_written: Vec<bool>,
    /// Servo cycles run since power-on or the last reset (Power `Sys.ServoCount`, `Sys.Time`).
    pub servo_cycles: u64,
}

impl CardState {
    /// A card with factory defaults for `profile` (the state after `$$$***` on a fresh card).
    pub fn new(profile: Profile) -> Self {
        let limits = limits(profile);
        let n = limits.vars as usize;
        let mut s = CardState {
            profile,
            limits,
            map: MemMap::of(profile),
            ring: ring_ivars(profile),
            vars: VarStore::for_limits(IVarTable::new(profile), &limits),
            mdefs: vec![MDef::SelfRef; n],
            mself: vec![0; n],
            memory: Memory::new(profile),
            motors: vec![MotorFlags::default(); limits.motors as usize],
            coords: vec![CsFlags::default(); limits.coords as usize],
            global: GlobalFlags::default(),
            password: String::new(),
            password_matched: true,
            ubuffer_words: 0,
            feed_written: vec![false; limits.coords as usize],
            servo_cycles: 0,
        };
        s.factory_memory();
        s
    }

    /// The profile.
    pub fn profile(&self) -> Profile {
        self.profile
    }

    /// Dimensions of the profile.
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// The profile's memory map.
    pub(crate) fn map(&self) -> &MemMap {
        &self.map
    }

    /// The profile's ring I-variable numbers.
    pub(crate) fn ring_ivars(&self) -> RingIvars {
        self.ring
    }

    /// Default memory contents: on PMAC2 the Ultralite encoder conversion table (node
    /// 0,1,4,5,8,9,12,13 → `$28C0An` + `$FFFFFF`; on Turbo the table is I8000-I8191, whose
    /// defaults are in the I-variable table), and the ring I-variable mirrors.
    fn factory_memory(&mut self) {
        if self.map.ect_ivar.is_none() {
            for k in 0..0x20 {
                self.memory.write(Space::Y, self.map.ect_start + k, 0);
            }
            for x in 1..=8u16 {
                let a = self.map.ect_start + 2 * Addr::from(x - 1);
                let node_reg = super::ivars::pmac2::motor_node_reg(x);
                self.memory.write(Space::Y, a, 0x280000 | node_reg);
                self.memory.write(Space::Y, a + 1, 0xFF_FFFF);
            }
        }
        for n in [self.ring.cfg, self.ring.nodes] {
            let d = self.vars.table().get(n).map(|s| s.default).unwrap_or(0.0);
            let addr = self.ivar_mirror(n).unwrap_or(self.map.ring_cfg_addr);
            self.memory.write(Space::Y, addr, d as u32);
        }
        self.reset_feed_words();
    }

    // ---- I-variables -----------------------------------------------------------------------

    /// Spec of I`n`.
    pub fn ivar_spec(&self, n: u32) -> Result<&IVarSpec, StateError> {
        self.vars
            .table()
            .get(n)
            .ok_or(StateError::NoSuchVariable(n))
    }

    fn ivar_mirror(&self, n: u32) -> Option<Addr> {
        if n == self.ring.cfg {
            Some(self.map.ring_cfg_addr)
        } else if n == self.ring.nodes {
            Some(self.map.ring_nodes_addr)
        } else {
            None
        }
    }

    /// Value of I`n` without side effects.
    pub fn peek_ivar(&self, n: u32) -> Result<f64, StateError> {
        match self.ivar_mirror(n) {
            Some(a) => Ok(self.memory.read(Space::Y, a) as f64),
            None => self.vars.i(n),
        }
    }

    /// Value of I`n` as a host query sees it: reading the ring configuration variable (I995,
    /// Turbo I6840) clears its status bits.
    pub fn read_ivar(&mut self, n: u32) -> Result<f64, StateError> {
        let v = self.peek_ivar(n)?;
        if n == self.ring.cfg {
            let a = self.map.ring_cfg_addr;
            let w = self.memory.read(Space::Y, a);
            self.memory.write(Space::Y, a, w & !I995_STATUS_BITS);
        }
        Ok(v)
    }

    /// Assign I`n` (range-checked, ERR003 on rejection); returns the stored value.
    pub fn set_ivar(&mut self, n: u32, v: f64) -> Result<f64, StateError> {
        let stored = self.vars.set_i(n, v)?;
        if let Some(a) = self.ivar_mirror(n) {
            self.memory.write(Space::Y, a, stored as u32);
        }
        Ok(stored)
    }

    /// `In=*`: factory default.
    pub fn default_ivar(&mut self, n: u32) -> Result<f64, StateError> {
        let d = self.vars.default_i(n)?;
        if let Some(a) = self.ivar_mirror(n) {
            self.memory.write(Space::Y, a, d as u32);
        }
        Ok(d)
    }

    /// Current I9 (listing/report form).
    pub fn i9(&self) -> u8 {
        self.vars.i(9).unwrap_or(2.0) as u8 & 3
    }

    /// Reply text for an `In` query per I9: value only (I9 0/2) or `In=value` (1/3); `$HEX`
    /// for address-type variables when I9 bit 1 is set. Reading I995 clears its status bits.
    pub fn ivar_text(&mut self, n: u32) -> Result<String, StateError> {
        let v = self.read_ivar(n)?;
        let hex = self.ivar_spec(n)?.hex && self.i9() & 2 != 0;
        let body = if hex { format_hex(v) } else { format_value(v) };
        Ok(if self.i9() & 1 != 0 {
            format!("I{n}={body}")
        } else {
            body
        })
    }

    // ---- M-variables -----------------------------------------------------------------------

    /// Definition of M`n`.
    pub fn mdef(&self, n: u32) -> Result<MDef, StateError> {
        self.mdefs
            .get(n as usize)
            .copied()
            .ok_or(StateError::NoSuchVariable(n))
    }

    /// Define M`n` (validated; `->*` resets the self-referenced value to 0).
    pub fn set_mdef(&mut self, n: u32, def: MDef) -> Result<(), StateError> {
        if n as usize >= self.mdefs.len() {
            return Err(StateError::NoSuchVariable(n));
        }
        mvar::validate(&def)?;
        if def.address().is_some_and(|a| a > self.map.max_addr) {
            return Err(StateError::BadDefinition(
                "address beyond the memory map".into(),
            ));
        }
        self.mdefs[n as usize] = def;
        self.mself[n as usize] = 0;
        Ok(())
    }

    /// Reply text for `Mn->` per I9: `Y:$C0A0,8,16,S` or `Mn->Y:$C0A0,8,16,S` (Turbo:
    /// six address digits, `Y:$0000C0,0`).
    pub fn mdef_text(&self, n: u32) -> Result<String, StateError> {
        let body = mvar::format_def(&self.mdef(n)?, self.map.addr_digits);
        Ok(if self.i9() & 1 != 0 {
            format!("M{n}->{body}")
        } else {
            body
        })
    }

    /// Value of M`n` read through its definition (side effects of the register apply).
    pub fn read_m(&mut self, n: u32) -> Result<f64, StateError> {
        let def = self.mdef(n)?;
        Ok(match def {
            MDef::SelfRef => self.mself[n as usize] as f64,
            _ => mvar::read(&def, self),
        })
    }

    /// Write M`n` through its definition.
    pub fn write_m(&mut self, n: u32, v: f64) -> Result<(), StateError> {
        let def = self.mdef(n)?;
        match def {
            MDef::SelfRef => self.mself[n as usize] = mvar::wrap_self(v),
            _ => mvar::write(&def, self, v),
        }
        Ok(())
    }

    /// All definitions and self-referenced values (persistence).
    pub fn mdefs_all(&self) -> (&[MDef], &[i32]) {
        (&self.mdefs, &self.mself)
    }

    /// Load saved definitions (common length only; invalid ones become `->*`).
    pub fn load_mdefs(&mut self, defs: &[MDef], vals: &[i32]) {
        for (k, d) in defs.iter().enumerate().take(self.mdefs.len()) {
            self.mdefs[k] = if mvar::validate(d).is_ok() {
                *d
            } else {
                MDef::SelfRef
            };
        }
        for (k, v) in vals.iter().enumerate().take(self.mself.len()) {
            self.mself[k] = mvar::wrap_self(*v as f64);
        }
    }

    // ---- Memory with special registers -------------------------------------------------------

    /// Read a 24-bit word as `R`, `RH`, M-variables and the motion code see it: status words
    /// are computed from the flags, P/Q areas show the 48-bit float halves, MACRO node
    /// registers give the latched feedback, Y:$C08F (I995) clears its status bits.
    pub fn read(&mut self, space: Space, addr: Addr) -> u32 {
        match self.map.classify(space, addr) {
            Some(Special::Global(w)) => self.global_status()[w as usize - 1],
            Some(Special::Motor(x, w)) if x <= self.limits.motors => {
                self.motor_status(x)[w as usize - 1]
            }
            Some(Special::Coord(x, w)) if x <= self.limits.coords => {
                self.cs_words(x)[w as usize - 1]
            }
            Some(Special::RingCfg) => {
                let w = self.memory.read(Space::Y, addr);
                self.memory.write(Space::Y, addr, w & !I995_STATUS_BITS);
                w
            }
            Some(Special::EctWord(n)) => self.vars.i(n).unwrap_or(0.0) as i64 as u32 & 0xFF_FFFF,
            Some(Special::P(n)) => half(encode_float(self.vars.p(n).unwrap_or(0.0)), space),
            Some(Special::Q(n)) => half(encode_float(self.vars.q(1, n).unwrap_or(0.0)), space),
            _ => self.memory.read(space, addr),
        }
    }

    /// Write a 24-bit word (`W`, M-variables): status words set the flags, P/Q halves update
    /// the variable, I995/I996 mirrors update the I-variable, node registers take the command.
    pub fn write(&mut self, space: Space, addr: Addr, value: u32) {
        let value = value & 0xFF_FFFF;
        match self.map.classify(space, addr) {
            Some(Special::Global(1)) => self.global.set_word1(value),
            Some(Special::Global(_)) => {}
            Some(Special::Motor(x, w)) if x <= self.limits.motors => {
                let turbo = self.profile == Profile::Turbo;
                let f = &mut self.motors[x as usize - 1];
                match (w, turbo) {
                    (1, false) => f.set_word1(value),
                    (_, false) => f.set_word2(value),
                    (1, true) => f.set_turbo_word1(value),
                    (_, true) => f.set_turbo_word2(value),
                }
            }
            Some(Special::Coord(x, w)) if x <= self.limits.coords => {
                let f = &mut self.coords[x as usize - 1];
                if w == 1 {
                    f.set_word1(value)
                } else {
                    f.set_word2(value)
                }
            }
            Some(Special::RingCfg) | Some(Special::RingNodes) => {
                self.memory.write(space, addr, value);
                let n = if addr == self.map.ring_cfg_addr {
                    self.ring.cfg
                } else {
                    self.ring.nodes
                };
                self.vars.force_i(n, value as f64);
            }
            Some(Special::EctWord(n)) => self.vars.force_i(n, value as f64),
            Some(Special::FeedCmd(x)) if x <= self.limits.coords => {
                self.memory.write(space, addr, value);
                self.feed_written[x as usize - 1] = true;
            }
            Some(Special::P(n)) => {
                let old = encode_float(self.vars.p(n).unwrap_or(0.0));
                let _ = self
                    .vars
                    .set_p(n, decode_float(set_half(old, space, value)));
            }
            Some(Special::Q(n)) => {
                let old = encode_float(self.vars.q(1, n).unwrap_or(0.0));
                let _ = self
                    .vars
                    .set_q(1, n, decode_float(set_half(old, space, value)));
            }
            _ => self.memory.write(space, addr, value),
        }
    }

    /// Read the 48-bit long word at `addr` (X high), as `RL` shows it.
    pub fn read_long(&mut self, addr: Addr) -> u64 {
        mvar::long(self, addr)
    }

    /// Write the 48-bit long word at `addr` (X high), as `WL` does.
    pub fn write_long(&mut self, addr: Addr, w: u64) {
        mvar::set_long(self, addr, w)
    }

    // ---- `%` command registers (seed 6645-6650) -------------------------------------------

    /// Address of C.S. `cs`'s `%` command register (X), if mapped.
    fn feed_addr(&self, cs: u16) -> Option<Addr> {
        (cs >= 1 && cs <= self.limits.coords.min(self.map.mapped_coords))
            .then(|| self.map.cs_feed_cmd + Addr::from(cs - 1) * self.map.cs_stride)
    }

    /// Store the `%` command register of `cs` as the `%` command does (I10 units, 24-bit
    /// signed), without marking it written through memory.
    pub fn set_feed_word(&mut self, cs: u16, word: i64) {
        if let Some(a) = self.feed_addr(cs) {
            let w = word.clamp(-(1 << 23), (1 << 23) - 1) as u32 & 0xFF_FFFF;
            self.memory.write(Space::X, a, w);
        }
    }

    /// Every C.S.'s `%` command register at 100 % (= I10), as after power-up.
    pub(crate) fn reset_feed_words(&mut self) {
        let i10 = self.vars.i(10).unwrap_or(3_713_707.0);
        for cs in 1..=self.limits.coords {
            self.set_feed_word(cs, i10.round() as i64);
        }
        self.feed_written.iter_mut().for_each(|w| *w = false);
    }

    /// The value of C.S. `cs`'s `%` command register if an M-variable or `W` wrote it since
    /// the last call (the servo loop then applies it as an override).
    pub fn take_feed_write(&mut self, cs: u16) -> Option<i64> {
        let k = usize::from(cs).checked_sub(1)?;
        if !std::mem::take(self.feed_written.get_mut(k)?) {
            return None;
        }
        let w = self.memory.read(Space::X, self.feed_addr(cs)?);
        Some(i64::from(((w << 8) as i32) >> 8))
    }

    // ---- MACRO ring side (used by the runtime) ------------------------------------------

    /// Command registers of `node` as written by the card (what goes out on the ring).
    pub fn node_command(&self, node: usize) -> [u32; 4] {
        self.memory.node_command(node)
    }

    /// The MACRO node whose register 0 sits at `space:addr` (a motor's Ix02 output address).
    pub fn node_at(&self, space: Space, addr: Addr) -> Option<usize> {
        (0..16).find(|&n| self.map.node_addr(n, 0) == (space, addr))
    }

    /// The feedback registers of `node` as latched from the ring.
    pub fn node_feedback(&self, node: usize) -> [u32; 4] {
        self.memory.node_feedback(node)
    }

    /// Latch feedback registers of `node` received from the ring.
    pub fn set_node_feedback(&mut self, node: usize, regs: [u32; 4]) {
        self.memory.set_node_feedback(node, regs)
    }

    /// OR ring status bits (bits 0-3 error, bit 6 sync packet received) into the ring
    /// configuration variable (I995 / I6840).
    ///
    /// \[DECISION\] A synchronizing master (I995 bit 5) does not show bit 6 "sync node packet
    /// received": it generates the sync packet and does not phase-lock to one (bit 7 clear),
    /// so it reads its set-up `$30` as the manual gives it (seed 004 5495); the ring core
    /// still counts its own sync packet's returns in its check (the core's own copy).
    pub fn latch_ring_status(&mut self, bits: u32) {
        let a = self.map.ring_cfg_addr;
        let w = self.memory.read(Space::Y, a);
        let mut bits = bits & I995_STATUS_BITS;
        if w & I995_SYNC_MASTER != 0 {
            bits &= !I995_SYNC_RECEIVED;
        }
        self.memory.write(Space::Y, a, w | bits);
    }

    /// The ring configuration word with its latched status bits, without clearing them (a
    /// read of I995 / `MacroModeA` clears them).
    pub(crate) fn ring_cfg_latched(&self) -> u32 {
        self.memory.read(Space::Y, self.map.ring_cfg_addr)
    }

    /// Auxiliary images of `node`: `(X read/status image, Y write/command image)` (PMAC2
    /// $0F7n, Turbo $344n).
    pub fn aux_images(&self, node: usize) -> (u32, u32) {
        let a = self.map.aux_image(node);
        (self.memory.read(Space::X, a), self.memory.read(Space::Y, a))
    }

    /// Store the status image of `node` (copied from the node's auxiliary register).
    pub fn set_aux_status_image(&mut self, node: usize, value: u32) {
        let a = self.map.aux_image(node);
        self.memory.write(Space::X, a, value)
    }
}

fn half(w: u64, space: Space) -> u32 {
    match space {
        Space::X => ((w >> 24) & 0xFF_FFFF) as u32,
        Space::Y => (w & 0xFF_FFFF) as u32,
    }
}

fn set_half(w: u64, space: Space, v: u32) -> u64 {
    match space {
        Space::X => (w & 0xFF_FFFF) | ((v as u64) << 24),
        Space::Y => (w & 0xFFFF_FF00_0000) | v as u64,
    }
}

impl WordAccess for CardState {
    fn read_word(&mut self, space: Space, addr: Addr) -> u32 {
        self.read(space, addr)
    }
    fn write_word(&mut self, space: Space, addr: Addr, value: u32) {
        self.write(space, addr, value)
    }
}
