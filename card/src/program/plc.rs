//! Interpreted PLC programs (pmac-commands.md §6): PLC 0 one scan per servo tick, PLC 1-31 one
//! scan each per background cycle, I5 gating, enable/pause state, scan semantics (a scan ends
//! at the end of the program or at ENDWHILE, where the next scan re-tests the WHILE), `CMD`s run
//! after the scan, an operation budget per scan.

use std::sync::Arc;

use super::compile::{compile, Compiled, Op};
use super::env;
use super::motion_move::read_args;
use super::stmt::{exec_common, run_cmds, Commands, Common, Ctx, QueuedCmd};
use crate::domain::ast::{PlcVerb, StmtKind};
use crate::model::{CardModel, StackOf};

/// Most instructions one PLC scan executes; a scan that reaches it ends there and the next
/// scan continues from that point ([DECISION] the runaway guard).
pub(crate) const PLC_SCAN_BUDGET: u32 = 2000;

/// Run-state of one PLC.
#[derive(Debug, Clone, Default)]
struct PlcState {
    code: Option<Arc<Compiled>>,
    /// Line count of the source the code was compiled from (`None`: no program).
    len: Option<usize>,
    /// `code`/`broken` reflect the present source.
    compiled: bool,
    pc: usize,
    was_active: bool,
    motor: u16,
    coord: u16,
    /// A structural defect: the PLC does not run.
    broken: bool,
    /// Subroutine and subprogram calls under way, innermost last (the code executing is the
    /// innermost call's, else `code`).
    calls: Vec<PlcCall>,
}

/// One call of a PLC: the code called, where the caller resumes, the calling line's
/// arguments not yet read.
#[derive(Debug, Clone)]
struct PlcCall {
    code: Arc<Compiled>,
    ret: usize,
    args: Vec<(u8, f64)>,
    /// The motion-program buffer whose code this is (`None`: the PLC's own).
    prog: Option<u16>,
    /// Local-variable stack slot of its `L0`.
    base: u32,
}

/// All 32 interpreted PLCs.
#[derive(Debug, Clone)]
pub struct PlcRunner {
    plcs: Vec<PlcState>,
    /// Scans executed per PLC (diagnostics / tests).
    pub scans: Vec<u64>,
}

impl Default for PlcRunner {
    fn default() -> Self {
        PlcRunner {
            plcs: vec![
                PlcState {
                    motor: 1,
                    coord: 1,
                    ..PlcState::default()
                };
                32
            ],
            scans: vec![0; 32],
        }
    }
}

/// PLC `n` exists, is enabled and was asked to run one line (`step plc`).
fn stepping(card: &CardModel, n: u8) -> bool {
    card.run.plc_step & (1u32 << n) != 0
        && card.bufs.plcs.contains_key(&n)
        && card.run.plc.get(usize::from(n)).is_some_and(|p| p.enabled)
}

impl PlcRunner {
    /// One scan of PLC 0 if I5 bit 0 allows it.
    pub fn foreground(&mut self, card: &mut CardModel, cmd: &mut dyn Commands, out: &mut Vec<u8>) {
        let i5 = env::ivar(card, 5, 0.0) as i64;
        self.track(card, 0);
        if i5 & 1 != 0 && (card.plc_active(0) || stepping(card, 0)) {
            self.scan(card, cmd, 0, out);
        }
    }

    /// One scan of each PLC 1-31 that is enabled, not paused and allowed by I5 bit 1.
    pub fn background(&mut self, card: &mut CardModel, cmd: &mut dyn Commands, out: &mut Vec<u8>) {
        let i5 = env::ivar(card, 5, 0.0) as i64;
        for n in 1..32u8 {
            self.track(card, n);
            if i5 & 2 != 0 && (card.plc_active(n) || stepping(card, n)) {
                self.scan(card, cmd, n, out);
            }
        }
    }

    /// Follow enable transitions and source changes: a PLC (re-)enabled or edited starts at
    /// the top.
    fn track(&mut self, card: &mut CardModel, n: u8) {
        let enabled = card.run.plc.get(n as usize).is_some_and(|p| p.enabled);
        let st = &mut self.plcs[n as usize];
        let lines = card.bufs.plcs.get(&n).map(|p| &p.lines);
        let rising = enabled && !st.was_active;
        let len = lines.map(Vec::len);
        // Editing needs OPEN PLC, which disables the PLC: the (re-)enable recompiles. A length
        // change catches edits made without a disable/enable in between.
        if rising || len != st.len || !st.compiled {
            st.len = len;
            st.compiled = true;
            st.code = None;
            st.broken = false;
            st.pc = 0;
            st.calls.clear();
            if let Some(at) = card.run.plc_next.get_mut(n as usize) {
                *at = 0;
            }
            if let Some(l) = lines {
                match compile(l, true) {
                    Ok(c) => st.code = Some(Arc::new(c)),
                    Err(_) => st.broken = true,
                }
            }
        }
        st.was_active = enabled;
    }

