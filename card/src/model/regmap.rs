//! Addresses of the special registers, per profile ([`MemMap`]).
//!
//! **PMAC2** (pmac-variables §7): global status X/Y:$0003, motor x calculation block at
//! $0020 + (x−1)·$3C (status word 1 X:$003D…) and status/control block at $0800 + (x−1)·$C0
//! (status word 2 Y:$0814…), C.S. status X:$0818/Y:$0817 + (x−1)·$C0, MACRO node registers
//! X/Y:$C0A0-$C0BF, I995/I996 mirrors Y:$C08F/$C08E, ECT Y:$0720-$073F, auxiliary flag images
//! X/Y:$0F70-$0F7F, P0.. at L:$1000, Q0.. at L:$1400.
//!
//! **Turbo** [DECISION, from the Turbo suggested M-variables]: motor xx block at
//! $0080 + (xx−1)·$80 (status words X:$00B0/Y:$00C0, commanded D:$0088, actual D:$008B,
//! velocity X:$009D, filter output X:$00BF, target D:$00C7, position bias D:$00CC, home
//! capture Y:$00CE, jog register L:$00D7), global status X/Y:$0006, C.S. s status
//! X:$2040/Y:$203F (third word Y:$2040) + (s−1)·$100, MACRO IC 0 node registers
//! X/Y:$078420-$07843F, its ring setup I6840/I6841 mirrored at Y:$07840F/$07840E (the same
//! offsets from the IC base $078400 as I995/I996 from PMAC2's $C080), ECT Y:$3501-$35C0
//! (= I8000-I8191), flag images X/Y:$3440-$344F, P0.. at L:$6000, Q0.. at L:$8000.

use super::memory::Space;
use crate::domain::profile::Profile;

/// A memory address (24 bits on Turbo, 16 on PMAC2).
pub(crate) type Addr = u32;

/// MACRO auxiliary error value (X), both profiles.
pub(crate) const AUX_ERROR_VALUE: Addr = 0x0798;
/// The servo cycle counter (X), both profiles.
pub(crate) const SERVO_COUNTER: Addr = 0x0000;

/// Where one profile keeps its special registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct MemMap {
    /// Global status words 1 (X) and 2 (Y).
    pub(crate) global_status: Addr,
    /// Motor 1 status word 1 (X), stride [`MemMap::motor_stride1`].
    pub(crate) motor_status1: Addr,
    /// Stride of motor status word 1.
    pub(crate) motor_stride1: Addr,
    /// Motor 1 status word 2 (Y), stride [`MemMap::motor_stride2`].
    pub(crate) motor_status2: Addr,
    /// Stride of motor status word 2.
    pub(crate) motor_stride2: Addr,
    /// Motors with a register block.
    pub(crate) mapped_motors: u16,
    /// C.S. 1 status word 1 (X).
    pub(crate) cs_status1: Addr,
    /// C.S. 1 status word 2 (Y).
    pub(crate) cs_status2: Addr,
    /// C.S. 1 status word 3 (Y), Turbo only.
    pub(crate) cs_status3: Option<Addr>,
    /// Stride between C.S. blocks.
    pub(crate) cs_stride: Addr,
    /// C.S. 1's `%` command register (X), signed, I10 units.
    pub(crate) cs_feed_cmd: Addr,
    /// C.S.s with a register block.
    pub(crate) mapped_coords: u16,
    /// First MACRO node register (node 0 register 0 in Y).
    pub(crate) node_base: Addr,
    /// Mirror of the ring configuration I-variable (I995 / I6840), Y.
    pub(crate) ring_cfg_addr: Addr,
    /// Mirror of the node activation I-variable (I996 / I6841), Y.
    pub(crate) ring_nodes_addr: Addr,
    /// First ECT setup word (Y).
    pub(crate) ect_start: Addr,
    /// Last word of the ECT area.
    pub(crate) ect_end: Addr,
    /// Auxiliary flag image of node 0 (X = read image, Y = write image).
    pub(crate) aux_image_base: Addr,
    /// L address of P0 and the number of P variables mapped.
    pub(crate) p_base: (Addr, u32),
    /// L address of C.S. 1's Q0 and the number mapped.
    pub(crate) q_base: (Addr, u32),
    /// I-variable number of the first ECT word when the table is I-variables (Turbo I8000).
    pub(crate) ect_ivar: Option<u32>,
    /// Hex digits an address prints with in `Mn->` replies.
    pub(crate) addr_digits: usize,
    /// Largest address accepted.
    pub(crate) max_addr: Addr,
    /// Machine-input word (Y) whose bit 1 is MI2, the `GATHER TRIGGER` input: PMAC2
    /// Y:$FFC2 (JOPTO, seed 15527), Turbo Y:$078802.
    pub(crate) machine_inputs: Addr,
}

