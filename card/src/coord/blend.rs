//! The move queue of one coordinate system on the trajectory-time axis τ (ms), with PMAC
//! blending and look-ahead.
//!
//! Blended moves (LINEAR, CIRCLE, DELAY) have a nominal interval `[start, start+dur]` at
//! constant speed. At each boundary `c` the velocity changes over the accel time TA' of the
//! incoming move, in a window `[c−h, c+h]` (h = TA'/2) centred on the boundary, with the S-curve
//! shape of TS. Inside a window the position is
//! `p = Pa(τ) + 2h·G(u)·(Pb(τ) − Pa(τ))/(τ − c)`, u = (τ−c+h)/2h, where Pa, Pb are the two
//! moves extended beyond their intervals. For two lines this is exactly the integral of the
//! S-curve velocity change (so the corner is cut symmetrically and every point off the windows
//! is on the programmed path at its nominal time); position and velocity are continuous for any
//! pair of curves. Starting from rest and stopping are blends with a standing point, so a
//! single move lasts `dur + TA'`.
//!
//! Look-ahead: the executor keeps at least two moves queued beyond the executing one
//! ([`Timeline::wants_more`]). When a blend window is reached with no next move queued, the
//! move decelerates to a stop (as PMAC does when calculation falls behind or a `Q` ends it).

use std::collections::VecDeque;

use super::axes::AxisVec;
use super::prims::Prim;
use super::profile::Ramp;
use super::transform::Affine;
use super::CoordError;

/// Most pieces queued at once.
pub(crate) const MAX_PIECES: usize = 16;

/// How a piece connects to its neighbours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Kind {
    /// LINEAR / CIRCLE / DELAY: blended over `ta` ms (TA'), S fraction `s`; a stop at its
    /// end decelerates over `td` ms (TD', Power `td`), S fraction `sd`.
    Blend {
        /// Effective accel time TA' = max(TA, 2·TS) (ms).
        ta: f64,
        /// TS / TA'.
        s: f64,
        /// Effective final decel time (ms; TA' unless Power's `td` is in force).
        td: f64,
        /// TS / TD'.
        sd: f64,
    },
    /// PVT segment (contiguous, velocity given).
    Pvt,
    /// SPLINE1 segment (contiguous).
    Spline,
    /// RAPID (from rest to rest).
    Solo,
    /// DWELL (fixed time base, blocks look-ahead).
    Dwell,
}

/// How a piece ends.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Out {
    Undecided,
    Next { h: f64, s: f64 },
    Stop { h: f64, s: f64 },
}

/// A move placed on the time axis.
#[derive(Debug, Clone, PartialEq)]
struct Piece {
    id: u64,
    prim: Prim,
    start: f64,
    dur: f64,
    kind: Kind,
    h_in: f64,
    s_in: f64,
    from_rest: bool,
    out: Out,
    xf: Affine,
}

impl Piece {
    fn end(&self) -> f64 {
        self.start + self.dur
    }
    fn exec_start(&self) -> f64 {
        self.start - self.h_in
    }
    fn at(&self, tau: f64) -> (AxisVec, AxisVec) {
        let (p, v) = self.prim.eval(self.start, self.dur, tau);
        (self.xf.to_base(&p), self.xf.vel_to_base(&v))
    }
    fn stop_h(&self) -> f64 {
        match self.kind {
            Kind::Blend { td, .. } => (td / 2.0).min(self.dur / 2.0),
            _ => 0.0,
        }
    }
}

/// A new move for [`Timeline::push`] (program units, the transformation in force).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NewPiece {
    /// Path.
    pub prim: Prim,
    /// Nominal duration (ms, > 0).
    pub dur: f64,
    /// Connection kind.
    pub kind: Kind,
    /// Program → base transformation at calculation time.
    pub xf: Affine,
}

/// Blend `a` into `b` around boundary `c` with half window `h`.
fn blend(
    a: &dyn Fn(f64) -> (AxisVec, AxisVec),
    b: &dyn Fn(f64) -> (AxisVec, AxisVec),
    lines: bool,
    c: f64,
    h: f64,
    s: f64,
    tau: f64,
) -> AxisVec {
    if h <= 0.0 {
        return if tau < c { a(tau).0 } else { b(tau).0 };
    }
    let u = (tau - (c - h)) / (2.0 * h);
    let (pa, va) = a(tau);
    let (pb, vb) = b(tau);
    let dt = tau - c;
    let d = if lines {
        vb - va
    } else if dt.abs() < 1e-4 * h {
        b(c).1 - a(c).1
    } else {
        (pb - pa) / dt
    };
    pa + d * (2.0 * h * Ramp::new(s).big_g(u))
}

