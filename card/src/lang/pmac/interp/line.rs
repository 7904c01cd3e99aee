//! The command-line loop: parse item by item (the parse mode follows buffers opened/closed on
//! the same line), store program statements, execute commands left to right, frame the reply.
//! On the first error the rest of the line is dropped; data already produced is sent, then
//! the error report, no acknowledge (§2.8 [DECISION]).
//!
//! A line is a [`LineRun`] that `Card::step_line` advances within a [`Budget`] of work units
//! (one per command, one per variable a selection reads), so a heavy legal line (`P0..8191`
//! queried a hundred times over) is served in slices; a command that needs the operating
//! system stops the run with an [`Effect`] until `Card::finish_effect` hands the result back.

use super::exec::{Flow, Out};
use super::exec_macro::{AuxJob, AuxStep};
use super::image::{Effect, EffectResult};
use super::reply::{Framing, Outcome, Reply};
use super::{Pmac, Session};
use crate::domain::ErrCode;
use crate::lang::pmac::ast::{BufferKind, CmdKind, Item, Stmt, VarKind, VarList};
use crate::lang::pmac::{LineParser, Mode, ParserState};
use crate::model::BufId;

/// Work a slice may do: one unit per command and per variable a selection touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    left: u64,
}

impl Budget {
    /// `units` of work.
    pub fn new(units: u64) -> Self {
        Budget { left: units }
    }

    /// No limit (a line run to the end at once).
    pub fn unlimited() -> Self {
        Budget { left: u64::MAX }
    }

    /// Units left.
    pub fn left(&self) -> u64 {
        self.left
    }

    /// Nothing left.
    pub fn exhausted(&self) -> bool {
        self.left == 0
    }

    pub(crate) fn spend(&mut self, n: u64) {
        self.left = self.left.saturating_sub(n);
    }
}

/// What one slice of a line ended with.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// The line is finished: its whole framed reply.
    Done(Vec<u8>),
    /// The budget ran out: call `Card::step_line` again (next slice).
    Yield,
    /// A command needs this done before the line can go on (`Card::finish_effect`).
    Effect(Effect),
    /// A MACRO auxiliary access is on the ring: call `Card::step_line` again after a servo
    /// tick (the line holds back later lines of its connection only).
    Wait,
}

/// A selection query (`P0..8191`, `M1..100->`) being answered in slices.
#[derive(Debug, Clone)]
struct Split {
    kind: VarKind,
    mdef: bool,
    cs: u16,
    rest: Vec<u32>,
    next: usize,
}

/// Variables a selection query answers at once before it is split across slices.
const SPLIT_ABOVE: usize = 64;

/// One command line under way.
#[derive(Debug, Clone)]
pub struct LineRun {
    clean: Vec<u8>,
    parser: Option<ParserState>,
    pending: Vec<Stmt>,
    lines: Vec<(Framing, String)>,
    reply: Reply,
    outcome: Option<Outcome>,
    split: Option<Split>,
    waiting: Option<Effect>,
    /// A MACRO auxiliary command waiting for the ring.
    pub(super) aux: Option<AuxJob>,
    /// Issued by a program (`CMD"…"`): no chain addressing, the caller frames the reply.
    program: bool,
}

impl LineRun {
    /// The line waits for an effect.
    pub fn is_waiting(&self) -> bool {
        self.waiting.is_some()
    }

    /// A MACRO auxiliary command of the line waits for the ring.
    pub fn waits_for_ring(&self) -> bool {
        self.aux.is_some()
    }

    pub(super) fn push_line(&mut self, f: Framing, text: String) {
        self.lines.push((f, text));
    }

    /// The line's refusal, once it is done (`None` while it runs or when it succeeded).
    pub fn refusal(&self) -> Option<ErrCode> {
        match self.outcome {
            Some(Outcome::Err(e)) => Some(e),
            _ => None,
        }
    }

    pub(super) fn fail(&mut self, code: ErrCode) {
        self.outcome = Some(Outcome::Err(code));
    }
}

