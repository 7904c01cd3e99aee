//! Turbo host-compatibility I-variable table (host-protocols.md §4.0, issue item 6).
//!
//! Numbering as a Turbo PMAC: I0-I99 global (PMAC2 meanings except I20-I23 = MACRO IC base
//! addresses, answered `$0` = "no IC", and I68 = number of C.S. − 1 = 15), Ixx00-Ixx99 motor xx
//! (xx = 1..32, I100-I3299), I5000-I5099 global (gather), Isx00-Isx99 C.S. s (s = 1..16,
//! I5100-I6699; Isx87-Isx99 take the PMAC2 Ix87-Ix99 meanings), everything else up to I8191
//! stored generically. Ixx24 is the Turbo flag-mode word, printed in hex.

use super::{pmac2, IVarSpec as S, U24};

/// Spec of Turbo motor variable Ixxnn for motor `m` (1..=32).
pub(crate) fn motor(m: u16, nn: u16) -> S {
    match nn {
        // Turbo flag control word: bit 0 = PMAC2-style flags, bit 18 = flags via MACRO.
        24 => S::hex(if m <= 8 { 0x40001 as f64 } else { 0.0 }, U24),
        0..=86 => {
            let mut s = pmac2::motor(m.min(8), nn);
            if m > 8 && matches!(nn, 0 | 2 | 3 | 4 | 25 | 83) {
                s.default = 0.0;
            }
            s
        }
        _ => S::generic(),
    }
}

/// Spec of Turbo I-variable `n` (0..=8191).
pub(crate) fn spec(n: u16) -> S {
    match n {
        20..=23 => S::hex(0.0, 0.0).ro(),
        68 => S::int(15.0, 0.0, 15.0),
        0..=99 => pmac2::global(n),
        100..=3299 => motor(n / 100, n % 100),
        5050 | 5051 => S::hex(0.0, U24),
        5100..=6699 => {
            let (s, nn) = ((n - 5000) / 100, n % 100);
            if nn >= 87 {
                pmac2::coord(s, nn)
            } else {
                S::generic()
            }
        }
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
        assert_eq!(spec(8191), S::generic());
    }
}
