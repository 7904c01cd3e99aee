//! PMAC2 Ultralite I-variable table (seed 004; pmac-variables-servo-macro.md §2, §3, §5.5, §6).
//!
//! I0-I99 global, In00-In86 motor n, In87-In99 coordinate system n (n = 1..8), I900-I999
//! hardware (Ultralite clocks and MACRO IC), I1000-I1023 MACRO software setup.

use super::{IVarSpec as S, S24MAX, U24};

/// 2^35, the range of the ±2^35 software limits and rollover.
const P35: f64 = 34_359_738_368.0;
/// Servo-node base register of motor x (1-based): node 0,1,4,5,8,9,12,13 → $C0A0 + 4(x-1).
pub(crate) fn motor_node_reg(x: u16) -> u32 {
    0xC0A0 + 4 * (x as u32).saturating_sub(1)
}
/// MACRO servo node number of motor x (1-based): 0,1,4,5,8,9,12,13.
pub(crate) fn motor_node(x: u16) -> u32 {
    let k = (x as u32).saturating_sub(1);
    (k / 2) * 4 + (k % 2)
}

/// Spec of global I-variable `n` (0..=99).
pub(crate) fn global(n: u16) -> S {
    match n {
        0 => S::int(0.0, 0.0, 15.0),
        1 | 2 | 4 | 5 | 45 => S::int(0.0, 0.0, 3.0),
        3 => S::int(1.0, 0.0, 3.0),
        6 => S::int(3.0, 0.0, 3.0),
        7 => S::int(0.0, 0.0, 255.0),
        8 => S::int(2.0, 0.0, 255.0),
        9 => S::int(2.0, 0.0, 3.0),
        10 => S::int(3_713_707.0, 0.0, S24MAX),
        11 | 13 | 19 => S::int(0.0, 0.0, S24MAX),
        12 => S::int(10.0, 1.0, S24MAX),
        14 | 50 => S::int(1.0, 0.0, 1.0),
        15 | 48 | 49 | 51 | 53 | 55 | 56 | 57 | 58 | 62 | 63 | 64 | 66 => S::int(0.0, 0.0, 1.0),
        16 => S::int(5.0, 0.0, S24MAX),
        17 | 18 => S::int(10.0, 0.0, S24MAX),
        20..=44 => S::hex(0.0, U24),
        46 => S::int(0.0, 0.0, 15.0),
        47 => S::hex(0.0, 65535.0),
        52 => S::int(37_137.0, 0.0, S24MAX),
        54 => S::int(12.0, 0.0, 15.0),
        59 => S::int(0.0, 0.0, 8.0),
        60 => S::hex(0.0, U24),
        61 => S::int(0.0, 0.0, 15.0),
        65 => S::int(0.0, 0.0, U24),
        70..=77 => S::hex(0.0, U24),
        81..=88 | 91..=98 => S::int(0.0, 0.0, 4095.0),
        89 => S::float(0.99848, -1.0, 0.99999),
        90 => S::pos_float(0.0),
        99 => S::int(64.0, 0.0, S24MAX),
        _ => S::generic(),
    }
}