impl Pmac<'_> {
    /// Current I3/I4/I6.
    pub(crate) fn framing(&self) -> Framing {
        let i = |n: u32, d: f64| self.model.state.peek_ivar(n).unwrap_or(d) as i64;
        Framing::from_ivars(i(3, 1.0), i(4, 0.0), i(6, 3.0))
    }

    /// Keep a session's addressing inside the profile (sessions are built by host code).
    pub(crate) fn clamp_session(&self, s: &mut Session) {
        let lim = self.model.state.limits();
        s.motor = s.motor.clamp(&lim);
        s.coord = s.coord.clamp(&lim);
    }

    fn parse_mode(&self, s: &Session) -> Mode {
        match self.open_for(s) {
            Some(o) if !o.binary => Mode::Buffer(match o.id {
                BufId::Prog(_) => BufferKind::Prog,
                BufId::Plc(n) => BufferKind::Plc(n),
                BufId::Rot => BufferKind::Rotary,
            }),
            _ => Mode::Online,
        }
    }

    /// Begin a host line: control characters in it act at once (their replies lead the
    /// reply); `remember` = it becomes the "last line" of CTRL-I / CTRL-Y.
    pub(crate) fn start_line(&mut self, s: &mut Session, line: &[u8], remember: bool) -> LineRun {
        let mut reply = Reply::new();
        // Control characters act on arrival and never belong to the line (§1.3); LF is ignored.
        let mut clean = Vec::with_capacity(line.len());
        for &b in line {
            match b {
                b'\r' | b'\n' => {}
                0x00..=0x1F => {
                    let r = self.control(s, b);
                    reply.raw(&r);
                }
                _ => clean.push(b),
            }
        }
        if remember && !clean.is_empty() && clean.len() <= super::MAX_LINE {
            self.mem.last_line.clone_from(&clean);
        }
        self.run_for(clean, reply, false)
    }

    fn run_for(&mut self, clean: Vec<u8>, reply: Reply, program: bool) -> LineRun {
        let (parser, outcome) = match LineParser::new(&clean) {
            Ok(p) => (Some(p.state()), None),
            Err(e) => (None, Some(Outcome::Err(e.code))),
        };
        LineRun {
            clean,
            parser,
            pending: Vec::new(),
            lines: Vec::new(),
            reply,
            outcome,
            split: None,
            waiting: None,
            aux: None,
            program,
        }
    }

    /// Advance `run` within `budget`.
    pub(crate) fn step_line(
        &mut self,
        run: &mut LineRun,
        s: &mut Session,
        budget: &mut Budget,
    ) -> Step {
        if run.waiting.is_some() {
            return Step::Yield;
        }
        self.clamp_session(s);
        loop {
            if run.aux.is_some() && self.step_aux(run) == AuxStep::Wait {
                return Step::Wait;
            }
            if let Some(outcome) = run.outcome {
                return Step::Done(self.finish_run(run, s, outcome));
            }
            if budget.exhausted() {
                return Step::Yield;
            }
            if run.split.is_some() {
                self.step_split(run, budget);
                continue;
            }
            let Some(state) = run.parser else {
                run.outcome = Some(Outcome::Ok);
                continue;
            };
            let mode = self.parse_mode(s);
            let mut parser = LineParser::resume(&run.clean, state);
            let item = parser.next_item(mode);
            run.parser = Some(parser.state());
            budget.spend(1);
            let cmd = match item {
                None => {
                    if !run.pending.is_empty() {
                        if let Err(code) = self.store_line(s, std::mem::take(&mut run.pending)) {
                            run.outcome = Some(Outcome::Err(code));
                            continue;
                        }
                    }
                    run.outcome = Some(Outcome::Ok);
                    continue;
                }
                Some(Err(e)) => {
                    run.outcome = Some(Outcome::Err(e.code));
                    continue;
                }
                Some(Ok(Item::Stmt(st))) => {
                    if run.program || self.chain_listening(s) {
                        run.pending.push(st);
                    }
                    continue;
                }
                Some(Ok(Item::Cmd(c))) => c.kind,
            };
            let chain_cmd = matches!(cmd, CmdKind::AddrCard(_) | CmdKind::AddrAllCards);
            if !run.program && !self.chain_listening(s) && !chain_cmd {
                continue;
            }
            if !run.pending.is_empty() {
                if let Err(code) = self.store_line(s, std::mem::take(&mut run.pending)) {
                    run.outcome = Some(Outcome::Err(code));
                    continue;
                }
            }
            if let Some(split) = self.split_for(s, &cmd) {
                match split {
                    Ok(sp) => run.split = Some(sp),
                    Err(code) => run.outcome = Some(Outcome::Err(code)),
                }
                continue;
            }
            let mut out = Out::default();
            let r = self.exec_cmd(s, &cmd, &mut out);
            budget.spend(out.lines.len() as u64);
            // Under `@@` card 0 rejects data-returning commands (§8.2 [DECISION]).
            let r = if r.is_ok()
                && !run.program
                && s.chain_all
                && self.software_addressing()
                && !out.lines.is_empty()
                && cmd != CmdKind::ReportCard
            {
                out.lines.clear();
                Err(ErrCode::Data)
            } else {
                r
            };
            let f = self.framing();
            run.lines.extend(out.lines.into_iter().map(|l| (f, l)));
            if let Err(code) = r {
                run.outcome = Some(Outcome::Err(code));
                continue;
            }
            run.aux = out.aux;
            match out.flow {
                Flow::Next => {}
                Flow::Effect(e) => {
                    run.waiting = Some(e.clone());
                    return Step::Effect(e);
                }
            }
        }
    }

    /// The effect `run` waited for is done: the command finishes with `result`.
    pub(crate) fn finish_effect(
        &mut self,
        run: &mut LineRun,
        s: &mut Session,
        result: EffectResult,
    ) {
        let Some(e) = run.waiting.take() else {
            return;
        };
        match (e, result) {
            (Effect::Save(_), EffectResult::Saved(ok)) => {
                if !ok {
                    run.outcome = Some(Outcome::Err(ErrCode::Data));
                }
            }
            (Effect::Load, loaded @ EffectResult::Loaded(_)) => {
                // A refused image is reported by the caller (core load error, log).
                let _ = self.apply_loaded(loaded);
                // Power-up/reset: card 0 is the addressed card (§8.2).
                // The host connection's duplex mode is its port's, kept across the reset.
                *s = Session {
                    chain_addressed: self.card_number() == 0,
                    echo: s.echo,
                    ..Session::with_id(s.id)
                };
                run.outcome = Some(Outcome::Silent);
            }
            // A result of the wrong kind: the command failed.
            _ => run.outcome = Some(Outcome::Err(ErrCode::Data)),
        }
    }

    /// The data framed so far, to leave before the line ends (a streamed reply: a real card
    /// sends data as it produces it); nothing while the card is not talking on the chain, and
    /// nothing for a program's line (its caller frames the whole reply).
    pub(crate) fn take_output(&mut self, run: &mut LineRun, s: &Session) -> Vec<u8> {
        if run.program || !self.chain_talking(s) {
            return Vec::new();
        }
        let mut reply = std::mem::take(&mut run.reply);
        // Taken, not drained: the list's capacity (a slice's worth of lines) goes too.
        for (fr, l) in std::mem::take(&mut run.lines) {
            reply.data_line(fr, l.as_bytes());
        }
        reply.into_bytes()
    }

    fn finish_run(&mut self, run: &mut LineRun, s: &Session, outcome: Outcome) -> Vec<u8> {
        let mut reply = std::mem::take(&mut run.reply);
        let talk = run.program || self.chain_talking(s);
        if talk && !run.program {
            let f = self.framing();
            for (fr, l) in &run.lines {
                reply.data_line(*fr, l.as_bytes());
            }
            reply.finish(f, outcome, &run.clean);
        }
        reply.into_bytes()
    }

    /// A selection query big enough to be answered in slices: its indices (or the error).
    fn split_for(&mut self, s: &Session, cmd: &CmdKind) -> Option<Result<Split, ErrCode>> {
        let (v, mdef): (&VarList, bool) = match cmd {
            CmdKind::VarQuery(v) => (v, false),
            CmdKind::MDefQuery(v) if v.kind == VarKind::M => (v, true),
            _ => return None,
        };
        if v.constant_indices().is_none_or(|l| l.len() <= SPLIT_ABOVE) {
            return None;
        }
        Some(self.indices(s.coord.get(), v).map(|rest| Split {
            kind: v.kind,
            mdef,
            cs: s.coord.get(),
            rest,
            next: 0,
        }))
    }

    fn step_split(&mut self, run: &mut LineRun, budget: &mut Budget) {
        let Some(mut sp) = run.split.take() else {
            return;
        };
        let f = self.framing();
        while sp.next < sp.rest.len() && !budget.exhausted() {
            let n = sp.rest[sp.next];
            sp.next += 1;
            budget.spend(1);
            let text = if sp.mdef {
                self.model.state.mdef_text(n).map_err(|e| e.err_code())
            } else {
                self.query_var(sp.kind, sp.cs, n)
            };
            match text {
                Ok(t) => run.lines.push((f, t)),
                Err(code) => {
                    run.outcome = Some(Outcome::Err(code));
                    return;
                }
            }
        }
        if sp.next < sp.rest.len() {
            run.split = Some(sp);
        }
    }

    /// Run `line` to its end for a program (`CMD"…"`): the outcome and the data lines
    /// with their framing. Effects go to the detached list (performed by the caller; the
    /// command does not wait: SAVE is acknowledged, `$$$` resets once the image is loaded).
    pub(crate) fn execute_line(
        &mut self,
        s: &mut Session,
        line: &[u8],
    ) -> (Outcome, Vec<(Framing, String)>) {
        let mut run = self.run_for(line.to_vec(), Reply::new(), true);
        loop {
            match self.step_detached(&mut run, s, &mut Budget::unlimited()) {
                Step::Done(_) => {
                    let outcome = run.outcome.unwrap_or(Outcome::Ok);
                    return (outcome, std::mem::take(&mut run.lines));
                }
                Step::Wait => self.abandon_aux(&mut run),
                Step::Yield | Step::Effect(_) => {}
            }
        }
    }

    /// Execute one line completely (start-up and configuration lines); effects are detached
    /// as for program commands.
    pub(crate) fn run_line(&mut self, s: &mut Session, line: &[u8], remember: bool) -> Vec<u8> {
        self.run_line_refused(s, line, remember).0
    }

    /// [`Pmac::run_line`], with the line's refusal (whether or not I6 printed it).
    pub(crate) fn run_line_refused(
        &mut self,
        s: &mut Session,
        line: &[u8],
        remember: bool,
    ) -> (Vec<u8>, Option<ErrCode>) {
        let mut run = self.start_line(s, line, remember);
        loop {
            match self.step_detached(&mut run, s, &mut Budget::unlimited()) {
                Step::Done(r) => return (r, run.refusal()),
                Step::Wait => self.abandon_aux(&mut run),
                Step::Yield | Step::Effect(_) => {}
            }
        }
    }

    /// Run `run` within `budget` with effects detached: [`Step::Done`] with its reply,
    /// [`Step::Yield`] when the budget ran out, [`Step::Wait`] while a MACRO auxiliary
    /// command waits for the ring (call again after a servo tick); never [`Step::Effect`].
    pub(crate) fn step_detached(
        &mut self,
        run: &mut LineRun,
        s: &mut Session,
        budget: &mut Budget,
    ) -> Step {
        loop {
            match self.step_line(run, s, budget) {
                Step::Effect(e) => {
                    run.waiting = None;
                    if e == Effect::Load {
                        run.outcome = Some(Outcome::Silent);
                    }
                    self.mem.detached.push(e);
                }
                other => return other,
            }
        }
    }
}
