//! `open forward [(n)]` / `open inverse [(n)]` … `close` (seed L37469-37610): the kinematic
//! routines of Power C.S. `n` (alone: the thread's addressed C.S.), kept in the dialect's
//! program-side state and run by the engine (`program::kin`) with KinPosMotor n = `L n` and
//! KinPosAxis = `C` (A0 B1 C2 U3 V4 W5 X6 Y7 Z8).

use crate::domain::PowerErr;
use std::collections::HashMap;
use std::sync::Arc;

use super::parse::{AxisReport, SyntaxError, EXT_C, EXT_D, EXT_L};
use super::{progvars, OpenBuf, Power, Thread};
use crate::lang::Card;
use crate::model::BufId;
use crate::model::KinRoutine;
use crate::model::{CardModel, ExtAt};

/// One routine: what the engine runs and the text `list` shows (and the saved image keeps).
#[derive(Debug, Clone)]
pub(crate) struct Kin {
    pub(crate) routine: KinRoutine,
    pub(crate) text: Vec<String>,
}

/// The kinematic routines of the card: (model C.S., inverse) → routine.
pub(crate) type Routines = HashMap<(u16, bool), Kin>;

fn routine(code: crate::program::compile::Compiled) -> KinRoutine {
    KinRoutine {
        code: Arc::new(code),
        motor_family: EXT_L,
        axis_family: EXT_C,
    }
}

/// `list forward|inverse [(n)]` (`rest`: after `list`, lower case): the routine's lines, or
/// the error code; `None`: not such a listing.
pub(super) fn list(r: &Routines, th: &Thread, rest: &str) -> Option<Result<Vec<String>, PowerErr>> {
    // A copy: a listing changes no addressing.
    let mut th = th.clone();
    let key = open_words(&format!("open {rest}"), &mut th)?;
    Some(
        r.get(&key)
            .map(|k| k.text.clone())
            .ok_or(PowerErr::IllegalParameter),
    )
}

/// The routines' texts for the saved image (`forward`/`inverse`, Power C.S. number).
pub(crate) fn export(r: &Routines) -> Vec<super::saved::SourceText> {
    let mut v: Vec<_> = r
        .iter()
        .map(|(&(cs, inv), k)| super::saved::SourceText {
            kind: if inv { "inverse" } else { "forward" }.to_string(),
            n: u32::from(cs - 1),
            lines: k.text.clone(),
            stack: crate::model::DEFAULT_STACK_OFFSET,
        })
        .collect();
    v.sort_by(|a, b| (&a.kind, a.n).cmp(&(&b.kind, b.n)));
    v
}

/// Rebuild a routine from its saved text (`false`: not a routine's kind; a text that no
/// longer parses is left out).
pub(crate) fn rebuild(pv: &mut progvars::ProgVars, kind: &str, n: u32, text: &[String]) -> bool {
    let inverse = match kind {
        "forward" => false,
        "inverse" => true,
        _ => return false,
    };
    if n > MAX_CS {
        return true;
    }
    let mut blocks = Vec::new();
    let mut lines = Vec::new();
    for t in text {
        let Ok(stmts) =
            super::program::parse_program_line(t.as_bytes(), &mut blocks, &mut pv.elems)
        else {
            return true;
        };
        let parts = super::program::stored_lines(stmts);
        lines.extend(parts.into_iter().map(crate::model::ProgLine::new));
    }
    if !blocks.is_empty() || lines.is_empty() {
        return true;
    }
    if let Ok(code) = crate::program::compile::compile(&lines, false) {
        let k = Kin {
            routine: routine(code),
            text: text.to_vec(),
        };
        pv.kin.insert((n as u16 + 1, inverse), k);
    }
    true
}

/// Power C.S. numbers a routine may belong to (0-127, seed: one of each per C.S.).
const MAX_CS: u32 = 127;