    /// The next instruction PLC `n` will execute (for tests and LIST PLC n,).
    pub fn position(&self, n: u8) -> usize {
        self.plcs.get(n as usize).map_or(0, |p| p.pc)
    }

    fn scan(&mut self, card: &mut CardModel, cmd: &mut dyn Commands, n: u8, out: &mut Vec<u8>) {
        let k = n as usize;
        let Some(top) = self.plcs[k].code.clone() else {
            return;
        };
        if self.plcs[k].broken {
            return;
        }
        self.scans[k] = self.scans[k].saturating_add(1);
        let at = |card: &CardModel, st: &PlcState| {
            let (base, offset) = st
                .calls
                .last()
                .map_or((0, card.stack_offset(StackOf::Plc(n))), |c| {
                    (c.base, code_offset(card, n, c.prog))
                });
            crate::model::ExtAt {
                thread: crate::model::Thread::Plc(n),
                coord: st.coord,
                motor: st.motor,
                base,
                offset,
            }
        };
        card.exec = at(card, &self.plcs[k]);
        let mut cmds: Vec<QueuedCmd> = Vec::new();
        let mut pc = self.plcs[k].pc;
        let mut ops = 0;
        // `step plc`: one program line, then the PLC stays paused.
        let step = stepping(card, n);
        card.run.plc_step &= !(1u32 << n);
        let mut step_line = None;
        loop {
            let code = self.plcs[k]
                .calls
                .last()
                .map_or_else(|| top.clone(), |c| c.code.clone());
            let Some(instr) = code.ops.get(pc) else {
                // The end of a called program returns; the end of the PLC ends the scan.
                match self.plcs[k].calls.pop() {
                    Some(c) => {
                        pc = c.ret;
                        card.exec = at(card, &self.plcs[k]);
                        continue;
                    }
                    None => {
                        pc = 0;
                        break;
                    }
                }
            };
            ops += 1;
            if ops > PLC_SCAN_BUDGET {
                break;
            }
            if step {
                match step_line {
                    None => step_line = Some((instr.line, Arc::as_ptr(&code))),
                    Some(l) if l != (instr.line, Arc::as_ptr(&code)) => break,
                    Some(_) => {}
                }
            }
            let st = &self.plcs[k];
            let (motor, coord) = (st.motor, st.coord);
            match &instr.op {
                Op::Nop => pc += 1,
                Op::Jump { to, back } => {
                    pc = *to;
                    if *back {
                        break;
                    }
                }
                Op::Branch { cond, else_to } => {
                    // [DECISION] an unreadable variable in a condition reads as false.
                    let t = env::test(card, coord, cond).unwrap_or(false);
                    pc = if t { pc + 1 } else { *else_to };
                }
                Op::Switch {
                    value,
                    cases,
                    default,
                } => {
                    let v = env::value(card, coord, value).unwrap_or(f64::NAN);
                    pc = super::compile::switch_target(v, cases, *default);
                }
                Op::Exec(s) => {
                    match self.call_stmt(card, k, &code, pc, &s.kind) {
                        CallFlow::NotACall => {}
                        CallFlow::Jump(to) => {
                            pc = to;
                            card.exec = at(card, &self.plcs[k]);
                            continue;
                        }
                        CallFlow::EndScan => {
                            pc = 0;
                            break;
                        }
                        CallFlow::Stop => {
                            // A call that cannot be made stops the PLC (seed L39878).
                            if let Some(p) = card.run.plc.get_mut(k) {
                                p.enabled = false;
                            }
                            pc = 0;
                            self.plcs[k].calls.clear();
                            break;
                        }
                    }
                    let mut ctx = Ctx {
                        motor,
                        coord,
                        cmds: &mut cmds,
                        out,
                        cmd,
                        // MACRO auxiliary statements: background PLCs only (§5.9 table)
                        plc: (n > 0).then_some(n),
                    };
                    let r = exec_common(card, &mut ctx, &s.kind);
                    if r == Common::AuxWait {
                        // the PLC waits at this statement; the next scan tries it again
                        break;
                    }
                    pc += 1;
                    match r {
                        Common::Address(m, c) => {
                            let lim = card.state.limits();
                            let st = &mut self.plcs[k];
                            if let Some(m) = m.filter(|m| (1..=u32::from(lim.motors)).contains(m)) {
                                st.motor = m as u16;
                            }
                            if let Some(c) = c.filter(|c| (1..=u32::from(lim.coords)).contains(c)) {
                                st.coord = c as u16;
                            }
                        }
                        Common::Plc(verb, mask) if mask & (1 << n) != 0 => match verb {
                            PlcVerb::Pause | PlcVerb::Disable => break,
                            PlcVerb::Enable => {
                                pc = 0;
                                break;
                            }
                            _ => {}
                        },
                        Common::Plc(PlcVerb::Enable, mask) => {
                            for j in 0..32 {
                                if mask & (1 << j) != 0 {
                                    self.plcs[j].pc = 0;
                                }
                            }
                        }
                        _ => {}
                    }
                }
            }
        }
        let enabled = card.run.plc.get(k).is_some_and(|p| p.enabled);
        if self.plcs[k].calls.is_empty() {
            if let Some(at) = card.run.plc_next.get_mut(k) {
                *at = top.offset_of(pc);
            }
        }
        let st = &mut self.plcs[k];
        st.pc = pc;
        st.was_active = enabled;
        run_cmds(card, cmd, &mut cmds, out);
    }

