//! Status words of [`CardState`]: `?` (motor), `??` (C.S.), `???` (global) as words and as
//! reply text (pmac-commands §4).

use super::card_state::CardState;
use super::number::format_status_words;
use super::status::MotorSetup;
use crate::domain::profile::Profile;

impl CardState {
    fn motor_setup(&self, x: u16) -> MotorSetup {
        let i = |nn: u32| self.vars.i(100 * x as u32 + nn).unwrap_or(0.0) != 0.0;
        MotorSetup {
            activated: i(0),
            handwheel: i(6),
            phased: i(1),
            integration_mode: i(34),
        }
    }

    /// `?` words of motor `x` (1-based; out-of-range motors read as zero words).
    pub fn motor_status(&self, x: u16) -> [u32; 2] {
        match x.checked_sub(1).and_then(|k| self.motors.get(k as usize)) {
            Some(f) if self.profile() == Profile::Turbo => {
                [f.turbo_word1(self.motor_setup(x)), f.turbo_word2()]
            }
            Some(f) => [f.word1(self.motor_setup(x)), f.word2()],
            None => [0, 0],
        }
    }

    pub(super) fn cs_words(&self, x: u16) -> [u32; 2] {
        match x.checked_sub(1).and_then(|k| self.coords.get(k as usize)) {
            Some(f) => [f.word1(), f.word2()],
            None => [0, 0],
        }
    }

    /// `??` words of C.S. `x`: two words on PMAC2, three on Turbo (third word all clear).
    pub fn cs_status(&self, x: u16) -> Vec<u32> {
        let [a, b] = self.cs_words(x);
        if self.limits().cs_status_digits == 18 {
            vec![a, b, 0]
        } else {
            vec![a, b]
        }
    }

    /// `???` words.
    pub fn global_status(&self) -> [u32; 2] {
        [self.global.word1(), self.global.word2()]
    }

    /// `?` reply text of motor `x`: 12 hex digits.
    pub fn motor_status_text(&self, x: u16) -> String {
        format_status_words(&self.motor_status(x))
    }

    /// `??` reply text of C.S. `x`: 12 hex digits (PMAC2) or 18 (Turbo).
    pub fn cs_status_text(&self, x: u16) -> String {
        format_status_words(&self.cs_status(x))
    }

    /// `???` reply text: 12 hex digits.
    pub fn global_status_text(&self) -> String {
        format_status_words(&self.global_status())
    }
}
