//! Dispatch of one on-line command to its command-group executor. Each executor pushes reply
//! lines into `out` and returns `Err(code)` for `ERRnnn`.

use super::{Pmac, Session};
use crate::domain::ErrCode;
use crate::lang::pmac::ast::CmdKind;

/// Result of one command: `Err(n)` = report `ERRnnn`.
pub(crate) type Exec = Result<(), ErrCode>;

/// What the line loop must do after a command.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) enum Flow {
    /// Continue with the next command.
    #[default]
    Next,
    /// The command finishes once this is done (SAVE's write, `$$$`'s image load).
    Effect(super::image::Effect),
}

/// Reply lines produced by one command.
#[derive(Debug, Default)]
pub(crate) struct Out {
    /// Data lines without terminators.
    pub lines: Vec<String>,
    /// Flow control for the line loop.
    pub flow: Flow,
    /// A MACRO auxiliary command's accesses: the line waits for them (`exec_macro`).
    pub aux: Option<super::exec_macro::AuxJob>,
}

impl Out {
    /// Add a reply line.
    pub(crate) fn line(&mut self, s: impl Into<String>) {
        self.lines.push(s.into());
    }
}

impl Pmac<'_> {
    /// Execute one on-line command. Every command kind is listed in exactly one group (no
    /// catch-all arm): a new kind does not compile until it has an executor.
    pub(crate) fn exec_cmd(&mut self, s: &mut Session, cmd: &CmdKind, out: &mut Out) -> Exec {
        use CmdKind as K;
        match cmd {
            K::VarQuery(_)
            | K::VarAssign(..)
            | K::VarDefault(_)
            | K::MDefQuery(_)
            | K::MDefine(..)
            | K::BareNumber(_)
            | K::ReadMem { .. }
            | K::WriteMem { .. } => self.exec_vars(s, cmd, out),

            K::Open(_)
            | K::Close
            | K::Clear
            | K::List(_)
            | K::Define(_)
            | K::Delete(_)
            | K::Gather { .. }
            | K::EndGather
            | K::Plc(_)
            | K::SetPhase(_) => self.exec_buffers(s, cmd, out),

            K::Reset
            | K::Reinit
            | K::Save
            | K::Password(_)
            | K::ClearFault
            | K::Type
            | K::Version
            | K::Date
            | K::EaVersion
            | K::Checksum
            | K::Size
            | K::Cid
            | K::Cpu
            | K::GlobalStatus
            | K::AddrCard(_)
            | K::AddrAllCards
            | K::ReportCard => self.exec_info(s, cmd, out),

            K::MacroAux { .. }
            | K::MacroAuxRead { .. }
            | K::MacroAuxWrite { .. }
            | K::MacroSlaveCmd { .. }
            | K::MacroSlaveVar { .. }
            | K::MacroSlaveRange { .. }
            | K::MacroSlaveRead { .. }
            | K::MacroSlaveWrite { .. } => self.exec_macro(s, cmd, out),

            K::AddrMotor { .. }
            | K::ReportMotor
            | K::AddrCoord { .. }
            | K::ReportCoord
            | K::UndefineAll
            | K::AxisDefQuery { .. }
            | K::AxisDefine { .. }
            | K::AxisUndefine { .. }
            | K::Undefine
            | K::CsStatus
            | K::OverrideQuery
            | K::OverrideSet { .. }
            | K::Begin { .. }
            | K::Run
            | K::Step
            | K::Quit
            | K::Abort
            | K::Hold
            | K::StopAtEnd
            | K::HoldJog
            | K::BackUp
            | K::Resume
            | K::MFlush
            | K::PMatch
            | K::AxisRename { .. }
            | K::ZeroAxes
            | K::Abs { .. }
            | K::Inc { .. }
            | K::Frax { .. }
            | K::ProgCounter
            | K::ExecPointer
            | K::RotaryRemaining
            | K::Learn { .. }
            | K::MotorInit
            | K::MotorAbsRead
            | K::Home
            | K::HomeZ
            | K::Kill
            | K::OpenLoop { .. }
            | K::Jog { .. }
            | K::Position
            | K::Velocity
            | K::FollowingError
            | K::MotorStatus => self.exec_motion(s, cmd, out),
        }
    }
}