/// Offsets of the motor registers the servo loop maintains, from a motor's block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct MotorRegs {
    /// D: commanded position (Mx61).
    pub(crate) commanded: Addr,
    /// D: actual position (Mx62).
    pub(crate) actual: Addr,
    /// X: actual velocity (Mx66).
    pub(crate) velocity: Addr,
    /// X: filter output (Mx68).
    pub(crate) filter: Addr,
    /// D: target (pre-jog / most recent programmed) position (Mx63).
    pub(crate) target: Addr,
    /// D: position bias (Mx64).
    pub(crate) bias: Addr,
    /// L: variable jog position/distance (Mx72).
    pub(crate) jog: Addr,
    /// Y: home capture position, counts (Mx73), where the profile has one.
    pub(crate) capture: Option<Addr>,
}

impl MemMap {
    /// The map of `profile`.
    pub(crate) const fn of(profile: Profile) -> MemMap {
        match profile {
            Profile::Pmac2 => MemMap {
                global_status: 0x0003,
                motor_status1: 0x003D,
                motor_stride1: 0x3C,
                motor_status2: 0x0814,
                motor_stride2: 0xC0,
                mapped_motors: 8,
                cs_status1: 0x0818,
                cs_status2: 0x0817,
                cs_status3: None,
                cs_stride: 0xC0,
                cs_feed_cmd: 0x0806,
                mapped_coords: 8,
                node_base: 0xC0A0,
                ring_cfg_addr: 0xC08F,
                ring_nodes_addr: 0xC08E,
                ect_start: 0x0720,
                ect_end: 0x073F,
                aux_image_base: 0x0F70,
                p_base: (0x1000, 1024),
                q_base: (0x1400, 1024),
                ect_ivar: None,
                addr_digits: 4,
                max_addr: 0xFFFF,
                machine_inputs: 0xFFC2,
            },
            Profile::Turbo | Profile::Power => MemMap {
                global_status: 0x0006,
                motor_status1: 0x00B0,
                motor_stride1: 0x80,
                motor_status2: 0x00C0,
                motor_stride2: 0x80,
                mapped_motors: 32,
                cs_status1: 0x2040,
                cs_status2: 0x203F,
                cs_status3: Some(0x2040),
                cs_stride: 0x100,
                cs_feed_cmd: 0x2000,
                mapped_coords: 16,
                node_base: 0x07_8420,
                ring_cfg_addr: 0x07_840F,
                ring_nodes_addr: 0x07_840E,
                ect_start: 0x3501,
                ect_end: 0x35C0,
                aux_image_base: 0x3440,
                p_base: (0x6000, 8192),
                q_base: (0x8000, 8192),
                ect_ivar: Some(8000),
                addr_digits: 6,
                max_addr: 0x7_FFFF,
                machine_inputs: 0x07_8802,
            },
        }
    }

    /// The motor register block of motor `x` (1-based), `None` beyond the mapped motors.
    pub(crate) fn motor_regs(&self, x: u16) -> Option<MotorRegs> {
        if x == 0 || x > self.mapped_motors {
            return None;
        }
        let k = Addr::from(x - 1);
        Some(if self.addr_digits == 4 {
            let calc = 0x0020 + k * 0x3C;
            let block = 0x0800 + k * 0xC0;
            MotorRegs {
                commanded: calc + 0x08,
                actual: calc + 0x0B,
                velocity: calc + 0x13,
                filter: calc + 0x23,
                target: block + 0x0B,
                bias: block + 0x13,
                jog: block + 0x2B,
                capture: None,
            }
        } else {
            let b = 0x0080 + k * 0x80;
            MotorRegs {
                commanded: b + 0x08,
                actual: b + 0x0B,
                velocity: b + 0x1D,
                filter: b + 0x3F,
                target: b + 0x47,
                bias: b + 0x4C,
                jog: b + 0x57,
                capture: Some(b + 0x4E),
            }
        })
    }

    /// Following-error register addresses of motor `x` (PMAC2: calculation block + $2B and
    /// status block + $40).
    pub(crate) fn following_regs(&self, x: u16) -> Vec<Addr> {
        if self.addr_digits != 4 || x == 0 || x > self.mapped_motors {
            return Vec::new();
        }
        let k = Addr::from(x - 1);
        vec![0x0020 + k * 0x3C + 0x2B, 0x0800 + k * 0xC0 + 0x40]
    }