/// The queue of moves of one coordinate system.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Timeline {
    pieces: VecDeque<Piece>,
    rest: AxisVec,
    next_id: u64,
    reported: u64,
    spline: Option<[AxisVec; 3]>,
}

impl Timeline {
    /// Empty queue standing at base position `rest`.
    pub(crate) fn new(rest: AxisVec) -> Self {
        Timeline {
            pieces: VecDeque::new(),
            rest,
            next_id: 1,
            reported: 0,
            spline: None,
        }
    }

    /// Drop every move and stand at `rest` (abort, PMATCH while idle).
    pub(crate) fn clear(&mut self, rest: AxisVec) {
        self.pieces.clear();
        self.rest = rest;
        self.spline = None;
        self.reported = self.next_id - 1;
    }

    /// No move queued or executing.
    pub(crate) fn is_idle(&self) -> bool {
        self.pieces.is_empty()
    }

    /// Whether the executor should calculate another move: fewer than two queued moves have
    /// not started yet, and no DWELL is pending (DWELL stops look-ahead).
    pub(crate) fn wants_more(&self, tau: f64) -> bool {
        if self.pieces.len() >= MAX_PIECES - 3 || self.pieces.iter().any(|p| p.kind == Kind::Dwell)
        {
            return false;
        }
        self.pieces.iter().filter(|p| p.exec_start() > tau).count() < 2
    }

    /// Whether τ lies in a DWELL (the clock then runs on the fixed time base).
    pub(crate) fn in_dwell(&self, tau: f64) -> bool {
        self.pieces
            .iter()
            .any(|p| p.kind == Kind::Dwell && tau >= p.start && tau < p.end())
    }

    /// Id of the move executing at τ (PE), if any.
    pub(crate) fn executing(&self, tau: f64) -> Option<u64> {
        self.pieces
            .iter()
            .rev()
            .find(|p| p.exec_start() <= tau)
            .map(|p| p.id)
    }

    /// Velocity (base units/ms) at the end of the last queued move when it can still blend.
    pub(crate) fn tail_blend_velocity(&self, tau: f64) -> Option<AxisVec> {
        let p = self.pieces.back()?;
        match (p.kind, p.out) {
            (Kind::Blend { .. }, Out::Undecided) if tau < p.end() - p.stop_h() => {
                Some(p.at(p.end()).1)
            }
            _ => None,
        }
    }

    fn time_at_rest(&self, tau: f64) -> f64 {
        match self.pieces.back() {
            None => tau,
            Some(p) => match p.out {
                Out::Stop { h, .. } | Out::Next { h, .. } => tau.max(p.end() + h),
                Out::Undecided => tau.max(p.end()),
            },
        }
    }

    /// Close an open PVT/SPLINE sequence or stop a blended tail so a new sequence can follow.
    pub(crate) fn settle_tail(&mut self) {
        let Some(p) = self.pieces.back_mut() else {
            return;
        };
        if p.out != Out::Undecided {
            return;
        }
        match p.kind {
            Kind::Blend { sd, .. } => {
                let h = p.stop_h();
                p.out = Out::Stop { h, s: sd };
            }
            Kind::Pvt => {
                // End the sequence at rest on the programmed point: re-plan the last segment
                // with a zero end velocity (it has at most just started).
                if let Prim::Cubic { p0, v0, .. } = p.prim {
                    let p1 = p.prim.end(p.dur);
                    p.prim = Prim::pvt(p0, v0, p1, AxisVec::zeros(), p.dur);
                }
                p.out = Out::Stop { h: 0.0, s: 0.0 };
            }
            Kind::Spline => self.close_spline(),
            Kind::Solo | Kind::Dwell => p.out = Out::Stop { h: 0.0, s: 0.0 },
        }
    }

