//! The seam between a card core and its command language. A core holds one [`Dialect`] and
//! asks it everything that depends on the language: how a host line runs, what a control
//! character does, what a daisy-chain line means to a synchronized start, how program
//! `CMD`s run after a servo tick. The PMAC2/Turbo language runs a host line as a
//! [`LineRun`](super::LineRun) in budgeted slices (the core steps it); the Power script
//! language answers a line whole ([`Dialect::whole_line`]).

use super::pmac::ast::CmdKind;
use super::power::{self, Power, PowerWait};
use super::{Budget, Card, LineRun, Session};
use crate::domain::{CsNum, MotorNum, Profile, Refusal};
use crate::model::CardModel;
use crate::program::Commands;

/// A card's command language and its state.
#[derive(Debug, Default)]
pub enum Dialect {
    /// PMAC2 / Turbo: its state lives in the [`Card`] (sessions are the core's).
    #[default]
    Pmac,
    /// Power PMAC: its communication threads and the elements the model does not keep.
    Power(Box<Power>),
}

/// A line a whole-line dialect answered.
#[derive(Debug)]
pub struct WholeLine {
    /// The reply.
    pub bytes: Vec<u8>,
    /// Its first refusal.
    pub error: Option<Refusal>,
    /// The reply waits for an effect (`save`, `$$$`): answer with [`HeldReply`] once done.
    pub held: Option<HeldReply>,
    /// Its cost in budget units, counted as a PMAC line's are (one per line, one per data
    /// line it answers). A Power line runs whole: its executor bounds one line's values
    /// (`MAX_VALUES`), so a slice overruns by at most that.
    pub units: u64,
}

/// A reply held until its effect is done.
#[derive(Debug)]
pub struct HeldReply(PowerWait);

impl HeldReply {
    /// The effect to perform.
    pub fn effect(&self) -> &super::Effect {
        &self.0.effect
    }

    /// The reply for the effect's outcome (`ok`: written / loaded) and its refusal.
    pub fn answer(self, ok: bool) -> (Vec<u8>, Option<Refusal>) {
        if ok {
            (self.0.ok, None)
        } else {
            (self.0.failed, self.0.refusal.map(Refusal::Power))
        }
    }
}

/// Threads of a Power card's daisy-chain connections are kept under the connection id with
/// this bit set (host connections never have it).
pub(crate) const CHAIN_THREAD: u64 = 1 << 63;

/// A synchronized start's line after its slice ([`Dialect::started_line`]).
#[derive(Debug)]
pub enum Started {
    /// Done: its whole reply and its refusal.
    Done(Vec<u8>, Option<Refusal>),
    /// Its budget ran out: go on with [`Dialect::step_started`].
    Running(Box<LineRun>),
}

impl Dialect {
    /// The language of `card`'s profile, installed in its model.
    pub fn for_card(card: &mut Card) -> Dialect {
        if card.profile() == Profile::Power {
            Power::attach(card);
            Dialect::Power(Box::new(Power::new()))
        } else {
            Dialect::Pmac
        }
    }

    /// A host line runs whole in this dialect ([`Dialect::whole_line`]); otherwise the core
    /// steps a [`LineRun`](super::LineRun).
    pub fn answers_whole_lines(&self) -> bool {
        matches!(self, Dialect::Power(_))
    }

    /// Run host line `line` of connection `conn` whole (`None`: the dialect steps its lines).
    pub fn whole_line(&mut self, card: &mut Card, conn: u64, line: &[u8]) -> Option<WholeLine> {
        let Dialect::Power(p) = self else {
            return None;
        };
        let (bytes, refused, wait) = p.host_line(card, conn, line);
        let units = 1 + bytes.iter().filter(|&&b| b == b'\n').count() as u64;
        Some(WholeLine {
            units,
            bytes,
            error: refused.map(Refusal::Power),
            held: wait.map(HeldReply),
        })
    }

    /// One line on connection (or thread) `conn` outside any host port (configuration,
    /// start-up, a synchronized start): the reply and its refusal. `session` is the PMAC
    /// addressing it runs with.
    pub fn detached_line(
        &mut self,
        card: &mut Card,
        session: &mut Session,
        conn: u64,
        line: &[u8],
    ) -> (Vec<u8>, Option<Refusal>) {
        match self {
            Dialect::Pmac => {
                let (bytes, e) = card.command_line_refused(session, line);
                (bytes, e.map(Refusal::Pmac))
            }
            Dialect::Power(p) => {
                let (bytes, e) = p.line_refused(card, conn, line);
                (bytes, e.map(Refusal::Power))
            }
        }
    }

    /// A synchronized start's line, run within `budget` (the tick of its ring cycle gives it
    /// a slice): done (with its refusal), or a run to go on with ([`Dialect::step_started`])
    /// between later ticks. A PMAC line runs as a `<CR>` would (it becomes the last line of
    /// CTRL-I/CTRL-Y); a Power line runs whole on thread `conn`.
    pub fn started_line(
        &mut self,
        card: &mut Card,
        session: &mut Session,
        conn: u64,
        line: &[u8],
        budget: &mut Budget,
    ) -> Started {
        match self {
            Dialect::Pmac => {
                let run = card.start_line(session, line, true);
                Self::step_started(card, session, Box::new(run), budget)
            }
            Dialect::Power(p) => {
                let (bytes, e) = p.line_refused(card, conn, line);
                Started::Done(bytes, e.map(Refusal::Power))
            }
        }
    }

