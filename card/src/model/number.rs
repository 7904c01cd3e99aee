//! PMAC number printing (pmac-commands §2.6, pmac-variables §1.3).
//!
//! Rules: integral values print without a decimal point; other values print in plain decimal,
//! rounded to at most 9 digits after the point and at most 11 significant digits, trailing zeros
//! stripped, never an exponent; `-` only for negative non-zero results. Address-type variables
//! print as `$` + upper-case hex without padding. Motor positions/velocities/following errors
//! print rounded to 0.1.

/// Largest magnitude printed; values beyond are saturated (PMAC's 48-bit limits, 2^47).
const SATURATE: f64 = 140_737_488_355_328.0;

/// Round `v` to `decimals` digits after the point and print it without trailing zeros.
fn fixed(v: f64, decimals: usize) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "0".into()
        } else if v > 0.0 {
            format!("{}", SATURATE as i64)
        } else {
            format!("-{}", SATURATE as i64)
        };
    }
    let v = v.clamp(-SATURATE, SATURATE);
    let mut s = format!("{:.*}", decimals, v);
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

/// Print a variable value (I, P, Q, M, expression result) the way a PMAC does.
/// Examples: `25`, `-373`, `17.5`, `0.0005`, `-0.333333333`, `6.666666667`.
pub(crate) fn format_value(v: f64) -> String {
    if !v.is_finite() {
        return fixed(v, 0);
    }
    let a = v.abs();
    // Number of digits before the decimal point (at least 1).
    let int_digits = if a < 1.0 {
        1
    } else {
        (a.log10().floor() as i64 + 1).max(1) as usize
    };
    let decimals = 11usize.saturating_sub(int_digits).min(9);
    fixed(v, decimals)
}

/// Print a value in `$` hex, upper case, no padding (`$C000`, `$0`). The value is truncated to
/// an integer; negative values print as their 24-bit two's complement (`-1` → `$FFFFFF`) when
/// they fit in 24 bits, otherwise as 48-bit two's complement.
pub(crate) fn format_hex(v: f64) -> String {
    let i = if v.is_finite() {
        v.trunc().clamp(-SATURATE, SATURATE) as i64
    } else {
        0
    };
    let u = if i >= 0 {
        i as u64
    } else if i >= -(1 << 23) {
        (i as u64) & 0xFF_FFFF
    } else {
        (i as u64) & 0xFFFF_FFFF_FFFF
    };
    format!("${:X}", u)
}

/// Print a motor position, velocity or following error: counts rounded to 0.1, no trailing
/// `.0` (`1995`, `-0.5`, `9999.5`, `0`).
pub(crate) fn format_position(v: f64) -> String {
    fixed((v * 10.0).round() / 10.0, 1)
}

/// Print a status word pair as 12 upper-case hex digits (word 1 first, 6 digits each).
pub(crate) fn format_status_words(words: &[u32]) -> String {
    let mut s = String::with_capacity(words.len() * 6);
    for w in words {
        s.push_str(&format!("{:06X}", w & 0xFF_FFFF));
    }
    s
}

/// `R` reply for a short word: signed decimal of the 24-bit value (`-7389161`).
#[cfg(test)]
pub(crate) fn format_word_signed(w: u32) -> String {
    let w = w & 0xFF_FFFF;
    let v = if w & 0x80_0000 != 0 {
        w as i64 - (1 << 24)
    } else {
        w as i64
    };
    v.to_string()
}

/// `R` reply for a long (L) word: signed decimal of the 48-bit value (`3072000`).
#[cfg(test)]
pub(crate) fn format_long_signed(w: u64) -> String {
    let w = w & 0xFFFF_FFFF_FFFF;
    let v = if w & (1 << 47) != 0 {
        w as i64 - (1i64 << 48)
    } else {
        w as i64
    };
    v.to_string()
}

/// `RH` reply for a short word: 6 upper-case hex digits, no `$` (`8F4017`).
#[cfg(test)]
pub(crate) fn format_word_hex(w: u32) -> String {
    format!("{:06X}", w & 0xFF_FFFF)
}

