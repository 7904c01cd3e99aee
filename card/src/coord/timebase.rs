//! Time base / `%` feedrate override / feed hold (pmac-variables §5.1).
//!
//! Units as on the card: the time base TB is in 2^-23 ms per servo cycle, so each servo cycle
//! the trajectory clock advances TB / 2^23 ms; `%p` commands TB = p·I10/100, saturating at 2^23
//! (= 2^23/I10 × 100 %). The present TB slews at Ix94 per cycle, at Ix95 for `H` and for the
//! ramp back up after it.

/// 2^23.
pub(crate) const TWO23: f64 = 8_388_608.0;

/// Time base of one coordinate system.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeBase {
    /// I10: servo interrupt period in 2^-23 ms.
    pub i10: f64,
    /// Ix94 slew (2^-23 ms per cycle per cycle).
    pub ix94: f64,
    /// Ix95 feed-hold slew.
    pub ix95: f64,
    cmd: f64,
    present: f64,
    held: bool,
    recovering: bool,
    /// `\` program hold: slew per servo cycle from I52 (used for the stop and the restart).
    hold_slew: Option<f64>,
}

fn clean(v: f64, dflt: f64) -> f64 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        dflt
    }
}

impl TimeBase {
    /// Time base at %100 for servo period `i10` (I10 units) and slews Ix94/Ix95.
    pub fn new(i10: f64, ix94: f64, ix95: f64) -> Self {
        let i10 = clean(i10, 3_713_707.0).min(TWO23);
        TimeBase {
            i10,
            ix94: clean(ix94, 1644.0),
            ix95: clean(ix95, 1644.0),
            cmd: i10,
            present: i10,
            held: false,
            recovering: false,
            hold_slew: None,
        }
    }

    /// Real time of one servo cycle in ms (the fixed time base used by DWELL).
    pub fn servo_ms(&self) -> f64 {
        self.i10 / TWO23
    }

    /// New Ix94 / Ix95 slews (read live: a change applies from the next `%` or `R`).
    pub fn set_slews(&mut self, ix94: f64, ix95: f64) {
        self.ix94 = clean(ix94, self.ix94);
        self.ix95 = clean(ix95, self.ix95);
    }

    /// `%{p}`: commanded override in percent (negative/NaN → 0, saturates at 2^23/I10·100).
    pub fn set_percent(&mut self, p: f64) {
        let p = if p.is_finite() && p > 0.0 { p } else { 0.0 };
        self.cmd = (p * self.i10 / 100.0).min(TWO23);
    }

    /// `%` reply: the present time base in percent (0 during a completed hold).
    pub fn percent(&self) -> f64 {
        self.present * 100.0 / self.i10
    }

    /// `H` feed hold: ramp to 0 at Ix95.
    pub fn hold(&mut self) {
        self.held = true;
        self.recovering = false;
        self.hold_slew = None;
    }

    /// `\` program hold in a segmented move: ramp to 0 at `slew` (I52 converted to 2^-23 ms
    /// per servo cycle), and back up at the same rate on `R` (seed 1962-1972).
    pub fn program_hold(&mut self, slew: f64) {
        self.hold();
        self.hold_slew = Some(clean(slew, self.ix95));
    }

    /// `R`/`S` after `H`: ramp back up at Ix95, then Ix94 governs.
    pub fn release(&mut self) {
        if self.held {
            self.held = false;
            self.recovering = true;
        }
    }

    /// Whether a feed hold is in force.
    pub fn is_held(&self) -> bool {
        self.held
    }

    /// Advance one servo cycle; returns the trajectory time increment in ms.
    pub fn tick(&mut self) -> f64 {
        let target = if self.held { 0.0 } else { self.cmd };
        let slew = if self.held || self.recovering {
            self.hold_slew.unwrap_or(self.ix95)
        } else {
            self.ix94
        };
        let d = target - self.present;
        if d.abs() <= slew {
            self.present = target;
            if self.recovering {
                self.hold_slew = None;
            }
            self.recovering = false;
        } else {
            self.present += slew * d.signum();
        }
        self.present / TWO23
    }
}
