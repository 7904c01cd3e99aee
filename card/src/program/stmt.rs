//! Statements shared by motion programs and PLCs (pmac-commands.md §5.9, §6.6): `=`
//! assignments, `CMD`/`SEND`, `DISPLAY`, PLC control, `ADDRESS`, `SETPHASE`, `GATHER`, and the
//! MACRO auxiliary statements of background PLCs (`MSR`/`MSW`/`MXR`/`MXW`: the PLC waits at the
//! statement while its access is on the ring, see [`Common::AuxWait`]).

use super::env;
use crate::domain::ast::VarRef;
use crate::domain::ast::{AssignOp, Message, NumRange, PlcVerb, SendPort, StmtKind};
use crate::model::macro_aux::{slave_request, AuxOwner, Protocol};
use crate::model::CardModel;
use mcc_ring::aux_channel::{Reply, Request};

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
    /// The background PLC running the statement (`None`: a motion program or PLC 0, where
    /// MACRO auxiliary statements are not allowed).
    pub plc: Option<u8>,
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
    /// `MXR`/`MXW`/`MSR`/`MSW` outside a background PLC: the statement does nothing and sets
    /// the MACRO auxiliary error bit (`???`), as a failed transfer (ERR008) would.
    MacroRefused,
    /// `MXR`/`MXW`/`MSR`/`MSW`: the access is on the ring (or waits for the channel): the PLC
    /// stays at this statement and its scan ends; the next scan executes it again, which
    /// collects the result (pmac-commands §3.5: the PLC waits for the reply or the timeout).
    AuxWait,
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
        StmtKind::Assign { target, op, value } => {
            let Ok(n) = env::var_number(card, ctx.coord, target) else {
                return Common::BadVariable;
            };
            let Ok(v) = env::value(card, ctx.coord, value) else {
                return Common::BadVariable;
            };
            let v = match op {
                AssignOp::Set | AssignOp::SyncSet => v,
                AssignOp::Op(b) | AssignOp::SyncOp(b) => {
                    let Ok(old) = env::value(
                        card,
                        ctx.coord,
                        &crate::domain::ast::Expr {
                            kind: crate::domain::ast::ExprKind::Var(crate::domain::ast::VarRef {
                                kind: target.kind,
                                index: crate::domain::ast::VarIndex::Const(n),
                                pos: target.pos,
                            }),
                            pos: target.pos,
                        },
                    ) else {
                        return Common::BadVariable;
                    };
                    env::combine(card, *b, old, v)
                }
                AssignOp::SyncAnd | AssignOp::SyncOr | AssignOp::SyncXor => {
                    return Common::NotMine;
                }
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
        StmtKind::SendFormat { text, args, .. } | StmtKind::CommandFormat { text, args } => {
            let mut vals = Vec::with_capacity(args.len());
            for e in args {
                let Ok(v) = env::value(card, ctx.coord, e) else {
                    return Common::BadVariable;
                };
                vals.push(v);
            }
            // Checked at entry; a format that no longer parses is used as it stands.
            let text = match super::printf::parse(text) {
                Ok(p) => super::printf::format(&p, &vals),
                Err(_) => text.clone(),
            };
            if matches!(s, StmtKind::SendFormat { .. }) {
                send(card, ctx.out, &Message::Text(text));
            } else if ctx.cmds.len() < MAX_CMDS {
                ctx.cmds.push(QueuedCmd {
                    motor: ctx.motor,
                    coord: ctx.coord,
                    msg: Message::Text(text),
                });
            }
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
        | StmtKind::MacroSlaveWrite { .. } => match ctx.plc {
            Some(n) => macro_stmt(card, ctx.coord, AuxOwner::Plc(n), s),
            None => {
                card.state.global.macro_aux_error = true;
                Common::MacroRefused
            }
        },
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

/// A background PLC's MACRO auxiliary statement: start the access when the channel is free,
/// wait while it is on the ring, then copy the value (`MSR`/`MXR`) or just finish. A failure
/// (precondition, slave error, timeout) is flagged in `???` word 1 bit 5 and X:$0798; a PLC
/// has no ERR text to report (pmac-commands §3.5).
fn macro_stmt(card: &mut CardModel, cs: u16, owner: AuxOwner, s: &StmtKind) -> Common {
    if let Some(done) = card.aux.take_finished(owner) {
        match (done, s) {
            (Ok(Reply::Value(v, _)), StmtKind::MacroAuxRead { var, .. })
            | (Ok(Reply::Value(v, _)), StmtKind::MacroSlaveRead { dest: var, .. }) => {
                let Ok(n) = env::var_number(card, cs, var) else {
                    return Common::BadVariable;
                };
                if !env::write(card, cs, var.kind, n, v) {
                    return Common::BadVariable;
                }
            }
            (Ok(_), _) => {}
            (Err(f), _) => card.aux_failed(f),
        }
        return Common::Done;
    }
    if card.aux.holds(owner) {
        return Common::AuxWait;
    }
    // A new access: the error bit is cleared at its start.
    card.state.global.macro_aux_error = false;
    let value_of = |card: &mut CardModel, v: &VarRef| env::read(card, cs, v).ok();
    let (proto, node, req) = match s {
        StmtKind::MacroAuxRead { node, param, .. } => (
            Protocol::Type0,
            *node,
            Some(Request::ReadParam(*param as u16)),
        ),
        StmtKind::MacroAuxWrite { node, param, var } => {
            let v = value_of(card, var);
            let req = v
                .filter(|v| (-32_768.0..=32_767.0).contains(v) && (2..=253).contains(param))
                .map(|v| Request::WriteParam(*param as u16, v as i16));
            (Protocol::Type0, *node, req)
        }
        StmtKind::MacroSlaveRead { node, var, .. } => {
            (Protocol::Type1, *node, slave_request(*var, None))
        }
        StmtKind::MacroSlaveWrite { node, var, src } => {
            let v = value_of(card, src);
            (
                Protocol::Type1,
                *node,
                v.and_then(|v| slave_request(*var, Some(v))),
            )
        }
        _ => return Common::NotMine,
    };
    let Some(req) = req else {
        return Common::BadVariable;
    };
    let settings = card.aux_settings();
    match card
        .aux
        .begin(owner, proto, (node & 0xF) as u8, req, settings)
    {
        Ok(_) => Common::AuxWait,
        Err(f) => {
            card.aux_failed(f);
            Common::Done
        }
    }
}
