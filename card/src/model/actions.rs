//! Motion requests: what a command language asks of the motors and the program engine. The
//! interpreter queues them on the model ([`super::CardModel::push_action`]); the servo loop
//! drains them at its next tick, offers each to the program engine (coordinate-system and
//! program requests) and applies the motor side. Dialect-neutral: any command language maps
//! its own syntax onto these.

use crate::domain::ast::JogKind;
use crate::domain::{CsNum, MotorNum};

/// Most actions kept for the motion code before the oldest are dropped.
pub(crate) const MAX_ACTIONS: usize = 4096;

/// A motion request with the addressing in force when it was given.
#[derive(Debug, Clone, PartialEq)]
pub struct Action {
    /// Motor addressed when the command was given.
    pub motor: MotorNum,
    /// Coordinate system addressed when the command was given.
    pub coord: CsNum,
    /// What was asked.
    pub kind: ActionKind,
}

/// The kinds of [`Action`].
#[derive(Debug, Clone, PartialEq)]
pub enum ActionKind {
    // --- the addressed motor
    /// Kill: open loop, output 0, amplifier off (`K`; also `$*`).
    Kill,
    /// Close the loop where the motor stands (`$`).
    Enable,
    /// Open-loop output at `n` % of Ix69 (`O{n}`).
    OpenLoop(f64),
    /// Homing search (`HM`).
    Home,
    /// Zero the position here (`HMZ`).
    HomeZero,
    /// `$*`: kill and read the absolute position (Ix10 = 0: zero it), bias 0.
    AbsRead,
    /// A jog (`J+`, `J=…`, …), with the jog-until-trigger distance.
    Jog {
        /// Which jog.
        kind: JogKind,
        /// `^{d}` distance past the trigger.
        trigger: Option<f64>,
    },
    // --- the addressed coordinate system
    /// Point the program counter (`B`): the engine drops its frames and stop point.
    Begin,
    /// Run continuously (`R`).
    Run,
    /// Run one step (`S`).
    Step,
    /// Resume (`>`).
    Resume,
    /// Quit at the end of the calculated moves (`Q`).
    Quit,
    /// Stop at the end of the executing move (`/`).
    StopAtEnd,
    /// Abort: decelerate the C.S.'s motors at Ix15 (`A`).
    Abort,
    /// Abort the one motor `motor` (Ix15 deceleration): a Power card's global abort input for
    /// a motor in no C.S. (`Coord[0].AbortAllMode`).
    AbortMotor,
    /// Feed hold (`H`).
    Hold,
    /// Hold allowing jogs (`\`).
    HoldJog,
    /// Back up (`<`).
    BackUp,
    /// Feedrate override in percent (`%{v}`).
    Override(f64),
    /// Discard pending synchronous M-variable assignments (`MFLUSH`).
    MFlush,
    /// Re-match axis positions to motor positions (`PMATCH`).
    PMatch,
    /// `{axis}={v}`: rename the axis's present commanded position through the motors'
    /// position bias.
    AxisRename(crate::domain::ast::Axis, f64),
    /// `Z`: every axis of the C.S. renamed to zero.
    ZeroAxes,
    // --- every motor / coordinate system
    /// Abort everything (CTRL-A).
    AbortAll,
    /// Kill every motor (CTRL-K).
    KillAll,
    /// Feed hold on every C.S. (CTRL-O).
    HoldAll,
    /// Quit every C.S. (CTRL-Q).
    QuitAll,
}

impl ActionKind {
    /// Starts a motion program (`R`, `S`): what synchronized start records.
    pub fn starts_program(&self) -> bool {
        matches!(self, ActionKind::Run | ActionKind::Step)
    }
}
