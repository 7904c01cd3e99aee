//! Buffer control (§3.2.6, §3.3.5, §3.4.4) and PLC control (§3.2.5): OPEN/CLOSE/CLEAR/LIST,
//! GATHER, ENABLE/DISABLE/PAUSE/RESUME PLC, storing program lines (DEFINE/DELETE: exec_defines),
//! SETPHASE.

use crate::domain::ErrCode;
use crate::model::{list_lines, BufErr, BufId, ProgLine};

/// The listing renderer of a stored line (`long` keywords with I9 = 1 or 3).
fn render(long: bool) -> impl Fn(&ProgLine) -> String {
    move |l| crate::lang::pmac::listing::line(&l.stmts, long)
}
use super::exec::{Exec, Out};
use super::exec_info::LIST_LINK;

use super::{OpenBuf, Pmac, Session};
use crate::lang::pmac::ast::{
    CmdKind, ListSpan, ListTarget, NumRange, OpenTarget, PlcVerb, Stmt, StmtKind,
};

/// Bit 19 of `???` word 1: data gathering on.
const GATHER_ON: u32 = 1 << 19;
/// `???` word 1 bit 17: gathering armed to start on the rising edge of MI2.
const GATHER_ON_TRIGGER: u32 = 1 << 17;

fn to_err(e: BufErr) -> ErrCode {
    e.0
}

/// Block-structural statements stand on their own stored line.
fn is_block(s: &Stmt) -> bool {
    matches!(
        &s.kind,
        StmtKind::If(_)
            | StmtKind::EndIf
            | StmtKind::While(_)
            | StmtKind::EndWhile
            | StmtKind::AndCond(_)
            | StmtKind::OrCond(_)
    ) || matches!(&s.kind, StmtKind::Else(b) if b.is_empty())
}

fn plc_list(list: &[NumRange]) -> Result<Vec<u8>, ErrCode> {
    let v = NumRange::expand(list);
    if v.iter().any(|&n| n > 31) || list.iter().any(|r| r.last < r.first) {
        return Err(ErrCode::Data);
    }
    Ok(v.into_iter().map(|n| n as u8).collect())
}

fn offsets(span: &ListSpan) -> Option<(u32, Option<u32>)> {
    span.offsets.then(|| (span.start.unwrap_or(0), span.len))
}