    /// The auxiliary flag image address of `node`.
    pub(crate) fn aux_image(&self, node: usize) -> Addr {
        self.aux_image_base + (node % 16) as Addr
    }

    /// The node and register number (0..=3) that `space:addr` maps to, if it is a MACRO node
    /// register. Servo nodes (0,1,4,5,8,9,12,13) are in Y, I/O nodes (2,3,6,7,…) in X.
    pub(crate) fn node_of(&self, space: Space, addr: Addr) -> Option<(usize, usize)> {
        if addr < self.node_base || addr > self.node_base + 0x1F {
            return None;
        }
        let off = (addr - self.node_base) as usize;
        let (group, within) = (off / 8, off % 8);
        let (half, reg) = (within / 4, within % 4);
        let node = 4 * group + half + if space == Space::X { 2 } else { 0 };
        Some((node, reg))
    }

    /// The X or Y address of register `reg` of `node` (inverse of [`MemMap::node_of`]).
    pub(crate) fn node_addr(&self, node: usize, reg: usize) -> (Space, Addr) {
        let node = node % 16;
        let group = node / 4;
        let space = if node % 4 >= 2 { Space::X } else { Space::Y };
        let half = node % 2;
        (
            space,
            self.node_base + (group * 8 + half * 4 + reg % 4) as Addr,
        )
    }

    /// Classify `space:addr`.
    pub(crate) fn classify(&self, space: Space, addr: Addr) -> Option<Special> {
        if addr == self.global_status {
            return Some(Special::Global(if space == Space::X { 1 } else { 2 }));
        }
        let (pb, pn) = self.p_base;
        if addr >= pb && addr < pb + pn {
            return Some(Special::P(addr - pb));
        }
        let (qb, qn) = self.q_base;
        if addr >= qb && addr < qb + qn {
            return Some(Special::Q(addr - qb));
        }
        let block = |first: Addr, stride: Addr, n: u16| -> Option<u16> {
            (addr >= first
                && addr <= first + Addr::from(n - 1) * stride
                && (addr - first) % stride == 0)
                .then(|| ((addr - first) / stride + 1) as u16)
        };
        match space {
            Space::X => {
                if let Some(x) = block(self.motor_status1, self.motor_stride1, self.mapped_motors) {
                    return Some(Special::Motor(x, 1));
                }
                if let Some(x) = block(self.cs_status1, self.cs_stride, self.mapped_coords) {
                    return Some(Special::Coord(x, 1));
                }
                if let Some(x) = block(self.cs_feed_cmd, self.cs_stride, self.mapped_coords) {
                    return Some(Special::FeedCmd(x));
                }
            }
            Space::Y => {
                if let Some(x) = block(self.motor_status2, self.motor_stride2, self.mapped_motors) {
                    return Some(Special::Motor(x, 2));
                }
                if let Some(x) = block(self.cs_status2, self.cs_stride, self.mapped_coords) {
                    return Some(Special::Coord(x, 2));
                }
                if let Some(a3) = self.cs_status3 {
                    if let Some(x) = block(a3, self.cs_stride, self.mapped_coords) {
                        return Some(Special::Coord(x, 3));
                    }
                }
                if addr == self.ring_cfg_addr {
                    return Some(Special::RingCfg);
                }
                if addr == self.ring_nodes_addr {
                    return Some(Special::RingNodes);
                }
                if let Some(first) = self.ect_ivar {
                    if addr >= self.ect_start && addr <= self.ect_end {
                        return Some(Special::EctWord(first + (addr - self.ect_start)));
                    }
                }
            }
        }
        None
    }
}

