//! Interpreter actions → motor commands. Every action is offered to the program engine first
//! (it takes the coordinate-system and program ones); the motor side of the motor commands,
//! of the C.S. abort `A` and of CTRL-A / CTRL-K is applied here whatever the engine says.
//!
//! | action | motors | command |
//! |---|---|---|
//! | `K` | addressed | kill |
//! | `$` | addressed | enable (close the loop where it stands) |
//! | `$*` | addressed | kill; Ix10 = 0: actual position 0; position bias 0 |
//! | `O{n}` | addressed | open loop at n % of Ix69 |
//! | `J...` | addressed | jog (`*` forms read the Mx72 jog register), `J!` rounds |
//! | `HM` / `HMZ` | addressed | homing search / zero here |
//! | `A` | the motors of the addressed C.S. | abort (Ix15 deceleration) |
//! | CTRL-A | every activated motor | abort |
//! | CTRL-K | every motor | kill |
//!
//! Motors with Ix00 = 0 ignore everything but kills (documented refusal: a deactivated motor
//! has no servo loop to command).

use crate::domain::ast::JogKind;
use crate::model::{Action, ActionKind, CardModel};
use crate::motion::motor::{Motor, MotorCommand};
use crate::motion::params::MotorParams;
use crate::program::{MotorUpdate, ProgramEngine};

use super::registers::jog_register;

/// Apply one drained action.
pub(super) fn apply_action(
    card: &mut CardModel,
    motors: &mut [Motor],
    params: &[MotorParams],
    engine: &mut ProgramEngine,
    a: &Action,
) {
    let _ = engine.handle_action(card, motors, a);
    let all: Vec<u16> = (1..=motors.len() as u16).collect();
    let (targets, cmd): (Vec<u16>, Option<MotorCommand>) = match &a.kind {
        ActionKind::AbortAll => (all, Some(MotorCommand::Abort)),
        ActionKind::KillAll => (all, Some(MotorCommand::Kill)),
        c => match c {
            ActionKind::Abort => (card.run.motors_in(a.coord.get()), Some(MotorCommand::Abort)),
            ActionKind::AbortMotor => (vec![a.motor.get()], Some(MotorCommand::Abort)),
            ActionKind::Kill => (vec![a.motor.get()], Some(MotorCommand::Kill)),
            ActionKind::Enable => (vec![a.motor.get()], Some(MotorCommand::Enable)),
            ActionKind::OpenLoop(v) => (vec![a.motor.get()], Some(MotorCommand::OpenLoop(*v))),
            ActionKind::Home => (vec![a.motor.get()], Some(MotorCommand::Home)),
            ActionKind::HomeZero => (vec![a.motor.get()], Some(MotorCommand::HomeZero)),
            ActionKind::AbsRead => (vec![a.motor.get()], Some(MotorCommand::AbsRead)),
            ActionKind::Jog { kind, trigger } => {
                let k = a.motor.index();
                let Some(m) = motors.get_mut(k) else {
                    return;
                };
                let cmd = if *kind == JogKind::Round {
                    Some(MotorCommand::Round)
                } else {
                    let reg = jog_register(&mut card.state, a.motor.get());
                    m.resolve_jog(*kind, reg).map(|cmd| MotorCommand::Jog {
                        cmd,
                        trigger: trigger.filter(|d| d.is_finite()),
                    })
                };
                (vec![a.motor.get()], cmd)
            }
            _ => return,
        },
    };
    let Some(cmd) = cmd else {
        return;
    };
    for x in targets {
        let k = usize::from(x.max(1) - 1);
        let (Some(m), Some(p)) = (motors.get_mut(k), params.get(k)) else {
            continue;
        };
        // Homing puts the axis-definition offset into the position bias (seed 8244-8246).
        m.axis_offset = card
            .run
            .axes
            .get(k)
            .and_then(|d| d.as_ref())
            .map_or(0.0, |(_, d)| d.offset)
            .clamp(-1e15, 1e15);
        if p.active || matches!(cmd, MotorCommand::Kill | MotorCommand::AbsRead) {
            m.command(cmd, p);
        }
    }
}

/// Motors marked to be disabled once their commanded stop is over (`MotorRun::
/// disable_at_rest`): killed in the first tick that finds them stopped; a motor that is no
/// longer closed-loop (killed, tripped, open loop) drops the mark.
pub(super) fn disable_at_rest(card: &mut CardModel, motors: &mut [Motor]) {
    for (run, m) in card.run.motors.iter_mut().zip(motors.iter_mut()) {
        if !run.disable_at_rest {
            continue;
        }
        if !m.closed_loop() {
            run.disable_at_rest = false;
        } else if !m.flags.abort_decel && m.trajectory().finished() {
            m.kill();
            run.disable_at_rest = false;
        }
    }
}

/// Apply the program engine's motor changes (target registers, position bias). Targets come
/// in the axis frame; the register holds motor counts.
pub(super) fn apply_updates(engine: &mut ProgramEngine, motors: &mut [Motor]) {
    for u in engine.take_motor_updates() {
        let (x, v) = match u {
            MotorUpdate::Target(x, p) => (x, p),
            MotorUpdate::Bias(x, d) => (x, d),
        };
        let Some(m) = motors.get_mut(usize::from(x.max(1) - 1)) else {
            continue;
        };
        if !v.is_finite() {
            continue;
        }
        match u {
            MotorUpdate::Target(..) => m.prejog = v - m.pos_bias,
            MotorUpdate::Bias(..) => m.pos_bias += v,
        }
    }
}
