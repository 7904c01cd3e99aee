//! The stand-alone EMCL program (spec emcl.md §6): application state, program counter,
//! accumulator, X register, flags, the 8-deep subroutine stack and WAIT, and the interpreter
//! that runs at most one instruction per 1 ms tick (D: §6.4). The program memory itself is
//! in the EEPROM image.
//!
//! Decisions: a WAIT holds its tick; when its condition is met (or its timeout expires, which
//! sets ETO) the program counter moves on and the next instruction runs in the next tick.
//! STOP leaves the PC on the STOP instruction. An instruction that would give an error
//! status in direct mode is a no-op (§6.7), and so are the host-control instructions
//! 128..=137 and a jump to an address outside 0..=2047. Running past slot 2047 stops the
//! program.
//!
//! \[DECISION\] Single-stepping (130): every accepted step is one instruction, however many
//! arrive within one tick (they are counted, not merged); a WAIT is one instruction and holds
//! its step until it ends. At most [`STEP_QUEUE`] steps wait; one more is answered with
//! status 6 (not available) and changes nothing. Stop, run and reset drop the steps not taken.

use std::cmp::Ordering;

use super::codec::Instr;
use super::drive::{Ctx, Drive};
use super::eeprom::PROGRAM_SLOTS;

/// Subroutine stack depth (§6.2, \[L1006\]).
pub const STACK_DEPTH: usize = 8;
/// Steps (130) a drive holds at once; one more is refused with status 6 (see
/// [`Program::grant_step`]).
pub const STEP_QUEUE: u16 = 256;
/// One WAIT tick, ms (\[L1108\]).
pub const WAIT_TICK_MS: u64 = 10;

/// Application status (GP 128, instruction 135).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AppState {
    /// Stopped.
    #[default]
    Stop = 0,
    /// Running.
    Run = 1,
    /// Single-stepping (130).
    Step = 2,
    /// Reset (131): PC 0, not running.
    Reset = 3,
}

impl AppState {
    /// The status word used by `mcc status`.
    pub fn name(self) -> &'static str {
        match self {
            AppState::Stop => "stop",
            AppState::Run => "run",
            AppState::Step => "step",
            AppState::Reset => "reset",
        }
    }
}

/// What a WAIT waits for (type field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaitKind {
    /// 0: a number of 10 ms ticks.
    Ticks,
    /// 1: target position reached.
    Pos,
    /// 2: reference (home) switch.
    RefSw,
    /// 3: a limit switch.
    LimSw,
    /// 4: reference search finished.
    Rfs,
}

/// A WAIT in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wait {
    /// Condition.
    pub kind: WaitKind,
    /// ms at which it ends (TICKS) or times out (others); None = no timeout.
    pub until_ms: Option<u64>,
}

/// Interpreter flags (§6.2–6.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// Zero flag: the last accumulator write was 0, or the last COMP found equality.
    pub zero: bool,
    /// Result of the last COMP (accumulator vs value, signed).
    pub cmp: Option<Ordering>,
    /// Timeout flag (a WAIT timed out).
    pub eto: bool,
    /// Deviation flag (POS_ERROR raised).
    pub edv: bool,
}

/// Program registers and run state.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Program {
    /// Application state.
    pub state: AppState,
    /// Program counter (GP 130).
    pub pc: u16,
    /// Accumulator.
    pub accu: i32,
    /// X register.
    pub x: i32,
    /// Return addresses.
    pub stack: Vec<u16>,
    /// Flags.
    pub flags: Flags,
    /// WAIT in progress.
    pub wait: Option<Wait>,
    /// 130: steps granted and not yet taken (each one instruction; at most [`STEP_QUEUE`]).
    pub steps_pending: u16,
    /// Instructions executed since power-up.
    pub executed: u64,
}

impl Program {
    /// 129 type 1 / autostart: run from `pc`.
    pub fn start_at(&mut self, pc: u16) {
        self.pc = pc;
        self.stack.clear();
        self.wait = None;
        self.steps_pending = 0;
        self.state = AppState::Run;
    }

    /// 128: stop (the PC stays; a WAIT in progress is abandoned and runs again on continue).
    pub fn stop(&mut self) {
        self.state = AppState::Stop;
        self.wait = None;
        self.steps_pending = 0;
    }

    /// 130: enter single-step mode and grant one more instruction; false (nothing granted)
    /// when [`STEP_QUEUE`] steps are already waiting.
    pub fn grant_step(&mut self) -> bool {
        if self.steps_pending >= STEP_QUEUE {
            return false;
        }
        self.state = AppState::Step;
        self.steps_pending += 1;
        true
    }

    /// 131: PC 0, stack and WAIT cleared, not running.
    pub fn reset(&mut self) {
        self.pc = 0;
        self.stack.clear();
        self.wait = None;
        self.flags = Flags::default();
        self.steps_pending = 0;
        self.state = AppState::Reset;
    }

    /// Write the accumulator (sets Z).
    pub fn load(&mut self, v: i32) {
        self.accu = v;
        self.flags.zero = v == 0;
    }
}

impl Drive {
    /// One interpreter tick: one instruction, or one check of a WAIT.
    pub(crate) fn program_tick(&mut self) {
        let stepping = match self.prog.state {
            AppState::Run => false,
            AppState::Step if self.prog.steps_pending > 0 => true,
            _ => return,
        };
        self.program_instr_tick();
        // A step is taken when its instruction is done: a WAIT holds it until the wait ends.
        if stepping && self.prog.wait.is_none() {
            self.prog.steps_pending = self.prog.steps_pending.saturating_sub(1);
        }
    }