impl Pmac<'_> {
    /// The buffer `s` has open (lines it types are stored there).
    pub(crate) fn open_for(&self, s: &Session) -> Option<OpenBuf> {
        self.mem.open.filter(|o| o.session == s.id)
    }

    /// Store the statements typed on one line into the open buffer, one stored line per
    /// block-structural statement and one for the rest.
    pub(crate) fn store_line(&mut self, s: &Session, stmts: Vec<Stmt>) -> Exec {
        let open = self.open_for(s).ok_or(ErrCode::NeedsBuffer)?;
        let mut group: Vec<Stmt> = Vec::new();
        let mut lines: Vec<Vec<Stmt>> = Vec::new();
        for st in stmts {
            if is_block(&st) {
                if !group.is_empty() {
                    lines.push(std::mem::take(&mut group));
                }
                lines.push(vec![st]);
            } else {
                group.push(st);
            }
        }
        if !group.is_empty() {
            lines.push(group);
        }
        for l in lines {
            let line = ProgLine::new(l);
            match open.id {
                BufId::Rot => self
                    .bufs
                    .append_rotary(s.coord.get() as u8, line)
                    .map_err(to_err)?,
                id => self.model.bufs.append(id, line).map_err(to_err)?,
            }
        }
        self.sync_global_flags();
        Ok(())
    }

    /// Close whatever buffer is open (CLOSE, CTRL-L, end of session).
    pub(crate) fn close_buffer(&mut self) -> Exec {
        let Some(o) = self.mem.open.take() else {
            return Ok(());
        };
        let r = self.model.bufs.close(o.id).map_err(to_err);
        self.sync_global_flags();
        r
    }

    pub(crate) fn exec_buffers(&mut self, s: &mut Session, cmd: &CmdKind, out: &mut Out) -> Exec {
        match cmd {
            CmdKind::Open(t) => self.open_buffer(s, *t)?,
            // Any connection's CLOSE closes the open buffer (as on a real card), so a buffer
            // left open by a vanished connection can always be released.
            CmdKind::Close => self.close_buffer()?,
            CmdKind::Clear => {
                let o = self.open_for(s).ok_or(ErrCode::NeedsBuffer)?;
                self.model.bufs.clear(o.id, s.coord.get() as u8);
            }
            CmdKind::List(t) => self.list(s, t, out)?,
            CmdKind::Define(t) => self.define(s, t)?,
            CmdKind::Delete(t) => self.delete(s, *t)?,
            CmdKind::Gather { trigger: false } => {
                self.model.state.global.word1_other &= !GATHER_ON_TRIGGER;
                self.model.state.global.word1_other |= GATHER_ON;
                self.model.gather.start();
            }
            // Armed: `???` bit 17 until the servo cycle after MI2 rises (seed 7062, 8173).
            CmdKind::Gather { trigger: true } => {
                self.model.state.global.word1_other |= GATHER_ON_TRIGGER;
            }
            CmdKind::EndGather => {
                self.model.state.global.word1_other &= !(GATHER_ON | GATHER_ON_TRIGGER)
            }
            CmdKind::Plc(pc) => {
                for n in plc_list(&pc.list)? {
                    let p = &mut self.model.run.plc[n as usize];
                    match pc.verb {
                        PlcVerb::Enable => {
                            *p = crate::model::PlcRun {
                                enabled: true,
                                paused: false,
                            }
                        }
                        PlcVerb::Disable => p.enabled = false,
                        PlcVerb::Pause => p.paused = p.enabled,
                        PlcVerb::Resume => p.paused = false,
                        PlcVerb::EnableCompiled | PlcVerb::DisableCompiled => {}
                    }
                }
            }
            CmdKind::SetPhase(list) => {
                let max = u32::from(self.model.state.limits().motors);
                if NumRange::expand(list).iter().any(|&m| m == 0 || m > max) {
                    return Err(ErrCode::Data);
                }
                // Phasing is not modelled (no commutation): checked, then nothing to do.
            }
            _ => return Err(ErrCode::Data),
        }
        self.sync_global_flags();
        Ok(())
    }

    fn open_buffer(&mut self, s: &Session, t: OpenTarget) -> Exec {
        if self.mem.open.is_some() {
            return Err(ErrCode::BufferInUse);
        }
        let (id, binary) = match t {
            OpenTarget::Prog(n) => {
                let n = u16::try_from(n)
                    .ok()
                    .filter(|n| (1..=32_767).contains(n))
                    .ok_or(ErrCode::Data)?;
                if self.model.state.coords.iter().any(|c| c.running) {
                    return Err(ErrCode::Running);
                }
                (BufId::Prog(n), false)
            }
            OpenTarget::Plc(n) => (
                BufId::Plc(
                    u8::try_from(n)
                        .ok()
                        .filter(|n| *n <= 31)
                        .ok_or(ErrCode::Data)?,
                ),
                false,
            ),
            OpenTarget::Rotary => (BufId::Rot, false),
            OpenTarget::BinRotary => (BufId::Rot, true),
        };
        if id.protected() && !self.password_ok() {
            return Err(ErrCode::Password);
        }
        self.model.bufs.open(id).map_err(to_err)?;
        match id {
            BufId::Prog(_) => self.model.run.cs.iter_mut().for_each(|c| c.pointer = None),
            BufId::Plc(n) => self.model.run.plc[n as usize].enabled = false,
            BufId::Rot => {}
        }
        self.mem.open = Some(OpenBuf {
            session: s.id,
            id,
            binary,
        });
        Ok(())
    }

    fn list(&mut self, s: &Session, t: &ListTarget, out: &mut Out) -> Exec {
        let long = self.model.state.i9() & 1 == 1;
        let lines: Vec<String> = match t {
            ListTarget::Open => {
                let o = self.open_for(s).ok_or(ErrCode::NeedsBuffer)?;
                match o.id {
                    BufId::Rot => self.rotary_lines(s.coord.get(), long, None),
                    id => list_lines(
                        &self
                            .model
                            .bufs
                            .program(id)
                            .ok_or(ErrCode::NeedsBuffer)?
                            .lines,
                        render(long),
                        None,
                    ),
                }
            }
            ListTarget::Prog(n, span) | ListTarget::Plc(n, span) => {
                let id = match t {
                    ListTarget::Prog(..) => {
                        BufId::Prog(u16::try_from(*n).map_err(|_| ErrCode::Data)?)
                    }
                    _ => BufId::Plc(u8::try_from(*n).map_err(|_| ErrCode::Data)?),
                };
                let p = self.model.bufs.program(id).ok_or(ErrCode::Data)?;
                if id.protected() && !self.password_ok() {
                    return Err(ErrCode::Password);
                }
                // LIST PLC n, with no start: from the line the PLC's next scan executes
                // first (seed 8785-8791); LIST PROG's start defaults to 0.
                let at = match id {
                    BufId::Plc(k) if span.offsets && span.start.is_none() => {
                        self.model.run.plc_next.get(k as usize).copied()
                    }
                    _ => None,
                };
                let offs = offsets(span).map(|(s, l)| (at.unwrap_or(s), l));
                list_lines(&p.lines, render(long), offs)
            }
            ListTarget::Rotary(span) => self.rotary_lines(s.coord.get(), long, offsets(span)),
            ListTarget::Gather(span) => {
                let (start, len) = (span.start, span.len);
                self.model.gather.list_lines(start, len)
            }
            ListTarget::Pc(span) => self.list_pc(s.coord.get(), span, long, false)?,
            ListTarget::Pe(span) => self.list_pc(s.coord.get(), span, long, true)?,
            ListTarget::Comp(def) | ListTarget::BlComp(def) | ListTarget::TComp(def) => {
                let tables = match t {
                    ListTarget::Comp(_) => &self.model.bufs.defines.comp,
                    ListTarget::BlComp(_) => &self.model.bufs.defines.blcomp,
                    _ => &self.model.bufs.defines.tcomp,
                };
                let tab = tables.get(&(s.motor.get() as u8)).ok_or(ErrCode::Data)?;
                if *def {
                    vec![tab.def.clone()]
                } else {
                    tab.data
                        .chunks(8)
                        .map(|c| c.iter().map(i64::to_string).collect::<Vec<_>>().join(" "))
                        .collect()
                }
            }
            ListTarget::Link => vec![LIST_LINK.to_string()],
        };
        lines.into_iter().for_each(|l| out.line(l));
        Ok(())
    }

    fn rotary_lines(
        &self,
        cs: u16,
        long: bool,
        offsets: Option<(u32, Option<u32>)>,
    ) -> Vec<String> {
        self.model
            .bufs
            .rotary
            .get(&(cs as u8))
            .map(|r| list_lines(&r.lines, render(long), offsets))
            .unwrap_or_default()
    }

    /// `LIST PC` / `LIST PE` (seed 8720-8770): from the next line to be calculated (PC) or
    /// the line of the move executing (PE) while a program is under way, otherwise from the
    /// line the C.S. points at; first line `P{n}:{off}:text`.
    fn list_pc(
        &self,
        cs: u16,
        span: &ListSpan,
        long: bool,
        pe: bool,
    ) -> Result<Vec<String>, ErrCode> {
        let r = &self.model.run.cs[cs as usize - 1];
        let (pointed, label) = r.pointer.ok_or(ErrCode::Data)?;
        let (prog, start) = match if pe { r.pe_at } else { r.pc_at } {
            Some((p, off)) if p > 0 => (p, off),
            _ => (pointed, self.label_offset(pointed, label)),
        };
        let p = u16::try_from(prog)
            .ok()
            .and_then(|n| self.model.bufs.progs.get(&n))
            .ok_or(ErrCode::Data)?;
        let len = if span.offsets { span.len } else { Some(1) };
        let mut v = list_lines(&p.lines, render(long), Some((start, len)));
        if let Some(first) = v.first_mut() {
            *first = format!("P{prog}:{first}");
        }
        Ok(v)
    }
}
