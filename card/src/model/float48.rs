//! PMAC 48-bit word formats: floating point (L:), fixed point (D:), and the DPRAM 32-bit
//! formats (DP:, F:) split over the low 16 bits of X and Y.
//!
//! [DECISION] The seed does not document the 48-bit float layout; we use the Turbo-PMAC one:
//! a 36-bit two's-complement normalised mantissa (X bits 23-0 = mantissa bits 35-12, Y bits
//! 23-12 = mantissa bits 11-0) and a 12-bit exponent offset by $800 in Y bits 11-0;
//! value = mantissa / 2^35 × 2^(exp − $800). Zero is all zero bits.

/// Round `v` to the precision a 48-bit PMAC float keeps (35 magnitude bits).
/// Non-finite values become 0; a value that rounds beyond `f64::MAX` saturates at the largest
/// 35-bit mantissa with the largest f64 exponent (the 48-bit format's own exponent range, ±2^2047,
/// is wider than f64's, so every finite f64 has a 48-bit neighbour).
pub(crate) fn round48(v: f64) -> f64 {
    if !v.is_finite() || v == 0.0 {
        return 0.0;
    }
    let (m, e) = frexp(v.abs());
    let mut mi = (m * TWO35).round();
    let mut e = e;
    if mi >= TWO35 {
        mi /= 2.0;
        e += 1;
    }
    let r = ldexp(mi / TWO35, e);
    if r.is_finite() {
        v.signum() * r
    } else {
        v.signum() * MAX48
    }
}

const TWO35: f64 = (1u64 << 35) as f64;

/// The largest 48-bit float value that is also a finite f64: (2^35 − 1)/2^35 × 2^1024.
const MAX48: f64 = 1.797_693_134_809_996_2e308;

/// `x × 2^e` without overflowing or underflowing the intermediate power of two.
fn ldexp(x: f64, e: i32) -> f64 {
    let e = e.clamp(-2200, 2200);
    let half = e / 2;
    x * 2f64.powi(half) * 2f64.powi(e - half)
}

/// `(m, e)` with `x = m × 2^e`, `0.5 <= m < 1`, for finite positive `x` (subnormals included),
/// read from the IEEE-754 bits: no loop, whatever the input.
fn frexp(x: f64) -> (f64, i32) {
    debug_assert!(x.is_finite() && x > 0.0);
    let (x, bias) = if x < f64::MIN_POSITIVE {
        (x * 2f64.powi(64), -64)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7FF) as i32;
    // Put the exponent field at 1022 (value in [0.5, 1)).
    let m = f64::from_bits((bits & !(0x7FF << 52)) | (1022u64 << 52));
    (m, exp - 1022 + bias)
}

/// Encode `v` as a 48-bit PMAC float (X word in bits 47-24, Y word in bits 23-0).
pub(crate) fn encode_float(v: f64) -> u64 {
    if !v.is_finite() || v == 0.0 {
        return 0;
    }
    let (m, e) = frexp(v.abs());
    let mut mant = (m * (1u64 << 35) as f64).round() as i64;
    let mut e = e;
    if mant >= 1 << 35 {
        mant >>= 1;
        e += 1;
    }
    if v < 0.0 {
        mant = -mant;
        if mant == -(1 << 34) {
            mant = -(1 << 35);
            e -= 1;
        }
    }
    let exp = (e + 0x800).clamp(0, 0xFFF) as u64;
    let mant = (mant as u64) & 0xF_FFFF_FFFF;
    (mant << 12) | exp
}

/// Decode a 48-bit PMAC float.
pub(crate) fn decode_float(w: u64) -> f64 {
    let w = w & 0xFFFF_FFFF_FFFF;
    let raw = (w >> 12) as i64;
    let mant = if raw & (1 << 35) != 0 {
        raw - (1 << 36)
    } else {
        raw
    };
    if mant == 0 {
        return 0.0;
    }
    let exp = (w & 0xFFF) as i32 - 0x800;
    // The 48-bit exponent reaches 2^2047: beyond f64 the value saturates at ±f64::MAX.
    let v = ldexp(mant as f64, exp - 35);
    if v.is_finite() {
        v
    } else {
        v.signum() * f64::MAX
    }
}