/// `open forward|inverse [(n)]` in `text` (lower case): (model C.S., inverse), or `Some` with
/// C.S. `u16::MAX` for a bad number.
///
/// `&n` before it addresses C.S. n first (`&2open forward,64`, seed L37532); after the kind
/// come the stack offset and the label count (`open forward,512,256`, L37530-37537): both are
/// accepted in their ranges; neither changes anything, a routine calling no subroutine (its
/// `L` variables are the motors').
pub(super) fn open_words(text: &str, th: &mut Thread) -> Option<(u16, bool)> {
    let mut t = text.trim_start();
    let mut cs_prefix = None;
    if let Some(rest) = t.strip_prefix('&') {
        let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
        let n: u32 = rest[..digits].parse().ok()?;
        cs_prefix = Some(n);
        t = &rest[digits..];
    }
    let t = t.replace(['(', ')'], " ");
    let w: Vec<&str> = t.split_whitespace().collect();
    let (kind, n) = match w.as_slice() {
        ["open", k] => (*k, None),
        ["open", k, n] => (*k, Some(*n)),
        _ => return None,
    };
    let mut args = kind.split(',');
    let inverse = match args.next() {
        Some("forward") => false,
        Some("inverse") => true,
        _ => return None,
    };
    let opt: Vec<&str> = args.collect();
    let args_ok = opt.len() <= 2
        && opt.iter().enumerate().all(|(k, a)| {
            a.is_empty()
                || match (k, a.parse::<u32>()) {
                    (0, Ok(v)) => (1..super::LOCALS as u32).contains(&v),
                    (_, Ok(v)) => v > 0,
                    _ => false,
                }
        });
    if let Some(c) = cs_prefix {
        if c > MAX_CS {
            return Some((u16::MAX, inverse));
        }
        th.coord = c as u16;
    }
    if !args_ok {
        return Some((u16::MAX, inverse));
    }
    let n = match n {
        None => u32::from(th.coord),
        Some(n) => n
            .parse::<u32>()
            .ok()
            .filter(|&n| n <= MAX_CS)
            .unwrap_or(u32::MAX),
    };
    Some((
        u16::try_from(n.saturating_add(1)).unwrap_or(u16::MAX),
        inverse,
    ))
}

impl Power {
    pub(super) fn open_kin(
        &mut self,
        card: &mut Card,
        conn: u64,
        (cs, inverse): (u16, bool),
    ) -> Result<(), SyntaxError> {
        let bad = |code| SyntaxError { at: 0, code };
        if self.open.is_some() || self.rot.is_some() {
            return Err(bad(PowerErr::IllegalParameter));
        }
        if cs == u16::MAX {
            return Err(bad(PowerErr::IllegalParameter));
        }
        if card
            .model
            .state
            .coords
            .get(usize::from(cs - 1))
            .is_some_and(|c| c.running)
        {
            return Err(bad(PowerErr::ProgramRunning));
        }
        // Seed §2.9: `open` clears the buffer.
        progvars::with(card, |_, pv| pv.kin.remove(&(cs, inverse)));
        self.open = Some(OpenBuf {
            conn,
            id: BufId::Rot,
            blocks: Vec::new(),
            lines: 0,
            text: Vec::new(),
            stored: Vec::new(),
            kin: Some((cs, inverse)),
            kin_lines: Vec::new(),
            stack: crate::model::DEFAULT_STACK_OFFSET,
        });
        Ok(())
    }

    pub(super) fn close_kin(&mut self, card: &mut Card, o: OpenBuf) -> Result<(), SyntaxError> {
        let Some(key) = o.kin else {
            return Ok(());
        };
        if o.lines == 0 {
            return Ok(());
        }
        let bad = SyntaxError {
            at: 0,
            code: PowerErr::IllegalCmd,
        };
        if !o.blocks.is_empty() {
            return Err(bad);
        }
        let code = crate::program::compile::compile(&o.kin_lines, false).map_err(|_| bad)?;
        let k = Kin {
            routine: routine(code),
            text: o.text,
        };
        progvars::with(card, |_, pv| pv.kin.insert(key, k));
        Ok(())
    }
}

