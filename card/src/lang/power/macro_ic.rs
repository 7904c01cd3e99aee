//! The MACRO elements of a Power card's ring IC (power-pmac.md §3.2-3.5) on the card model:
//! `Gate3[0]` bank A (and its PMAC2-style view `Gate2[0]`) is the model's MACRO IC 0, the
//! IC on the cluster's ring; its node registers are the same registers the ring carries.
//!
//! - `MacroEnableA` is the ring node-enable word (I996 layout: node enables 0-15, sync node
//!   16-19, master number 20-23) shifted left by 8; `MacroModeA` the ring configuration and
//!   status word (I995 layout) shifted left by 8, its status bits cleared by the read. In
//!   `Gate2[0]` both are unshifted (`MacroEnable`, `MacroMode`).
//! - `MacroInA[j][k]` is node j's feedback register k as received, `MacroOutA[j][k]` its
//!   command register (written onto the ring; reads back what was written). The 24 ring bits
//!   of register 0 (16 of registers 1-3) sit in the upper bits of the 32-bit value.
//!   `Gate2[0].Macro[j][k]` reads the input and writes the output, as on a DSPGATE2.
//! - `MacroError` (status): one bit per enabled bank-A node while the IC's error latches
//!   (overrun, byte violation, parity, underrun) hold an error; the model keeps no per-node,
//!   per-cycle flags, so every enabled node of the IC shows it.
//!
//! Bank B and the other ICs carry no ring here: their elements keep their values in the
//! dialect (`None` from [`read`]/[`write`]).

use super::catalog::{St, DEFS};
use super::elements::{AccessError, Key, OUT_OF_RANGE};
use crate::model::{CardModel, Space};

/// Error latches of the ring configuration word (I995 bits 0-3).
const ERROR_BITS: u32 = 0x0F;

/// Sign-extend the 24-bit register value `v`.
fn signed24(v: u32) -> i64 {
    let v = i64::from(v & 0xFF_FFFF);
    if v & 0x80_0000 != 0 {
        v - 0x100_0000
    } else {
        v
    }
}

/// The 32-bit element value of a 24-bit ring register.
fn from_reg(v: u32) -> f64 {
    (signed24(v) * 256) as f64
}

/// The 24-bit ring register of a 32-bit element value.
fn to_reg(v: f64) -> Result<u32, AccessError> {
    if !v.is_finite() || !(-2_147_483_648.0..=4_294_967_295.0).contains(&v) {
        return Err(OUT_OF_RANGE);
    }
    let w = v.floor() as i64;
    Ok(((w >> 8) & 0xFF_FFFF) as u32)
}

/// The element of the ring IC `k` names: (name, shift of the control words).
fn ring_element(k: &Key) -> Option<(&'static str, u32)> {
    let name = DEFS[k.def].name;
    match (k.st, k.idx, name) {
        (St::Gate3, 0, "MacroEnableA" | "MacroModeA" | "MacroInA" | "MacroOutA" | "MacroError") => {
            Some((name, 8))
        }
        (St::Gate2, 0, "MacroEnable" | "MacroMode" | "Macro") => Some((name, 0)),
        _ => None,
    }
}

/// Read a ring-IC element (`None`: not one).
pub(crate) fn read(card: &mut CardModel, k: &Key) -> Option<f64> {
    let (name, shift) = ring_element(k)?;
    let st = &mut card.state;
    let rv = st.ring_ivars();
    let (node, reg) = (k.sub[0] as usize, k.sub[1] as usize);
    let v = match name {
        "MacroEnableA" | "MacroEnable" => {
            f64::from((st.peek_ivar(rv.nodes).unwrap_or(0.0) as u32) << shift)
        }
        "MacroModeA" | "MacroMode" => {
            let (space, addr) = (Space::Y, st.map().ring_cfg_addr);
            f64::from(st.read(space, addr) << shift)
        }
        "MacroError" => {
            let enabled = st.peek_ivar(rv.nodes).unwrap_or(0.0) as u32 & 0xFFFF;
            if st.ring_cfg_latched() & ERROR_BITS != 0 {
                f64::from(enabled)
            } else {
                0.0
            }
        }
        "MacroInA" | "Macro" => {
            let (space, addr) = st.map().node_addr(node, reg);
            from_reg(st.read(space, addr))
        }
        _ => from_reg(st.node_command(node)[reg % 4]),
    };
    Some(v)
}

