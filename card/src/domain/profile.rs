//! Per-profile card dimensions (pmac2 = seed manual, turbo = DLS host-compatibility).

/// Which table set the card answers with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Profile {
    /// PMAC2 (seed manual): 8 motors, 8 coordinate systems, variables 0-1023.
    #[default]
    Pmac2,
    /// Turbo host-compatibility: 32 motors, 16 coordinate systems, variables 0-8191, CID.
    Turbo,
    /// Power PMAC (seed 000): motors 0-31, coordinate systems 0-15, P0-65535, Q0-8191 per
    /// C.S., M0-16383; the script language and data structures of the Power PMAC. The model
    /// numbers motors and C.S.s from 1 (model motor k is the controller's motor k-1).
    Power,
}

impl Profile {
    /// The profile named `s` in a config file or on the command line (`pmac2`, `turbo`,
    /// `power`, case-insensitive).
    pub fn from_name(s: &str) -> Option<Profile> {
        parse(s)
    }

    /// Its lower-case name.
    pub fn name(self) -> &'static str {
        name(self)
    }
}

/// Sizes and identity answers of one profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Number of motors (`#1..#motors`).
    pub motors: u16,
    /// Number of coordinate systems (`&1..&coords`).
    pub coords: u16,
    /// Number of I-variables in the model (numbers `0..vars`); on the classic profiles also
    /// the number of P, Q and M variables.
    pub vars: u16,
    /// Number of P-variables (`0..p_vars`).
    pub p_vars: u32,
    /// Number of Q-variables per coordinate system (`0..q_vars`).
    pub q_vars: u32,
    /// Number of M-variables (`0..m_vars`).
    pub m_vars: u32,
    /// `CID` answer, `None` when the command does not exist (pmac2: ERR003).
    pub cid: Option<u32>,
    /// `CPU` / `cpu` answer, `None` when the command does not exist (pmac2: ERR003; seed 004
    /// has no CPU command). Turbo: the DSP type, as DLS's SimPMAC answers and the DLS pmac
    /// IOC expects (`DSP56321`, a 240 MHz Option 5F CPU); Power: seed 000's example form.
    pub cpu: Option<&'static str>,
    /// Hex digits in a `??` reply (12 on PMAC2, 18 on Turbo).
    pub cs_status_digits: u8,
    /// How the motion core and the evaluator behave where the profiles differ.
    pub sem: Semantics,
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
        // Power PMAC cards run on the Turbo model (see docs/power-pmac.md).
        Profile::Turbo | Profile::Power => RingIvars {
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
/// Behaviour of the shared motion core and evaluator that differs between controller
/// generations (dialect-neutral switches; each profile sets them once).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Semantics {
    /// IEEE double arithmetic: values are kept as 64-bit doubles (not rounded to the 48-bit
    /// PMAC float), division by zero gives ±infinity and NaN/infinity are kept.
    pub ieee: bool,
    /// What the fraction of a `CALL n.f` label is multiplied by (100,000 classic,
    /// 1,000,000 Power PMAC).
    pub call_label_scale: f64,
    /// Total acceleration time of a blended move is Ta + Ts (2·Ts when Ts > Ta) rather than
    /// Ta (Power PMAC).
    pub accel_adds_scurve: bool,
    /// Subprograms (`CALL n`, G/M/T/D codes) live in their own namespace: buffer number
    /// `subprog_base + n` (0: they are motion programs).
    pub subprog_base: u16,
    /// G/M/T/D codes call the subprograms whose numbers are in C.S. I-variables
    /// Isx{n}..Isx{n+3} at label round(code × 1000) (Power PMAC `Coord[x].Gprog` ...);
    /// `None`: classic PROG 10n0-10n3.
    pub code_prog_ivar: Option<u8>,
    /// Deepest nesting of calls (GOSUB, CALL, G-codes) in a motion program.
    pub max_call_depth: u16,
    /// Where `READ` puts the arguments: `Some(f)`: letter k (A = 1 … Z = 26) into number k
    /// of the language's extension family `f`, the mask of letters read (bit k−1) into
    /// numbers 0 and 54 (Power PMAC D-variables); `None`: Q101-Q126 and Q100 (classic).
    pub read_ext: Option<u16>,
    /// A call of a missing program stops the program with a run-time error and a missing
    /// label calls the program's top (Power PMAC, seed L39878-39880); `false`: both are
    /// ignored (classic).
    pub strict_calls: bool,
    /// PLCs call subroutines and subprograms (`gosub`, `callsub`, `call`, G/M/T/D codes, with
    /// `read`), which then run by PLC rules (Power PMAC); `false`: these statements do nothing
    /// in a PLC (classic).
    pub plc_calls: bool,
}

