//! Quadrature encoder and the station's position conversion into node register 0.
//!
//! The encoder has `counts_per_rev` counts per revolution *after* ×4 quadrature decoding
//! (a 1000-line encoder is 4000 counts/rev). Ideal decoding: the count is
//! `floor(θ/2π · counts_per_rev)`; the A/B channel levels follow the count's quadrature state
//! (count mod 4 → AB = 00, 10, 11, 01, i.e. A leads B in the + direction).
//!
//! Register 0 carries the position in **1/32 count** (5 fractional bits) as a 24-bit
//! two's-complement value that **wraps modulo 2^24** (spec §6.5, §6.6: the card's ECT entry
//! $28C0An with mask $FFFFFF extends it across the rollover). With `sub_count = true` the
//! station fills the fractional bits from the interpolated position (like the PMAC2 1/T
//! extension, truncated to 1/32 count); with `sub_count = false` they are 0 (whole counts
//! only, a bare quadrature counter).

use std::f64::consts::TAU;

/// Mask of a 24-bit register.
pub const REG24_MASK: u32 = 0xFF_FFFF;

/// Encoder parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderParams {
    /// Counts per revolution after ×4 decoding (> 0).
    pub counts_per_rev: f64,
    /// Report sub-count position in the 5 fractional bits.
    pub sub_count: bool,
}

/// A quadrature encoder on a motor shaft.
#[derive(Clone, Copy, Debug)]
pub struct Encoder {
    p: EncoderParams,
}

impl Encoder {
    /// An encoder with these parameters.
    pub fn new(p: EncoderParams) -> Self {
        Encoder { p }
    }

    /// Parameters.
    pub fn params(&self) -> EncoderParams {
        self.p
    }

    /// Continuous position in counts for shaft angle `theta` (rad).
    pub fn counts(&self, theta: f64) -> f64 {
        theta / TAU * self.p.counts_per_rev
    }

    /// Counts per second for shaft speed `omega` (rad/s).
    pub fn counts_per_s(&self, omega: f64) -> f64 {
        omega / TAU * self.p.counts_per_rev
    }

    /// Shaft speed (rad/s) for `counts_per_s`.
    pub fn omega_for(&self, counts_per_s: f64) -> f64 {
        counts_per_s / self.p.counts_per_rev * TAU
    }

    /// Position in 1/32 count as the station measures it (not wrapped; saturates far out).
    pub fn position_32nds(&self, theta: f64) -> i64 {
        let c = self.counts(theta);
        if self.p.sub_count {
            (c * 32.0).floor() as i64
        } else {
            (c.floor() as i64).saturating_mul(32)
        }
    }

    /// Node register 0: the position in 1/32 count, wrapped to 24 bits.
    pub fn register0(&self, theta: f64) -> u32 {
        wrap24(self.position_32nds(theta))
    }

    /// Quadrature channel levels (A, B) at shaft angle `theta`.
    pub fn channels(&self, theta: f64) -> (bool, bool) {
        let count = self.counts(theta).floor() as i64;
        match count.rem_euclid(4) {
            0 => (false, false),
            1 => (true, false),
            2 => (true, true),
            _ => (false, true),
        }
    }
}

/// A signed value wrapped to a 24-bit register (two's complement, modulo 2^24).
pub fn wrap24(v: i64) -> u32 {
    (v & i64::from(REG24_MASK)) as u32
}

/// A 24-bit register read as a signed value (−2^23 ..= 2^23 − 1).
pub fn signed24(r: u32) -> i32 {
    (((r & REG24_MASK) << 8) as i32) >> 8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enc(sub: bool) -> Encoder {
        Encoder::new(EncoderParams {
            counts_per_rev: 4000.0,
            sub_count: sub,
        })
    }

    fn theta_for(counts: f64) -> f64 {
        counts / 4000.0 * TAU
    }

    #[test]
    fn register0_is_position_in_32nds() {
        let e = enc(true);
        assert_eq!(e.register0(0.0), 0);
        assert_eq!(e.register0(theta_for(1000.0 + 1e-9)), 32_000);
        assert_eq!(e.register0(theta_for(1.5 + 1e-12)), 48); // 1.5 counts = 48/32
                                                             // one full revolution = 4000 counts = 128000 / 32
        assert_eq!(e.register0(TAU * (1.0 + 1e-12)), 128_000);
        // negative: −1 count = −32 = $FFFFE0
        assert_eq!(e.register0(theta_for(-1.0 + 1e-9)), 0xFF_FFE0);
        // whole counts only without sub-count
        assert_eq!(enc(false).register0(theta_for(1.7)), 32);
        assert_eq!(enc(false).register0(theta_for(-0.2)), 0xFF_FFE0);
    }

    #[test]
    fn register0_wraps_modulo_2_pow_24() {
        let e = enc(true);
        // 2^24 / 32 = 524288 counts is one full register turn
        let full = 524_288.0;
        assert_eq!(e.register0(theta_for(full - 1.0 + 1e-7)), 0xFF_FFE0);
        assert_eq!(e.register0(theta_for(full + 1e-7)), 0);
        assert_eq!(e.register0(theta_for(full + 1.0 + 1e-7)), 32);
        // the largest positive value before the sign flips, then the sign flips
        assert_eq!(
            signed24(e.register0(theta_for(full / 2.0 - 1.0 + 1e-7))),
            (1 << 23) - 32
        );
        assert_eq!(
            signed24(e.register0(theta_for(full / 2.0 + 1e-7))),
            -(1 << 23)
        );
        // a card extending by sign-extended 24-bit deltas recovers the true position
        let mut ext: i64 = 0;
        let mut last = e.register0(0.0);
        for k in 1..=400 {
            let c = k as f64 * 3_000.25; // 96,008 (1/32 ct) per step, < 2^23
            let r = e.register0(theta_for(c + 1e-7));
            ext += i64::from(signed24(r.wrapping_sub(last)));
            last = r;
            assert_eq!(ext, (c * 32.0).floor() as i64, "step {k}");
        }
        assert!(ext > 2 * (1 << 24)); // crossed the rollover twice
    }

    #[test]
    fn quadrature_channels_follow_the_count() {
        let e = enc(true);
        let seq: Vec<(bool, bool)> = (0..8)
            .map(|c| e.channels(theta_for(c as f64 + 0.5)))
            .collect();
        let ab = [(false, false), (true, false), (true, true), (false, true)];
        assert_eq!(seq[..4], ab);
        assert_eq!(seq[4..], ab);
        assert_eq!(e.channels(theta_for(-0.5)), (false, true));
    }

    #[test]
    fn signed24_and_wrap24_are_inverse_on_the_register_range() {
        for v in [0i64, 1, -1, (1 << 23) - 1, -(1 << 23), 12345, -98765] {
            assert_eq!(i64::from(signed24(wrap24(v))), v);
        }
        assert_eq!(wrap24(1 << 24), 0);
        assert_eq!(signed24(0xFFFF_FFFF), -1);
    }
}
