//! [`CardModel`]: everything a card holds that more than one layer reads or changes — the
//! variable/memory/status state, the program buffers, run state of coordinate systems, motors
//! and PLCs, the motion requests waiting for the servo loop, gathered data and program output.
//! Pure data with small invariant-keeping operations; the interpreter, the program engine and
//! the servo loop all work on it.

use super::actions::{Action, MAX_ACTIONS};
use super::buffers::Buffers;
use super::card_state::CardState;
use super::gather::{GatherBuffer, GATHER_ON};
use super::macro_aux::{AuxFailure, AuxSettings, MacroAux};
use super::memory::Space;
use super::progline::ProgLine;
use super::regmap::AUX_ERROR_VALUE;
use super::runstate::RunState;
use super::unsolicited::UNSOLICITED_LIMIT;
use crate::domain::Profile;

/// User buffer memory in words: $1800-$9FFF on PMAC2 (34,816); Turbo gets the same
/// budget scaled ×4 ([DECISION]: Turbo boards carry more program memory).
pub(crate) fn user_memory_words(profile: Profile) -> u32 {
    match profile {
        Profile::Pmac2 => 34_816,
        Profile::Turbo | Profile::Power => 4 * 34_816,
    }
}

/// Interpreted PLCs per card (PLC 0-31).
pub(crate) const PLCS: usize = 32;

/// One controller card's data.
#[derive(Debug)]
pub struct CardModel {
    profile: Profile,
    /// Variables, registers, status flags, password.
    pub state: CardState,
    /// Programs, PLCs, rotary and DEFINE'd buffers.
    pub bufs: Buffers<ProgLine>,
    /// Run state: C.S. program pointers, axis definitions, PLC flags, motor reports.
    pub run: RunState,
    actions: Vec<Action>,
    /// Program output for the terminals (`SEND`, program `CMD` replies) not yet taken.
    output: Vec<u8>,
    /// Data gathered by `GATHER` (the servo loop samples into it; `LIST GATHER` prints it).
    pub gather: GatherBuffer,
    /// Number of resets (`$$$`, `$$$***`) so far: the servo loop re-initialises its motors
    /// when it changes.
    resets: u64,
    /// The MACRO auxiliary channel (node 15; `MS`/`MX` commands, PLC `MSR`/`MSW`/`MXR`/`MXW`).
    pub(crate) aux: MacroAux,
    /// The command language's own variable families (see [`super::ExtVars`]).
    pub(super) ext: Option<Box<dyn super::ExtVars>>,
    /// The thread the program engine (or the interpreter) is evaluating for: whose locals
    /// extension variables are.
    pub exec: super::ExtAt,
    /// State of the pseudo-random generator (`rnd`, `randx`).
    pub rng: [u64; 2],
}

impl CardModel {
    /// A card with factory defaults for `profile`.
    pub fn new(profile: Profile) -> Self {
        let state = CardState::new(profile);
        let lim = state.limits();
        let mut c = CardModel {
            profile,
            state,
            bufs: Buffers::new(user_memory_words(profile)),
            run: RunState::new(lim.motors, lim.coords, PLCS),
            actions: Vec::new(),
            output: Vec::new(),
            gather: GatherBuffer::default(),
            resets: 0,
            aux: MacroAux::default(),
            ext: None,
            exec: super::ExtAt::default(),
            rng: [0x853C_49E6_748F_EA9B, 0xDA3E_39CB_94B9_5BDB],
        };
        c.state.power_on();
        c.sync_motor_coords();
        c
    }

    /// The profile this card answers with.
    pub fn profile(&self) -> Profile {
        self.profile
    }

    /// Queue an action for the motion code (bounded: the oldest is dropped when full).
    pub fn push_action(&mut self, a: Action) {
        if self.actions.len() >= MAX_ACTIONS {
            self.actions.remove(0);
        }
        self.actions.push(a);
    }

    /// The actions queued and not yet taken.
    pub fn actions(&self) -> &[Action] {
        &self.actions
    }

    /// Drain the motion requests accepted since the last call.
    pub fn take_actions(&mut self) -> Vec<Action> {
        std::mem::take(&mut self.actions)
    }

    /// Drop every queued action (a reset).
    pub fn clear_actions(&mut self) {
        self.actions.clear();
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
        self.state.global.word1_other & GATHER_ON != 0
    }

    /// Number of resets (`$$$`, `$$$***`) executed so far.
    pub fn resets(&self) -> u64 {
        self.resets
    }

    /// Count a reset (the servo loop and the program engine start afresh at their next tick).
    pub fn note_reset(&mut self) {
        self.resets += 1;
        self.aux.reset();
    }

    /// The ring settings the auxiliary preconditions read (I995, I1000, I1003).
    pub(crate) fn aux_settings(&self) -> AuxSettings {
        let i = |n: u32| self.state.peek_ivar(n).unwrap_or(0.0).max(0.0) as u32;
        AuxSettings {
            i995: i(995),
            i1000: i(1000),
            i1003: i(1003),
        }
    }

    /// An auxiliary access failed: `???` word 1 bit 5 and X:$0798 (pmac-commands §3.5).
    pub(crate) fn aux_failed(&mut self, f: AuxFailure) {
        self.state.global.macro_aux_error = true;
        self.state.write(Space::X, AUX_ERROR_VALUE, f.x0798);
    }

    /// Whether the interpreted PLC `n` exists, is enabled and not paused (for the PLC runner).
    pub fn plc_active(&self, n: u8) -> bool {
        self.bufs.plcs.contains_key(&n) && self.run.plc_active(n)
    }

    /// Whether C.S. `cs` is running a motion program.
    pub fn cs_running(&self, cs: u16) -> bool {
        cs.checked_sub(1)
            .and_then(|k| self.state.coords.get(k as usize))
            .is_some_and(|c| c.running)
    }

    /// Copy axis-definition membership into the motor status flags (`?` word 2 bits 23-20).
    pub fn sync_motor_coords(&mut self) {
        for (k, m) in self.state.motors.iter_mut().enumerate() {
            m.coord = self
                .run
                .axes
                .get(k)
                .and_then(|a| a.as_ref().map(|(c, _)| *c as u8));
        }
    }

    /// Add program output for the terminals (bounded: the oldest bytes go first, as in the
    /// terminals' own log).
    pub fn push_output(&mut self, bytes: &[u8]) {
        self.output.extend_from_slice(bytes);
        if self.output.len() > UNSOLICITED_LIMIT {
            let cut = self.output.len() - UNSOLICITED_LIMIT;
            self.output.drain(..cut);
        }
    }

    /// The next pseudo-random number in [0, 1) (xorshift128+; deterministic from the seeds).
    pub fn random(&mut self) -> f64 {
        let [mut s1, s0] = self.rng;
        let r = s1.wrapping_add(s0);
        s1 ^= s1 << 23;
        self.rng = [s0, s1 ^ s0 ^ (s1 >> 17) ^ (s0 >> 26)];
        (r >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Program output produced since the last call (`SEND`, program `CMD` replies).
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.output)
    }
}