/// The output of a line with its kinematic axis reports put in (`exec::KinRequest`, in output
/// order): each `&x p|d|f|v` of a C.S. with `#n->I` motors is the forward routine run on the
/// motors' reported positions (seed L33955-33967), with the dialect's variables in place.
pub(super) fn fill_reports(
    card: &mut CardModel,
    out: Vec<u8>,
    reqs: &[super::exec::KinRequest],
) -> Vec<u8> {
    let mut v = Vec::with_capacity(out.len() + 32 * reqs.len());
    let mut at = 0;
    for r in reqs {
        let cut = r.at.clamp(at, out.len());
        v.extend_from_slice(&out[at..cut]);
        v.extend_from_slice(axis_report(card, r.x, r.what).as_bytes());
        at = cut;
    }
    v.extend_from_slice(&out[at..]);
    v
}

/// `&x p|d|f|v` of a kinematic C.S. (Power C.S. `x`): the axes the forward routine computes
/// (those it names in `KinAxisUsed`, D0, or else those it sets), in user units; `No Solution`
/// when it fails or there is none. [DECISION] `v` is the change of the forward solution over
/// one unit of the motors' reported velocities (the routine's velocity pass is not modelled).
fn axis_report(card: &mut CardModel, x: u16, what: AxisReport) -> String {
    use crate::coord::axes::{AxisVec, AXES};
    let cs = x.saturating_add(1);
    let motors = card.run.motors_in(cs);
    let rep: Vec<(f64, f64, f64)> = motors
        .iter()
        .map(|&n| super::exec::reported(card, n))
        .collect();
    let at = ExtAt {
        thread: crate::model::Thread::Kin(cs),
        coord: cs,
        motor: 1,
        ..ExtAt::default()
    };
    // The axes the routine leaves alone keep this value (no routine computes it).
    const UNSET: f64 = -9.876_543_21e299;
    let unset = AxisVec::from_element(UNSET);
    let mut used_bits = 0u64;
    let mut set = [false; 9];
    let mut solve = |card: &mut CardModel, pos: Vec<f64>| -> Option<AxisVec> {
        let _ = card.ext_write(&at, EXT_D, 0, 0.0);
        let r = crate::program::kin::forward(card, cs, &motors, &pos, &unset)?.ok()?;
        used_bits = card.ext_read(&at, EXT_D, 0).unwrap_or(0.0).max(0.0) as u64;
        for (k, s) in set.iter_mut().enumerate() {
            *s = r[k] != UNSET;
        }
        Some(r)
    };
    let pos: Vec<f64> = rep.iter().map(|r| r.0).collect();
    let des: Vec<f64> = rep.iter().map(|r| r.0 + r.2).collect();
    let out = match what {
        AxisReport::Pos => solve(card, pos),
        AxisReport::Des => solve(card, des),
        AxisReport::Fe => {
            let p = solve(card, pos);
            solve(card, des).zip(p).map(|(d, p)| d - p)
        }
        AxisReport::Vel => {
            let moved: Vec<f64> = rep.iter().map(|r| r.0 + r.1).collect();
            let p = solve(card, pos);
            solve(card, moved).zip(p).map(|(m, p)| m - p)
        }
    };
    let Some(out) = out else {
        return "No Solution".to_string();
    };
    let text: Vec<String> = (0..AXES.len())
        .filter(|&k| {
            let y = crate::program::kin::AXIS_VAR[k];
            if used_bits != 0 {
                used_bits & (1 << y) != 0
            } else {
                set[k]
            }
        })
        .map(|k| {
            let v = if set[k] { out[k] } else { 0.0 };
            format!("{}{}", AXES[k].letter(), crate::model::format_value(v))
        })
        .collect();
    if text.is_empty() {
        return "No Solution".to_string();
    }
    text.join(" ")
}
