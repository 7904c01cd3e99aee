//! Why a card refuses a command, in its dialect's own terms: [`ErrCode`], the PMAC2/Turbo
//! `ERRnnn` codes (pmac-commands §7: `ERR001`-`ERR018`), [`PowerErr`], the Power PMAC
//! `error #n` numbers, and [`Refusal`] over both. Every executor returns one of these; the reply
//! framing prints it (PMAC: I6 decides whether `ERRnnn` is sent at all; Power:
//! `stdin:L:C: error #n: TEXT: line`), and a host reply carries it typed
//! (`HostReply::error`), so no caller reads a refusal back out of reply bytes. This module is
//! the only place an error number is written as a literal (the layering test holds it).

use std::fmt;

/// A PMAC error code (`ERRnnn`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum ErrCode {
    /// ERR001: command not allowed while a program executes.
    Running = 1,
    /// ERR002: password error.
    Password = 2,
    /// ERR003: data error or unrecognised command.
    Data = 3,
    /// ERR004: illegal character.
    IllegalChar = 4,
    /// ERR005: command needs an open buffer.
    NeedsBuffer = 5,
    /// ERR006: no room in buffer.
    NoRoom = 6,
    /// ERR007: buffer already in use.
    BufferInUse = 7,
    /// ERR008: MACRO auxiliary communication error.
    MacroAux = 8,
    /// ERR009: program structural error.
    Structure = 9,
    /// ERR010: both overtravel limits set for a motor in the C.S.
    BothLimits = 10,
    /// ERR011: previous move not completed.
    MoveNotDone = 11,
    /// ERR012: a motor in the C.S. is open-loop.
    OpenLoop = 12,
    /// ERR013: a motor in the C.S. is not activated.
    NotActivated = 13,
    /// ERR014: no motors in the C.S.
    NoMotors = 14,
    /// ERR015: not pointing to a valid program buffer.
    NoProgram = 15,
    /// ERR016: running an improperly structured program.
    BadProgram = 16,
    /// ERR017: resume after `/` or `\` with motors away from the stop point.
    AwayFromStop = 17,
    /// ERR018 (Turbo): phase reference during a move, a move during phase reference, or an
    /// enable with a phase-clock error.
    Phase = 18,
}

impl ErrCode {
    /// Every code, ERR001 first.
    pub const ALL: [ErrCode; 18] = [
        ErrCode::Running,
        ErrCode::Password,
        ErrCode::Data,
        ErrCode::IllegalChar,
        ErrCode::NeedsBuffer,
        ErrCode::NoRoom,
        ErrCode::BufferInUse,
        ErrCode::MacroAux,
        ErrCode::Structure,
        ErrCode::BothLimits,
        ErrCode::MoveNotDone,
        ErrCode::OpenLoop,
        ErrCode::NotActivated,
        ErrCode::NoMotors,
        ErrCode::NoProgram,
        ErrCode::BadProgram,
        ErrCode::AwayFromStop,
        ErrCode::Phase,
    ];

    /// The number printed after `ERR`.
    pub fn code(self) -> u16 {
        self as u16
    }

    /// The code for number `n` (1-18).
    pub fn from_code(n: u16) -> Option<ErrCode> {
        ErrCode::ALL.get(usize::from(n).checked_sub(1)?).copied()
    }

    /// The manual's meaning of the code.
    pub fn meaning(self) -> &'static str {
        match self {
            ErrCode::Running => "command not allowed while a program executes",
            ErrCode::Password => "password error",
            ErrCode::Data => "data error or unrecognised command",
            ErrCode::IllegalChar => "illegal character",
            ErrCode::NeedsBuffer => "command needs an open buffer",
            ErrCode::NoRoom => "no room in buffer",
            ErrCode::BufferInUse => "buffer already in use",
            ErrCode::MacroAux => "MACRO auxiliary communication error",
            ErrCode::Structure => "program structural error",
            ErrCode::BothLimits => "both overtravel limits set for a motor in the C.S.",
            ErrCode::MoveNotDone => "previous move not completed",
            ErrCode::OpenLoop => "a motor in the C.S. is open-loop",
            ErrCode::NotActivated => "a motor in the C.S. is not activated",
            ErrCode::NoMotors => "no motors in the C.S.",
            ErrCode::NoProgram => "not pointing to a valid program buffer",
            ErrCode::BadProgram => "improperly structured program",
            ErrCode::AwayFromStop => "motors away from the stop point",
            ErrCode::Phase => "phase reference error",
        }
    }
}

impl fmt::Display for ErrCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ERR{:03}", self.code())
    }
}

impl std::error::Error for ErrCode {}

impl From<ErrCode> for u16 {
    fn from(e: ErrCode) -> u16 {
        e.code()
    }
}

/// A Power PMAC error (`stdin:L:C: error #n: TEXT: line`). \[DECISION\] The seed names only
/// #20 (`ILLEGAL CMD`); the others are numbered here, after it (docs/power-pmac.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum PowerErr {
    /// #20: a command the language does not have.
    IllegalCmd = 20,
    /// #21: an unknown element or variable, an index out of range, a bad parameter.
    IllegalParameter = 21,
    /// #22: a number outside what the command or element allows.
    OutOfRange = 22,
    /// #23: a write to a read-only (status) element.
    ReadOnly = 23,
    /// #24: the motor is not activated.
    MotorNotActive = 24,
    /// #25: the coordinate system is not ready to run (no program, limits, open loop…).
    NotReadyToRun = 25,
    /// #26: not allowed while a program runs.
    ProgramRunning = 26,
    /// #27: the simulated card does not support the function (or the ring refused it).
    NotSupported = 27,
}

