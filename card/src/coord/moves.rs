//! Modal move state of a coordinate system and the move-time rules (pmac-commands.md §5.3.2-
//! §5.3.8, pmac-variables §5.4, §5.5).
//!
//! * LINEAR/CIRCLE: T = (vector length over the feedrate axes) / F × Ix90, or TM; limited to
//!   [1, 2^23] ms and at least TA' = max(round(TA), 2·round(TS)); with I13 = 0 slowed so no
//!   motor exceeds Ix16, and TA' lengthened so no motor's corner Δv/TA' exceeds Ix17.
//! * RAPID: per motor a jog-style profile at Ix16 (I50=1) or Ix22, accel Ix19-Ix21; the motor
//!   needing the longest time sets one common profile (straight path).
//! * PVT: Hermite cubic per segment, velocities in units per Ix90 ms.

use nalgebra::DMatrix;

use super::axes::AxisVec;
use super::CoordError;

/// Move mode (LINEAR after reset).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// `LINEAR`
    Linear,
    /// `RAPID`
    Rapid,
    /// `CIRCLE1` (clockwise about the normal)
    Circle1,
    /// `CIRCLE2`
    Circle2,
    /// `PVT{t}`
    Pvt,
    /// `SPLINE1` (and `SPLINE2`, executed as SPLINE1)
    Spline1,
}

/// Feedrate or move-time mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feed {
    /// `F`: vector speed, user units per Ix90 ms.
    Rate(f64),
    /// `TM`: move time, ms.
    Time(f64),
}

/// Per-motor limits used by move planning and abort.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorLimits {
    /// Ix15 abort/limit deceleration, counts/ms².
    pub ix15: f64,
    /// Ix16 max program velocity, counts/ms.
    pub ix16: f64,
    /// Ix17 max program acceleration, counts/ms².
    pub ix17: f64,
    /// Ix19 max jog acceleration, counts/ms².
    pub ix19: f64,
    /// Ix20 jog accel time, ms.
    pub ix20: f64,
    /// Ix21 jog S-curve time, ms.
    pub ix21: f64,
    /// Ix22 jog speed, counts/ms.
    pub ix22: f64,
}

impl Default for MotorLimits {
    fn default() -> Self {
        MotorLimits {
            ix15: 0.25,
            ix16: 32.0,
            ix17: 0.5,
            ix19: 0.25,
            ix20: 0.0,
            ix21: 50.0,
            ix22: 32.0,
        }
    }
}

/// Coordinate-system setup read from I-variables (seed defaults in `Default`).
#[derive(Debug, Clone, PartialEq)]
pub struct CsConfig {
    /// Ix87 default TA (ms).
    pub ix87: f64,
    /// Ix88 default TS (ms).
    pub ix88: f64,
    /// Ix89 default feedrate.
    pub ix89: f64,
    /// Ix90 feedrate time unit (ms).
    pub ix90: f64,
    /// Ix92 = 1: no blending.
    pub ix92: bool,
    /// Ix94 time-base slew.
    pub ix94: f64,
    /// Ix95 feed-hold slew.
    pub ix95: f64,
    /// Ix96 circle error limit.
    pub ix96: f64,
    /// Ix98 maximum feedrate (0 = none).
    pub ix98: f64,
    /// I10 servo period (2^-23 ms).
    pub i10: f64,
    /// I13 segmentation time (0: CIRCLE runs as LINEAR; Ix16/Ix17 enforced).
    pub i13: f64,
    /// I50 = 1: RAPID at Ix16, else Ix22.
    pub i50: bool,
    /// I90 minimum arc angle (semicircles; 0 = 2^-20).
    pub i90: f64,
    /// Power `Coord[x].Td`: the final deceleration time at power-up (`None`: TA, as PMAC).
    pub td: Option<f64>,
    /// Power `Coord[x].Tm` (legacy Isx89): < 0 a feedrate of its magnitude (seed 000
    /// L5124-5135). `None`: PMAC, where Ix89 is the default feedrate.
    pub tm: Option<f64>,
    /// Limits of the C.S. motors (same order as the C.S. motor list; missing = defaults).
    pub motors: Vec<MotorLimits>,
}

impl Default for CsConfig {
    fn default() -> Self {
        CsConfig {
            ix87: 0.0,
            ix88: 50.0,
            ix89: 1000.0,
            ix90: 1000.0,
            ix92: false,
            ix94: 1644.0,
            ix95: 1644.0,
            ix96: 0.0,
            ix98: 0.0,
            i10: 3_713_707.0,
            i13: 0.0,
            i50: true,
            i90: 0.0,
            td: None,
            tm: None,
            motors: Vec::new(),
        }
    }
}

impl CsConfig {
    /// Limits of the motor at row `r`.
    pub fn limits(&self, r: usize) -> MotorLimits {
        self.motors.get(r).copied().unwrap_or_default()
    }
}

