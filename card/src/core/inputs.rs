//! The card's discrete hardware inputs that stop motion (issue 23 item 3): a typed input of
//! the card core, pure — the ring application sets and clears it with the ring cycle, the
//! core looks at it once per servo tick ([`CardInputs::before_tick`]).
//!
//! PMAC2 and Turbo (seed 004): the control-panel port (JPAN) inputs, Y:$FFC0 bit 13 STOP/
//! (Stop/Abort, J2-10, `M25`) and bit 15 HOLD/ (Feed Hold, J2-12, `M27`), active when I2 = 0
//! (L1382-1390; with I2 ≠ 0 they are general-purpose inputs and the card does nothing with
//! them). They act on the coordinate system selected by the BCD lines FPD0/-FPD3/ (bits 16-19,
//! `M32`). Stop/Abort does what the `A` command does for that C.S. (L7200-7222): its motors
//! decelerate at Ix15 (motor `?` bit 12 *Abort Deceleration* while they do, L6805), its program
//! is aborted (`??` program-running clear), killed or open-loop motors of the C.S. are closed
//! at zero velocity. Feed Hold does what `H` does (L8195-8210). \[DECISION\] the card acts on
//! the input's rising edge, as on a press of the panel button (a held input does not repeat
//! it, `R` runs again); the seed does not say what a select of 0 (no FPD line low) does: it
//! selects no C.S., and the inputs do nothing.
//!
//! Power (seed 000): the global abort input, bit `Sys.AbortAllBit` of the register
//! `Sys.pAbortAll` names (0, the default on a non-Brick card: no input, L20029-20040).
//! Every scan (here every servo cycle) the card counts `Sys.AbortAllCount` up while the bit
//! is 1 and down while it is 0; once the count exceeds `Sys.AbortAllLimit` every C.S. acts
//! per `Coord[x].AbortAllMode` (L3095-3130): 0 abort (closed-loop stop, as `abort`), 1 kill at
//! once (as `disable`), 2 abort, then each motor killed once its commanded velocity is zero
//! (`dkill`; no brake is modelled), 3 ignore. Motors in no C.S. follow `Coord[0]`.
//! \[DECISION\] the card acts once per activation; it acts again after the count has gone
//! back to 0. The injected input is wired to the bit the card watches.

use crate::domain::Profile;
use crate::domain::{CsNum, MotorNum};
use crate::lang::abort_all;
use crate::model::{Action, ActionKind, CardModel};

/// A hardware input the card has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputKind {
    /// Stop/Abort (PMAC2/Turbo JPAN STOP/; Power the global abort input).
    Abort,
    /// Feed Hold (PMAC2/Turbo JPAN HOLD/).
    FeedHold,
}

impl InputKind {
    /// Every kind, as `mcc fault CARD input KIND` spells it.
    pub const WORDS: &'static str = "abort, feed-hold";

    /// The kind `word` names.
    pub fn parse(word: &str) -> Result<InputKind, String> {
        match word {
            "abort" => Ok(InputKind::Abort),
            "feed-hold" => Ok(InputKind::FeedHold),
            w => Err(format!(
                "unknown card input {w:?} (one of: {})",
                InputKind::WORDS
            )),
        }
    }

    /// The word for this kind.
    pub fn word(self) -> &'static str {
        match self {
            InputKind::Abort => "abort",
            InputKind::FeedHold => "feed-hold",
        }
    }
}

/// One input held active.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeldInput {
    /// Which input.
    pub kind: InputKind,
    /// PMAC2/Turbo: the C.S. the FPD lines select (0: none). Power: unused.
    pub select: u16,
    /// The ring cycle it went active.
    pub since: u64,
    /// Released automatically at this cycle (`--cycles N`), else held until cleared.
    pub until: Option<u64>,
    /// The card has acted on this activation.
    pub acted: bool,
}

/// The card's stop inputs (see the module docs).
#[derive(Debug, Default, Clone)]
pub struct CardInputs {
    held: Vec<HeldInput>,
    /// Power `Sys.AbortAllCount`.
    abort_count: u32,
    /// Power: the card has acted on the present activation of the global abort input.
    abort_fired: bool,
}

impl CardInputs {
    /// Make `kind` active from `cycle` on (for `cycles` cycles, or until cleared) on a card
    /// of `profile` with `coords` coordinate systems; what was done, or why not.
    pub fn press(
        &mut self,
        profile: Profile,
        coords: u16,
        kind: InputKind,
        select: u16,
        cycle: u64,
        cycles: Option<u64>,
    ) -> Result<String, String> {
        if profile == Profile::Power && kind != InputKind::Abort {
            return Err(format!(
                "a Power card has no {} input (its stop input is the global abort: abort)",
                kind.word()
            ));
        }
        if profile != Profile::Power && select > coords {
            return Err(format!(
                "C.S. {select} cannot be selected on this card (FPD select 0..={coords}; 0 selects none)"
            ));
        }
        if cycles == Some(0) {
            return Err("--cycles must be at least 1 (omit it to hold until cleared)".into());
        }
        self.held.retain(|h| h.kind != kind);
        self.held.push(HeldInput {
            kind,
            select,
            since: cycle,
            until: cycles.map(|n| cycle.saturating_add(n)),
            acted: false,
        });
        let on = match profile {
            Profile::Power => "global abort input (Sys.AbortAllBit of Sys.pAbortAll)".to_string(),
            _ => format!("JPAN {} with FPD select {select}", jpan_pin(kind)),
        };
        let how = cycles.map_or("until cleared".to_string(), |n| format!("for {n} cycles"));
        Ok(format!(
            "input {} active from cycle {cycle} {how} ({on})",
            kind.word()
        ))
    }

