//! The one place where a motor's flag image word maps to logical flag inputs.
//!
//! With MACRO flags (Ix25 bit 18) the image is X:$0F7n, filled from node register 3 (Type 1)
//! by the auxiliary copy (I1000). The bit layout is the station's (station/src/plant/flags.rs),
//! the PMAC2 channel status layout in 24-bit bit numbers:
//!
//! | 24-bit bit | flag | logical meaning here |
//! |---|---|---|
//! | 14 | AENA (card → station, Y:$0F7n) | amplifier enable |
//! | 15 | FAULT | amp fault = bit if Ix25 bit 23 = 1 (high-true), else = !bit (low-true, default) |
//! | 16 | HMFL | home flag active |
//! | 17 | PLIM | positive end limit tripped (blocks positive motion) |
//! | 18 | MLIM | negative end limit tripped (blocks negative motion) |
//! | 19 | USER | user flag |

/// 24-bit image bit written by the card: amplifier enable (register 3 bit 6).
pub(crate) const AMP_ENABLE_BIT: u32 = 1 << 14;
const FAULT_BIT: u32 = 1 << 15;
const HOME_BIT: u32 = 1 << 16;
const PLIM_BIT: u32 = 1 << 17;
const MLIM_BIT: u32 = 1 << 18;
const USER_BIT: u32 = 1 << 19;

/// Logical flag inputs of one motor, polarity already applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FlagInputs {
    /// Home flag active.
    pub home: bool,
    /// Positive end limit tripped.
    pub plus_limit: bool,
    /// Negative end limit tripped.
    pub minus_limit: bool,
    /// Amplifier fault (after the Ix25 bit 23 polarity; Ix25 bit 20 is applied by the motor).
    pub amp_fault: bool,
    /// User flag.
    pub user: bool,
}

impl FlagInputs {
    /// Decode a 24-bit flag image word with the motor's Ix25.
    pub fn from_image(word: u32, ix25: u32) -> Self {
        let fault_level = word & FAULT_BIT != 0;
        FlagInputs {
            home: word & HOME_BIT != 0,
            plus_limit: word & PLIM_BIT != 0,
            minus_limit: word & MLIM_BIT != 0,
            amp_fault: if ix25 & (1 << 23) != 0 {
                fault_level
            } else {
                !fault_level
            },
            user: word & USER_BIT != 0,
        }
    }

    /// Healthy inputs as a word with the default polarity (for tests and simulations).
    pub fn healthy_image() -> u32 {
        FAULT_BIT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decode_type1_image() {
        let f = FlagInputs::from_image(FAULT_BIT | HOME_BIT | MLIM_BIT, 0x40F70);
        assert_eq!(
            f,
            FlagInputs {
                home: true,
                plus_limit: false,
                minus_limit: true,
                amp_fault: false,
                user: false
            }
        );
        assert!(
            FlagInputs::from_image(0, 0x40F70).amp_fault,
            "low-true default"
        );
        assert!(!FlagInputs::from_image(0, 0x840F70).amp_fault, "high-true");
        assert!(FlagInputs::from_image(FAULT_BIT, 0x840F70).amp_fault);
        assert!(FlagInputs::from_image(PLIM_BIT | USER_BIT, 0).plus_limit);
        assert!(FlagInputs::from_image(PLIM_BIT | USER_BIT, 0).user);
    }
}
