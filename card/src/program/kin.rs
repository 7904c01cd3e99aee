//! Kinematic subroutines (Power PMAC, seed §2.12 L37469-37610, L23943-23955): a C.S. whose
//! motors include `#m->I` motors has its axis positions transformed to those motors' positions
//! by its *inverse* routine, and its motor positions back to axis positions (at a PMATCH, a
//! program start) by its *forward* routine.
//!
//! The dialect keeps the routines ([`crate::model::ExtVars::kinematics`]); this module runs
//! them on the engine. Axis positions go in and out through the routine thread's axis family
//! (Power: `C`, KinPosAxis α at the index A0 B1 C2 U3 V4 W5 X6 Y7 Z8), motor positions through
//! its motor family (Power: `L`, KinPosMotor n at L n, n the motor's Power number). Each C.S.
//! runs its routines on its own thread (`model::Thread::Kin`), so their locals persist from
//! call to call and do not touch the motion program's.
//!
//! [DECISION] The inverse routine runs every servo cycle while the C.S. produces output, on
//! the trajectory's present base axis position: the finest segmentation there is
//! (`Coord[x].SegMoveTime` equal to the servo period), so the motors follow the transformed
//! path exactly at every cycle, not only at the moves' end points.

use super::compile::{switch_target, Compiled, Op};
use super::env;
use super::stmt::{exec_common, Common, Ctx, NoCommands};
use crate::coord::axes::AxisVec;
use crate::model::{CardModel, ExtAt, KinRoutine, Thread};

/// Jump-backs (the end of a `while` loop) one routine call may make beyond which it has
/// failed: `Coord[x].Ldata.GoBack` + 1 (seed L23926-23955, L4076-4080: GoBack's power-up
/// value 10 for a C.S.). [DECISION] the power-up value is used, not a changed element.
pub(crate) const MAX_GOBACK: usize = 10 + 1;
/// Most instructions one routine call executes (a guard; a routine without loops is bounded
/// by its length, one with loops by [`MAX_GOBACK`]).
pub(crate) const MAX_STEPS: usize = 100_000;

/// KinPosAxis index of each [`AxisVec`] entry (X Y Z A B C U V W → C6 C7 C8 C0 … C5).
pub(crate) const AXIS_VAR: [u32; 9] = [6, 7, 8, 0, 1, 2, 3, 4, 5];

/// Why a routine gave no result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum KinError {
    /// More than [`MAX_GOBACK`] jump-backs or [`MAX_STEPS`] instructions.
    TooLong,
    /// A statement failed (bad variable) or is not allowed in a kinematic routine.
    Failed,
}

fn routine(card: &CardModel, cs: u16, inverse: bool) -> Option<KinRoutine> {
    card.ext_kinematics(cs, inverse)
}

/// Run `code` on C.S. `cs`'s kinematic thread.
fn run(card: &mut CardModel, cs: u16, code: &Compiled) -> Result<(), KinError> {
    let mut pc = 0;
    let mut steps = 0;
    let mut back = 0;
    let mut cmds = Vec::new();
    let mut out = Vec::new();
    let mut none = NoCommands;
    while let Some(ins) = code.ops.get(pc) {
        steps += 1;
        if steps > MAX_STEPS {
            return Err(KinError::TooLong);
        }
        pc += 1;
        match &ins.op {
            Op::Nop => {}
            Op::Jump { to, back: b } => {
                if *b || *to < pc {
                    back += 1;
                    if back > MAX_GOBACK {
                        return Err(KinError::TooLong);
                    }
                }
                pc = *to;
            }
            Op::Branch { cond, else_to } => {
                if !env::test(card, cs, cond).map_err(|_| KinError::Failed)? {
                    pc = *else_to;
                }
            }
            Op::Switch {
                value,
                cases,
                default,
            } => {
                let v = env::value(card, cs, value).map_err(|_| KinError::Failed)?;
                pc = switch_target(v, cases, *default);
            }
            Op::Exec(s) => {
                if matches!(s.kind, crate::domain::ast::StmtKind::Return) {
                    return Ok(());
                }
                let mut ctx = Ctx {
                    motor: 1,
                    coord: cs,
                    cmds: &mut cmds,
                    out: &mut out,
                    cmd: &mut none,
                    plc: None,
                };
                if exec_common(card, &mut ctx, &s.kind) != Common::Done {
                    return Err(KinError::Failed);
                }
            }
        }
    }
    Ok(())
}

