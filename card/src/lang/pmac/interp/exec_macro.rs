//! MACRO auxiliary commands (§3.5): `MX`, `MXR`, `MXW` (Type 0) and `MS…`, `MSR`, `MSW`
//! (Type 1) on-line. After the argument checks (ERR003) a command becomes an [`AuxJob`]: the
//! line waits ([`super::Step::Wait`]) while its accesses travel the ring on node 15 (the servo
//! tick streams them, [`crate::model::macro_aux`]), then prints the value, copies it into a
//! PMAC variable, or just finishes. A failure (preconditions, slave error, timeout) answers
//! ERR008, sets `???` word 1 bit 5 and X:$0798. A line run where the servo loop cannot turn
//! meanwhile (a program's `CMD"…"`, CTRL-I, the daisy chain) cannot wait: its access fails as a
//! timeout would.

use super::exec::{Exec, Out};
use super::line::LineRun;
use super::{Pmac, Session};
use crate::domain::{ErrCode, NodeNum};
use crate::lang::pmac::ast::{CmdKind, SlaveCmd, SlaveVar, VarIndex, VarRef};
use crate::model::format_value as number;
use crate::model::macro_aux::{
    format_value, slave_request, AuxFailure, AuxOwner, Begin, Protocol, X0798_TIMEOUT,
};
use crate::program::env;
use mcc_ring::aux_channel::{Reply, Request, StationCmd};

/// Most station variables one range (`MS{n},MI{a}..{b}`) reads.
pub(crate) const MAX_RANGE: u32 = 1024;

/// What a finished access leads to.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AuxThen {
    /// Report the value (one line per access).
    Print,
    /// Copy the value into this PMAC variable (C.S. for Q).
    Store(VarRef, u16),
}

/// The accesses of one on-line MACRO command, done one after the other.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct AuxJob {
    proto: Protocol,
    node: NodeNum,
    reqs: Vec<Request>,
    next: usize,
    then: AuxThen,
    owner: Option<AuxOwner>,
}

/// Where an [`AuxJob`] stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AuxStep {
    /// Waiting for the channel or the reply.
    Wait,
    /// Finished (the line goes on, or its outcome is set).
    Done,
}

fn node_ok(node: u32) -> Result<NodeNum, ErrCode> {
    NodeNum::new(node).ok_or(ErrCode::Data)
}

fn var_ok(card: &Pmac<'_>, v: &VarRef) -> Exec {
    match &v.index {
        VarIndex::Const(n) if *n < u32::from(card.state.limits().vars) => Ok(()),
        VarIndex::Const(_) => Err(ErrCode::Data),
        VarIndex::Expr(_) => Ok(()),
    }
}

fn slave_var_ok(v: &SlaveVar) -> Exec {
    match v {
        SlaveVar::Mi(n) | SlaveVar::Mc(n) if *n <= 1023 => Ok(()),
        _ => Err(ErrCode::Data),
    }
}

fn station_cmd(c: SlaveCmd) -> Request {
    match c {
        SlaveCmd::Reset => Request::Command(StationCmd::Reset),
        SlaveCmd::Reinit => Request::Command(StationCmd::Reinit),
        SlaveCmd::ClearFault => Request::Command(StationCmd::ClearFault),
        SlaveCmd::Config(None) => Request::Command(StationCmd::ConfigRead),
        SlaveCmd::Config(Some(v)) => Request::ConfigWrite(f64::from(v)),
        SlaveCmd::Date => Request::Command(StationCmd::Date),
        SlaveCmd::Save => Request::Command(StationCmd::Save),
        SlaveCmd::Version => Request::Command(StationCmd::Version),
    }
}