/// Write a ring-IC element (`None`: not one).
pub(crate) fn write(card: &mut CardModel, k: &Key, v: f64) -> Option<Result<(), AccessError>> {
    let (name, shift) = ring_element(k)?;
    let st = &mut card.state;
    let rv = st.ring_ivars();
    let (node, reg) = (k.sub[0] as usize, k.sub[1] as usize);
    let word = |v: f64| -> Result<u32, AccessError> {
        if !(0.0..=4_294_967_295.0).contains(&v) {
            return Err(OUT_OF_RANGE);
        }
        Ok(((v as u64) >> shift) as u32 & 0xFF_FFFF)
    };
    let r = match name {
        "MacroEnableA" | "MacroEnable" => word(v).and_then(|w| {
            st.set_ivar(rv.nodes, f64::from(w))
                .map(|_| ())
                .map_err(|_| OUT_OF_RANGE)
        }),
        "MacroModeA" | "MacroMode" => word(v).and_then(|w| {
            st.set_ivar(rv.cfg, f64::from(w))
                .map(|_| ())
                .map_err(|_| OUT_OF_RANGE)
        }),
        "MacroOutA" | "Macro" => to_reg(v).map(|w| {
            let (space, addr) = st.map().node_addr(node, reg);
            st.write(space, addr, w);
        }),
        // MacroInA and MacroError are status elements (refused before this).
        _ => Err(super::elements::READ_ONLY),
    };
    Some(r)
}

/// Bit marking an X-space register in an element address (Y-space addresses are the model's
/// own, as the motor pointer I-variables hold them).
const X_SPACE: u32 = 1 << 19;

/// The address of a ring-IC register element (`Gate3[0].MacroInA/MacroOutA[j][k]`,
/// `Gate2[0].Macro[j][k]`): the model's address of node j's register k, which is what the
/// Motor pointer elements hold (`Motor[x].pDac=Gate3[0].MacroOutA[j][0].a` re-points the
/// motor); `None` for any other element.
pub(crate) fn register_address(card: &CardModel, k: &Key) -> Option<u32> {
    let (name, _) = ring_element(k)?;
    if !matches!(name, "MacroInA" | "MacroOutA" | "Macro") {
        return None;
    }
    let (space, addr) = card
        .state
        .map()
        .node_addr(k.sub[0] as usize, k.sub[1] as usize);
    Some(addr | if space == Space::X { X_SPACE } else { 0 })
}

