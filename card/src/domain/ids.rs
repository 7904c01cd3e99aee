//! Numbers that name things on a card: motors (`#n`), coordinate systems (`&n`) and MACRO ring
//! nodes. Each is a newtype so a motor number cannot be passed where a C.S. number is meant;
//! the range a profile allows is checked where the number enters (`MotorNum::new(n, limits)`).

use std::fmt;

use super::profile::Limits;

macro_rules! card_number {
    ($(#[$doc:meta])* $name:ident, $field:ident, $prefix:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(u16);

        impl $name {
            /// Number `n` if the profile has it (1-based).
            pub fn new(n: u32, limits: &Limits) -> Option<Self> {
                (1..=u32::from(limits.$field))
                    .contains(&n)
                    .then(|| $name(n as u16))
            }

            /// Number `n` without a profile check (`n` ≥ 1 is the caller's promise; 0 becomes 1).
            pub fn from_index(k: usize) -> Self {
                $name(u16::try_from(k + 1).unwrap_or(u16::MAX))
            }

            /// Number `n` without a profile check (0 becomes 1; the range is checked where
            /// the number is used, [`Self::clamp`]).
            pub fn of(n: u16) -> Self {
                $name(n.max(1))
            }

            /// Number 1 (the power-up addressing).
            pub const FIRST: Self = $name(1);

            /// This number kept inside the profile's range.
            pub fn clamp(self, limits: &Limits) -> Self {
                $name(self.0.clamp(1, u16::from(limits.$field).max(1)))
            }

            /// The 1-based number.
            pub fn get(self) -> u16 {
                self.0
            }

            /// The 0-based index into per-unit tables.
            pub fn index(self) -> usize {
                usize::from(self.0.max(1) - 1)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!($prefix, "{}"), self.0)
            }
        }
    };
}

card_number!(
    /// A motor number (`#1`…): 1-8 on PMAC2, 1-32 on Turbo.
    MotorNum,
    motors,
    "#"
);
card_number!(
    /// A coordinate-system number (`&1`…): 1-8 on PMAC2, 1-16 on Turbo.
    CsNum,
    coords,
    "&"
);

/// A MACRO ring node number, 0-15 (node 15 carries the sync packet).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeNum(u8);

impl NodeNum {
    /// Node `n` if it is 0-15.
    pub fn new(n: u32) -> Option<Self> {
        (n < 16).then_some(NodeNum(n as u8))
    }

    /// The node number.
    pub fn get(self) -> u8 {
        self.0
    }

    /// Its bit in I996 / I1000 / I1002.
    pub fn bit(self) -> u32 {
        1 << self.0
    }
}

impl fmt::Display for NodeNum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "node {}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::profile::{limits, Profile};

    #[test]
    fn numbers_are_checked_against_the_profile() {
        let p = limits(Profile::Pmac2);
        let t = limits(Profile::Turbo);
        assert_eq!(MotorNum::new(8, &p).map(MotorNum::get), Some(8));
        assert_eq!(MotorNum::new(9, &p), None);
        assert_eq!(MotorNum::new(0, &p), None);
        assert_eq!(MotorNum::new(32, &t).map(MotorNum::index), Some(31));
        assert_eq!(
            CsNum::new(16, &t).map(|c| c.to_string()),
            Some("&16".into())
        );
        assert_eq!(CsNum::new(9, &p), None);
        assert_eq!(NodeNum::new(15).map(NodeNum::bit), Some(0x8000));
        assert_eq!(NodeNum::new(16), None);
        assert_eq!(MotorNum::from_index(0).to_string(), "#1");
    }
}
