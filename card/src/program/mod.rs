//! Motion programs, PLCs and run control: the program engine of a card.
//!
//! Contract with the servo loop (`crate::servo`): every servo tick the loop calls
//! [`ProgramEngine::handle_action`] for each drained interpreter action (the engine takes the
//! coordinate-system / program ones and returns `false` for the rest), then
//! [`ProgramEngine::servo_tick`] (PLC 0, trajectory of every running coordinate system) which
//! returns each motor's program setpoint, then runs the motors, reports trips through
//! [`ProgramEngine::on_trip`], and finally calls [`ProgramEngine::background`] once (PLC 1-31
//! scans, program look-ahead) — one background cycle per servo tick, in ring time.

use crate::interp::{Action, Card};
use crate::motion::motor::{Motor, TripScope};

/// The program engine of one card.
#[derive(Debug, Default)]
pub struct ProgramEngine {}

impl ProgramEngine {
    /// An engine with nothing running.
    pub fn new() -> Self {
        ProgramEngine {}
    }

    /// Take a coordinate-system or program action (R, S, Q, A, H, B, /, \, PC, PE, CTRL-R/S/Q/
    /// O/A, ...). Returns `false` when the action is not the engine's (motor actions).
    pub fn handle_action(&mut self, _card: &mut Card, _motors: &[Motor], _action: &Action) -> bool {
        false
    }

    /// One servo tick at ring cycle `cycle`, `dt_ms` of (time-base scaled) time: PLC 0 and every
    /// running coordinate system. Returns, per motor (index 0 = motor 1), the program's
    /// commanded position in counts, or `None` when the motor is not under program control.
    pub fn servo_tick(
        &mut self,
        _card: &mut Card,
        motors: &[Motor],
        _cycle: u64,
        _dt_ms: f64,
    ) -> Vec<Option<f64>> {
        vec![None; motors.len()]
    }

    /// A motor tripped (following error, amp fault, limit): abort or kill per `scope`.
    pub fn on_trip(&mut self, _card: &mut Card, _motor: usize, _scope: TripScope) {}

    /// The ring failed: abort every program (the servo loop kills the motors).
    pub fn on_ring_fault(&mut self, _card: &mut Card) {}

    /// One background cycle: PLC 1-31 scans (I5 gating), program look-ahead.
    pub fn background(&mut self, _card: &mut Card, _motors: &[Motor]) {}
}
