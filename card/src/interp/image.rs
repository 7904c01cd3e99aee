//! What the interpreter contributes to `SAVE` (programs, PLCs, DEFINE'd buffers, axis
//! definitions) and the reset paths `$$$` / `$$$***` / start-up. File I/O goes through
//! `state::persist` (atomic write, checked load).

use serde::{Deserialize, Serialize};

use super::buffers::Buffers;
use super::progline::ProgLine;
use super::runstate::RunState;
use super::{Card, Profile};
use crate::lang::ast::AxisDef;
use crate::state::persist;

/// User buffer memory in words: $1800-$9FFF on PMAC2 (34,816); Turbo gets the same
/// budget scaled ×4 ([DECISION]: Turbo boards carry more program memory).
pub fn user_memory_words(profile: Profile) -> u32 {
    match profile {
        Profile::Pmac2 => 34_816,
        Profile::Turbo => 4 * 34_816,
    }
}

/// `???` word 1 bit 10: saved data bad, factory defaults used.
pub const EAROM_ERROR: u32 = 1 << 10;

/// INTERP's part of the saved image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InterpImage {
    /// Programs, PLCs, rotary and DEFINE'd buffers.
    pub bufs: Buffers<ProgLine>,
    /// Axis definitions per motor.
    pub axes: Vec<Option<(u16, AxisDef)>>,
}

impl Card {
    /// Serialize INTERP's saved part.
    pub(crate) fn interp_blob(&self) -> Vec<u8> {
        let img = InterpImage {
            bufs: self.bufs.clone(),
            axes: self.run.axes.clone(),
        };
        bincode::serde::encode_to_vec(&img, bincode::config::standard()).unwrap_or_default()
    }

    /// Restore INTERP's saved part (an undecodable blob leaves empty buffers).
    fn load_blob(&mut self, blob: &[u8]) {
        let lim = self.state.limits();
        self.run = RunState::new(lim.motors, lim.coords, 32);
        self.bufs = Buffers::new(user_memory_words(self.profile));
        if blob.is_empty() {
            return;
        }
        let cfg = bincode::config::standard().with_limit::<{ 64 << 20 }>();
        if let Ok((img, _)) = bincode::serde::decode_from_slice::<InterpImage, _>(blob, cfg) {
            let mut img: InterpImage = img;
            img.bufs.capacity = user_memory_words(self.profile);
            self.bufs = img.bufs;
            for (k, a) in img.axes.into_iter().enumerate().take(self.run.axes.len()) {
                self.run.axes[k] = a.filter(|(c, _)| *c >= 1 && *c <= lim.coords);
            }
        }
    }

    /// `SAVE`: write the image atomically. Returns false on an I/O failure (no file
    /// configured counts as success: nothing to write).
    pub(crate) fn save(&mut self) -> bool {
        let Some(path) = self.state_file.clone() else {
            return true;
        };
        let img = self.state.to_image(self.interp_blob());
        persist::save(&path, &img).is_ok()
    }

    /// `$$$` / start-up: reload the saved image (factory defaults without one).
    pub(crate) fn reset_from_file(&mut self) -> Result<(), persist::PersistError> {
        let loaded = match &self.state_file {
            Some(p) => persist::load(p),
            None => Ok(None),
        };
        let (image, mut result) = match loaded {
            Ok(img) => (img, Ok(())),
            Err(e) => (None, Err(e)),
        };
        let blob = match self.state.reset(image.as_ref()) {
            Ok(b) => b,
            Err(e) => {
                let _ = self.state.reset(None);
                result = Err(e);
                Vec::new()
            }
        };
        self.load_blob(&blob);
        self.after_reset();
        if result.is_err() {
            // Saved data bad: factory defaults in use (`???` word 1 bit 10, EAROM error).
            self.state.global.word1_other |= EAROM_ERROR;
        }
        result
    }

    /// Common tail of every reset: no open buffer, status coords (the resetting session's
    /// chain addressing goes back to card 0 in `exec_info`).
    fn after_reset(&mut self) {
        self.open = None;
        self.pending_table = None;
        self.actions.clear();
        self.resets += 1;
        self.sync_motor_coords();
        self.sync_global_flags();
    }

    /// `$$$***`: factory I-variables, programs and DEFINE'd buffers erased, password cleared;
    /// P/Q, M-definitions and axis definitions kept.
    pub(crate) fn reinit(&mut self) {
        self.state.factory();
        self.bufs = Buffers::new(user_memory_words(self.profile));
        self.open = None;
        self.pending_table = None;
        let lim = self.state.limits();
        let axes = std::mem::take(&mut self.run.axes);
        self.run = RunState::new(lim.motors, lim.coords, 32);
        self.run.axes = axes;
        self.push_action(super::Action {
            motor: 1,
            coord: 1,
            kind: super::ActionKind::Ctrl(0x0B),
        });
        self.resets += 1;
        self.sync_motor_coords();
        self.sync_global_flags();
    }

    /// Copy axis-definition membership into the motor status flags (`?` word 2 bits 23-20).
    pub(crate) fn sync_motor_coords(&mut self) {
        for (k, m) in self.state.motors.iter_mut().enumerate() {
            m.coord = self
                .run
                .axes
                .get(k)
                .and_then(|a| a.as_ref().map(|(c, _)| *c as u8));
        }
    }

    /// Buffer-open bits of the global status word.
    pub(crate) fn sync_global_flags(&mut self) {
        use super::buffers::BufId;
        let i18 = self.state.peek_ivar(18).unwrap_or(10.0);
        let nearly_full = (self.bufs.free() as f64) < i18;
        let g = &mut self.state.global;
        let id = self.open.map(|o| o.id);
        g.motion_buffer_open = matches!(id, Some(BufId::Prog(_)) | Some(BufId::Rot));
        g.rotary_open = matches!(id, Some(BufId::Rot));
        g.plc_open = matches!(id, Some(BufId::Plc(_)));
        g.binary_rotary = self.open.is_some_and(|o| o.binary);
        g.buffer_nearly_full = nearly_full;
    }
}