/// The classic (PMAC2/Turbo) behaviour.
const CLASSIC: Semantics = Semantics {
    ieee: false,
    call_label_scale: 100_000.0,
    accel_adds_scurve: false,
    subprog_base: 0,
    code_prog_ivar: None,
    max_call_depth: 16,
    read_ext: None,
    strict_calls: false,
    plc_calls: false,
};

/// The dimensions of `profile`.
pub(crate) fn limits(profile: Profile) -> Limits {
    match profile {
        Profile::Pmac2 => Limits {
            motors: 8,
            coords: 8,
            vars: 1024,
            p_vars: 1024,
            q_vars: 1024,
            m_vars: 1024,
            cid: None,
            cpu: None,
            cs_status_digits: 12,
            sem: CLASSIC,
        },
        Profile::Turbo => Limits {
            motors: 32,
            coords: 16,
            vars: 8192,
            p_vars: 8192,
            q_vars: 8192,
            m_vars: 8192,
            cid: Some(602413),
            cpu: Some("DSP56321"),
            cs_status_digits: 18,
            sem: CLASSIC,
        },
        Profile::Power => Limits {
            motors: 32,
            coords: 16,
            vars: POWER_IVARS,
            p_vars: 65_536,
            q_vars: 8192,
            m_vars: 16_384,
            cid: Some(604020),
            cpu: Some("Power PC, 460EX"),
            cs_status_digits: 16,
            sem: Semantics {
                ieee: true,
                call_label_scale: 1_000_000.0,
                accel_adds_scurve: true,
                subprog_base: POWER_SUBPROG_BASE,
                code_prog_ivar: Some(POWER_CODE_PROG_IVAR),
                max_call_depth: 255,
                read_ext: Some(POWER_READ_EXT),
                strict_calls: true,
                plc_calls: true,
            },
        },
    }
}

/// Model I-variables of the Power profile: the Turbo numbering (0-8191); the dialect keeps
/// the elements without a classic variable itself.
pub(crate) const POWER_IVARS: u16 = 8192;

/// Model C.S. I-variables Isx40-Isx43 hold `Coord[x].Gprog/Mprog/Tprog/Dprog` on the Power
/// profile.
pub(crate) const POWER_CODE_PROG_IVAR: u8 = 40;

/// The extension family of the Power dialect's D-variables (`READ` fills them).
pub(crate) const POWER_READ_EXT: u16 = 4;

/// Buffer number of Power PMAC subprogram 0 (subprograms 0-32767 are buffers 32768-65535).
pub(crate) const POWER_SUBPROG_BASE: u16 = 32_768;

/// Stable lower-case name used in config files and `mcc status --json`.
pub(crate) fn name(profile: Profile) -> &'static str {
    match profile {
        Profile::Pmac2 => "pmac2",
        Profile::Turbo => "turbo",
        Profile::Power => "power",
    }
}

/// Parse a profile name as written in config (`pmac2`, `turbo`, `power`, case-insensitive).
pub(crate) fn parse(s: &str) -> Option<Profile> {
    match s.to_ascii_lowercase().as_str() {
        "pmac2" => Some(Profile::Pmac2),
        "turbo" => Some(Profile::Turbo),
        "power" => Some(Profile::Power),
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
        assert_eq!(Profile::from_name("POWER"), Some(Profile::Power));
        assert_eq!(limits(Profile::Power).p_vars, 65_536);
        assert!(limits(Profile::Power).sem.ieee && !limits(Profile::Turbo).sem.ieee);
    }
}
