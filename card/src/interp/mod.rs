//! The interpreter facade: bytes in, reply bytes out. One `Card` per controller, shared by all
//! host connections; one `Session` per connection (addressed motor and coordinate system, open
//! buffer bookkeeping that is per connection).
//!
//! This facade's signatures are a contract between the interpreter and the host ports.

pub mod buffers;
pub mod control;
pub mod defines;
mod exec;
mod exec_buffers;
mod exec_defines;
mod exec_info;
mod exec_macro;
mod exec_motion;
mod exec_vars;
mod image;
mod line;
pub mod progline;
mod program_cmd;
pub mod reply;
pub mod runstate;
pub mod unsolicited;

pub use program_cmd::MAX_ACTIONS;

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

use buffers::{BufId, Buffers};
use progline::ProgLine;
use runstate::RunState;

use crate::state::card_state::CardState;

/// Longest command line accepted (characters before the CR); longer lines get ERR003.
pub const MAX_LINE: usize = 1024;

static NEXT_SESSION: AtomicU64 = AtomicU64::new(1);

/// Per-connection interpreter state (addressed motor / coordinate system, ...).
#[derive(Debug, Clone)]
pub struct Session {
    /// Addressed motor (`#n`), 1-based.
    pub motor: u16,
    /// Addressed coordinate system (`&n`), 1-based.
    pub coord: u16,
    /// Identity of the connection (distinguishes who opened a program buffer).
    pub id: u64,
    /// Serial-chain addressing of this connection: this card is addressed (`@n` = I0, or
    /// `@@`). Only meaningful with software addressing (I1 bit 1); power-up: addressed.
    pub chain_addressed: bool,
    /// Serial-chain addressing of this connection: all cards are addressed (`@@`).
    pub chain_all: bool,
}

impl Session {
    /// A fresh addressing state (#1, &1, this card addressed) keeping the connection `id`.
    pub fn with_id(id: u64) -> Self {
        Session {
            motor: 1,
            coord: 1,
            id,
            chain_addressed: true,
            chain_all: false,
        }
    }
}

impl Default for Session {
    fn default() -> Self {
        Session::with_id(NEXT_SESSION.fetch_add(1, Ordering::Relaxed))
    }
}

/// Which table set the card answers with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Profile {
    /// PMAC2 (seed manual): 8 motors, 8 coordinate systems, variables 0-1023.
    #[default]
    Pmac2,
    /// Turbo host-compatibility: 32 motors, 16 coordinate systems, variables 0-8191, CID.
    Turbo,
}

/// A motor/C.S./program command accepted by the interpreter whose motion effect belongs to the
/// motion code, which drains them with [`Card::take_actions`].
#[derive(Debug, Clone, PartialEq)]
pub struct Action {
    /// Motor addressed when the command was given.
    pub motor: u16,
    /// Coordinate system addressed when the command was given.
    pub coord: u16,
    /// What was asked.
    pub kind: ActionKind,
}

/// The kinds of [`Action`].
#[derive(Debug, Clone, PartialEq)]
pub enum ActionKind {
    /// An on-line command (jog, home, kill, run, abort, ...), as parsed.
    Cmd(crate::lang::ast::CmdKind),
    /// A control character acting on motion (`0x01` CTRL-A, `0x0B` CTRL-K, ...).
    Ctrl(u8),
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

/// One controller card's interpreter state.
#[derive(Debug)]
pub struct Card {
    profile: Profile,
    /// Variables, registers, status flags, password (STATE).
    pub state: CardState,
    pub(crate) bufs: Buffers<ProgLine>,
    pub(crate) open: Option<OpenBuf>,
    pub(crate) run: RunState,
    pub(crate) actions: Vec<Action>,
    pub(crate) last_line: Vec<u8>,
    pub(crate) echo: bool,
    pub(crate) state_file: Option<PathBuf>,
    /// A compensation table just defined and not yet filled: bare numbers are its entries.
    pub(crate) pending_table: Option<(defines::TableKind, u8)>,
    /// Unsolicited output (`SEND`, program `CMD` replies) for the terminal ports.
    pub unsolicited: unsolicited::Unsolicited,
    /// Data gathered by `GATHER` (the servo loop samples into it; `LIST GATHER` prints it).
    pub gather: crate::servo::gather::GatherBuffer,
    /// Number of resets (`$$$`, `$$$***`) so far: the servo loop re-initialises its motors
    /// when it changes.
    pub(crate) resets: u64,
}

impl Card {
    /// A card with factory defaults for `profile`.
    pub fn new(profile: Profile) -> Self {
        let state = CardState::new(profile);
        let lim = state.limits();
        let mut c = Card {
            profile,
            state,
            bufs: Buffers::new(image::user_memory_words(profile)),
            open: None,
            run: RunState::new(lim.motors, lim.coords, 32),
            actions: Vec::new(),
            last_line: Vec::new(),
            echo: false,
            state_file: None,
            pending_table: None,
            unsolicited: unsolicited::Unsolicited::default(),
            gather: Default::default(),
            resets: 0,
        };
        c.state.power_on();
        c.sync_motor_coords();
        c
    }