    /// One instruction, or one check of the WAIT in progress.
    fn program_instr_tick(&mut self) {
        if let Some(w) = self.prog.wait {
            let met = self.wait_met(w.kind, w.until_ms);
            let timed_out =
                w.kind != WaitKind::Ticks && w.until_ms.is_some_and(|t| self.now_ms >= t);
            if met || timed_out {
                if !met {
                    self.prog.flags.eto = true;
                }
                self.prog.wait = None;
                self.advance_pc();
            }
            return;
        }
        let pc = usize::from(self.prog.pc);
        if pc >= PROGRAM_SLOTS {
            self.prog.stop();
            return;
        }
        let i = self.eeprom.slot(pc);
        self.prog.executed += 1;
        self.execute_program_instr(i);
    }

    fn advance_pc(&mut self) {
        self.prog.pc = self.prog.pc.saturating_add(1);
        if usize::from(self.prog.pc) >= PROGRAM_SLOTS {
            self.prog.pc = (PROGRAM_SLOTS - 1) as u16;
            self.prog.stop();
        }
    }

    fn jump(&mut self, to: i32) {
        match u16::try_from(to) {
            Ok(a) if usize::from(a) < PROGRAM_SLOTS => self.prog.pc = a,
            _ => self.advance_pc(),
        }
    }

    fn execute_program_instr(&mut self, i: Instr) {
        match i.op {
            20 => {
                // COMP: Z and the ordering flags from accu vs value (signed).
                let ord = self.prog.accu.cmp(&i.value);
                self.prog.flags.cmp = Some(ord);
                self.prog.flags.zero = ord == Ordering::Equal;
                self.advance_pc();
            }
            21 => {
                if self.condition(i.typ) {
                    self.jump(i.value);
                } else {
                    self.advance_pc();
                }
            }
            22 => self.jump(i.value),
            23 => {
                let valid = (0..PROGRAM_SLOTS as i32).contains(&i.value);
                if valid && self.prog.stack.len() < STACK_DEPTH {
                    self.prog.stack.push(self.prog.pc.saturating_add(1));
                    self.jump(i.value);
                } else {
                    // Stack full (or a bad address): ignored [L1006].
                    self.advance_pc();
                }
            }
            24 => match self.prog.stack.pop() {
                Some(ret) if usize::from(ret) < PROGRAM_SLOTS => self.prog.pc = ret,
                Some(_) => self.prog.stop(),
                None => self.advance_pc(),
            },
            27 => self.start_wait(i),
            28 => self.prog.stop(),
            36 => {
                match i.typ {
                    0 => {
                        self.prog.flags.eto = false;
                        self.prog.flags.edv = false;
                    }
                    1 => self.prog.flags.eto = false,
                    3 => self.prog.flags.edv = false,
                    2 | 4 => {}
                    _ => {}
                }
                self.advance_pc();
            }
            op if op >= 128 => self.advance_pc(),
            _ => {
                // Everything else runs as in direct mode; an error makes it a no-op (§6.7).
                let _ = self.exec(i, Ctx::Program);
                self.advance_pc();
            }
        }
    }

    /// JC conditions 0..=8; EAL/EDV/EPO have no number (types > 8 read as false).
    fn condition(&self, typ: u8) -> bool {
        let f = self.prog.flags;
        let c = f.cmp;
        match typ {
            0 => f.zero,
            1 => !f.zero,
            2 => c == Some(Ordering::Equal),
            3 => c.is_some_and(|o| o != Ordering::Equal),
            4 => c == Some(Ordering::Greater),
            5 => matches!(c, Some(Ordering::Greater | Ordering::Equal)),
            6 => c == Some(Ordering::Less),
            7 => matches!(c, Some(Ordering::Less | Ordering::Equal)),
            8 => f.eto,
            _ => false,
        }
    }

    fn start_wait(&mut self, i: Instr) {
        let kind = match i.typ {
            0 => WaitKind::Ticks,
            1 => WaitKind::Pos,
            2 => WaitKind::RefSw,
            3 => WaitKind::LimSw,
            4 => WaitKind::Rfs,
            _ => {
                self.advance_pc();
                return;
            }
        };
        if kind != WaitKind::Ticks && i.motor != 0 {
            self.advance_pc();
            return;
        }
        let ticks = u64::try_from(i.value).unwrap_or(0);
        let until_ms = match kind {
            WaitKind::Ticks => Some(self.now_ms + ticks * WAIT_TICK_MS),
            _ if ticks == 0 => None,
            _ => Some(self.now_ms + ticks * WAIT_TICK_MS),
        };
        if kind == WaitKind::Ticks && ticks == 0 {
            self.advance_pc();
            return;
        }
        self.prog.wait = Some(Wait { kind, until_ms });
    }

    fn wait_met(&self, kind: WaitKind, until_ms: Option<u64>) -> bool {
        match kind {
            WaitKind::Ticks => until_ms.is_none_or(|t| self.now_ms >= t),
            WaitKind::Pos => self.target_reached(),
            WaitKind::RefSw => self.home_active(),
            WaitKind::LimSw => self.right_limit_active() || self.left_limit_active(),
            WaitKind::Rfs => self.rfs.is_none(),
        }
    }
}
