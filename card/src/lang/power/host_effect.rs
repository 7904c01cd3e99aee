//! A host's `save` or `$$$` on a Power card: the effect (the image to write, the saved image
//! to load) and the thread's replies, chosen once the card's runtime has performed it off the
//! servo thread. The host's next line runs after it (a `$$$` then `P1` reads the saved P1).

use super::exec::{frame, render};
use super::parse::SyntaxError;
use super::{Power, Thread};
use crate::domain::PowerErr;
use crate::lang::{Card, Effect};

/// \[DECISION\] The error a `save` that could not be written answers: the Power number of
/// the PMAC dialect's failed SAVE (ERR003 → error #21, as `exec::from_pmac` maps it; the
/// seed has no error for a failed flash write). The reason is in the card's log.
pub(crate) const SAVE_FAILED: PowerErr = PowerErr::IllegalParameter;

/// An effect a host line waits for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct PowerWait {
    /// What to perform.
    pub(crate) effect: Effect,
    /// The thread's reply once it is done.
    pub(crate) ok: Vec<u8>,
    /// The thread's reply when it failed (a `save` not written).
    pub(crate) failed: Vec<u8>,
    /// The refusal `failed` reports.
    pub(crate) refusal: Option<PowerErr>,
}

impl PowerWait {
    /// `save` on thread `th` (its line counted): write the card's image.
    pub(crate) fn save(card: &mut Card, th: &Thread, line: &[u8]) -> Self {
        let e = SyntaxError {
            at: 0,
            code: SAVE_FAILED,
        };
        PowerWait {
            effect: Effect::Save(card.view().save_image()),
            ok: frame(th, line, None),
            failed: render(th, line, Some(e)),
            refusal: Some(SAVE_FAILED),
        }
    }

    /// `$$$`: reload the saved image (no reply either way, seed §2.7; a refused image gives
    /// factory defaults and is reported as the card's load error).
    pub(crate) fn reset() -> Self {
        PowerWait {
            effect: Effect::Load,
            ok: Vec::new(),
            failed: Vec::new(),
            refusal: None,
        }
    }
}

impl Power {
    /// [`Power::line`] for a host connection: a `save` or `$$$` on it is not performed here
    /// but handed back, for the caller to perform and answer with [`PowerWait::ok`] or
    /// [`PowerWait::failed`] before the connection's next line.
    pub(crate) fn host_line(
        &mut self,
        card: &mut Card,
        conn: u64,
        line: &[u8],
    ) -> (Vec<u8>, Option<PowerErr>, Option<PowerWait>) {
        self.host = true;
        self.wait = None;
        let (out, refusal) = self.line_refused(card, conn, line);
        self.host = false;
        (out, refusal, self.wait.take())
    }
}