/// Encode `v` as a 48-bit two's-complement fixed-point integer (rounded, wrapped).
pub(crate) fn encode_fixed(v: f64) -> u64 {
    let i = if v.is_finite() {
        v.round().clamp(-1.8e19, 1.8e19) as i128
    } else {
        0
    };
    (i as u64) & 0xFFFF_FFFF_FFFF
}

/// Decode a 48-bit two's-complement fixed-point integer.
pub fn decode_fixed(w: u64) -> f64 {
    let w = w & 0xFFFF_FFFF_FFFF;
    if w & (1 << 47) != 0 {
        (w as i64 - (1i64 << 48)) as f64
    } else {
        w as f64
    }
}

/// Join the low 16 bits of X (most significant) and Y into a 32-bit DPRAM word.
pub(crate) fn dp_join(x: u32, y: u32) -> u32 {
    ((x & 0xFFFF) << 16) | (y & 0xFFFF)
}

/// Split a 32-bit DPRAM word into `(x_low16, y_low16)`.
pub(crate) fn dp_split(w: u32) -> (u32, u32) {
    (w >> 16, w & 0xFFFF)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_round_trip() {
        for v in [
            1.0,
            -1.0,
            0.5,
            -0.5,
            25.0,
            -373.0,
            0.1,
            3713707.0,
            1e-30,
            -2.75e20,
            1.0 / 3.0,
        ] {
            let back = decode_float(encode_float(v));
            assert!(
                (back - v).abs() <= v.abs() * 2f64.powi(-34),
                "{v} -> {back}"
            );
            assert_eq!(back, round48(v));
        }
        assert_eq!(encode_float(0.0), 0);
        assert_eq!(decode_float(0), 0.0);
    }

    #[test]
    fn float_layout() {
        // 1.0 = 0.5 × 2^1: mantissa $400000000, exponent $801.
        assert_eq!(encode_float(1.0), 0x4000_0000_0801);
        // -1.0 = -1 × 2^0: mantissa $800000000 (two's complement), exponent $800.
        assert_eq!(encode_float(-1.0), 0x8000_0000_0800);
    }

    #[test]
    fn round48_keeps_35_bits() {
        let v = 1.0 + 2f64.powi(-40);
        assert_eq!(round48(v), 1.0);
        let w = 1.0 + 2f64.powi(-30);
        assert_eq!(round48(w), w);
        assert_eq!(round48(f64::NAN), 0.0);
    }

    #[test]
    fn extremes_never_hang_and_saturate() {
        // Regression: frexp looped forever for values >= 2^1023 (P1=EXP(710) hung the card).
        for v in [
            f64::MAX,
            -f64::MAX,
            2f64.powi(1023),
            1.7e308,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE / 3.0,
            5e-324,
            -5e-324,
        ] {
            let r = round48(v);
            assert!(r.is_finite(), "{v} -> {r}");
            assert_eq!(r.signum(), v.signum());
            let back = decode_float(encode_float(v));
            assert!(back.is_finite(), "{v} -> {back}");
        }
        assert_eq!(MAX48, ((1u64 << 35) - 1) as f64 * 2f64.powi(989));
        assert_eq!(round48(f64::MAX), MAX48);
        assert_eq!(round48(2f64.powi(1023)), 2f64.powi(1023));
        let (m, e) = frexp(5e-324);
        assert_eq!((m, e), (0.5, -1073));
        // A word with the largest 48-bit exponent saturates instead of giving infinity.
        assert_eq!(decode_float(0x4000_0000_0FFF), f64::MAX);
        assert_eq!(decode_float(0x8000_0000_0FFF), -f64::MAX);
        assert_eq!(decode_float(0x4000_0000_0001), 0.0);
    }

    #[test]
    fn fixed_and_dp() {
        assert_eq!(decode_fixed(encode_fixed(-5.0)), -5.0);
        assert_eq!(encode_fixed(-1.0), 0xFFFF_FFFF_FFFF);
        assert_eq!(decode_fixed(encode_fixed(3_072_000.4)), 3_072_000.0);
        assert_eq!(dp_join(0xAB1234, 0xCD5678), 0x1234_5678);
        assert_eq!(dp_split(0x1234_5678), (0x1234, 0x5678));
    }
}