/// What a special address holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Special {
    /// Global status word 1 or 2.
    Global(u8),
    /// Motor x status word 1 or 2.
    Motor(u16, u8),
    /// C.S. x status word 1, 2 (or 3 on Turbo).
    Coord(u16, u8),
    /// The ring configuration I-variable mirror (I995 / I6840).
    RingCfg,
    /// The node activation I-variable mirror (I996 / I6841).
    RingNodes,
    /// An ECT word that is also an I-variable (Turbo I8000-I8191).
    EctWord(u32),
    /// C.S. x's `%` command register (Ix93's default target, seed 6645-6650).
    FeedCmd(u16),
    /// Half of P-variable n's 48-bit float (X = high, Y = low).
    P(u32),
    /// Half of C.S. 1's Q-variable n.
    Q(u32),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pmac2_addresses() {
        let m = MemMap::of(Profile::Pmac2);
        assert_eq!(m.classify(Space::X, 0x0003), Some(Special::Global(1)));
        assert_eq!(m.classify(Space::Y, 0x0003), Some(Special::Global(2)));
        assert_eq!(m.classify(Space::X, 0x0079), Some(Special::Motor(2, 1)));
        assert_eq!(m.classify(Space::Y, 0x08D4), Some(Special::Motor(2, 2)));
        assert_eq!(m.classify(Space::X, 0x0D58), Some(Special::Coord(8, 1)));
        assert_eq!(m.classify(Space::Y, 0x0817), Some(Special::Coord(1, 2)));
        assert_eq!(m.classify(Space::Y, 0xC08F), Some(Special::RingCfg));
        assert_eq!(m.classify(Space::X, 0xC08F), None);
        assert_eq!(m.classify(Space::X, 0x1001), Some(Special::P(1)));
        assert_eq!(m.classify(Space::Y, 0x17FF), Some(Special::Q(1023)));
        assert_eq!(m.classify(Space::X, 0x0814), None);
        assert_eq!(m.classify(Space::X, 0x01F9), None);
        assert_eq!(m.classify(Space::X, 0x0806), Some(Special::FeedCmd(1)));
        assert_eq!(m.classify(Space::X, 0x08C6), Some(Special::FeedCmd(2)));
        assert_eq!(m.classify(Space::Y, 0x0806), None);
        let r = m.motor_regs(2).unwrap();
        assert_eq!(
            (r.actual, r.target, r.bias, r.jog),
            (0x0067, 0x08CB, 0x08D3, 0x08EB)
        );
    }

    #[test]
    fn pmac2_node_registers() {
        let m = MemMap::of(Profile::Pmac2);
        assert_eq!(m.node_of(Space::Y, 0xC0A0), Some((0, 0)));
        assert_eq!(m.node_of(Space::Y, 0xC0A7), Some((1, 3)));
        assert_eq!(m.node_of(Space::X, 0xC0A0), Some((2, 0)));
        assert_eq!(m.node_of(Space::X, 0xC0A4), Some((3, 0)));
        assert_eq!(m.node_of(Space::Y, 0xC0A8), Some((4, 0)));
        assert_eq!(m.node_of(Space::X, 0xC0A9), Some((6, 1)));
        assert_eq!(m.node_of(Space::Y, 0xC0B2), Some((8, 2)));
        assert_eq!(m.node_of(Space::Y, 0xC0BC), Some((13, 0)));
        assert_eq!(m.node_of(Space::X, 0xC0BF), Some((15, 3)));
        assert_eq!(m.node_of(Space::Y, 0xC09F), None);
        assert_eq!(m.node_of(Space::Y, 0xC0C0), None);
        for node in 0..16 {
            for reg in 0..4 {
                let (s, a) = m.node_addr(node, reg);
                assert_eq!(m.node_of(s, a), Some((node, reg)));
            }
        }
    }

    #[test]
    fn turbo_addresses() {
        let m = MemMap::of(Profile::Turbo);
        assert_eq!(m.classify(Space::X, 0x0006), Some(Special::Global(1)));
        assert_eq!(m.classify(Space::X, 0x00B0), Some(Special::Motor(1, 1)));
        assert_eq!(m.classify(Space::Y, 0x0140), Some(Special::Motor(2, 2)));
        assert_eq!(m.classify(Space::Y, 0x1040), Some(Special::Motor(32, 2)));
        assert_eq!(m.classify(Space::X, 0x2140), Some(Special::Coord(2, 1)));
        assert_eq!(m.classify(Space::Y, 0x203F), Some(Special::Coord(1, 2)));
        assert_eq!(m.classify(Space::Y, 0x2040), Some(Special::Coord(1, 3)));
        assert_eq!(m.classify(Space::Y, 0x3501), Some(Special::EctWord(8000)));
        assert_eq!(m.classify(Space::X, 0x2100), Some(Special::FeedCmd(2)));
        assert_eq!(m.classify(Space::Y, 0x07_840F), Some(Special::RingCfg));
        assert_eq!(m.classify(Space::X, 0x6001), Some(Special::P(1)));
        assert_eq!(m.node_of(Space::Y, 0x07_8428), Some((4, 0)));
        assert_eq!(m.node_addr(13, 3), (Space::Y, 0x07_843F));
        let r = m.motor_regs(1).unwrap();
        assert_eq!((r.actual, r.jog, r.bias), (0x008B, 0x00D7, 0x00CC));
        assert_eq!(m.aux_image(4), 0x3444);
    }
}