/// Modal state set by program statements.
#[derive(Debug, Clone, PartialEq)]
pub struct Modal {
    /// Move mode.
    pub mode: Mode,
    /// TA as programmed (ms, unrounded).
    pub ta: f64,
    /// TS as programmed (ms, unrounded).
    pub ts: f64,
    /// F or TM.
    pub feed: Feed,
    /// PVT segment time (ms).
    pub pvt_time: f64,
    /// SPLINE segment time (ms; PMAC: TA, Power: `spline{t}`).
    pub spline_time: f64,
    /// Power `td`: the final deceleration time of blended moves (ms); `None`: TA (PMAC, and
    /// Power after `ta`, which sets `Coord[x].Td` too).
    pub td: Option<f64>,
    /// Axes in INC mode (X..W).
    pub inc: [bool; 9],
    /// `ABS(R)`: circle centre vector from the origin.
    pub centre_abs: bool,
    /// Feedrate axes (FRAX), default X Y Z.
    pub frax: [bool; 9],
    /// NORMAL vector.
    pub normal: [f64; 3],
    /// Cutter radius compensation: 0 off (`CC0`), 1 left (`CC1`), 2 right (`CC2`). Only the
    /// `??` bits follow it (word 2 bits 2-3, seed 004 7006-7008); the path is not offset.
    pub cutter: u8,
}

fn positive(v: f64, what: &'static str) -> Result<f64, CoordError> {
    if v.is_finite() && v > 0.0 && v <= 8_388_608.0 * 1e6 {
        Ok(v)
    } else {
        Err(CoordError::BadTime(what))
    }
}

fn non_negative(v: f64, what: &'static str) -> Result<f64, CoordError> {
    if (0.0..=8_388_607.0).contains(&v) {
        Ok(v)
    } else {
        Err(CoordError::BadTime(what))
    }
}

impl Modal {
    /// State after power-up/reset (§5.11): LINEAR, ABS, F = Ix89, TA = Ix87, TS = Ix88.
    pub fn new(cfg: &CsConfig) -> Self {
        let clean = |v: f64, d: f64| if v.is_finite() && v >= 0.0 { v } else { d };
        Modal {
            mode: Mode::Linear,
            ta: clean(cfg.ix87, 0.0),
            ts: clean(cfg.ix88, 50.0),
            // Power `Coord[x].Tm` (seed 000 L5113-5135): negative, a feedrate of its
            // magnitude (default -1); positive, a move time in ms.
            feed: match cfg.tm {
                Some(tm) if tm.is_finite() && tm < 0.0 => Feed::Rate(-tm),
                Some(tm) if tm.is_finite() && tm > 0.0 => Feed::Time(tm),
                _ => Feed::Rate(if cfg.ix89.is_finite() && cfg.ix89 > 0.0 {
                    cfg.ix89
                } else {
                    1000.0
                }),
            },
            pvt_time: clean(cfg.ix87, 0.0),
            spline_time: clean(cfg.ix87, 0.0),
            td: cfg.td.filter(|v| v.is_finite() && *v >= 0.0),
            inc: [false; 9],
            centre_abs: false,
            frax: [true, true, true, false, false, false, false, false, false],
            normal: [0.0, 0.0, -1.0],
            cutter: 0,
        }
    }

    /// `TA{v}` (also the PVT and SPLINE segment times, and the final deceleration).
    pub fn set_ta(&mut self, v: f64) -> Result<(), CoordError> {
        self.set_ta_only(v)?;
        self.pvt_time = self.ta;
        self.spline_time = self.ta;
        Ok(())
    }

    /// Power `ta{v}`: the accel and final decel times; the PVT and SPLINE segment times are
    /// left alone (seed L43355-43356, L43986-43987: Power sets them only with `pvt`/`spline`).
    pub fn set_ta_only(&mut self, v: f64) -> Result<(), CoordError> {
        self.ta = non_negative(v, "TA")?;
        self.td = None;
        Ok(())
    }

    /// Power `td{v}`: the final deceleration time (≥ 0; 0 with TS 0 is a step, seed L44490).
    pub fn set_td(&mut self, v: f64) -> Result<(), CoordError> {
        self.td = Some(non_negative(v, "TD")?);
        Ok(())
    }

    /// Power `spline{t}`: SPLINE mode with segment time t ms (rounded, ≥ 1).
    pub fn set_spline(&mut self, t: f64) -> Result<(), CoordError> {
        let t = positive(t, "SPLINE time")?.round();
        if !(1.0..=8_388_607.0).contains(&t) {
            return Err(CoordError::BadTime("SPLINE time"));
        }
        self.spline_time = t;
        self.mode = Mode::Spline1;
        Ok(())
    }

