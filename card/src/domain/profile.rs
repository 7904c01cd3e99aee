//! Per-profile card dimensions (pmac2 = seed manual, turbo = DLS host-compatibility).

/// Which table set the card answers with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Profile {
    /// PMAC2 (seed manual): 8 motors, 8 coordinate systems, variables 0-1023.
    #[default]
    Pmac2,
    /// Turbo host-compatibility: 32 motors, 16 coordinate systems, variables 0-8191, CID.
    Turbo,
}

/// Sizes and identity answers of one profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Number of motors (`#1..#motors`).
    pub motors: u16,
    /// Number of coordinate systems (`&1..&coords`).
    pub coords: u16,
    /// Number of I, P, Q and M variables each (numbers `0..vars`).
    pub vars: u16,
    /// `CID` answer, `None` when the command does not exist (pmac2: ERR003).
    pub cid: Option<u32>,
    /// Hex digits in a `??` reply (12 on PMAC2, 18 on Turbo).
    pub cs_status_digits: u8,
}

/// The dimensions of `profile`.
pub(crate) fn limits(profile: Profile) -> Limits {
    match profile {
        Profile::Pmac2 => Limits {
            motors: 8,
            coords: 8,
            vars: 1024,
            cid: None,
            cs_status_digits: 12,
        },
        Profile::Turbo => Limits {
            motors: 32,
            coords: 16,
            vars: 8192,
            cid: Some(602413),
            cs_status_digits: 18,
        },
    }
}

/// Stable lower-case name used in config files and `mcc status --json`.
pub(crate) fn name(profile: Profile) -> &'static str {
    match profile {
        Profile::Pmac2 => "pmac2",
        Profile::Turbo => "turbo",
    }
}

/// Parse a profile name as written in config (`pmac2`, `turbo`, case-insensitive).
#[cfg(test)]
pub(crate) fn parse(s: &str) -> Option<Profile> {
    match s.to_ascii_lowercase().as_str() {
        "pmac2" => Some(Profile::Pmac2),
        "turbo" => Some(Profile::Turbo),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dimensions() {
        assert_eq!(limits(Profile::Pmac2).motors, 8);
        assert_eq!(limits(Profile::Pmac2).vars, 1024);
        assert_eq!(limits(Profile::Turbo).coords, 16);
        assert_eq!(limits(Profile::Turbo).cid, Some(602413));
        assert_eq!(parse("Turbo"), Some(Profile::Turbo));
        assert_eq!(parse("pmac1"), None);
        assert_eq!(name(Profile::Pmac2), "pmac2");
    }
}