/// `RH` reply for a long word: 12 upper-case hex digits, no `$`.
#[cfg(test)]
pub(crate) fn format_long_hex(w: u64) -> String {
    format!("{:012X}", w & 0xFFFF_FFFF_FFFF)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_print_without_point() {
        assert_eq!(format_value(25.0), "25");
        assert_eq!(format_value(-373.0), "-373");
        assert_eq!(format_value(49152.0), "49152");
        assert_eq!(format_value(0.0), "0");
        assert_eq!(format_value(-0.0), "0");
        assert_eq!(format_value(2000.0), "2000");
        assert_eq!(format_value(3713707.0), "3713707");
        assert_eq!(format_value(140737488355328.0), "140737488355328");
    }

    #[test]
    fn fractions_as_seed_examples() {
        assert_eq!(format_value(17.5), "17.5");
        assert_eq!(format_value(0.0005), "0.0005");
        assert_eq!(format_value(-1.0 / 3.0), "-0.333333333");
        assert_eq!(format_value(10.0 * 2.0 / 3.0), "6.666666667");
        assert_eq!(format_value(3.44444444), "3.44444444");
        assert_eq!(format_value(-3.4578), "-3.4578");
        assert_eq!(format_value(98.5), "98.5");
        assert_eq!(format_value(225.882305744), "225.88230574");
        assert_eq!(format_value(0.99848), "0.99848");
        assert_eq!(format_value(0.015625), "0.015625");
    }

    #[test]
    fn never_exponent() {
        assert_eq!(format_value(1e-12), "0");
        assert_eq!(format_value(-1e-12), "0");
        assert_eq!(format_value(1e-9), "0.000000001");
        assert_eq!(format_value(1e14), "100000000000000");
        assert_eq!(format_value(1e300), "140737488355328");
        assert_eq!(format_value(f64::NEG_INFINITY), "-140737488355328");
        assert!(!format_value(123456789.123).contains('e'));
        assert_eq!(format_value(123456789.123), "123456789.12");
        assert_eq!(format_value(2.0000000001), "2");
    }

    #[test]
    fn hex_without_padding() {
        assert_eq!(format_hex(49152.0), "$C000");
        assert_eq!(format_hex(0.0), "$0");
        assert_eq!(format_hex(16777215.0), "$FFFFFF");
        assert_eq!(format_hex(0x40F70 as f64), "$40F70");
        assert_eq!(format_hex(-1.0), "$FFFFFF");
        assert_eq!(format_hex(-((1u64 << 30) as f64)), "$FFFFC0000000");
    }

    #[test]
    fn positions_to_tenth() {
        assert_eq!(format_position(1995.0), "1995");
        assert_eq!(format_position(-0.5), "-0.5");
        assert_eq!(format_position(9999.49), "9999.5");
        assert_eq!(format_position(10001.23), "10001.2");
        assert_eq!(format_position(-0.04), "0");
        assert_eq!(format_position(5.66), "5.7");
    }

    #[test]
    fn status_words_twelve_digits() {
        assert_eq!(format_status_words(&[0x812000, 0x804401]), "812000804401");
        assert_eq!(format_status_words(&[0, 0x800]), "000000000800");
        assert_eq!(
            format_status_words(&[0xA80020, 0x020000, 0]),
            "A80020020000000000"
        );
    }

    #[test]
    fn register_reads() {
        assert_eq!(format_word_signed(0x8F4017), "-7389161");
        assert_eq!(format_word_hex(0x8F4017), "8F4017");
        assert_eq!(format_word_signed(0x7FFFFF), "8388607");
        assert_eq!(format_long_signed(3_072_000), "3072000");
        assert_eq!(format_long_signed(0xFFFF_FFFF_FFFF), "-1");
        assert_eq!(format_long_hex(0x4000_0000_0801), "400000000801");
        assert_eq!(format_word_hex(5), "000005");
    }
}