/// Spec of motor variable Ixnn for motor `x` (1-based), nn = 0..=86.
pub(crate) fn motor(x: u16, nn: u16) -> S {
    let node_reg = motor_node_reg(x) as f64;
    let s24 = |d: f64| S::int(d, -8_388_608.0, S24MAX);
    let u23 = |d: f64| S::int(d, 0.0, S24MAX);
    let s16 = |d: f64| S::int(d, -32_768.0, 32_767.0);
    let u15 = |d: f64| S::int(d, 0.0, 32_767.0);
    match nn {
        0 => S::int(if x == 1 { 1.0 } else { 0.0 }, 0.0, 1.0),
        1 | 6 => S::int(0.0, 0.0, 1.0),
        2 => S::hex(node_reg, U24),
        3 | 4 => S::hex((0x0721 + 2 * (x as u32).saturating_sub(1)) as f64, U24),
        5 => S::hex(0x073F as f64, U24),
        7 => s24(96.0),
        8 | 9 => u23(96.0),
        10 => S::hex(0.0, U24),
        11 => u23(32_000.0),
        12 => u23(16_000.0),
        13 | 14 | 27 => S::int(0.0, -P35, P35),
        15 => S::pos_float(0.25),
        16 => S::pos_float(32.0),
        17 => S::pos_float(0.5),
        19 => S::pos_float(0.015625),
        20 => u23(0.0),
        21 => u23(50.0),
        22 => S::pos_float(32.0),
        23 => S::float(32.0, -140_737_488_355_328.0, 140_737_488_355_328.0),
        25 => S::hex((0x40F70 + motor_node(x)) as f64, U24),
        26 | 86 => s24(0.0),
        28 => u23(160.0),
        29 | 64 | 68 | 79 => s16(0.0),
        30 => s24(2000.0),
        31 => s24(1280.0),
        32 => u23(1280.0),
        33 | 35 | 58 | 60 | 61 | 62 | 67 | 85 => u23(if nn == 67 { 4_194_304.0 } else { 0.0 }),
        34 => S::int(1.0, 0.0, 1.0),
        36..=39 => S::float(0.0, -2.0, 2.0),
        40 => S::float(0.0, 0.0, 0.9999999),
        57 | 66 | 73 => u15(0.0),
        59 => S::int(0.0, 0.0, 3.0),
        63 => s24(4_194_304.0),
        65 => u15(16.0),
        69 => u15(20_480.0),
        70 => S::int(1.0, 0.0, 255.0),
        71 => u23(1000.0),
        72 => S::int(85.0, 0.0, 255.0),
        74 => S::int(0.0, 0.0, 255.0),
        75..=77 => s24(0.0),
        78 => S::float(0.0, 0.0, 1.0),
        80 => S::int(0.0, 0.0, 7.0),
        81 | 82 => S::hex(0.0, U24),
        83 => S::hex((0x80000 + motor_node_reg(x)) as f64, U24),
        84 => S::hex(0xFFF000 as f64, U24),
        _ => S::generic(),
    }
}

/// Spec of coordinate-system variable Ixnn for C.S. `x` (1-based), nn = 87..=99.
pub(crate) fn coord(x: u16, nn: u16) -> S {
    match nn {
        87 => S::int(0.0, 0.0, S24MAX),
        88 => S::int(50.0, 0.0, S24MAX),
        89 | 90 => S::pos_float(1000.0),
        91 => S::int(0.0, 0.0, 32_767.0),
        92 => S::int(0.0, 0.0, 1.0),
        93 => S::hex(
            (0x0806 + 0xC0 * (x as u32).saturating_sub(1)) as f64,
            65_535.0,
        ),
        94 | 95 => S::int(1644.0, 0.0, S24MAX),
        96 | 98 => S::pos_float(0.0),
        97 => S::int(1.0, 0.0, 1.0),
        _ => S::generic(),
    }
}

/// Spec of hardware variable `n` (900..=999).
pub(crate) fn hardware(n: u16) -> S {
    match n {
        900 | 906 | 992 => S::int(6527.0, 0.0, 32_767.0),
        901 | 997 => S::int(0.0, 0.0, 15.0),
        902 | 998 => S::int(3.0, 0.0, 15.0),
        903 | 907 | 993 => S::int(2258.0, 0.0, 4095.0),
        904 | 908 | 994 => S::int(15.0, 0.0, 255.0),
        905 | 909 => S::hex(0x7FFFC0 as f64, U24),
        990 | 991 => S::int(7.0, 0.0, 15.0),
        995 => S::hex(0.0, 65_535.0),
        996 => S::hex(0.0, U24),
        910..=989 => match n % 10 {
            0 => S::int(7.0, 0.0, 15.0),
            1 | 4 | 8 | 9 => S::int(0.0, 0.0, 1.0),
            2 => S::int(1.0, 0.0, 15.0),
            _ => S::int(0.0, 0.0, 3.0),
        },
        _ => S::generic(),
    }
}

