//! Addresses of the special registers of the PMAC2 memory map (pmac-variables §7).
//! Motors/C.S. beyond 8 (Turbo profile) have no register-map address: their status is
//! reachable through `?`/`??` only.

use super::memory::Space;

/// Global status word 1 (X) and word 2 (Y).
pub(crate) const GLOBAL_STATUS: u16 = 0x0003;
/// Motor 1 calculation block base; motor x at + (x−1)·$3C.
pub(crate) const MOTOR_CALC_BASE: u16 = 0x0020;
/// Stride between motor calculation blocks.
pub(crate) const MOTOR_CALC_STRIDE: u16 = 0x3C;
/// Motor/C.S. 1 status and control block; block x at + (x−1)·$C0.
pub(crate) const BLOCK_BASE: u16 = 0x0800;
/// Stride between motor/C.S. status blocks.
pub(crate) const BLOCK_STRIDE: u16 = 0xC0;
/// I995 mirror (MACRO ring configuration/status).
pub(crate) const I995_ADDR: u16 = 0xC08F;
/// I996 mirror (MACRO node activation).
pub(crate) const I996_ADDR: u16 = 0xC08E;
/// Auxiliary flag images of node 0..15: X = read (status) image, Y = write (command) image.
pub(crate) const AUX_IMAGE_BASE: u16 = 0x0F70;
/// MACRO auxiliary error value (X).
pub(crate) const AUX_ERROR_VALUE: u16 = 0x0798;
/// P0 in L memory (PMAC2 only, P0..P1023).
pub(crate) const P_BASE: u16 = 0x1000;
/// Q0 in L memory (C.S. 1's set, Q0..Q1023).
pub(crate) const Q_BASE: u16 = 0x1400;
/// Start of the encoder conversion table (Y = setup, X = results).
pub(crate) const ECT_BASE: u16 = 0x0720;
/// Address of motor status word 1 (X) for motor `x` (1..=8).
#[cfg(test)]
pub(crate) fn motor_status1(x: u16) -> u16 {
    0x003Du16.wrapping_add(x.saturating_sub(1).wrapping_mul(MOTOR_CALC_STRIDE))
}
/// Address of motor status word 2 (Y) for motor `x` (1..=8).
#[cfg(test)]
pub(crate) fn motor_status2(x: u16) -> u16 {
    0x0814u16.wrapping_add(x.saturating_sub(1).wrapping_mul(BLOCK_STRIDE))
}
/// Address of C.S. status word 1 (X) for C.S. `x` (1..=8).
#[cfg(test)]
pub(crate) fn cs_status1(x: u16) -> u16 {
    0x0818u16.wrapping_add(x.saturating_sub(1).wrapping_mul(BLOCK_STRIDE))
}
/// Address of C.S. status word 2 (Y) for C.S. `x` (1..=8).
#[cfg(test)]
pub(crate) fn cs_status2(x: u16) -> u16 {
    0x0817u16.wrapping_add(x.saturating_sub(1).wrapping_mul(BLOCK_STRIDE))
}

/// What a special address holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Special {
    /// Global status word 1 or 2.
    Global(u8),
    /// Motor x status word 1 or 2.
    Motor(u16, u8),
    /// C.S. x status word 1 or 2.
    Coord(u16, u8),
    /// I-variable mirror.
    IVar(u16),
    /// Half of P-variable n's 48-bit float (X = high, Y = low).
    P(u16),
    /// Half of C.S. 1's Q-variable n.
    Q(u16),
}

/// Classify `space:addr` (PMAC2 map, 8 motors / 8 C.S.).
pub(crate) fn classify(space: Space, addr: u16) -> Option<Special> {
    if addr == GLOBAL_STATUS {
        return Some(Special::Global(if space == Space::X { 1 } else { 2 }));
    }
    if (P_BASE..P_BASE + 1024).contains(&addr) {
        return Some(Special::P(addr - P_BASE));
    }
    if (Q_BASE..Q_BASE + 1024).contains(&addr) {
        return Some(Special::Q(addr - Q_BASE));
    }
    match space {
        Space::X => {
            if (0x003D..=0x003D + 7 * MOTOR_CALC_STRIDE).contains(&addr)
                && (addr - 0x003D) % MOTOR_CALC_STRIDE == 0
            {
                return Some(Special::Motor((addr - 0x003D) / MOTOR_CALC_STRIDE + 1, 1));
            }
            if block_of(addr, 0x0818).is_some() {
                return block_of(addr, 0x0818).map(|x| Special::Coord(x, 1));
            }
        }
        Space::Y => {
            if let Some(x) = block_of(addr, 0x0814) {
                return Some(Special::Motor(x, 2));
            }
            if let Some(x) = block_of(addr, 0x0817) {
                return Some(Special::Coord(x, 2));
            }
            if addr == I995_ADDR {
                return Some(Special::IVar(995));
            }
            if addr == I996_ADDR {
                return Some(Special::IVar(996));
            }
        }
    }
    None
}

fn block_of(addr: u16, first: u16) -> Option<u16> {
    if addr >= first && addr <= first + 7 * BLOCK_STRIDE && (addr - first) % BLOCK_STRIDE == 0 {
        Some((addr - first) / BLOCK_STRIDE + 1)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_addresses() {
        assert_eq!(motor_status1(1), 0x003D);
        assert_eq!(motor_status1(2), 0x0079);
        assert_eq!(motor_status2(8), 0x0D54);
        assert_eq!(cs_status1(2), 0x08D8);
        assert_eq!(cs_status2(1), 0x0817);
        assert_eq!(classify(Space::X, 0x0003), Some(Special::Global(1)));
        assert_eq!(classify(Space::Y, 0x0003), Some(Special::Global(2)));
        assert_eq!(classify(Space::X, 0x0079), Some(Special::Motor(2, 1)));
        assert_eq!(classify(Space::Y, 0x08D4), Some(Special::Motor(2, 2)));
        assert_eq!(classify(Space::X, 0x0D58), Some(Special::Coord(8, 1)));
        assert_eq!(classify(Space::Y, 0x0817), Some(Special::Coord(1, 2)));
        assert_eq!(classify(Space::Y, 0xC08F), Some(Special::IVar(995)));
        assert_eq!(classify(Space::X, 0xC08F), None);
        assert_eq!(classify(Space::X, 0x1001), Some(Special::P(1)));
        assert_eq!(classify(Space::Y, 0x17FF), Some(Special::Q(1023)));
        assert_eq!(classify(Space::X, 0x0814), None);
        assert_eq!(classify(Space::X, 0x01F9), None);
    }
}
