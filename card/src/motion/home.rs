//! Homing search and jog-until-trigger as a per-cycle state machine
//! (pmac-variables-servo-macro.md §5.3, pmac-commands §3.4.2 `{jog}^{d}`).
//!
//! MACRO flags come from the station once per ring cycle, so capture is "software capture": the
//! trigger position is the actual position of the first servo cycle in which the trigger input
//! (the home flag selected by Ix25, or the warning-following-error bit when Ix03 bit 17 = 1) is
//! seen true after the move was armed. Level-sensitive: a motor already sitting on its home flag
//! triggers at once.

/// What fires the trigger.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TriggerSource {
    /// The home flag of the Ix25 flag image (Ix03 bit 17 = 0).
    HomeFlag,
    /// The warning following-error bit (Ix03 bit 17 = 1, "torque-mode triggering").
    WarningFe,
}

impl TriggerSource {
    /// The source: the warning following error when `fe` (PMAC2 Ix03 bit 17, Turbo Ixx97
    /// bit 1), else the capture flag.
    pub(crate) fn new(fe: bool) -> Self {
        if fe {
            TriggerSource::WarningFe
        } else {
            TriggerSource::HomeFlag
        }
    }
}

/// The kind of triggered move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum TriggerKind {
    /// `HM`: the trigger position + Ix26/16 becomes motor zero.
    Home {
        /// Ix26/16, counts.
        offset: f64,
    },
    /// `{definite jog}^{d}`: stop `d` counts past the trigger.
    Jog {
        /// Distance past the trigger, counts.
        distance: f64,
    },
}

/// Phase of a triggered move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Moving, watching the trigger (software limits off for a home search).
    Search,
    /// Trigger found, moving to the post-trigger end point.
    PostTrigger,
}

/// A triggered move in progress.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TriggeredMove {
    /// Home or jog-until-trigger.
    pub kind: TriggerKind,
    /// Trigger input.
    pub source: TriggerSource,
    /// Where it is.
    pub phase: Phase,
}

/// What the motor must do when the trigger fires.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TriggerAction {
    /// Captured (actual) position, counts, in the motor's frame before re-referencing.
    pub capture: f64,
    /// For homing: the old-frame position that becomes the new zero.
    pub new_zero: Option<f64>,
    /// Post-trigger end point, in the frame after re-referencing.
    pub target: f64,
}

impl TriggeredMove {
    /// A home search armed with the Ix26 offset (1/16 count) and the Ix03 trigger source.
    pub(crate) fn home(ix26: f64, fe: bool) -> Self {
        TriggeredMove {
            kind: TriggerKind::Home {
                offset: ix26 / 16.0,
            },
            source: TriggerSource::new(fe),
            phase: Phase::Search,
        }
    }

    /// A jog-until-trigger armed with distance `d` counts.
    pub(crate) fn jog(distance: f64, fe: bool) -> Self {
        TriggeredMove {
            kind: TriggerKind::Jog { distance },
            source: TriggerSource::new(fe),
            phase: Phase::Search,
        }
    }

    /// True while searching for a home trigger (software limits are off then).
    pub(crate) fn is_home_search(&self) -> bool {
        matches!(self.kind, TriggerKind::Home { .. }) && self.phase == Phase::Search
    }

    /// One servo cycle: if searching and the selected input is true, switch to the
    /// post-trigger phase and return the action to take.
    pub(crate) fn on_cycle(
        &mut self,
        home_flag: bool,
        warning_fe: bool,
        actual: f64,
    ) -> Option<TriggerAction> {
        if self.phase != Phase::Search {
            return None;
        }
        let fired = match self.source {
            TriggerSource::HomeFlag => home_flag,
            TriggerSource::WarningFe => warning_fe,
        };
        if !fired {
            return None;
        }
        self.phase = Phase::PostTrigger;
        Some(match self.kind {
            TriggerKind::Home { offset } => TriggerAction {
                capture: actual,
                new_zero: Some(actual + offset),
                target: 0.0,
            },
            TriggerKind::Jog { distance } => TriggerAction {
                capture: actual,
                new_zero: None,
                target: actual + distance,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn home_trigger_sets_new_zero_with_offset() {
        let mut h = TriggeredMove::home(160.0, false);
        assert!(h.is_home_search());
        assert_eq!(
            h.on_cycle(false, true, 100.0),
            None,
            "warning FE is not the source"
        );
        let a = h.on_cycle(true, false, 1234.5).unwrap();
        assert_eq!(a.new_zero, Some(1244.5));
        assert_eq!(a.target, 0.0);
        assert!(!h.is_home_search());
        assert_eq!(h.on_cycle(true, false, 2000.0), None, "fires once");
    }

    #[test]
    fn jog_until_trigger_on_warning_fe() {
        let mut j = TriggeredMove::jog(-50.0, true);
        assert_eq!(j.source, TriggerSource::WarningFe);
        assert_eq!(j.on_cycle(true, false, 0.0), None);
        let a = j.on_cycle(false, true, 300.0).unwrap();
        assert_eq!((a.capture, a.target, a.new_zero), (300.0, 250.0, None));
    }
}