    /// End velocity (program units/ms) of an open PVT sequence the next PVT move continues.
    pub(crate) fn pvt_tail_velocity(&self) -> Option<AxisVec> {
        let p = self.pieces.back()?;
        (p.kind == Kind::Pvt && p.out == Out::Undecided)
            .then(|| p.prim.eval(p.start, p.dur, p.end()).1)
    }

    fn close_spline(&mut self) {
        let Some(q) = self.spline.take() else { return };
        let Some(p) = self.pieces.back_mut() else {
            return;
        };
        p.out = Out::Next { h: 0.0, s: 0.0 };
        let last = q[2];
        let segs = [[q[0], q[1], last, last], [q[1], last, last, last]];
        let mut start = p.end();
        let tmpl = p.clone();
        for (k, cp) in segs.into_iter().enumerate() {
            let out = if k == 1 {
                Out::Stop { h: 0.0, s: 0.0 }
            } else {
                Out::Next { h: 0.0, s: 0.0 }
            };
            self.pieces.push_back(Piece {
                prim: Prim::Spline(cp),
                start,
                out,
                ..tmpl.clone()
            });
            start += tmpl.dur;
        }
    }

    /// Queue a move. Blended moves blend with a blendable undecided tail when its window has
    /// not begun; PVT continues a PVT tail; everything else starts from rest after the tail.
    pub(crate) fn push(&mut self, np: NewPiece, tau: f64) -> Result<u64, CoordError> {
        if self.pieces.len() >= MAX_PIECES - 3 {
            return Err(CoordError::QueueFull);
        }
        if !(np.dur.is_finite() && np.dur > 0.0) {
            return Err(CoordError::BadTime("move time"));
        }
        let id = self.next_id;
        let mut piece = Piece {
            id,
            prim: np.prim,
            start: 0.0,
            dur: np.dur,
            kind: np.kind,
            h_in: 0.0,
            s_in: 0.0,
            from_rest: false,
            out: Out::Undecided,
            xf: np.xf,
        };
        let joined = match (self.pieces.back_mut(), np.kind) {
            (Some(last), Kind::Blend { ta, s, .. }) if last.out == Out::Undecided => {
                let is_blend = matches!(last.kind, Kind::Blend { .. });
                let h = (ta / 2.0).min(last.dur / 2.0).min(np.dur / 2.0);
                if is_blend && tau < last.end() - h {
                    last.out = Out::Next { h, s };
                    piece.start = last.end();
                    piece.h_in = h;
                    piece.s_in = s;
                    true
                } else {
                    false
                }
            }
            (Some(last), Kind::Pvt) if last.out == Out::Undecided && last.kind == Kind::Pvt => {
                last.out = Out::Next { h: 0.0, s: 0.0 };
                piece.start = last.end();
                true
            }
            _ => false,
        };
        if !joined {
            self.settle_tail();
            let t0 = self.time_at_rest(tau);
            if let Kind::Blend { ta, s, .. } = np.kind {
                piece.h_in = (ta / 2.0).min(np.dur / 2.0);
                piece.s_in = s;
                piece.from_rest = true;
            }
            piece.start = t0 + piece.h_in;
            if matches!(np.kind, Kind::Solo | Kind::Dwell) {
                piece.out = Out::Stop { h: 0.0, s: 0.0 };
            }
        }
        self.pieces.push_back(piece);
        self.next_id += 1;
        Ok(id)
    }

    /// Queue one SPLINE1 point `p` (program units) with segment time `ta`, the sequence
    /// starting at `from` when none is open (uniform cubic B-spline, triple end points: the
    /// path starts and ends at rest; n points give n + 2 segments).
    pub(crate) fn push_spline(
        &mut self,
        from: AxisVec,
        p: AxisVec,
        ta: f64,
        xf: Affine,
        tau: f64,
    ) -> Result<u64, CoordError> {
        let cont = matches!(self.pieces.back(), Some(l) if l.kind == Kind::Spline && l.out == Out::Undecided
            && l.dur == ta && l.xf == xf && self.spline.is_some());
        let q = if cont {
            self.spline.unwrap_or([from; 3])
        } else {
            [from; 3]
        };
        let np = NewPiece {
            prim: Prim::Spline([q[0], q[1], q[2], p]),
            dur: ta,
            kind: Kind::Spline,
            xf,
        };
        let id = if cont {
            let last = self.pieces.back_mut().ok_or(CoordError::QueueFull)?;
            last.out = Out::Next { h: 0.0, s: 0.0 };
            let start = last.end();
            let id = self.push(np, tau)?;
            if let Some(l) = self.pieces.back_mut() {
                l.start = start;
            }
            id
        } else {
            self.push(np, tau)?
        };
        self.spline = Some([q[1], q[2], p]);
        Ok(id)
    }

