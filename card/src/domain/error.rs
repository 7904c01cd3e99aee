//! The PMAC error codes a command can be refused with (pmac-commands §7): `ERR001`-`ERR018`.
//! Declared, not yet wired: the interpreter still returns bare `u16` error numbers and the
//! reply framing prints those as `ERRnnn` (I6 decides whether the text is sent at all).
//! Issue 24 item 2 makes every refusal one of these.

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
}
