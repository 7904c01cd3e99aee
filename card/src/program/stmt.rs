//! Statements shared by motion programs and PLCs (pmac-commands.md §5.9, §6.6): `=`
//! assignments, `CMD`/`SEND`, `DISPLAY`, PLC control, `ADDRESS`, `SETPHASE`, `GATHER`, and the
//! MACRO auxiliary statements (refused: see [`Common::MacroRefused`]).

use super::env;
use crate::domain::ast::{AssignOp, Message, NumRange, PlcVerb, SendPort, StmtKind};
use crate::model::CardModel;

/// Most bytes of unsolicited output kept for the host before the oldest are dropped.
pub(crate) const MAX_OUTPUT: usize = 65_536;

/// Most queued program commands (`CMD`) per calculation pass or PLC scan.
pub(crate) const MAX_CMDS: usize = 64;

/// A queued `CMD"…"` / `CMD^x` with the issuing program's addressing.
#[derive(Debug, Clone, PartialEq)]
pub struct QueuedCmd {
    /// Default motor.
    pub motor: u16,
    /// Default C.S.
    pub coord: u16,
    /// Text or control character.
    pub msg: Message,
}

/// How programs reach the command language: `CMD"…"` lines and `CMD^x` control characters
/// run through it with the issuing program's addressing (the language layer implements it; the
/// engine never depends on a dialect's interpreter).
pub trait Commands {
    /// Execute a command line issued by a program (`CMD"..."`); its unsolicited output.
    fn line(&mut self, card: &mut CardModel, motor: u16, coord: u16, line: &[u8]) -> Vec<u8>;
    /// Execute a control character issued by a program (`CMD^x`); its reply.
    fn control(&mut self, card: &mut CardModel, motor: u16, coord: u16, c: u8) -> Vec<u8>;
}

/// A command path that runs nothing (engine tests without a language).
#[derive(Debug, Default, Clone, Copy)]
pub struct NoCommands;

impl Commands for NoCommands {
    fn line(&mut self, _: &mut CardModel, _: u16, _: u16, _: &[u8]) -> Vec<u8> {
        Vec::new()
    }
    fn control(&mut self, _: &mut CardModel, _: u16, _: u16, _: u8) -> Vec<u8> {
        Vec::new()
    }
}

/// Execution context of one statement.
pub(crate) struct Ctx<'a> {
    /// Motor for `CMD` lines without `#`.
    pub motor: u16,
    /// C.S. of the Q-variables and of `CMD` lines without `&`.
    pub coord: u16,
    /// Commands to run after the scan / calculation pass.
    pub cmds: &'a mut Vec<QueuedCmd>,
    /// Unsolicited output (`SEND`).
    pub out: &'a mut Vec<u8>,
    /// The command language (`GATHER`, `ENDGATHER` run through it at once).
    pub cmd: &'a mut dyn Commands,
}

/// What a shared statement did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Common {
    /// Done.
    Done,
    /// A variable could not be read or written (bad number / value): run-time error.
    BadVariable,
    /// PLC control acted on these PLCs (the runner checks for a self-pause / restart).
    Plc(PlcVerb, u32),
    /// `ADDRESS`: new default motor / C.S.
    Address(Option<u32>, Option<u32>),
    /// `MXR`/`MXW`/`MSR`/`MSW`: no auxiliary ring traffic yet; the statement does nothing and
    /// sets the MACRO auxiliary error bit (`???`), as a failed transfer (ERR008) would.
    MacroRefused,
    /// Not a shared statement.
    NotMine,
}

/// Append `bytes` to the bounded output queue.
pub(crate) fn emit(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(bytes);
    if out.len() > MAX_OUTPUT {
        let cut = out.len() - MAX_OUTPUT;
        out.drain(..cut);
    }
}