/// Spec of MACRO/reserved variable `n` (1000..=1023).
pub(crate) fn macro_sw(n: u16) -> S {
    match n {
        1000 | 1002 => S::hex(0.0, 65_535.0),
        1001 | 1003 => S::int(0.0, 0.0, 255.0),
        1004 => S::int(2.0, 0.0, 255.0),
        1005 => S::int(4.0, 0.0, 65_535.0),
        _ => S::generic(),
    }
}

/// Spec of I-variable `n` of a PMAC2 card (n < 1024; larger numbers get a generic spec but the
/// table only asks for 0..1024).
pub(crate) fn spec(n: u16) -> S {
    match n {
        0..=99 => global(n),
        100..=899 => {
            let (x, nn) = (n / 100, n % 100);
            if nn <= 86 {
                motor(x, nn)
            } else {
                coord(x, nn)
            }
        }
        900..=999 => hardware(n),
        1000..=1023 => macro_sw(n),
        _ => S::generic(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_defaults() {
        assert_eq!(spec(3).default, 1.0);
        assert_eq!(spec(6).default, 3.0);
        assert_eq!(spec(9).default, 2.0);
        assert_eq!(spec(10).default, 3_713_707.0);
        assert_eq!(spec(100).default, 1.0);
        assert_eq!(spec(200).default, 0.0);
        assert_eq!(spec(102).default, 0xC0A0 as f64);
        assert_eq!(spec(802).default, 0xC0BC as f64);
        assert_eq!(spec(303).default, 0x0725 as f64);
        assert_eq!(spec(125).default, 0x40F70 as f64);
        assert_eq!(spec(325).default, 0x40F74 as f64);
        assert_eq!(spec(825).default, 0x40F7D as f64);
        assert_eq!(spec(183).default, 0x8C0A0 as f64);
        assert_eq!(spec(187).default, 0.0);
        assert_eq!(spec(188).default, 50.0);
        assert_eq!(spec(193).default, 0x0806 as f64);
        assert_eq!(spec(893).default, 0x0D46 as f64);
        assert_eq!(spec(111).default, 32_000.0);
        assert_eq!(spec(115).default, 0.25);
        assert_eq!(spec(992).default, 6527.0);
        assert_eq!(spec(998).default, 3.0);
        assert_eq!(spec(1004).default, 2.0);
        assert_eq!(spec(1005).default, 4.0);
        assert_eq!(spec(99).default, 64.0);
    }

    #[test]
    fn hex_flags() {
        for n in [
            20, 21, 44, 47, 60, 102, 103, 104, 105, 110, 125, 181, 183, 193, 995, 996, 1000, 1002,
        ] {
            assert!(spec(n).hex, "I{n} should print in hex");
        }
        for n in [0, 3, 10, 100, 130, 177, 186, 187, 1001] {
            assert!(!spec(n).hex, "I{n} should print in decimal");
        }
    }

    #[test]
    fn ranges() {
        assert_eq!(spec(3).accept(4.0), None);
        assert_eq!(spec(3).accept(2.0), Some(2.0));
        assert_eq!(spec(3).accept(1.6), Some(2.0));
        assert_eq!(spec(12).accept(0.0), None);
        assert_eq!(spec(130).accept(-8_388_608.0), Some(-8_388_608.0));
        assert_eq!(spec(130).accept(8_388_608.0), None);
        assert_eq!(spec(115).accept(0.3), Some(0.3));
        assert_eq!(spec(115).accept(-0.3), None);
        assert_eq!(spec(995).accept(65_536.0), None);
        assert_eq!(spec(10).accept(f64::NAN), None);
    }
}