    /// A card whose `SAVE` writes `path` and which starts from the image saved there (factory
    /// defaults when the file does not exist or cannot be loaded).
    pub fn with_state_file(profile: Profile, path: impl Into<PathBuf>) -> Self {
        let mut c = Card::new(profile);
        c.state_file = Some(path.into());
        let _ = c.reset_from_file();
        c
    }

    /// The profile this card answers with.
    pub fn profile(&self) -> Profile {
        self.profile
    }

    /// Execute one complete command line (without its CR terminator). Returns the whole reply,
    /// framed per I3/I4/I6/I9 (ACK/LF/CR/BELL, ERRnnn placement, checksums).
    pub fn command_line(&mut self, session: &mut Session, line: &[u8]) -> Vec<u8> {
        self.run_line(session, line, true)
    }

    /// Execute one control-character command (0x01..=0x1A other than CR, LF, TAB/CTRL-I, BS).
    /// Returns the framed reply (possibly empty). CTRL-I (0x09) re-executes the last command
    /// line; CTRL-Y returns the last line (the host port puts it back into its line buffer);
    /// CTRL-N needs the partial line, see [`control::ctrl_n`].
    pub fn control_char(&mut self, session: &mut Session, c: u8) -> Vec<u8> {
        self.control(session, c)
    }

    /// Drain the motion-related commands accepted since the last call.
    pub fn take_actions(&mut self) -> Vec<Action> {
        std::mem::take(&mut self.actions)
    }

    /// Full-duplex echo toggled by CTRL-T (the host port echoes received characters when set).
    pub fn echo(&self) -> bool {
        self.echo
    }

    /// The last command line executed (for CTRL-Y / CTRL-I handling in host ports).
    pub fn last_line(&self) -> &[u8] {
        &self.last_line
    }

    /// A connection has gone away: close any buffer it left open.
    pub fn end_session(&mut self, session: &Session) {
        if let Some(o) = self.open {
            if o.session == session.id {
                let _ = self.close_buffer();
            }
        }
    }

    /// Motion code: report motor `m`'s (1-based) position, velocity and following error in
    /// counts, as `P`, `V`, `F` and CTRL-P/V/F answer them.
    pub fn set_motor_report(&mut self, m: u16, position: f64, velocity: f64, following_error: f64) {
        if let Some(r) = m
            .checked_sub(1)
            .and_then(|k| self.run.report.get_mut(k as usize))
        {
            *r = (position, velocity, following_error);
        }
    }

    /// Data gathering is on (`???` word 1 bit 19).
    pub fn gathering(&self) -> bool {
        self.state.global.word1_other & crate::servo::gather::GATHER_ON != 0
    }

    /// Number of resets (`$$$`, `$$$***`) executed so far.
    pub fn resets(&self) -> u64 {
        self.resets
    }

    /// Whether the interpreted PLC `n` exists, is enabled and not paused (for the PLC runner).
    pub fn plc_active(&self, n: u8) -> bool {
        self.bufs.plcs.contains_key(&n) && self.run.plc_active(n)
    }
}

#[cfg(test)]
mod tests;