/// Run a routine of `cs` with the card's evaluation context set to the kinematic thread.
fn call(
    card: &mut CardModel,
    cs: u16,
    inverse: bool,
    input: &[(u16, u32, f64)],
    output: &[(u16, u32)],
) -> Option<Result<Vec<f64>, KinError>> {
    let r = routine(card, cs, inverse)?;
    let at = ExtAt {
        thread: Thread::Kin(cs),
        coord: cs,
        motor: 1,
        ..ExtAt::default()
    };
    let saved = std::mem::replace(&mut card.exec, at);
    let res = (|| {
        for &(f, n, v) in input {
            card.ext_write(&at, f, n, v).map_err(|_| KinError::Failed)?;
        }
        let code = r.code.downcast_ref::<Compiled>().ok_or(KinError::Failed)?;
        run(card, cs, code)?;
        output
            .iter()
            .map(|&(f, n)| {
                let v = card.ext_read(&at, f, n).map_err(|_| KinError::Failed)?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(KinError::Failed)
                }
            })
            .collect()
    })();
    card.exec = saved;
    Some(res)
}

/// Inverse kinematics of C.S. `cs` (1-based): the positions of `motors` (model numbers,
/// 1-based) at base axis position `base`. `None`: the C.S. has no inverse routine.
pub(crate) fn inverse(
    card: &mut CardModel,
    cs: u16,
    base: &AxisVec,
    motors: &[u16],
) -> Option<Result<Vec<f64>, KinError>> {
    let r = routine(card, cs, true)?;
    let input: Vec<_> = (0..9)
        .map(|i| (r.axis_family, AXIS_VAR[i], base[i]))
        .collect();
    let output: Vec<_> = motors
        .iter()
        .map(|&m| (r.motor_family, u32::from(m.saturating_sub(1))))
        .collect();
    call(card, cs, true, &input, &output)
}

/// Forward kinematics of C.S. `cs`: the base axis position for `motors` (model numbers) at
/// positions `pos`. `None`: the C.S. has no forward routine.
pub(crate) fn forward(
    card: &mut CardModel,
    cs: u16,
    motors: &[u16],
    pos: &[f64],
    prev: &AxisVec,
) -> Option<Result<AxisVec, KinError>> {
    let r = routine(card, cs, false)?;
    // Axes the routine does not set keep their present values.
    let mut input: Vec<_> = (0..9)
        .map(|i| (r.axis_family, AXIS_VAR[i], prev[i]))
        .collect();
    input.extend(
        motors
            .iter()
            .zip(pos)
            .map(|(&m, &p)| (r.motor_family, u32::from(m.saturating_sub(1)), p)),
    );
    let output: Vec<_> = (0..9).map(|i| (r.axis_family, AXIS_VAR[i])).collect();
    Some(call(card, cs, false, &input, &output)?.map(AxisVec::from_iterator))
}

/// One servo cycle of C.S. `cs`: the `#m->I` motors of `c` take the inverse routine's
/// positions for the trajectory's present base position (`motors`: the cycle's output, C.S.
/// motor order). Nothing happens without `#m->I` motors or without a routine.
pub(crate) fn apply_inverse(
    card: &mut CardModel,
    cs: u16,
    c: &mut crate::coord::cs::CoordSystem,
    motors: &mut [f64],
) -> Result<(), KinError> {
    let rows = c.inverse_rows();
    if rows.is_empty() || !c.on_path() {
        return Ok(());
    }
    let list: Vec<u16> = rows.iter().map(|&r| c.motors()[r]).collect();
    let base = c.base_now();
    let Some(res) = inverse(card, cs, &base, &list) else {
        return Ok(());
    };
    for (&r, v) in rows.iter().zip(res?) {
        c.set_kin_motor(r, v, false);
        if let Some(m) = motors.get_mut(r) {
            *m = v;
        }
    }
    Ok(())
}

/// The end-of-move targets of the `#m->I` motors of `c` (`end`: C.S. motor order, the other
/// motors' targets): the inverse routine at the programmed end point.
pub(crate) fn end_targets(
    card: &mut CardModel,
    cs: u16,
    c: &crate::coord::cs::CoordSystem,
    end: &mut [f64],
) -> Result<(), KinError> {
    let rows = c.inverse_rows();
    if rows.is_empty() {
        return Ok(());
    }
    let list: Vec<u16> = rows.iter().map(|&r| c.motors()[r]).collect();
    let base = c.xf.current().to_base(&c.program_position());
    let Some(res) = inverse(card, cs, &base, &list) else {
        return Ok(());
    };
    for (&r, v) in rows.iter().zip(res?) {
        if let Some(e) = end.get_mut(r) {
            *e = v;
        }
    }
    Ok(())
}

/// PMATCH through the forward routine of `cs` (if it has `#m->I` motors and a forward
/// routine): the base axis position from the motors' commanded positions `pos` (C.S. motor
/// order).
pub(crate) fn apply_forward(
    card: &mut CardModel,
    cs: u16,
    c: &mut crate::coord::cs::CoordSystem,
    pos: &[f64],
) -> Result<(), KinError> {
    if c.inverse_rows().is_empty() {
        return Ok(());
    }
    let motors = c.motors().to_vec();
    let prev = c.base_now();
    match forward(card, cs, &motors, pos, &prev) {
        Some(Ok(base)) => {
            c.set_base_position(base);
            Ok(())
        }
        Some(Err(e)) => Err(e),
        None => Ok(()),
    }
}
