//! The PMAC interpreter: command lines in, framed reply bytes out, executed against the card
//! data model ([`CardModel`]). [`Card`] is one card as the PMAC dialect sees it: the model plus
//! what the dialect itself remembers (the open buffer, the last line for CTRL-I/CTRL-Y, echo,
//! a compensation table being filled). [`Session`] is one connection's addressing.
//!
//! A line runs as a [`LineRun`] that can stop between commands: [`Card::step_line`] executes
//! until a work budget is spent (the servo thread serves host work in bounded slices between
//! ticks) or until a command needs the operating system ([`Effect`]: SAVE's file write, the
//! saved image `$$$` reloads), which the caller performs off the servo thread and hands back
//! with [`Card::finish_effect`]. [`Card::command_line`] runs a line to the end with a storage
//! of its own (tests, tools).

mod control;
mod exec;
mod exec_buffers;
mod exec_defines;
mod exec_info;
mod exec_macro;
mod exec_motion;
mod exec_vars;
mod image;
mod line;
mod program_cmd;
mod reply;

pub(crate) use control::ctrl_n;
pub use image::{Effect, EffectResult, Storage};
pub use line::{Budget, LineRun, Step};

use crate::domain::{CsNum, ErrCode, MotorNum};
use std::ops::{Deref, DerefMut};
use std::sync::atomic::{AtomicU64, Ordering};

pub(crate) use crate::domain::Profile;
use crate::model::TableKind;
use crate::model::{BufId, CardModel};
use crate::program::Commands;

/// Longest command line accepted (characters before the CR); longer lines get ERR003.
pub const MAX_LINE: usize = 1024;

/// A line one byte longer than the interpreter accepts: the card rejects it with its own
/// ERR003 framing (I3/I4/I6) before parsing anything. A port discards over-long lines itself
/// (bounded memory) and hands the card this instead.
pub(crate) fn overlong_probe() -> Vec<u8> {
    vec![b'U'; MAX_LINE + 1]
}

static NEXT_SESSION: AtomicU64 = AtomicU64::new(1);

/// Per-connection interpreter state (addressed motor / coordinate system, ...).
#[derive(Debug, Clone)]
pub struct Session {
    /// Addressed motor (`#n`).
    pub motor: MotorNum,
    /// Addressed coordinate system (`&n`).
    pub coord: CsNum,
    /// Identity of the connection (distinguishes who opened a program buffer).
    pub id: u64,
    /// Serial-chain addressing of this connection: this card is addressed (`@n` = I0, or
    /// `@@`). Only meaningful with software addressing (I1 bit 1); power-up: addressed.
    pub chain_addressed: bool,
    /// Serial-chain addressing of this connection: all cards are addressed (`@@`).
    pub chain_all: bool,
    /// Full duplex (`<CTRL-T>`): the host port echoes what this connection sends. A mode of
    /// the port it arrives on (seed: "toggle serial port half/full duplex"), so one host's
    /// CTRL-T never changes another host's replies; power-up (a new connection): half duplex.
    pub echo: bool,
}

impl Session {
    /// A fresh addressing state (#1, &1, this card addressed) keeping the connection `id`.
    pub fn with_id(id: u64) -> Self {
        Session {
            motor: MotorNum::FIRST,
            coord: CsNum::FIRST,
            id,
            chain_addressed: true,
            chain_all: false,
            echo: false,
        }
    }
}

impl Default for Session {
    fn default() -> Self {
        Session::with_id(NEXT_SESSION.fetch_add(1, Ordering::Relaxed))
    }
}

/// Which buffer is open, and by which connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct OpenBuf {
    /// The session that opened it.
    pub session: u64,
    /// The buffer.
    pub id: BufId,
    /// `OPEN BIN ROT` (ASCII lines then execute as on-line commands).
    pub binary: bool,
}

