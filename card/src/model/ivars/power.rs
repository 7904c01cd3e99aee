//! The model I-variable table of the Power profile: the Turbo numbering, which the shared
//! motion core reads (motor xx = I{xx}00-99, C.S. s = I5s00-99), with the Power dialect writing
//! the values it derives from its data-structure elements. Differences from Turbo: every PLC
//! runs when enabled (Power PMAC has no I5), Isx40-Isx43 hold the G/M/T/D subprogram numbers
//! (`Coord[x].Gprog` …, default 1000-1003), and no motor is activated by default.

use super::{turbo, IVarSpec as S, U24};

/// Spec of model I-variable `n` (0..=8191) on the Power profile.
pub(crate) fn spec(n: u16) -> S {
    match n {
        5 => S::int(3.0, 0.0, 3.0),
        100..=3299 if n % 100 == 0 => S::int(0.0, 0.0, 15.0),
        5100..=6699 if (40..=43).contains(&(n % 100)) => {
            S::int(f64::from(1000 + n % 100 - 40), 0.0, 32_767.0)
        }
        5100..=6699 if n % 100 < 87 => S::float(0.0, -U24 * 1e6, U24 * 1e6),
        // `Coord[x].Ta`/`Ts` (a negative value is an inverse rate) and `Tm` (negative: a
        // feedrate), seed 000 L4974, L5113: Power's values as they are.
        5100..=6699 if (87..=89).contains(&(n % 100)) => {
            S::float(turbo::spec(n).default, -U24 * 1e6, U24 * 1e6)
        }
        // The servo gains the dialect converts from Power's float elements (Kp, Kvfb, Kvff,
        // Ki, Kaff, MaxInt): kept exactly, within Turbo's ranges.
        // `TimeBaseSlew`/`FeedHoldSlew` (×2^23) and `MinArcLen` (/π): exact, in Turbo's range.
        5100..=6699 if matches!(n % 100, 94 | 95 | 97) => {
            let t = turbo::spec(n);
            S::float(t.default, t.min, t.max)
        }
        100..=3299 if matches!(n % 100, 30..=33 | 35 | 63) => {
            let t = turbo::spec(n);
            S::float(t.default, t.min, t.max)
        }
        _ => turbo::spec(n),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_differences() {
        assert_eq!(spec(5).default, 3.0);
        assert_eq!(spec(100).default, 0.0);
        assert_eq!(spec(5140).default, 1000.0);
        assert_eq!(spec(5343).default, 1003.0);
        assert_eq!(spec(122), turbo::spec(122));
    }
}