    /// Calls, returns and `read` in a PLC (subprograms called from a PLC run by PLC rules,
    /// seed L39868-39872): what the statement at `pc` of `code` does to the flow.
    fn call_stmt(
        &mut self,
        card: &mut CardModel,
        k: usize,
        code: &Arc<Compiled>,
        pc: usize,
        s: &StmtKind,
    ) -> CallFlow {
        let coord = self.plcs[k].coord;
        let sem = card.state.limits().sem;
        if !sem.plc_calls && !matches!(s, StmtKind::Return) {
            return CallFlow::NotACall;
        }
        let (target, args) = match s {
            StmtKind::Return => {
                return match self.plcs[k].calls.pop() {
                    Some(c) => CallFlow::Jump(c.ret),
                    None => CallFlow::EndScan,
                };
            }
            StmtKind::Read(letters) => {
                let mut args = self.plcs[k]
                    .calls
                    .last_mut()
                    .map(|c| std::mem::take(&mut c.args))
                    .unwrap_or_default();
                read_args(card, coord, &mut args, letters);
                if let Some(c) = self.plcs[k].calls.last_mut() {
                    c.args = args;
                }
                return CallFlow::Jump(pc + 1);
            }
            StmtKind::Gosub(e, a) | StmtKind::CallSub(e, a) => {
                let Ok(v) = env::value(card, coord, e) else {
                    return CallFlow::Stop;
                };
                let mut args = Vec::with_capacity(a.len());
                for x in a {
                    match env::value(card, coord, &x.value) {
                        Ok(y) => args.push((x.letter, y)),
                        Err(_) => return CallFlow::Stop,
                    }
                }
                (None, (super::motion::label_number(v), args))
            }
            StmtKind::Call(e, a) | StmtKind::Code(_, e, a) => {
                let Ok(v) = env::value(card, coord, e) else {
                    return CallFlow::Stop;
                };
                let mut args = Vec::with_capacity(a.len());
                for x in a {
                    match env::value(card, coord, &x.value) {
                        Ok(y) => args.push((x.letter, y)),
                        Err(_) => return CallFlow::Stop,
                    }
                }
                let (prog, label) = match s {
                    StmtKind::Code(l, ..) => super::motion::code_target_for(card, coord, *l, v),
                    _ => super::motion::call_target_for(card, v),
                };
                (Some(prog), (label, args))
            }
            _ => return CallFlow::NotACall,
        };
        let (label, args) = args;
        if self.plcs[k].calls.len() >= usize::from(sem.max_call_depth) {
            return CallFlow::Stop;
        }
        let callee = match target {
            None => Some(code.clone()),
            Some(prog) => u16::try_from(prog)
                .ok()
                .and_then(|n| card.bufs.progs.get(&n))
                .and_then(|p| compile(&p.lines, true).ok())
                .map(Arc::new),
        };
        let Some(callee) = callee else {
            return if sem.strict_calls {
                CallFlow::Stop
            } else {
                CallFlow::Jump(pc + 1)
            };
        };
        let from = if target.is_none() { pc } else { 0 };
        let to = match callee.label(label, from).or(sem.strict_calls.then_some(0)) {
            Some(to) => to,
            None => return CallFlow::Jump(pc + 1),
        };
        // `gosub` runs on the caller's locals; `callsub` and `call` on a new frame.
        let caller = self.plcs[k].calls.last();
        let caller_prog = caller.and_then(|c| c.prog);
        let caller_base = caller.map_or(0, |c| c.base);
        let base = if matches!(s, StmtKind::Gosub(..)) {
            caller_base
        } else {
            caller_base.saturating_add(code_offset(card, k as u8, caller_prog))
        };
        self.plcs[k].calls.push(PlcCall {
            code: callee,
            ret: pc + 1,
            args,
            prog: match target {
                Some(p) => u16::try_from(p).ok(),
                None => caller_prog,
            },
            base,
        });
        CallFlow::Jump(to)
    }
}

/// The stack offset of the code PLC `n` runs: a called program's, else the PLC's own.
fn code_offset(card: &CardModel, n: u8, prog: Option<u16>) -> u32 {
    card.stack_offset(match prog {
        Some(p) => StackOf::Prog(p),
        None => StackOf::Plc(n),
    })
}

/// What a call statement did to a PLC's flow.
enum CallFlow {
    /// Not a call: run it as any statement.
    NotACall,
    /// Continue at this instruction (of the code now executing).
    Jump(usize),
    /// `return` at the top: the scan ends.
    EndScan,
    /// The call cannot be made: the PLC stops.
    Stop,
}
