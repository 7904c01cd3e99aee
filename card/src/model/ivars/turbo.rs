//! Turbo host-compatibility I-variable table (host-protocols.md §4.0, issue 14).
//!
//! Numbering as a Turbo PMAC2 Ultralite: I0-I99 global (PMAC2 meanings except I20-I23 = MACRO
//! IC base addresses, I68 = number of C.S. − 1 = 15, I70-I82 = MACRO IC 0 software setup),
//! Ixx00-Ixx99 motor xx (xx = 1..32, I100-I3299), I5000-I5099 global (gather), Isx00-Isx99 C.S.
//! s (s = 1..16, I5100-I6699; Isx11/Isx12 = user countdown timers, Isx87-Isx99 take the PMAC2
//! Ix87-Ix99 meanings), I6800-I6849 MACRO IC 0 (I6840 ring configuration, I6841 node
//! activation), I8000-I8191 the encoder conversion table (Y:$3501-$35C0), everything else up
//! to I8191 stored generically. Ixx24 is the Turbo flag-mode word, printed in hex.
//!
//! [DECISION] The factory motor addresses are the Ultralite's "motor on MACRO node" set:
//! Ixx02 = $078420 + 4(xx−1) (nodes 0,1,4,5,8,9,12,13 of MACRO IC 0), Ixx03/Ixx04 = the ECT
//! result $3502 + 2(xx−1), Ixx25 = the node's auxiliary flag image $3440 + node, Ixx24 =
//! $40001 (flags through MACRO), for motors 1-8; motors 9-32 have no MACRO IC (0).

use super::{pmac2, IVarSpec as S, S24MAX, U24};

/// MACRO IC 0 base address (I20 when the card serves ring nodes).
pub(crate) const MACRO_IC0_BASE: u32 = 0x07_8400;
/// Node 0 register 0 of MACRO IC 0.
pub(crate) const NODE_BASE: u32 = 0x07_8420;
/// First ECT word (I8000).
pub(crate) const ECT_START: u32 = 0x3501;
/// Auxiliary flag image of node 0.
pub(crate) const FLAG_IMAGE_BASE: u32 = 0x3440;

/// Servo-node base register of motor x (1..=8) on MACRO IC 0.
pub(crate) fn motor_node_reg(x: u16) -> u32 {
    NODE_BASE + 4 * u32::from(x.saturating_sub(1))
}

/// Spec of Turbo motor variable Ixxnn for motor `m` (1..=32).
pub(crate) fn motor(m: u16, nn: u16) -> S {
    let on_ic0 = (1..=8).contains(&m);
    let addr = |v: u32| {
        S::hex(
            if on_ic0 { f64::from(v) } else { 0.0 },
            f64::from(0x7_FFFFu32),
        )
    };
    match nn {
        2 => addr(motor_node_reg(m)),
        3 | 4 => addr(ECT_START + 1 + 2 * u32::from(m.saturating_sub(1))),
        5 => S::hex(0x35C0 as f64, U24),
        // Turbo flag control word: bit 0 = PMAC2-style flags, bit 18 = flags via MACRO.
        24 => S::hex(if on_ic0 { 0x40001 as f64 } else { 0.0 }, U24),
        25 => addr(FLAG_IMAGE_BASE + pmac2::motor_node(m)),
        83 => addr(motor_node_reg(m)),
        0..=86 => {
            let mut s = pmac2::motor(m.min(8), nn);
            if m > 8 && nn == 0 {
                s.default = 0.0;
            }
            s
        }
        // Ixx97 position capture and trigger mode (bit 0 software capture, bit 1 FE trigger).
        97 => S::int(0.0, 0.0, 3.0),
        _ => S::generic(),
    }
}

/// Spec of Turbo global variable `n` (0..=99).
fn global(n: u16) -> S {
    match n {
        // Set by the card at start-up from the MACRO ICs it has (`$0` = absent).
        20..=23 => S::hex(0.0, f64::from(0x7_FFFFu32)).ro(),
        68 => S::int(15.0, 0.0, 15.0),
        // MACRO IC 0-3 node auxiliary register enable / protocol type (I70-I77).
        70..=77 => S::hex(0.0, 65_535.0),
        78 | 79 => S::int(0.0, 0.0, 255.0),
        80 => S::int(0.0, 0.0, 255.0),
        81 => S::int(2.0, 0.0, 255.0),
        82 => S::int(4.0, 0.0, 65_535.0),
        _ => pmac2::global(n),
    }
}

/// Factory value of ECT word I8000+k: the Ultralite's eight MACRO servo nodes of IC 0
/// (`$2F8420`+node, `$018000`), then the end of the table.
fn ect_default(k: u16) -> f64 {
    if k >= 16 {
        return 0.0;
    }
    let x = k / 2 + 1;
    if k % 2 == 0 {
        f64::from(0x20_0000 | 0x8_0000 | motor_node_reg(x))
    } else {
        f64::from(0x01_8000u32)
    }
}

/// Spec of Turbo I-variable `n` (0..=8191).
pub(crate) fn spec(n: u16) -> S {
    match n {
        0..=99 => global(n),
        100..=3299 => motor(n / 100, n % 100),
        5050 | 5051 => S::hex(0.0, U24),
        5100..=6699 => {
            let (s, nn) = ((n - 5000) / 100, n % 100);
            match nn {
                // User countdown timers, servo cycles (decremented every servo cycle).
                11 | 12 => S::int(0.0, -8_388_608.0, S24MAX),
                87.. => pmac2::coord(s, nn),
                _ => S::generic(),
            }
        }
        6840 => S::hex(0.0, 65_535.0),
        6841 => S::hex(0.0, U24),
        8000..=8191 => S::hex(ect_default(n - 8000), U24),
        _ => S::generic(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turbo_host_answers() {
        for n in 20..=23 {
            assert_eq!(spec(n).default, 0.0);
            assert!(spec(n).hex && spec(n).read_only);
        }
        assert_eq!(spec(68).default, 15.0);
        assert_eq!(spec(124).default, 0x40001 as f64);
        assert!(spec(3224).hex);
        assert_eq!(spec(3200).default, 0.0);
        assert_eq!(spec(100).default, 1.0);
        assert_eq!(spec(130).default, 2000.0);
        assert_eq!(spec(5187).default, 0.0);
        assert_eq!(spec(5188).default, 50.0);
        assert_eq!(spec(10).default, 3_713_707.0);
        assert_eq!(spec(8191).default, 0.0);
    }

    #[test]
    fn ultralite_macro_defaults() {
        assert_eq!(spec(102).default, 0x07_8420 as f64);
        assert_eq!(spec(302).default, 0x07_8428 as f64);
        assert_eq!(spec(802).default, 0x07_843C as f64);
        assert_eq!(spec(902).default, 0.0);
        assert_eq!(spec(103).default, 0x3502 as f64);
        assert_eq!(spec(803).default, 0x3510 as f64);
        assert_eq!(spec(125).default, 0x3440 as f64);
        assert_eq!(spec(325).default, 0x3444 as f64);
        assert_eq!(spec(825).default, 0x344D as f64);
        assert_eq!(spec(8000).default, 0x2F_8420 as f64);
        assert_eq!(spec(8001).default, 0x01_8000 as f64);
        assert_eq!(spec(8014).default, 0x2F_843C as f64);
        assert_eq!(spec(8016).default, 0.0);
        assert_eq!(spec(5111), S::int(0.0, -8_388_608.0, S24MAX));
        assert_eq!(spec(81).default, 2.0);
    }
}