/// The ring-IC register element at address `a` (see [`register_address`]) as a pointer reads
/// back: `Gate3[0].MacroOutA[j][k].a` for an output pointer (`out`), `Gate3[0].MacroInA[j][k].a`
/// otherwise; `None` when `a` is no ring register.
pub(crate) fn register_name(card: &CardModel, a: f64, out: bool) -> Option<String> {
    if !(a.is_finite() && a > 0.0 && a <= f64::from(u32::MAX)) {
        return None;
    }
    let a = a as u32;
    let space = if a & X_SPACE != 0 { Space::X } else { Space::Y };
    let map = card.state.map();
    let (node, reg) = map.node_of(space, a & !X_SPACE & map.max_addr)?;
    if (a & !X_SPACE) > map.max_addr {
        return None;
    }
    let bank = if out { "MacroOutA" } else { "MacroInA" };
    Some(format!("Gate3[0].{bank}[{node}][{reg}].a"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;
    use crate::lang::power::Power;
    use crate::lang::Card;

    fn send(card: &mut Card, p: &mut Power, line: &str) -> String {
        let r = String::from_utf8(p.line(card, 1, line.as_bytes())).unwrap();
        r.strip_suffix("\x06\r\n").unwrap().to_string()
    }

    /// Gate3[0] bank A is the ring IC: the node registers the ring carries, the I6840/I6841
    /// words shifted left by 8 (Gate2[0] unshifted), errors per enabled node.
    #[test]
    fn gate3_bank_a_is_the_ring_ic() {
        let mut card = Card::new(Profile::Power);
        let mut p = Power::new();
        send(&mut card, &mut p, "echo7");
        card.model
            .state
            .set_node_feedback(0, [0x00_0100, 0x12_3400, 0, 0]);
        assert_eq!(
            send(&mut card, &mut p, "Gate3[0].MacroInA[0][0]"),
            "65536\r\n"
        );
        assert_eq!(
            send(&mut card, &mut p, "Gate3[0].MacroInA[0][1]"),
            "305397760\r\n"
        );
        assert_eq!(send(&mut card, &mut p, "Gate2[0].Macro[0][0]"), "65536\r\n");
        // Outputs go to the command registers and read back (negative values too).
        send(&mut card, &mut p, "Gate3[0].MacroOutA[1][0]=$12345600");
        send(&mut card, &mut p, "Gate3[0].MacroOutA[4][0]=-512");
        assert_eq!(card.model.state.node_command(1)[0], 0x12_3456);
        assert_eq!(card.model.state.node_command(4)[0], 0xFF_FFFE);
        assert_eq!(
            send(&mut card, &mut p, "Gate3[0].MacroOutA[1][0]"),
            "305419776\r\n"
        );
        assert_eq!(
            send(&mut card, &mut p, "Gate3[0].MacroOutA[4][0]"),
            "-512\r\n"
        );
        // The control words.
        send(
            &mut card,
            &mut p,
            "Gate3[0].MacroEnableA=$30003300 Gate3[0].MacroModeA=$3000",
        );
        let rv = card.model.state.ring_ivars();
        assert_eq!(
            card.model.state.peek_ivar(rv.nodes),
            Ok(f64::from(0x30_0033))
        );
        assert_eq!(card.model.state.peek_ivar(rv.cfg), Ok(f64::from(0x30)));
        assert_eq!(
            send(&mut card, &mut p, "Gate2[0].MacroEnable"),
            "$300033\r\n"
        );
        assert_eq!(send(&mut card, &mut p, "Gate3[0].MacroError"), "$0\r\n");
        // A ring error latch: every enabled node shows it; MacroModeA's read clears it.
        card.model.state.latch_ring_status(0x04);
        assert_eq!(send(&mut card, &mut p, "Gate3[0].MacroError"), "$33\r\n");
        assert_eq!(send(&mut card, &mut p, "Gate3[0].MacroModeA"), "$3400\r\n");
        assert_eq!(send(&mut card, &mut p, "Gate3[0].MacroModeA"), "$3000\r\n");
        assert_eq!(send(&mut card, &mut p, "Gate3[0].MacroError"), "$0\r\n");
        // Inputs and the error word are status; bank B and other ICs carry no ring.
        let r = send(&mut card, &mut p, "Gate3[0].MacroInA[0][0]=1");
        assert!(r.contains("error #23"), "{r}");
        send(
            &mut card,
            &mut p,
            "Gate3[1].MacroOutA[0][0]=$100 Gate3[0].MacroOutB[0][0]=$200",
        );
        assert_eq!(card.model.state.node_command(0)[0], 0);
        assert_eq!(
            send(&mut card, &mut p, "Gate3[1].MacroOutA[0][0]"),
            "256\r\n"
        );
        let r = send(&mut card, &mut p, "Gate3[0].MacroOutA[16][0]=1");
        assert!(r.contains("error #21"), "{r}");
    }

    #[test]
    fn registers_sit_in_the_upper_bits() {
        assert_eq!(from_reg(0x00_0001), 256.0);
        assert_eq!(from_reg(0xFF_FFFF), -256.0);
        assert_eq!(to_reg(-256.0), Ok(0xFF_FFFF));
        assert_eq!(to_reg(0x1234_5678 as f64), Ok(0x12_3456));
        assert_eq!(to_reg(f64::NAN), Err(OUT_OF_RANGE));
    }
}