    /// `TS{v}`.
    pub fn set_ts(&mut self, v: f64) -> Result<(), CoordError> {
        self.ts = non_negative(v, "TS")?;
        Ok(())
    }

    /// `F{v}` (> 0).
    pub fn set_f(&mut self, v: f64) -> Result<(), CoordError> {
        self.feed = Feed::Rate(positive(v, "F")?);
        Ok(())
    }

    /// `TM{v}` (> 0).
    pub fn set_tm(&mut self, v: f64) -> Result<(), CoordError> {
        self.feed = Feed::Time(positive(v, "TM")?);
        Ok(())
    }

    /// `PVT{t}`: PVT mode with segment time t ms (rounded, ≥ 1).
    pub fn set_pvt(&mut self, t: f64) -> Result<(), CoordError> {
        let t = positive(t, "PVT time")?.round();
        if t < 1.0 {
            return Err(CoordError::BadTime("PVT time"));
        }
        self.pvt_time = t;
        self.mode = Mode::Pvt;
        Ok(())
    }

    /// Effective final deceleration time TD' (ms) and its S fraction, given the accel time
    /// TA' and S fraction in use: with no `td`, those; else TD' = max(TD, 2·TS) rounded as
    /// TA' is, which may be 0 (a step to rest).
    pub fn decel(&self, tap: f64, s: f64) -> (f64, f64) {
        match self.td {
            None => (tap, s),
            Some(td) => {
                let ts = self.ts.round();
                let tdp = td.round().max(2.0 * ts);
                (tdp, if tdp > 0.0 { ts / tdp } else { 0.0 })
            }
        }
    }

    /// `NORMAL` vector (must be finite and non-zero).
    pub fn set_normal(&mut self, n: [f64; 3]) -> Result<(), CoordError> {
        let len2: f64 = n.iter().map(|v| v * v).sum();
        if !len2.is_finite() || len2 < 1e-24 {
            return Err(CoordError::OutOfRange("NORMAL vector"));
        }
        self.normal = n;
        Ok(())
    }

    /// Effective accel time TA' (ms) and S fraction: TA, TS rounded to whole ms;
    /// TA' = max(TA, 2·TS); zero → [`CoordError::ZeroAccelTime`].
    pub fn accel(&self) -> Result<(f64, f64), CoordError> {
        let ta = self.ta.round();
        let ts = self.ts.round();
        let tap = ta.max(2.0 * ts);
        if tap < 1.0 {
            return Err(CoordError::ZeroAccelTime);
        }
        Ok((tap, ts / tap))
    }
}

/// Move time (ms) of a LINEAR/CIRCLE move with displacement `d` (program units) and path
/// length `arc` of the XYZ part (`None`: straight), before the TA' minimum.
pub(crate) fn feed_time(modal: &Modal, cfg: &CsConfig, d: &AxisVec, arc: Option<f64>) -> f64 {
    let t = match modal.feed {
        Feed::Time(tm) => tm,
        Feed::Rate(f) => {
            let f = if cfg.ix98 > 0.0 { f.min(cfg.ix98) } else { f };
            let mut l2 = 0.0;
            for k in 0..9 {
                let in_arc = arc.is_some() && k < 3;
                if modal.frax[k] && !in_arc {
                    l2 += d[k] * d[k];
                }
            }
            if let Some(a) = arc {
                l2 += a * a;
            }
            let l = if l2 > 0.0 { l2.sqrt() } else { d.amax() };
            l / f * if cfg.ix90 > 0.0 { cfg.ix90 } else { 1000.0 }
        }
    };
    t.clamp(1.0, 8_388_608.0)
}

/// With I13 = 0: the time needed so no motor exceeds Ix16 for motor displacement `dm`.
pub(crate) fn ix16_time(cfg: &CsConfig, dm: &[f64]) -> f64 {
    let mut t: f64 = 0.0;
    for (r, d) in dm.iter().enumerate() {
        let v = cfg.limits(r).ix16;
        if v > 0.0 && v.is_finite() {
            t = t.max(d.abs() / v);
        }
    }
    t
}

/// With I13 = 0: TA' long enough that no motor's corner Δv/TA' exceeds Ix17.
pub(crate) fn ix17_accel(cfg: &CsConfig, dv_motor: &[f64], tap: f64) -> f64 {
    let mut t = tap;
    for (r, dv) in dv_motor.iter().enumerate() {
        let a = cfg.limits(r).ix17;
        if a > 0.0 && a.is_finite() {
            t = t.max(dv.abs() / a);
        }
    }
    t.min(8_388_607.0)
}

/// Motor-space image of a base-space vector.
pub(crate) fn to_motor(scale: &DMatrix<f64>, v: &AxisVec) -> Vec<f64> {
    (scale * v).iter().copied().collect()
}
