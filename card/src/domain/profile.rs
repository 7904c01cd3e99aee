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

/// The I-variable numbers of the MACRO ring setup (MACRO IC 0 on Turbo).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct RingIvars {
    /// Ring configuration/status (PMAC2 I995, Turbo I6840).
    pub(crate) cfg: u32,
    /// Node activation, sync node, master number (I996 / I6841).
    pub(crate) nodes: u32,
    /// Node auxiliary register copy enable (I1000 / I70).
    pub(crate) aux_enable: u32,
    /// Ring check period (I1001 / I80).
    pub(crate) check_period: u32,
    /// Node protocol type, 1 = Type 1 flags in register 3 (I1002 / I71).
    pub(crate) protocol: u32,
    /// Master/slave auxiliary communications timeout (I1003 / I78).
    pub(crate) aux_timeout: u32,
    /// Ring error count limit (I1004 / I81).
    pub(crate) error_limit: u32,
    /// Minimum sync packets per check period (I1005 / I82).
    pub(crate) sync_min: u32,
}

/// The ring I-variable numbers of `profile`.
pub(crate) const fn ring_ivars(profile: Profile) -> RingIvars {
    match profile {
        Profile::Pmac2 => RingIvars {
            cfg: 995,
            nodes: 996,
            aux_enable: 1000,
            check_period: 1001,
            protocol: 1002,
            aux_timeout: 1003,
            error_limit: 1004,
            sync_min: 1005,
        },
        Profile::Turbo => RingIvars {
            cfg: 6840,
            nodes: 6841,
            aux_enable: 70,
            check_period: 80,
            protocol: 71,
            aux_timeout: 78,
            error_limit: 81,
            sync_min: 82,
        },
    }
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
