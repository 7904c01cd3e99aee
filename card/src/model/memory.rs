//! Raw 24-bit word memory: X and Y spaces, $0000-$FFFF, plus the MACRO node registers whose
//! write side (command, goes out on the ring) and read side (latched feedback) differ
//! (pmac-variables §6.5). Special registers computed from other state (status words, mirrored
//! I-variables, P/Q) are handled one level up, in `CardState` (see `regmap`).

/// Which half of PMAC memory a short word lives in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Space {
    /// X memory.
    X,
    /// Y memory.
    Y,
}

/// Mask of a 24-bit word.
pub(crate) const WORD: u32 = 0xFF_FFFF;
/// Mask of a 16-bit node register (bits 8-23).
pub(crate) const REG16: u32 = 0xFF_FF00;

use super::regmap::{Addr, MemMap};
use crate::domain::profile::Profile;

/// Mask applied to register `reg` of a node: 24 bits for register 0, bits 8-23 otherwise.
pub(crate) fn node_mask(reg: usize) -> u32 {
    if reg == 0 {
        WORD
    } else {
        REG16
    }
}

/// X/Y memory image with MACRO node command/feedback sides. Words below $10000 are a flat
/// array; the rest of a Turbo card's 19-bit space ($10000-$7FFFF: DPRAM, I/O ICs) is kept
/// sparsely (only words ever written exist).
#[derive(Debug, Clone)]
pub struct Memory {
    map: MemMap,
    x: Vec<u32>,
    y: Vec<u32>,
    high: std::collections::BTreeMap<(bool, Addr), u32>,
    node_cmd: [[u32; 4]; 16],
    node_fb: [[u32; 4]; 16],
}

impl Default for Memory {
    fn default() -> Self {
        Memory::new(Profile::Pmac2)
    }
}

impl Memory {
    /// Zeroed memory laid out as `profile`'s map.
    pub fn new(profile: Profile) -> Self {
        Memory {
            map: MemMap::of(profile),
            x: vec![0; 65536],
            y: vec![0; 65536],
            high: std::collections::BTreeMap::new(),
            node_cmd: [[0; 4]; 16],
            node_fb: [[0; 4]; 16],
        }
    }

    /// Read a short word (node registers return the latched feedback side).
    pub fn read(&self, space: Space, addr: Addr) -> u32 {
        if let Some((node, reg)) = self.map.node_of(space, addr) {
            return self.node_fb[node][reg];
        }
        match (space, usize::try_from(addr).ok().filter(|&a| a < 65536)) {
            (Space::X, Some(a)) => self.x[a],
            (Space::Y, Some(a)) => self.y[a],
            _ => self
                .high
                .get(&(space == Space::X, addr & WORD))
                .copied()
                .unwrap_or(0),
        }
    }

    /// Write a short word (masked to 24 bits; node registers take the command side).
    pub fn write(&mut self, space: Space, addr: Addr, value: u32) {
        if let Some((node, reg)) = self.map.node_of(space, addr) {
            self.node_cmd[node][reg] = value & node_mask(reg);
            return;
        }
        match (space, usize::try_from(addr).ok().filter(|&a| a < 65536)) {
            (Space::X, Some(a)) => self.x[a] = value & WORD,
            (Space::Y, Some(a)) => self.y[a] = value & WORD,
            _ => {
                // Bounded: at most one entry per 24-bit address ever written.
                self.high
                    .insert((space == Space::X, addr & WORD), value & WORD);
            }
        }
    }

    /// The command registers of `node` (0..=15) as last written by the card.
    pub fn node_command(&self, node: usize) -> [u32; 4] {
        self.node_cmd[node % 16]
    }

    /// Latch feedback registers of `node` received from the ring (each masked to its width).
    pub fn set_node_feedback(&mut self, node: usize, regs: [u32; 4]) {
        let fb = &mut self.node_fb[node % 16];
        for (r, v) in regs.iter().enumerate() {
            fb[r] = v & node_mask(r);
        }
    }

    /// The feedback registers of `node` as latched.
    pub fn node_feedback(&self, node: usize) -> [u32; 4] {
        self.node_fb[node % 16]
    }

    /// Clear every node command register (reset: "MACRO output registers cleared").
    pub fn clear_node_commands(&mut self) {
        self.node_cmd = [[0; 4]; 16];
    }

    /// Copy of `count` words of `space` from `start`, for persistence.
    pub fn snapshot(&self, space: Space, start: Addr, count: usize) -> Vec<u32> {
        (0..count)
            .map(|i| self.read(space, start.wrapping_add(i as Addr) & WORD))
            .collect()
    }

    /// Write back a snapshot taken with [`Memory::snapshot`].
    pub fn restore(&mut self, space: Space, start: Addr, words: &[u32]) {
        for (i, w) in words.iter().enumerate() {
            self.write(space, start.wrapping_add(i as Addr) & WORD, *w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_is_command_read_is_feedback() {
        let mut m = Memory::default();
        m.write(Space::Y, 0xC0A0, 0x123456);
        assert_eq!(m.read(Space::Y, 0xC0A0), 0);
        assert_eq!(m.node_command(0), [0x123456, 0, 0, 0]);
        m.write(Space::Y, 0xC0A3, 0xFFFFFF);
        assert_eq!(m.node_command(0)[3], 0xFFFF00);
        m.set_node_feedback(0, [0x1FFFFFF, 0xABCDEF, 0, 0x12]);
        assert_eq!(m.read(Space::Y, 0xC0A0), 0xFFFFFF);
        assert_eq!(m.read(Space::Y, 0xC0A1), 0xABCD00);
        assert_eq!(m.read(Space::Y, 0xC0A3), 0);
        m.clear_node_commands();
        assert_eq!(m.node_command(0), [0; 4]);
    }

    #[test]
    fn plain_words_are_24_bit() {
        let mut m = Memory::default();
        m.write(Space::X, 0x0F70, 0x1_000_001);
        assert_eq!(m.read(Space::X, 0x0F70), 1);
        assert_eq!(m.read(Space::Y, 0x0F70), 0);
        m.write(Space::Y, 0xFFFF, 7);
        assert_eq!(m.snapshot(Space::Y, 0xFFFF, 2), vec![7, 0]);
        // Turbo: the 19-bit space, MACRO IC 0 node registers at $078420.
        let mut t = Memory::new(Profile::Turbo);
        t.write(Space::X, 0x06_0000, 0x12_3456);
        assert_eq!(t.read(Space::X, 0x06_0000), 0x12_3456);
        assert_eq!(t.read(Space::Y, 0x06_0000), 0);
        t.write(Space::Y, 0x07_8424, 5);
        assert_eq!(t.node_command(1), [5, 0, 0, 0]);
        t.write(Space::Y, 0xC0A0, 9);
        assert_eq!(t.read(Space::Y, 0xC0A0), 9, "a plain word on Turbo");
    }
}
