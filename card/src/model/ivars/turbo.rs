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

/// Spec of Turbo global variable `n` (0..=99), as the Turbo SRM's "Turbo PMAC Global
/// I-Variables" chapter gives them (sources: docs/turbo.md, "Global I-variables I0-I99"). Only the
/// variables that hold addresses or node bit masks print in hex (`$…` under I9 bit 1): I20-I24
/// (MACRO IC and DPRAM base addresses), I67/I69 (Modbus buffer addresses), I70-I77 (MACRO node
/// masks), I83 (parallel ring mask) and I90-I99 (VME address bytes). Every other global
/// prints in decimal — I30, I37, I40, I41, I42, I47, I60 among them, which the PMAC2 table
/// prints in hex (on a PMAC2, I20-I44 are DPRAM/gate addresses).
fn global(n: u16) -> S {
    let flag = |d: f64| S::int(d, 0.0, 1.0);
    match n {
        // Clock source I-variable number: on an Ultralite (no Servo IC 0) MACRO IC 0, I6807.
        19 => S::int(6807.0, 0.0, 9999.0),
        // Set by the card at start-up from the MACRO ICs it has (`$0` = absent).
        20..=23 => S::hex(0.0, f64::from(0x7_FFFFu32)).ro(),
        // Main DPRAM base address (none on this card).
        24 => S::hex(0.0, f64::from(0x7_FFFFu32)),
        // I27 alternate TWS format, I28 display port disable, I30 compensation table wrap,
        // I38 in-line CALL enable, I42 spline/PVT time control mode, I44 ladder enable,
        // I45 foreground binary rotary transfer, I48/I49 DPRAM reporting enables,
        // I51 compensation table enable, I55-I58 DPRAM enables, I62-I64 message controls.
        27 | 28 | 30 | 38 | 42 | 44 | 45 | 48 | 49 | 51 | 55..=58 | 62..=64 => flag(0.0),
        // Additional wait states, I39 UBUS ID display control.
        37 | 39 => S::int(0.0, 0.0, 255.0),
        // Watchdog timer reset value (0 sets 4095), servo cycles.
        40 => S::int(0.0, 0.0, 65_535.0),
        // I-variable lockout control (4 bits).
        41 => S::int(0.0, 0.0, 15.0),
        // Auxiliary/main serial port parser disable (2 bits).
        43 => S::int(0.0, 0.0, 3.0),
        // CPU frequency control, DPRAM foreground / background reporting periods.
        46 => S::int(0.0, 0.0, 31.0),
        47 | 50 => S::int(0.0, 0.0, 255.0),
        // Filtered velocity sample time and shift.
        60 | 61 => S::int(0.0, 0.0, 15.0),
        65 => S::int(0.0, -8_388_608.0, U24),
        // Modbus TCP buffer / software control panel start addresses.
        67 | 69 => S::hex(0.0, f64::from(0x03_FFFFu32)),
        68 => S::int(15.0, 0.0, 15.0),
        // MACRO IC 0-3 node auxiliary register enable / protocol type (I70-I77).
        70..=77 => S::hex(0.0, 65_535.0),
        78 | 79 => S::int(0.0, 0.0, 255.0),
        80 => S::int(0.0, 0.0, 255.0),
        81 => S::int(2.0, 0.0, 255.0),
        82 => S::int(4.0, 0.0, 65_535.0),
        // MACRO parallel ring enable mask; IC number for master communications; ring order.
        83 => S::hex(0.0, 255.0),
        84 => S::int(0.0, 0.0, 3.0),
        85 => S::int(0.0, 0.0, 255.0),
        86..=89 => S::int(0.0, -8_388_608.0, U24),
        // VME bus address bytes (no VME bus on this card; the factory values).
        90..=99 => S::hex(VME_DEFAULTS[usize::from(n - 90)], 255.0),
        // I0-I18 and the reserved numbers as on PMAC2 (the same meanings, all decimal).
        _ => {
            let mut s = pmac2::global(n);
            s.hex = false;
            s
        }
    }
}

/// Factory values of I90-I99 (VME address modifier, don't-care bits, base address bytes,
/// interrupt level and vector, DPRAM address and enable, address width): the PMAC2 VME
/// registers X:$0783-$078C these Turbo variables replace (seed 004 12861-12990).
const VME_DEFAULTS: [f64; 10] = [
    0x39 as f64,
    0x04 as f64,
    0xFF as f64,
    0x7F as f64,
    0xA0 as f64,
    0x02 as f64,
    0xA1 as f64,
    0x00 as f64,
    0x60 as f64,
    0x10 as f64,
];

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

    /// Issue 26 item 13: Turbo globals print as a Turbo prints them — decimal except the
    /// address and node-mask variables (I42 read back `$0` and the DLS IOC refused it).
    #[test]
    fn turbo_globals_print_decimal_except_addresses_and_masks() {
        let hex: Vec<u16> = (0..100).filter(|&n| spec(n).hex).collect();
        let want: Vec<u16> = [20, 21, 22, 23, 24, 67, 69]
            .into_iter()
            .chain(70..=77)
            .chain([83])
            .chain(90..=99)
            .collect();
        assert_eq!(hex, want);
        for n in [30, 37, 40, 41, 42, 47, 60] {
            assert!(!spec(n).hex, "I{n} decimal");
        }
        assert_eq!(spec(42), S::int(0.0, 0.0, 1.0));
        assert_eq!(spec(19).default, 6807.0, "MACRO IC 0 clock on an Ultralite");
        assert_eq!(spec(90).default, 57.0);
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