/// What the PMAC interpreter itself remembers about a card (beside the model).
#[derive(Debug, Default)]
pub(crate) struct Memory {
    pub(crate) open: Option<OpenBuf>,
    pub(crate) last_line: Vec<u8>,
    /// A compensation table just defined and not yet filled: bare numbers are its entries.
    pub(crate) pending_table: Option<(TableKind, u8)>,
    /// Effects of program-issued commands (`CMD"SAVE"`), for the caller to perform.
    pub(crate) detached: Vec<Effect>,
}

/// The interpreter at work: the model and the interpreter's memory, borrowed together.
#[derive(Debug)]
pub(crate) struct Pmac<'a> {
    pub(crate) model: &'a mut CardModel,
    pub(crate) mem: &'a mut Memory,
}

impl Deref for Pmac<'_> {
    type Target = CardModel;
    fn deref(&self) -> &CardModel {
        self.model
    }
}

impl DerefMut for Pmac<'_> {
    fn deref_mut(&mut self) -> &mut CardModel {
        self.model
    }
}

/// One controller card as the PMAC dialect sees it: the data model and the interpreter's own
/// memory. Dereferences to the model.
#[derive(Debug)]
pub struct Card {
    /// The card data model (shared with the program engine and the servo loop).
    pub model: CardModel,
    mem: Memory,
    /// Where [`Card::command_line`] performs effects (none: SAVE keeps nothing, `$$$` loads
    /// factory defaults).
    storage: Option<Box<dyn Storage + Send>>,
}

impl Deref for Card {
    type Target = CardModel;
    fn deref(&self) -> &CardModel {
        &self.model
    }
}

impl DerefMut for Card {
    fn deref_mut(&mut self) -> &mut CardModel {
        &mut self.model
    }
}

/// The interpreter as the program engine's command path (`CMD"…"`, `CMD^x`): hand it to
/// [`crate::servo::Servo::tick`] together with the model ([`Card::split`]).
#[derive(Debug)]
pub struct ProgramCommands<'a> {
    mem: &'a mut Memory,
}

impl Commands for ProgramCommands<'_> {
    fn line(&mut self, card: &mut CardModel, motor: u16, coord: u16, line: &[u8]) -> Vec<u8> {
        Pmac {
            model: card,
            mem: self.mem,
        }
        .program_command(motor, coord, line)
    }

    fn control(&mut self, card: &mut CardModel, motor: u16, coord: u16, c: u8) -> Vec<u8> {
        let mut s = Session {
            motor: MotorNum::of(motor),
            coord: CsNum::of(coord),
            ..Session::with_id(0)
        };
        Pmac {
            model: card,
            mem: self.mem,
        }
        .control(&mut s, c)
    }
}

impl Card {
    /// A card with factory defaults for `profile`.
    pub fn new(profile: Profile) -> Self {
        Card {
            model: CardModel::new(profile),
            mem: Memory::default(),
            storage: None,
        }
    }

    /// A card whose effects go to `storage`, starting from the image it holds (factory
    /// defaults when it has none or it cannot be loaded, `???` bit 10 set).
    pub fn with_storage(profile: Profile, storage: Box<dyn Storage + Send>) -> Self {
        let mut c = Card::new(profile);
        c.storage = Some(storage);
        let loaded = c.perform(&Effect::Load);
        let _ = c.apply_loaded(loaded);
        c
    }

