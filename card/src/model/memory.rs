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
/// First MACRO node register address.
pub(crate) const NODE_BASE: u16 = 0xC0A0;
/// Last MACRO node register address.
pub(crate) const NODE_LAST: u16 = 0xC0BF;

/// The node and register number (0..=3) that `space:addr` maps to, if it is a MACRO node
/// register. Servo nodes (0,1,4,5,8,9,12,13) are in Y, I/O nodes (2,3,6,7,10,11,14,15) in X.
pub(crate) fn node_of(space: Space, addr: u16) -> Option<(usize, usize)> {
    if !(NODE_BASE..=NODE_LAST).contains(&addr) {
        return None;
    }
    let off = (addr - NODE_BASE) as usize;
    let (group, within) = (off / 8, off % 8);
    let (half, reg) = (within / 4, within % 4);
    let node = 4 * group + half + if space == Space::X { 2 } else { 0 };
    Some((node, reg))
}

/// The X or Y address of register `reg` of `node` (inverse of [`node_of`]).
pub(crate) fn node_addr(node: usize, reg: usize) -> (Space, u16) {
    let node = node % 16;
    let group = node / 4;
    let space = if node % 4 >= 2 { Space::X } else { Space::Y };
    let half = node % 2;
    (space, NODE_BASE + (group * 8 + half * 4 + reg % 4) as u16)
}

/// Mask applied to register `reg` of a node: 24 bits for register 0, bits 8-23 otherwise.
pub(crate) fn node_mask(reg: usize) -> u32 {
    if reg == 0 {
        WORD
    } else {
        REG16
    }
}

/// X/Y memory image with MACRO node command/feedback sides.
#[derive(Debug, Clone)]
pub struct Memory {
    x: Vec<u32>,
    y: Vec<u32>,
    node_cmd: [[u32; 4]; 16],
    node_fb: [[u32; 4]; 16],
}

impl Default for Memory {
    fn default() -> Self {
        Memory {
            x: vec![0; 65536],
            y: vec![0; 65536],
            node_cmd: [[0; 4]; 16],
            node_fb: [[0; 4]; 16],
        }
    }
}

impl Memory {
    /// Read a short word (node registers return the latched feedback side).
    pub fn read(&self, space: Space, addr: u16) -> u32 {
        if let Some((node, reg)) = node_of(space, addr) {
            return self.node_fb[node][reg];
        }
        match space {
            Space::X => self.x[addr as usize],
            Space::Y => self.y[addr as usize],
        }
    }

    /// Write a short word (masked to 24 bits; node registers take the command side).
    pub fn write(&mut self, space: Space, addr: u16, value: u32) {
        if let Some((node, reg)) = node_of(space, addr) {
            self.node_cmd[node][reg] = value & node_mask(reg);
            return;
        }
        match space {
            Space::X => self.x[addr as usize] = value & WORD,
            Space::Y => self.y[addr as usize] = value & WORD,
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

    /// Copy of `count` words of `space` from `start` (wrapping at $FFFF), for persistence.
    pub fn snapshot(&self, space: Space, start: u16, count: usize) -> Vec<u32> {
        (0..count)
            .map(|i| self.read(space, start.wrapping_add(i as u16)))
            .collect()
    }

    /// Write back a snapshot taken with [`Memory::snapshot`].
    pub fn restore(&mut self, space: Space, start: u16, words: &[u32]) {
        for (i, w) in words.iter().enumerate() {
            self.write(space, start.wrapping_add(i as u16), *w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_layout_matches_spec_table() {
        assert_eq!(node_of(Space::Y, 0xC0A0), Some((0, 0)));
        assert_eq!(node_of(Space::Y, 0xC0A7), Some((1, 3)));
        assert_eq!(node_of(Space::X, 0xC0A0), Some((2, 0)));
        assert_eq!(node_of(Space::X, 0xC0A4), Some((3, 0)));
        assert_eq!(node_of(Space::Y, 0xC0A8), Some((4, 0)));
        assert_eq!(node_of(Space::X, 0xC0A9), Some((6, 1)));
        assert_eq!(node_of(Space::Y, 0xC0B2), Some((8, 2)));
        assert_eq!(node_of(Space::Y, 0xC0BC), Some((13, 0)));
        assert_eq!(node_of(Space::X, 0xC0BF), Some((15, 3)));
        assert_eq!(node_of(Space::Y, 0xC09F), None);
        assert_eq!(node_of(Space::Y, 0xC0C0), None);
        for node in 0..16 {
            for reg in 0..4 {
                let (s, a) = node_addr(node, reg);
                assert_eq!(node_of(s, a), Some((node, reg)));
            }
        }
    }

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
    }
}