    /// Go on with a synchronized start's line within `budget`.
    pub fn step_started(
        card: &mut Card,
        session: &mut Session,
        mut run: Box<LineRun>,
        budget: &mut Budget,
    ) -> Started {
        match card.step_started(&mut run, session, budget) {
            Some(r) => Started::Done(r, run.refusal().map(Refusal::Pmac)),
            None => Started::Running(run),
        }
    }

    /// Host connection `conn` closed.
    pub fn end(&mut self, card: &mut Card, session: &Session, conn: u64) {
        if let Dialect::Power(p) = self {
            p.end(card, conn);
        }
        card.end_session(session);
    }

    /// Control character `c` from a host port: PMAC's control-character commands; a Power
    /// `gpascii` thread has none (nothing, no reply). A host port's CTRL-I never comes here:
    /// the core runs it as a line (`CardCore::serve`), refusal and all.
    pub fn control(&mut self, card: &mut Card, session: &mut Session, c: u8) -> Vec<u8> {
        match self {
            Dialect::Pmac => card.control_char(session, c),
            Dialect::Power(_) => Vec::new(),
        }
    }

    /// The daisy chain passes control characters to the card's PMAC commands (a Power card
    /// only edits its collected line with them).
    pub fn has_control_commands(&self) -> bool {
        matches!(self, Dialect::Pmac)
    }

    /// Chain line `line` of a connection would start a motion program if it ran now (a
    /// synchronized start asks this); `session` is the connection's PMAC addressing.
    pub fn starts_program(&self, card: &Card, session: &Session, line: &[u8]) -> bool {
        match self {
            Dialect::Power(p) => p.starts_program(card, CHAIN_THREAD | session.id, line),
            Dialect::Pmac => {
                card.open_session() != Some(session.id)
                    && super::pmac::parse_line(line).is_ok_and(|cmds| {
                        cmds.iter()
                            .any(|k| matches!(k.kind, CmdKind::Run | CmdKind::Step))
                    })
            }
        }
    }

    /// A chain line taken to run elsewhere (a synchronized start): the line with its
    /// connection's addressing in front (`#m&c`), and the connection takes the line's modal
    /// `#n`/`&n` as if it had run here.
    pub fn take_line(&mut self, card: &Card, session: &mut Session, line: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        match self {
            Dialect::Power(p) => {
                // The thread's `Ldata.Motor`/`Ldata.Coord` in Power numbering.
                let key = CHAIN_THREAD | session.id;
                let (m, cs) = p.addressing(key);
                out.extend_from_slice(format!("#{m}&{cs} ").as_bytes());
                out.extend_from_slice(line);
                p.adopt_addressing(card, key, line);
            }
            Dialect::Pmac => {
                let (m, cs) = (session.motor.get(), session.coord.get());
                out.extend_from_slice(format!("#{m}&{cs}").as_bytes());
                out.extend_from_slice(line);
                for cmd in super::pmac::parse_line(line).unwrap_or_default() {
                    match cmd.kind {
                        CmdKind::AddrMotor(n) => {
                            session.motor = MotorNum::of(u16::try_from(n).unwrap_or(1));
                        }
                        CmdKind::AddrCoord(n) => {
                            session.coord = CsNum::of(u16::try_from(n).unwrap_or(1));
                        }
                        _ => {}
                    }
                }
            }
        }
        out
    }

    /// A chain line at `<CR>` in a whole-line dialect: its reply and refusal, on the
    /// connection's own thread (`None`: the PMAC chain runs it with the connection's
    /// session). `overflow`: the line was longer than the dialect takes (it answers its own
    /// error for it).
    pub fn chain_line(
        &mut self,
        card: &mut Card,
        session: &Session,
        line: &[u8],
        overflow: bool,
    ) -> Option<(Vec<u8>, Option<Refusal>)> {
        let Dialect::Power(p) = self else {
            return None;
        };
        let long;
        let line = if overflow {
            long = vec![b' '; power::MAX_LINE + 1];
            &long[..]
        } else {
            line
        };
        let (bytes, e) = p.line_refused(card, CHAIN_THREAD | session.id, line);
        Some((bytes, e.map(Refusal::Power)))
    }

    /// Connection `session` of the daisy chain is gone.
    pub fn end_chain(&mut self, card: &mut Card, session: &Session) {
        card.end_session(session);
        if let Dialect::Power(p) = self {
            p.end(card, CHAIN_THREAD | session.id);
        }
    }

    /// One servo tick: `tick` runs it with the sink program `CMD`s go to; the dialect runs
    /// them after it (Power: `cmd"…"` in Power syntax on its command thread).
    pub fn tick(&mut self, card: &mut Card, tick: impl FnOnce(&mut CardModel, &mut dyn Commands)) {
        match self {
            Dialect::Power(p) => {
                let mut q = power::CmdQueue::default();
                tick(&mut card.model, &mut q);
                p.program_commands(card, q);
            }
            Dialect::Pmac => {
                let (model, mut cmds) = card.split();
                tick(model, &mut cmds);
            }
        }
    }

    /// Run `line` in a whole-line dialect's own syntax on thread `conn`, as a host thread
    /// would (`None` on a PMAC card): for tests and tools that drive the language directly.
    pub fn script_line(&mut self, card: &mut Card, conn: u64, line: &[u8]) -> Option<Vec<u8>> {
        match self {
            Dialect::Power(p) => Some(p.line(card, conn, line)),
            Dialect::Pmac => None,
        }
    }
}