    pub(crate) fn view(&mut self) -> Pmac<'_> {
        Pmac {
            model: &mut self.model,
            mem: &mut self.mem,
        }
    }

    /// The model and the interpreter's command path, borrowed apart (for a servo tick).
    pub fn split(&mut self) -> (&mut CardModel, ProgramCommands<'_>) {
        (&mut self.model, ProgramCommands { mem: &mut self.mem })
    }

    /// The profile this card answers with.
    pub fn profile(&self) -> Profile {
        self.model.profile()
    }

    /// Execute one complete command line (without its CR terminator), performing any effect
    /// with this card's storage. Returns the whole reply, framed per I3/I4/I6/I9.
    pub fn command_line(&mut self, session: &mut Session, line: &[u8]) -> Vec<u8> {
        self.command_line_refused(session, line).0
    }

    /// [`Card::command_line`], with the line's refusal (whether or not I6 printed it).
    pub fn command_line_refused(
        &mut self,
        session: &mut Session,
        line: &[u8],
    ) -> (Vec<u8>, Option<ErrCode>) {
        let mut run = self.start_line(session, line, true);
        loop {
            match self.step_line(&mut run, session, &mut Budget::unlimited()) {
                Step::Done(r) => return (r, run.refusal()),
                Step::Yield => {}
                // No servo loop turns meanwhile: the access fails as a timeout.
                Step::Wait => self.view().abandon_aux(&mut run),
                Step::Effect(e) => {
                    let r = self.perform(&e);
                    self.finish_effect(&mut run, session, r);
                }
            }
        }
    }

    /// Begin a host line: control characters in it act at once (their replies lead the
    /// reply); `remember` = it becomes the "last line" of CTRL-I / CTRL-Y.
    pub fn start_line(&mut self, s: &mut Session, line: &[u8], remember: bool) -> LineRun {
        self.view().start_line(s, line, remember)
    }

    /// Advance `run` within `budget`.
    pub fn step_line(&mut self, run: &mut LineRun, s: &mut Session, budget: &mut Budget) -> Step {
        self.view().step_line(run, s, budget)
    }

    /// The data `run` has framed so far, to send before the line ends (streamed replies).
    pub fn take_output(&mut self, run: &mut LineRun, s: &Session) -> Vec<u8> {
        self.view().take_output(run, s)
    }

    /// The effect `run` waited for is done: the command finishes with `result`.
    pub fn finish_effect(&mut self, run: &mut LineRun, s: &mut Session, result: EffectResult) {
        self.view().finish_effect(run, s, result)
    }

    /// Perform `effect` with this card's own storage (none: SAVE fails, as there is nowhere
    /// to keep it, and there is no saved image).
    pub fn perform(&mut self, effect: &Effect) -> EffectResult {
        match (effect, self.storage.as_mut()) {
            (Effect::Save(bytes), Some(st)) => EffectResult::Saved(st.save(bytes).is_ok()),
            (Effect::Save(_), None) => EffectResult::Saved(false),
            (Effect::Load, Some(st)) => EffectResult::Loaded(st.load()),
            (Effect::Load, None) => EffectResult::Loaded(Ok(None)),
        }
    }

    /// `$$$` / start-up with the result of [`Effect::Load`]: reload the saved image (factory
    /// defaults without one, or when it is bad: then `???` word 1 bit 10 is set and the reason
    /// is returned).
    pub fn apply_loaded(&mut self, loaded: EffectResult) -> Result<(), String> {
        self.view().apply_loaded(loaded)
    }

    /// The encoded image `SAVE` writes.
    pub fn save_image(&mut self) -> Vec<u8> {
        self.view().save_image()
    }

    /// Execute one line completely on the servo thread (chain, synchronized start, start-up):
    /// effects are detached ([`Card::take_detached_effects`]): SAVE is acknowledged and
    /// written in the background, `$$$` resets once its image is loaded.
    pub fn run_detached(&mut self, session: &mut Session, line: &[u8]) -> Vec<u8> {
        self.view().run_line(session, line, true)
    }

    /// [`Card::run_detached`], with the line's refusal (whether or not I6 printed it).
    pub fn run_detached_refused(
        &mut self,
        session: &mut Session,
        line: &[u8],
    ) -> (Vec<u8>, Option<ErrCode>) {
        self.view().run_line_refused(session, line, true)
    }

    /// Begin a line run on the servo thread with effects detached (the daisy chain): see
    /// [`Card::step_detached`].
    pub(crate) fn start_detached(&mut self, session: &mut Session, line: &[u8]) -> LineRun {
        self.view().start_line(session, line, true)
    }

    /// Advance a detached line run within `budget`: [`Step::Done`] with its reply,
    /// [`Step::Yield`] (budget used) or [`Step::Wait`] (a MACRO auxiliary command waits for
    /// the ring): call again later. Never [`Step::Effect`]: effects are detached.
    pub(crate) fn step_detached(
        &mut self,
        run: &mut LineRun,
        s: &mut Session,
        budget: &mut Budget,
    ) -> Step {
        self.view().step_detached(run, s, budget)
    }

    /// Advance a synchronized start's line within `budget`, effects detached: its reply when
    /// done, `None` when the budget ran out (call again with the next slice). A MACRO
    /// auxiliary access cannot wait for the ring here: it fails as a timeout at once.
    pub(crate) fn step_started(
        &mut self,
        run: &mut LineRun,
        s: &mut Session,
        budget: &mut Budget,
    ) -> Option<Vec<u8>> {
        loop {
            match self.view().step_detached(run, s, budget) {
                Step::Done(r) => return Some(r),
                Step::Wait => self.view().abandon_aux(run),
                Step::Yield | Step::Effect(_) => return None,
            }
        }
    }

    /// Execute one control-character command (0x01..=0x1A other than CR, LF, TAB/CTRL-I, BS).
    /// Returns the framed reply (possibly empty). CTRL-I (0x09) re-executes the last command
    /// line; CTRL-Y returns the last line (the host port puts it back into its line buffer);
    /// CTRL-N needs the partial line, see `ctrl_n`.
    pub fn control_char(&mut self, session: &mut Session, c: u8) -> Vec<u8> {
        self.view().control(session, c)
    }

    /// Execute a command line issued by a program (`CMD"..."`) with the program's addressing.
    /// Returns the unsolicited output to send to the host (possibly empty).
    pub fn program_command(&mut self, motor: u16, coord: u16, line: &[u8]) -> Vec<u8> {
        self.view().program_command(motor, coord, line)
    }

    /// Execute one PMAC on-line command against this card (another dialect reusing the PMAC
    /// executors for motors and coordinate systems): its reply lines, or the ERR code.
    pub(crate) fn exec_pmac(
        &mut self,
        s: &mut Session,
        cmd: &crate::lang::pmac::ast::CmdKind,
    ) -> Result<Vec<String>, ErrCode> {
        let mut out = exec::Out::default();
        self.view().exec_cmd(s, cmd, &mut out)?;
        Ok(out.lines)
    }

    /// The last command line executed (for CTRL-Y / CTRL-I handling in host ports).
    pub fn last_line(&self) -> &[u8] {
        &self.mem.last_line
    }

    /// The session that has a buffer open, if any.
    pub fn open_session(&self) -> Option<u64> {
        self.mem.open.map(|o| o.session)
    }

    /// A connection has gone away: close any buffer it left open.
    pub fn end_session(&mut self, session: &Session) {
        if let Some(o) = self.mem.open {
            if o.session == session.id {
                let _ = self.view().close_buffer();
            }
        }
    }

    /// Effects of program-issued commands since the last call (performed by the caller).
    pub fn take_detached_effects(&mut self) -> Vec<Effect> {
        std::mem::take(&mut self.mem.detached)
    }

    /// Chain addressing: software addressing is on (I1 bit 1).
    pub fn software_addressing(&mut self) -> bool {
        self.view().software_addressing()
    }

    /// Chain addressing: this card's number (I0).
    pub fn card_number(&mut self) -> u8 {
        self.view().card_number()
    }

    /// Chain addressing: `@n` (`Some(n)`) or `@@` (`None`) for session `s`.
    pub fn chain_select(&mut self, s: &mut Session, card: Option<u8>) -> Result<(), ErrCode> {
        self.view().chain_select(s, card)
    }

    /// Chain addressing: this card collects line characters for session `s`.
    pub fn chain_listening(&mut self, s: &Session) -> bool {
        self.view().chain_listening(s)
    }

    /// Chain addressing: this card answers session `s`.
    pub fn chain_talking(&mut self, s: &Session) -> bool {
        self.view().chain_talking(s)
    }
}

#[cfg(test)]
#[path = "tests_interp.rs"]
mod tests;

#[cfg(test)]
mod tests_format1;
