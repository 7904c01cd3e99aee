//! Axis and global parameter tables (spec emcl.md §7, §8): number, range, access. Unlisted
//! numbers do not exist (status 3). Ranges are the seed's printed bounds (errata E15, E17:
//! the printed bounds are accepted as printed, clipped to i32 where they exceed it).

/// Who may write a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read-only (GAP/GGP); SAP/SGP/AAP/AGP/STAP give status 3 (D6, D16).
    R,
    /// Readable and writable.
    RW,
}

/// Allowed values of a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Range {
    /// Inclusive bounds.
    Span(i64, i64),
    /// One of these values.
    OneOf(&'static [i32]),
}

impl Range {
    /// Whether `v` is allowed.
    pub fn contains(self, v: i32) -> bool {
        match self {
            Range::Span(lo, hi) => (lo..=hi).contains(&i64::from(v)),
            Range::OneOf(set) => set.contains(&v),
        }
    }
}

/// One parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamInfo {
    /// Number.
    pub num: u8,
    /// Access.
    pub access: Access,
    /// Accepted values on write.
    pub range: Range,
}

const I32: Range = Range::Span(i32::MIN as i64, i32::MAX as i64);
const V24: Range = Range::Span(-8_388_608, 8_388_607);
const A23: Range = Range::Span(-4_194_304, 4_194_303);
const U8: Range = Range::Span(0, 255);
const B01: Range = Range::Span(0, 1);
const R03: Range = Range::Span(0, 3);
const CL25: Range = Range::Span(-16_777_216, 16_777_217);
const CL16: Range = Range::Span(-32_768, 32_768);
const POS31: Range = Range::Span(0, i32::MAX as i64);

const fn rw(num: u8, range: Range) -> ParamInfo {
    ParamInfo {
        num,
        access: Access::RW,
        range,
    }
}
const fn ro(num: u8, range: Range) -> ParamInfo {
    ParamInfo {
        num,
        access: Access::R,
        range,
    }
}

/// Every axis parameter of the EDB (§7.1–§7.3), ascending.
pub const AXIS_PARAMS: &[ParamInfo] = &[
    rw(0, I32),
    rw(1, I32),
    rw(2, V24),
    ro(3, V24),
    rw(4, V24),
    rw(5, V24),
    rw(6, U8),
    rw(7, U8),
    ro(8, B01),
    ro(10, B01),
    ro(11, B01),
    rw(12, Range::OneOf(&[0, 1, 3])),
    rw(13, Range::OneOf(&[0, 1, 3])),
    rw(15, V24),
    rw(16, A23),
    rw(17, A23),
    rw(18, V24),
    rw(19, A23),
    rw(20, V24),
    rw(21, A23),
    rw(26, I32),
    rw(27, I32),
    rw(28, R03),
    rw(29, Range::Span(0, 2)),
    rw(108, V24),
    rw(109, V24),
    rw(110, U8),
    rw(111, Range::Span(0, 511)),
    rw(112, I32),
    rw(113, U8),
    rw(114, U8),
    rw(115, CL25),
    rw(116, CL25),
    rw(117, CL16),
    rw(118, CL16),
    rw(119, I32),
    rw(120, CL25),
    rw(121, CL25),
    rw(124, CL25),
    rw(125, U8),
    rw(127, Range::Span(0, 2)),
    rw(129, B01),
    ro(133, B01),
    rw(134, I32),
    rw(136, I32),
    rw(137, I32),
    rw(138, I32),
    rw(162, R03),
    rw(163, B01),
    rw(164, R03),
    rw(165, Range::Span(-3, 12)),
    rw(166, Range::Span(0, 8)),
    rw(
        167,
        Range::OneOf(&[0, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]),
    ),
    rw(168, B01),
    rw(169, R03),
    rw(170, Range::Span(0, 15)),
    rw(171, R03),
    rw(172, Range::Span(0, 15)),
    rw(173, B01),
    rw(174, Range::Span(-64, 63)),
    rw(175, R03),
    rw(176, R03),
    rw(177, B01),
    rw(178, R03),
    rw(179, B01),
    ro(180, Range::Span(0, 31)),
    rw(181, V24),
    rw(182, V24),
    rw(183, U8),
    rw(193, Range::OneOf(&[9, 10])),
    rw(195, Range::Span(0, 51_200)),
    rw(200, U8),
    rw(202, Range::Span(1, 65_535)),
    ro(206, Range::Span(0, 1023)),
    ro(208, U8),
    rw(209, I32),
    rw(210, POS31),
    rw(212, POS31),
    rw(213, POS31),
    rw(214, Range::Span(0, 65_535)),
    rw(215, Range::Span(0, 16_383)),
    rw(254, Range::OneOf(&[0, 1, 2, 3, 5, 6, 7])),
];