impl PowerErr {
    /// Every error, #20 first.
    pub const ALL: [PowerErr; 8] = [
        PowerErr::IllegalCmd,
        PowerErr::IllegalParameter,
        PowerErr::OutOfRange,
        PowerErr::ReadOnly,
        PowerErr::MotorNotActive,
        PowerErr::NotReadyToRun,
        PowerErr::ProgramRunning,
        PowerErr::NotSupported,
    ];

    /// The number printed after `error #`.
    pub fn code(self) -> u16 {
        self as u16
    }

    /// The error numbered `n` (20-27).
    pub fn from_code(n: u16) -> Option<PowerErr> {
        PowerErr::ALL.get(usize::from(n).checked_sub(20)?).copied()
    }

    /// The text after the number.
    pub fn text(self) -> &'static str {
        match self {
            PowerErr::IllegalCmd => "ILLEGAL CMD",
            PowerErr::IllegalParameter => "ILLEGAL PARAMETER",
            PowerErr::OutOfRange => "OUT OF RANGE NUMBER",
            PowerErr::ReadOnly => "READ ONLY",
            PowerErr::MotorNotActive => "MOTOR NOT ACTIVE",
            PowerErr::NotReadyToRun => "NOT READY TO RUN",
            PowerErr::ProgramRunning => "PROGRAM RUNNING",
            PowerErr::NotSupported => "FUNCTION NOT SUPPORTED",
        }
    }

    /// The Power error a PMAC executor's refusal stands for, where a Power command reuses the
    /// PMAC one (a motor or C.S. command, SAVE).
    pub fn from_pmac(e: ErrCode) -> PowerErr {
        match e {
            ErrCode::Running => PowerErr::ProgramRunning,
            ErrCode::NotActivated => PowerErr::MotorNotActive,
            ErrCode::BothLimits
            | ErrCode::MoveNotDone
            | ErrCode::OpenLoop
            | ErrCode::NoMotors
            | ErrCode::NoProgram
            | ErrCode::BadProgram
            | ErrCode::AwayFromStop => PowerErr::NotReadyToRun,
            _ => PowerErr::IllegalParameter,
        }
    }
}

impl fmt::Display for PowerErr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "error #{}", self.code())
    }
}

impl std::error::Error for PowerErr {}

/// Why a card refused a host line: the first refusal of the line, in the card's dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Refusal {
    /// A PMAC2 or Turbo card's `ERRnnn` (sent as such, or as a bare `<BELL>` under I6 = 2, or
    /// not at all under I6 = 1: the refusal is the same).
    Pmac(ErrCode),
    /// A Power card's `error #n`.
    Power(PowerErr),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Pmac(e) => e.fmt(f),
            Refusal::Power(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for Refusal {}

impl From<ErrCode> for Refusal {
    fn from(e: ErrCode) -> Refusal {
        Refusal::Pmac(e)
    }
}

impl From<PowerErr> for Refusal {
    fn from(e: PowerErr) -> Refusal {
        Refusal::Power(e)
    }
}

/// The refusal as it travels to other processes (the `cmd`, `chain` and `at` endpoints:
/// `mcc_contracts::control::refusal`): the same text form, `ERR003` / `error #20`.
impl From<Refusal> for mcc_contracts::control::CardRefusal {
    fn from(r: Refusal) -> Self {
        match r {
            Refusal::Pmac(e) => Self::Pmac(e.code()),
            Refusal::Power(e) => Self::Power(e.code()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_print_as_the_manual_does() {
        assert_eq!(ErrCode::Data.to_string(), "ERR003");
        assert_eq!(ErrCode::AwayFromStop.to_string(), "ERR017");
        for (k, e) in ErrCode::ALL.iter().enumerate() {
            assert_eq!(usize::from(e.code()), k + 1);
            assert_eq!(ErrCode::from_code(e.code()), Some(*e));
        }
        assert_eq!(ErrCode::from_code(0), None);
        assert_eq!(ErrCode::from_code(19), None);
    }

    #[test]
    fn power_errors_print_as_the_dialect_does() {
        assert_eq!(PowerErr::IllegalCmd.to_string(), "error #20");
        assert_eq!(PowerErr::IllegalCmd.text(), "ILLEGAL CMD");
        for (k, e) in PowerErr::ALL.iter().enumerate() {
            assert_eq!(usize::from(e.code()), k + 20);
            assert_eq!(PowerErr::from_code(e.code()), Some(*e));
        }
        assert_eq!(PowerErr::from_code(19), None);
        assert_eq!(PowerErr::from_code(28), None);
        assert_eq!(
            PowerErr::from_pmac(ErrCode::Running),
            PowerErr::ProgramRunning
        );
        assert_eq!(
            PowerErr::from_pmac(ErrCode::Data),
            PowerErr::IllegalParameter
        );
        assert_eq!(Refusal::from(ErrCode::Data).to_string(), "ERR003");
        assert_eq!(Refusal::from(PowerErr::ReadOnly).to_string(), "error #23");
    }

    #[test]
    fn the_wire_form_is_the_display_form() {
        use mcc_contracts::control::CardRefusal;
        for r in ErrCode::ALL
            .map(Refusal::Pmac)
            .into_iter()
            .chain(PowerErr::ALL.map(Refusal::Power))
        {
            let wire = CardRefusal::from(r);
            assert_eq!(wire.to_string(), r.to_string());
            assert_eq!(r.to_string().parse::<CardRefusal>(), Ok(wire));
        }
    }
}