impl Pmac<'_> {
    pub(crate) fn exec_macro(&mut self, s: &mut Session, cmd: &CmdKind, out: &mut Out) -> Exec {
        let one = |proto, node, req, then| AuxJob {
            proto,
            node,
            reqs: vec![req],
            next: 0,
            then,
            owner: None,
        };
        let job = match cmd {
            CmdKind::MacroAux { node, param, value } => {
                let node = node_ok(*node)?;
                let param = u16::try_from(*param).map_err(|_| ErrCode::Data)?;
                let req = match value {
                    None => Request::ReadParam(param),
                    Some(v) => {
                        if !(2..=254).contains(&param) || !(-32_768.0..=32_767.0).contains(&v.value)
                        {
                            return Err(ErrCode::Data);
                        }
                        Request::WriteParam(param, v.value as i16)
                    }
                };
                one(Protocol::Type0, node, req, AuxThen::Print)
            }
            CmdKind::MacroAuxRead { node, param, var } => {
                let node = node_ok(*node)?;
                let param = u16::try_from(*param).map_err(|_| ErrCode::Data)?;
                var_ok(self, var)?;
                let then = AuxThen::Store(var.clone(), s.coord.get());
                one(Protocol::Type0, node, Request::ReadParam(param), then)
            }
            CmdKind::MacroAuxWrite { node, param, var } => {
                let node = node_ok(*node)?;
                var_ok(self, var)?;
                let v = env::read(self.model, s.coord.get(), var).map_err(|e| e.code)?;
                if !(2..=253).contains(param) || !(-32_768.0..=32_767.0).contains(&v) {
                    return Err(ErrCode::Data);
                }
                let req = Request::WriteParam(*param as u16, v as i16);
                one(Protocol::Type0, node, req, AuxThen::Print)
            }
            CmdKind::MacroSlaveCmd { node, cmd } => {
                let node = node_ok(*node)?;
                one(Protocol::Type1, node, station_cmd(*cmd), AuxThen::Print)
            }
            CmdKind::MacroSlaveVar { node, var, value } => {
                let node = node_ok(*node)?;
                slave_var_ok(var)?;
                let req = slave_request(*var, value.map(|v| v.value)).ok_or(ErrCode::Data)?;
                one(Protocol::Type1, node, req, AuxThen::Print)
            }
            CmdKind::MacroSlaveRange { node, first, last } => {
                let node = node_ok(*node)?;
                if first > last || *last > 1023 || last - first >= MAX_RANGE {
                    return Err(ErrCode::Data);
                }
                AuxJob {
                    reqs: (*first..=*last)
                        .map(|n| Request::ReadMi(n as u16))
                        .collect(),
                    ..one(Protocol::Type1, node, Request::ReadMi(0), AuxThen::Print)
                }
            }
            CmdKind::MacroSlaveRead { node, var, dest } => {
                let node = node_ok(*node)?;
                slave_var_ok(var)?;
                var_ok(self, dest)?;
                let req = slave_request(*var, None).ok_or(ErrCode::Data)?;
                one(
                    Protocol::Type1,
                    node,
                    req,
                    AuxThen::Store(dest.clone(), s.coord.get()),
                )
            }
            CmdKind::MacroSlaveWrite { node, var, src } => {
                let node = node_ok(*node)?;
                slave_var_ok(var)?;
                var_ok(self, src)?;
                let v = env::read(self.model, s.coord.get(), src).map_err(|e| e.code)?;
                let req = slave_request(*var, Some(v)).ok_or(ErrCode::Data)?;
                one(Protocol::Type1, node, req, AuxThen::Print)
            }
            _ => return Err(ErrCode::Data),
        };
        // The error bit is cleared at the start of each auxiliary command (one that passed its
        // argument checks: an ERR003 leaves it as it was).
        self.model.state.global.macro_aux_error = false;
        out.aux = Some(job);
        Ok(())
    }

    /// Advance the auxiliary job of `run`: start its next access when the channel is free,
    /// collect a finished one (its value line goes into the reply, or into the variable).
    pub(crate) fn step_aux(&mut self, run: &mut LineRun) -> AuxStep {
        let i9 = self.model.state.peek_ivar(9).unwrap_or(0.0) as u32;
        let framing = self.framing();
        loop {
            let Some(job) = run.aux.as_mut() else {
                return AuxStep::Done;
            };
            let Some(&req) = job.reqs.get(job.next) else {
                run.aux = None;
                return AuxStep::Done;
            };
            let Some(owner) = job.owner else {
                let owner = self.model.aux.line_id();
                let settings = self.model.aux_settings();
                match self
                    .model
                    .aux
                    .begin(owner, job.proto, job.node.get(), req, settings)
                {
                    Ok(Begin::Started) => job.owner = Some(owner),
                    Ok(Begin::Busy) => {}
                    Err(f) => {
                        self.aux_fail(run, f);
                        return AuxStep::Done;
                    }
                }
                return AuxStep::Wait;
            };
            match self.model.aux.take_finished(owner) {
                Some(Ok(reply)) => {
                    job.next += 1;
                    job.owner = None;
                    if let Reply::Value(v, f) = reply {
                        match &job.then {
                            AuxThen::Print => {
                                let text = format_value(v, f, i9, number);
                                run.push_line(framing, text);
                            }
                            AuxThen::Store(var, cs) => {
                                let (var, cs) = (var.clone(), *cs);
                                let stored = env::var_number(self.model, cs, &var)
                                    .ok()
                                    .is_some_and(|n| env::write(self.model, cs, var.kind, n, v));
                                if !stored {
                                    run.aux = None;
                                    run.fail(ErrCode::Data);
                                    return AuxStep::Done;
                                }
                            }
                        }
                    }
                }
                Some(Err(f)) => {
                    self.aux_fail(run, f);
                    return AuxStep::Done;
                }
                None if self.model.aux.holds(owner) => return AuxStep::Wait,
                // Dropped by a reset of the card: as a timeout.
                None => {
                    self.aux_fail(
                        run,
                        AuxFailure {
                            x0798: X0798_TIMEOUT,
                        },
                    );
                    return AuxStep::Done;
                }
            }
        }
    }

    /// The line cannot wait for the ring (the servo loop does not turn meanwhile): its
    /// access fails as a timeout (an access already on the ring is dropped).
    pub(crate) fn abandon_aux(&mut self, run: &mut LineRun) {
        if let Some(owner) = run.aux.as_ref().and_then(|j| j.owner) {
            if self.model.aux.holds(owner) {
                self.model.aux.reset();
            }
        }
        self.aux_fail(
            run,
            AuxFailure {
                x0798: X0798_TIMEOUT,
            },
        );
    }

    fn aux_fail(&mut self, run: &mut LineRun, f: AuxFailure) {
        run.aux = None;
        self.model.aux_failed(f);
        run.fail(ErrCode::MacroAux);
    }
}
