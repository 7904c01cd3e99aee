//! PMAC 48-bit word formats: floating point (L:), fixed point (D:), and the DPRAM 32-bit
//! formats (DP:, F:) split over the low 16 bits of X and Y.
//!
//! [DECISION] The seed does not document the 48-bit float layout; we use the Turbo-PMAC one:
//! a 36-bit two's-complement normalised mantissa (X bits 23-0 = mantissa bits 35-12, Y bits
//! 23-12 = mantissa bits 11-0) and a 12-bit exponent offset by $800 in Y bits 11-0;
//! value = mantissa / 2^35 × 2^(exp − $800). Zero is all zero bits.

/// Round `v` to the precision a 48-bit PMAC float keeps (35 magnitude bits).
/// Non-finite values become 0.
pub fn round48(v: f64) -> f64 {
    if !v.is_finite() || v == 0.0 {
        return 0.0;
    }
    let (m, e) = frexp(v.abs());
    let mut mi = (m * (1u64 << 35) as f64).round();
    let mut e = e;
    if mi >= (1u64 << 35) as f64 {
        mi /= 2.0;
        e += 1;
    }
    v.signum() * mi * 2f64.powi(e - 35)
}

/// `(m, e)` with `x = m × 2^e`, `0.5 <= m < 1`, for finite positive `x`.
fn frexp(x: f64) -> (f64, i32) {
    let mut e = x.log2().floor() as i32 + 1;
    let mut m = x / 2f64.powi(e);
    // Correct for log2 rounding at boundaries.
    while m >= 1.0 {
        m /= 2.0;
        e += 1;
    }
    while m < 0.5 {
        m *= 2.0;
        e -= 1;
    }
    (m, e)
}

/// Encode `v` as a 48-bit PMAC float (X word in bits 47-24, Y word in bits 23-0).
pub fn encode_float(v: f64) -> u64 {
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
pub fn decode_float(w: u64) -> f64 {
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
    mant as f64 * 2f64.powi(exp - 35)
}

/// Encode `v` as a 48-bit two's-complement fixed-point integer (rounded, wrapped).
pub fn encode_fixed(v: f64) -> u64 {
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
pub fn dp_join(x: u32, y: u32) -> u32 {
    ((x & 0xFFFF) << 16) | (y & 0xFFFF)
}

/// Split a 32-bit DPRAM word into `(x_low16, y_low16)`.
pub fn dp_split(w: u32) -> (u32, u32) {
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
    fn fixed_and_dp() {
        assert_eq!(decode_fixed(encode_fixed(-5.0)), -5.0);
        assert_eq!(encode_fixed(-1.0), 0xFFFF_FFFF_FFFF);
        assert_eq!(decode_fixed(encode_fixed(3_072_000.4)), 3_072_000.0);
        assert_eq!(dp_join(0xAB1234, 0xCD5678), 0x1234_5678);
        assert_eq!(dp_split(0x1234_5678), (0x1234, 0x5678));
    }
}