/// Bank-0 global parameters (§8.1), ascending. 64..=87 are the E (EEPROM) parameters.
pub const GLOBAL_PARAMS: &[ParamInfo] = &[
    rw(64, U8),
    rw(65, Range::Span(0, 11)),
    rw(66, U8),
    rw(68, Range::Span(0, 65_535)),
    rw(72, Range::Span(0, 7)),
    rw(73, Range::OneOf(&[1234, 4321])),
    rw(75, U8),
    rw(76, U8),
    rw(77, B01),
    rw(80, Range::Span(0, 2)),
    rw(81, R03),
    rw(84, B01),
    rw(87, U8),
    ro(128, R03),
    ro(129, B01),
    ro(130, Range::Span(0, 2047)),
    rw(132, I32),
    rw(133, POS31),
];

/// Axis parameter `n`, if the EDB has it.
pub fn axis(n: u8) -> Option<&'static ParamInfo> {
    AXIS_PARAMS
        .binary_search_by_key(&n, |p| p.num)
        .ok()
        .and_then(|i| AXIS_PARAMS.get(i))
}

/// Bank-0 global parameter `n`, if the EDB has it.
pub fn global(n: u8) -> Option<&'static ParamInfo> {
    GLOBAL_PARAMS
        .binary_search_by_key(&n, |p| p.num)
        .ok()
        .and_then(|i| GLOBAL_PARAMS.get(i))
}

/// Bank-0 parameters held in EEPROM (written at once by SGP, restored at power-up).
pub fn global_is_eeprom(n: u8) -> bool {
    (64..=87).contains(&n) && global(n).is_some()
}

/// Bank-2 user variables held in EEPROM (STGP/RSGP, restored at power-up): 0..=55.
pub const USER_EEPROM_VARS: usize = 56;

/// The valid EEPROM magic (GP 64).
pub const EEPROM_MAGIC: i32 = 0xE4;

/// GP 73 lock / unlock codes.
pub const LOCK_CODE: i32 = 1234;
/// GP 73 unlock code.
pub const UNLOCK_CODE: i32 = 4321;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_sorted_and_unique() {
        for t in [AXIS_PARAMS, GLOBAL_PARAMS] {
            assert!(t.windows(2).all(|w| w[0].num < w[1].num));
        }
    }

    #[test]
    fn lookups_and_ranges() {
        assert!(axis(9).is_none() && axis(14).is_none() && axis(140).is_none());
        assert_eq!(axis(3).map(|p| p.access), Some(Access::R));
        assert!(axis(202).is_some() && axis(214).is_some());
        let p12 = axis(12).unwrap();
        assert!(p12.range.contains(3) && !p12.range.contains(2));
        assert!(axis(174).unwrap().range.contains(-64));
        assert!(!axis(174).unwrap().range.contains(64));
        assert!(global(73).unwrap().range.contains(1234));
        assert!(!global(73).unwrap().range.contains(1));
        assert!(global(67).is_none() && global(79).is_none());
        assert!(global_is_eeprom(66) && !global_is_eeprom(128) && !global_is_eeprom(67));
    }
}