    /// `/`: finish the executing move and stop; later moves are discarded. Returns the base
    /// position where the motion will end.
    pub(crate) fn stop_after_current(&mut self, tau: f64) -> AxisVec {
        self.stop_after_current_inner(tau);
        match self.pieces.back() {
            Some(p) => p.at(p.end()).0,
            None => self.rest,
        }
    }

    fn stop_after_current_inner(&mut self, tau: f64) {
        let Some(k) = self.pieces.iter().rposition(|p| p.exec_start() <= tau) else {
            self.pieces.clear();
            return;
        };
        let id = self.pieces[k].id;
        while self.pieces.len() > k + 1 && self.pieces.back().is_some_and(|p| p.id != id) {
            self.pieces.pop_back();
        }
        if let Some(p) = self.pieces.back_mut() {
            if let Out::Next { .. } = p.out {
                p.out = Out::Undecided;
            }
            if p.kind == Kind::Spline {
                return; // the spline closes itself at its end
            }
            self.spline = None;
        }
        self.settle_tail();
    }

    /// Advance to τ: commit stops where look-ahead ran out, drop finished pieces. Returns the
    /// ids of moves that started and that finished since the last call.
    pub(crate) fn advance(&mut self, tau: f64) -> (Vec<u64>, Vec<u64>) {
        if let Some(p) = self.pieces.back_mut() {
            if p.out == Out::Undecided {
                let due = match p.kind {
                    Kind::Blend { .. } => tau >= p.end() - p.stop_h(),
                    Kind::Pvt => tau >= p.start,
                    _ => tau >= p.end(),
                };
                if due {
                    self.settle_tail();
                }
            }
        }
        let mut started = Vec::new();
        for p in &self.pieces {
            if p.id > self.reported && p.exec_start() <= tau {
                started.push(p.id);
                self.reported = p.id;
            }
        }
        let mut finished = Vec::new();
        while let Some(p) = self.pieces.front() {
            let done = match p.out {
                Out::Stop { h, .. } => tau >= p.end() + h,
                Out::Next { h, .. } => tau >= p.end() + h && self.pieces.len() > 1,
                Out::Undecided => false,
            };
            if !done {
                break;
            }
            let Some(p) = self.pieces.pop_front() else {
                break;
            };
            self.rest = p.at(p.end()).0;
            if !matches!(self.pieces.front(), Some(n) if n.id == p.id) {
                finished.push(p.id);
            }
        }
        (started, finished)
    }

    /// Base axis positions at τ.
    pub(crate) fn eval(&self, tau: f64) -> AxisVec {
        for (k, p) in self.pieces.iter().enumerate() {
            let end = p.end();
            if p.from_rest && tau < p.start + p.h_in {
                let hold = p.at(p.start).0;
                let a = move |_t: f64| (hold, AxisVec::zeros());
                return blend(
                    &a,
                    &|t| p.at(t),
                    p.prim.is_line(),
                    p.start,
                    p.h_in,
                    p.s_in,
                    tau,
                );
            }
            let (h, s, stop) = match p.out {
                Out::Undecided => return p.at(tau.min(end)).0,
                Out::Next { h, s } => (h, s, false),
                Out::Stop { h, s } => (h, s, true),
            };
            if tau <= end - h {
                return p.at(tau).0;
            }
            if tau < end + h {
                let a = |t: f64| p.at(t);
                if stop {
                    let hold = p.at(end).0;
                    let b = move |_t: f64| (hold, AxisVec::zeros());
                    return blend(&a, &b, p.prim.is_line(), end, h, s, tau);
                }
                if let Some(n) = self.pieces.get(k + 1) {
                    let lines = p.prim.is_line() && n.prim.is_line();
                    return blend(&a, &|t| n.at(t), lines, end, h, s, tau);
                }
                return p.at(tau).0;
            }
            if stop && self.pieces.get(k + 1).is_none() {
                return p.at(end).0;
            }
        }
        self.rest
    }
}