fn send(card: &CardModel, out: &mut Vec<u8>, msg: &Message) {
    let tag = env::ivar(card, 64, 0.0) != 0.0;
    let no_cr = env::ivar(card, 62, 0.0) != 0.0;
    let mut b = Vec::new();
    if tag {
        b.push(0x02);
    }
    match msg {
        Message::Text(t) => {
            b.extend_from_slice(t);
            if tag || !no_cr {
                b.push(b'\r');
            }
        }
        Message::Ctrl(c) => b.push(c.wrapping_sub(64) & 0x7F),
    }
    emit(out, &b);
}

/// Execute a shared statement.
pub(crate) fn exec_common(card: &mut CardModel, ctx: &mut Ctx<'_>, s: &StmtKind) -> Common {
    match s {
        StmtKind::Assign {
            target,
            op: AssignOp::Set,
            value,
        } => {
            let Ok(n) = env::var_number(card, ctx.coord, target) else {
                return Common::BadVariable;
            };
            let Ok(v) = env::value(card, ctx.coord, value) else {
                return Common::BadVariable;
            };
            if env::write(card, ctx.coord, target.kind, n, v) {
                Common::Done
            } else {
                Common::BadVariable
            }
        }
        StmtKind::Command(m) => {
            if ctx.cmds.len() < MAX_CMDS {
                ctx.cmds.push(QueuedCmd {
                    motor: ctx.motor,
                    coord: ctx.coord,
                    msg: m.clone(),
                });
            }
            Common::Done
        }
        StmtKind::Send(_port @ (SendPort::Any | SendPort::Serial | SendPort::Bus), m) => {
            send(card, ctx.out, m);
            Common::Done
        }
        StmtKind::Display(_) | StmtKind::CutterComp(_) => Common::Done,
        StmtKind::Plc(pc) => {
            let mut mask = 0u32;
            for n in NumRange::expand(&pc.list).into_iter().filter(|n| *n <= 31) {
                mask |= 1 << n;
                if let Some(p) = card.run.plc.get_mut(n as usize) {
                    match pc.verb {
                        PlcVerb::Enable => {
                            p.enabled = true;
                            p.paused = false;
                        }
                        PlcVerb::Disable => p.enabled = false,
                        PlcVerb::Pause => p.paused = p.enabled,
                        PlcVerb::Resume => p.paused = false,
                        PlcVerb::EnableCompiled | PlcVerb::DisableCompiled => {}
                    }
                }
            }
            Common::Plc(pc.verb, mask)
        }
        StmtKind::Address { motor, coord } => Common::Address(*motor, *coord),
        // Phasing is not modelled (no commutation): accepted, nothing to do.
        StmtKind::SetPhase(_) => Common::Done,
        StmtKind::Gather { trigger } => {
            let line: &[u8] = if *trigger {
                b"GATHER TRIGGER"
            } else {
                b"GATHER"
            };
            let _ = ctx.cmd.line(card, ctx.motor, ctx.coord, line);
            Common::Done
        }
        StmtKind::EndGather => {
            let _ = ctx.cmd.line(card, ctx.motor, ctx.coord, b"ENDGATHER");
            Common::Done
        }
        StmtKind::MacroAuxRead { .. }
        | StmtKind::MacroAuxWrite { .. }
        | StmtKind::MacroSlaveRead { .. }
        | StmtKind::MacroSlaveWrite { .. } => {
            card.state.global.macro_aux_error = true;
            Common::MacroRefused
        }
        _ => Common::NotMine,
    }
}

/// Run queued program commands (after a PLC scan / calculation pass); their replies go to `out`.
pub(crate) fn run_cmds(
    card: &mut CardModel,
    cmd: &mut dyn Commands,
    cmds: &mut Vec<QueuedCmd>,
    out: &mut Vec<u8>,
) {
    for c in std::mem::take(cmds) {
        match c.msg {
            Message::Text(t) => {
                let r = cmd.line(card, c.motor, c.coord, &t);
                emit(out, &r);
            }
            Message::Ctrl(x) => {
                let code = x.wrapping_sub(64);
                if (1..=0x1A).contains(&code) && code != 0x0D && code != 0x0A {
                    let r = cmd.control(card, c.motor.max(1), c.coord.max(1), code);
                    emit(out, &r);
                }
            }
        }
    }
}