    /// Release every input (`mcc fault clear`).
    pub fn clear(&mut self) {
        self.held.clear();
    }

    /// The inputs held now.
    pub fn held(&self) -> &[HeldInput] {
        &self.held
    }

    /// Power `Sys.AbortAllCount`.
    pub fn abort_count(&self) -> u32 {
        self.abort_count
    }

    /// Before the servo tick of `cycle`: release expired inputs and queue the actions the
    /// held ones cause.
    pub fn before_tick(&mut self, card: &mut CardModel, cycle: u64) {
        self.held.retain(|h| h.until.is_none_or(|u| cycle < u));
        if card.state.profile() == Profile::Power {
            self.power_scan(card);
            return;
        }
        let enabled = card.state.peek_ivar(2).unwrap_or(0.0) == 0.0;
        for h in self.held.iter_mut().filter(|h| !h.acted) {
            h.acted = true;
            if !enabled || h.select == 0 {
                continue;
            }
            let kind = match h.kind {
                InputKind::Abort => ActionKind::Abort,
                InputKind::FeedHold => ActionKind::Hold,
            };
            card.push_action(Action {
                motor: MotorNum::of(1),
                coord: CsNum::of(h.select),
                kind,
            });
        }
    }

    fn power_scan(&mut self, card: &mut CardModel) {
        let set = abort_all::setup(card);
        let seen = set.enabled && self.held.iter().any(|h| h.kind == InputKind::Abort);
        if seen {
            self.abort_count = self.abort_count.saturating_add(1).min(set.limit + 1);
        } else {
            self.abort_count = self.abort_count.saturating_sub(1);
        }
        if self.abort_count == 0 {
            self.abort_fired = false;
        }
        if !seen || self.abort_fired || self.abort_count <= set.limit {
            return;
        }
        self.abort_fired = true;
        let motors = card.state.limits().motors;
        for (x, &mode) in set.modes.iter().enumerate() {
            let x = x as u16;
            let members: Vec<u16> = if x == 0 {
                (1..=motors)
                    .filter(|&m| card.run.cs_of(m).is_none())
                    .collect()
            } else {
                card.run.motors_in(x)
            };
            match mode {
                0 | 2 => {
                    if x > 0 && x <= card.state.limits().coords {
                        card.push_action(Action {
                            motor: MotorNum::of(1),
                            coord: CsNum::of(x),
                            kind: ActionKind::Abort,
                        });
                    } else {
                        for &m in &members {
                            card.push_action(Action {
                                motor: MotorNum::of(m),
                                coord: CsNum::of(0),
                                kind: ActionKind::AbortMotor,
                            });
                        }
                    }
                    if mode == 2 {
                        // Killed by the servo loop once their deceleration is over.
                        for &m in &members {
                            if let Some(r) = card.run.motors.get_mut(usize::from(m.max(1) - 1)) {
                                r.disable_at_rest = true;
                            }
                        }
                    }
                }
                1 => {
                    if x > 0 && x <= card.state.limits().coords {
                        // The program stops with its motors (the kills follow at once).
                        card.push_action(Action {
                            motor: MotorNum::of(1),
                            coord: CsNum::of(x),
                            kind: ActionKind::Abort,
                        });
                    }
                    for &m in &members {
                        card.push_action(Action {
                            motor: MotorNum::of(m),
                            coord: CsNum::of(x),
                            kind: ActionKind::Kill,
                        });
                    }
                }
                _ => {}
            }
        }
    }

    /// The inputs for the card's status entry (`mcc status --json` members[].extra.inputs).
    pub fn status(&self, profile: Profile) -> serde_json::Value {
        let held: Vec<serde_json::Value> = self
            .held
            .iter()
            .map(|h| {
                let mut o = serde_json::json!({
                    "kind": h.kind.word(),
                    "since": h.since,
                    "until": h.until,
                });
                if profile != Profile::Power {
                    o["select"] = serde_json::json!(h.select);
                }
                o
            })
            .collect();
        let mut o = serde_json::json!({ "held": held });
        if profile == Profile::Power {
            o["abort_all_count"] = serde_json::json!(self.abort_count);
        }
        o
    }
}

/// The JPAN pin of a PMAC2/Turbo input (seed 004 L15420-15440).
fn jpan_pin(kind: InputKind) -> &'static str {
    match kind {
        InputKind::Abort => "STOP/ (J2-10, Y:$FFC0 bit 13)",
        InputKind::FeedHold => "HOLD/ (J2-12, Y:$FFC0 bit 15)",
    }
}
