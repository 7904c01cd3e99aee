//! Executing a parsed line for one thread and framing its output (see the module docs of
//! `ppmac` for the reply format).

use crate::domain::{CsNum, ErrCode, MotorNum, PowerErr};
use std::collections::HashMap;

use super::elements::{self, AccessError, Key, Store, ILLEGAL_PARAMETER};
use super::parse::{self, Cmd, CsCmd, ElemRef, Fam, MotorCmd, Parsed, Sel, EXT_ELEM, EXT_I};
use super::{Thread, MAX_LINE};
use crate::domain::ast::{Expr, VarIndex, VarKind};
use crate::domain::eval::{self, Env, EvalError};
use crate::lang::CmdKind;
use crate::lang::{Card, Session};
use crate::model::CardModel;

/// The acknowledge ending every line's output.
const ACK: &[u8] = b"\x06\r\n";

/// Most values one line may report (a list query beyond it is refused: a line is served in
/// one slice, so this bounds the time it takes; about a millisecond).
const MAX_VALUES: usize = 8192;
/// Most variables one assignment or M-definition selection covers.
const MAX_SET: usize = 65_536;

struct Ctx<'a> {
    card: &'a mut Card,
    store: &'a mut Store,
    /// The program threads' local data (`Plc[i].Ldata.…`, `Coord[x].Ldata.…`).
    others: &'a mut HashMap<crate::model::Thread, Thread>,
    /// Kinematic axis reports to run once the line has run.
    kin: &'a mut Vec<KinRequest>,
    th: &'a mut Thread,
    out: Vec<u8>,
    values: usize,
}

/// Run one line for thread `th`: its framed output; `kin` receives the kinematic axis
/// reports to put into it once the dialect's variables are back in the model.
pub(crate) fn run_line(
    card: &mut Card,
    store: &mut Store,
    others: &mut HashMap<crate::model::Thread, Thread>,
    th: &mut Thread,
    line: &[u8],
    kin: &mut Vec<KinRequest>,
) -> Vec<u8> {
    th.lines += 1;
    let mut cx = Ctx {
        card,
        store,
        others,
        kin,
        th,
        out: Vec::new(),
        values: 0,
    };
    if line.len() > MAX_LINE {
        cx.error(line, 0, PowerErr::IllegalCmd);
        cx.out.extend_from_slice(ACK);
        return cx.out;
    }
    let lim = cx.card.model.state.limits();
    let mut parsed = parse::parse_line(line, lim.motors, lim.coords);
    if no_short_cmds(cx.store) {
        // Seed L19994-20002: a short "action" command is a syntax error (#20); the
        // commands before it run.
        if let Some(k) = parsed.items.iter().position(|it| it.short) {
            let at = parsed.items[k].at;
            if parsed.error.is_none_or(|e| e.at > at) {
                parsed.error = Some(parse::SyntaxError {
                    at,
                    code: PowerErr::IllegalCmd,
                });
            }
            parsed.items.truncate(k);
        }
    }
    if let Some(e) = parsed.error {
        // The line is parsed whole first: a syntax error is reported before anything the
        // commands before it print (as gpascii does), and those commands still run.
        cx.error(line, e.at, e.code);
    }
    cx.exec_all(&parsed, line);
    cx.out.extend_from_slice(ACK);
    cx.out
}

/// `&x p|d|f|v` (seed L33912-33975, L34940-34962): each axis of C.S. x that a motor is
/// assigned to, in the order X Y Z A B C U V W, as `{letter}{value}` in user units, solved
/// from its motors' values as reported (PMATCH's solution: the lowest motor of an axis
/// wins); `No Motors` for a C.S. without motors, `No Solution` where the axes cannot be
/// computed from the definitions (`#n->I` motors: \[GAP\] the forward routine is not run
/// for a report).
///
/// Each reported axis value is also left in the thread's `L(256 + Sys.MaxMotors + n)`, n the
/// axis index (A 0, B 1, C 2, U 3, V 4, W 5, X 6, Y 7, Z 8; seed L33958-33962, L37940-37943):
/// returned with the text as (n, value).
/// The C.S.'s axes (X Y Z A B C U V W: used, value) that `what` reports, or the text that
/// replaces them (`No Motors`, `No Solution`).
fn axis_values(
    m: &CardModel,
    x: u16,
    what: parse::AxisReport,
    kin: bool,
) -> Result<(Vec<bool>, crate::coord::axes::AxisVec), AxisFail> {
    use crate::coord::axes::{CsAxes, MotorAxisDef};
    use parse::AxisReport as R;
    let motors = m.run.motors_in(x + 1);
    if motors.is_empty() {
        return Err(AxisFail::Text("No Motors".to_string()));
    }
    let no_solution = || Err(AxisFail::Text("No Solution".to_string()));
    let mut defs = Vec::with_capacity(motors.len());
    for &n in &motors {
        match m.run.axes.get(usize::from(n) - 1) {
            Some(Some((_, d))) => match MotorAxisDef::from_ast(d) {
                // `#n->I`: the forward routine computes the axes, with the dialect's variables
                // in place (once the line has run).
                Ok(MotorAxisDef::Inverse) if kin => return Err(AxisFail::Kin),
                Ok(MotorAxisDef::Inverse) | Err(_) => return no_solution(),
                Ok(def) => defs.push((n, def)),
            },
            _ => return no_solution(),
        }
    }
    let refs: Vec<(u16, &MotorAxisDef)> = defs.iter().map(|(n, d)| (*n, d)).collect();
    let cs = CsAxes::build(&refs);
    let rep = |n: u16| reported(m, n);
    let zero = crate::coord::axes::AxisVec::zeros();
    let solve = |vals: Vec<f64>| cs.pmatch(&vals, &zero);
    let pos = || solve(motors.iter().map(|&n| rep(n).0).collect());
    let des = || {
        solve(
            motors
                .iter()
                .map(|&n| {
                    let (p, _, f) = rep(n);
                    p + f
                })
                .collect(),
        )
    };
    let out = match what {
        R::Pos => pos(),
        R::Des => des(),
        R::Fe => des() - pos(),
        // A velocity has no offset.
        R::Vel => solve(
            motors
                .iter()
                .enumerate()
                .map(|(r, &n)| rep(n).1 + cs.offset[r])
                .collect(),
        ),
    };
    Ok((cs.axes_used().to_vec(), out))
}

/// A kinematic C.S.'s axis report a line asks for: it runs once the line has run, with the
/// dialect's variables back in the model, and its text goes at byte `at` of the output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct KinRequest {
    /// Where the text goes in the line's output.
    pub at: usize,
    /// Power C.S. number.
    pub x: u16,
    /// Which report.
    pub what: parse::AxisReport,
}

/// Why a C.S.'s axes are not reported here: a text that replaces them, or the forward
/// routine of a kinematic C.S. (run later: [`KinRequest`]).
enum AxisFail {
    Text(String),
    Kin,
}

/// Motor `n`'s (model number) position, velocity and following error as `p`/`v`/`f` report
/// them (0.1 count).
pub(crate) fn reported(m: &CardModel, n: u16) -> (f64, f64, f64) {
    let (p, v, f) = m
        .run
        .report
        .get(usize::from(n).wrapping_sub(1))
        .copied()
        .unwrap_or_default();
    let r = |a: f64| (a * 10.0).round() / 10.0;
    (r(p), r(v), r(f))
}

/// The thread whose local data `Ldata` key `k` names: another program thread's (made at its
/// defaults if it has not run yet) or `own`.
fn ldata_thread<'t>(
    others: &'t mut HashMap<crate::model::Thread, Thread>,
    own: &'t mut Thread,
    k: &Key,
) -> &'t mut Thread {
    match elements::ldata_owner(k) {
        Some(t) => others.entry(t).or_insert_with(|| elements::fresh_thread(t)),
        None => own,
    }
}

/// Power's axis index of X Y Z A B C U V W (seed L45470-45480).
const POWER_INDEX: [u32; 9] = [6, 7, 8, 0, 1, 2, 3, 4, 5];

fn axis_report(
    m: &CardModel,
    x: u16,
    what: parse::AxisReport,
) -> Result<(String, Vec<(u32, f64)>), AxisFail> {
    use crate::coord::axes::AXES;
    let (used, out) = match axis_values(m, x, what, true) {
        Ok(v) => v,
        Err(AxisFail::Text(text)) => return Ok((text, Vec::new())),
        Err(AxisFail::Kin) => return Err(AxisFail::Kin),
    };
    let text = AXES
        .iter()
        .enumerate()
        .filter(|(k, _)| used[*k])
        .map(|(k, a)| format!("{}{}", a.letter(), crate::model::format_value(out[k])))
        .collect::<Vec<_>>()
        .join(" ");
    let locals = (0..AXES.len())
        .filter(|k| used[*k])
        .map(|k| (POWER_INDEX[k], out[k]))
        .collect();
    Ok((text, locals))
}

/// `&x g` (seed L34990-35026): each axis's distance to go in the move executing (its end
/// less the present commanded position; 0 with no move), in Power's axis order (A B C U V W
/// X Y Z), after `N{Coord[x].Nsync}` when `Coord[x].Ndisplay` = 1; the values also go into
/// the thread's D-variables by axis index, as `dtogread` puts them. `No targets defined`
/// while `Coord[x].TPSize` is 0.
fn distance_to_go(m: &CardModel, store: &Store, x: u16) -> (String, Vec<(u32, f64)>) {
    use super::catalog::St;
    use crate::coord::axes::AXES;
    let coord = |name: &str| elements::kept_or_default(store, St::Coord, u32::from(x), name);
    if coord("TPSize") <= 0.0 {
        return ("No targets defined".to_string(), Vec::new());
    }
    let (used, des) = match axis_values(m, x, parse::AxisReport::Des, false) {
        Ok(v) => v,
        Err(AxisFail::Text(text)) => return (text, Vec::new()),
        Err(AxisFail::Kin) => return ("No Solution".to_string(), Vec::new()),
    };
    let run = m.run.cs.get(usize::from(x));
    let target = run.and_then(|r| r.target);
    let mut order: Vec<usize> = (0..AXES.len()).filter(|k| used[*k]).collect();
    order.sort_by_key(|&k| POWER_INDEX[k]);
    let mut parts = Vec::new();
    if coord("Ndisplay") == 1.0 {
        parts.push(format!("N{}", run.map_or(0, |r| r.nsync)));
    }
    let mut locals = Vec::new();
    for k in order {
        let d = target.map_or(0.0, |t| t[k] - des[k]);
        // Rounded as the reports are (0.1 count resolution of the positions it comes from).
        let d = (d * 1e9).round() / 1e9;
        parts.push(format!(
            "{}{}",
            AXES[k].letter(),
            crate::model::format_value(d)
        ));
        locals.push((POWER_INDEX[k], d));
    }
    (parts.join(" "), locals)
}

/// `Sys.NoShortCmds` is set: only the long forms of the action commands are accepted.
fn no_short_cmds(store: &Store) -> bool {
    let Some(def) = super::catalog::find(super::catalog::St::Sys, "NoShortCmds") else {
        return false;
    };
    let k = Key {
        st: super::catalog::St::Sys,
        idx: 0,
        def,
        sub: [0, 0],
    };
    store.value(&k).is_some_and(|v| v != 0.0)
}

/// The output of a line that prints nothing: its error (if any) and the ACK. The error is
/// the line's refusal ([`Thread::refuse`]).
pub(crate) fn frame(th: &Thread, line: &[u8], e: Option<parse::SyntaxError>) -> Vec<u8> {
    if let Some(e) = e {
        th.refuse(e.code);
    }
    render(th, line, e)
}

/// [`frame`]'s bytes, without recording a refusal (a reply prepared for an outcome not known
/// yet).
pub(crate) fn render(th: &Thread, line: &[u8], e: Option<parse::SyntaxError>) -> Vec<u8> {
    let mut out = Vec::new();
    if let Some(e) = e {
        let s = format!(
            "stdin:{}:{}: error #{}: {}: {}\r\n",
            th.lines,
            e.at + 1,
            e.code.code(),
            e.code.text(),
            String::from_utf8_lossy(line).trim_end()
        );
        out.extend_from_slice(s.as_bytes());
    }
    out.extend_from_slice(ACK);
    out
}

impl Ctx<'_> {
    fn error(&mut self, line: &[u8], at: usize, code: PowerErr) {
        self.th.refuse(code);
        let text = String::from_utf8_lossy(line);
        let s = format!(
            "stdin:{}:{}: error #{}: {}: {}\r\n",
            self.th.lines,
            at + 1,
            code.code(),
            code.text(),
            text.trim_end()
        );
        self.out.extend_from_slice(s.as_bytes());
    }

    fn say(&mut self, s: &str) {
        self.out.extend_from_slice(s.as_bytes());
        self.out.extend_from_slice(b"\r\n");
    }

    fn exec_all(&mut self, p: &Parsed, line: &[u8]) {
        // A `#list` / `&list` applies to the next command only.
        let mut motors: Option<Vec<u16>> = None;
        let mut coords: Option<Vec<u16>> = None;
        for it in &p.items {
            let r = match &it.cmd {
                Cmd::Motors(v, list) => {
                    if *list || v.len() != 1 {
                        motors = Some(v.clone());
                    } else {
                        self.th.motor = v[0];
                        motors = None;
                    }
                    continue;
                }
                Cmd::Coords(v, list) => {
                    if *list || v.len() != 1 {
                        coords = Some(v.clone());
                    } else {
                        self.th.coord = v[0];
                        coords = None;
                    }
                    continue;
                }
                Cmd::Motor(m) => {
                    let list = motors.take().unwrap_or_else(|| vec![self.th.motor]);
                    self.motor_cmd(m, &list)
                }
                Cmd::Cs(c) => {
                    let list = coords.take().unwrap_or_else(|| vec![self.th.coord]);
                    self.cs_cmd(c, &list)
                }
                other => {
                    motors = None;
                    coords = None;
                    self.exec(other, &p.elems)
                }
            };
            if let Err(code) = r {
                self.error(line, it.at, code);
                return;
            }
        }
    }

    fn exec(&mut self, cmd: &Cmd, elems: &[ElemRef]) -> Result<(), PowerErr> {
        match cmd {
            Cmd::MotorQuery => {
                let s = format!("#{}", self.th.motor);
                self.say(&s);
            }
            Cmd::CoordQuery => {
                let s = format!("&{}", self.th.coord);
                self.say(&s);
            }
            Cmd::GlobalStatus => {
                let s = format!("{:08X}", global_status(&self.card.model));
                self.say(&s);
            }
            Cmd::Echo(None) => {
                let s = format!("{}", self.th.echo);
                self.say(&s);
            }
            Cmd::Echo(Some(n)) => {
                if *n > 127 {
                    return Err(PowerErr::OutOfRange);
                }
                self.th.echo = *n;
            }
            Cmd::Info(w) => self.info(w),
            Cmd::VarQuery(f, sel) => self.var_query(*f, sel, elems)?,
            Cmd::VarSet(f, sel, e) => {
                // The value is computed once, before any variable of the selection is set.
                let v = self.eval(e, elems)?;
                let numbers = self.set_numbers(sel, elems)?;
                // A selection reaching past its family sets nothing (checked before any write;
                // [DECISION] a value one I-variable's element refuses stops the assignment there,
                // as the commands of a line run in order).
                if numbers.len() > 1 {
                    let m_count = self.card.model.state.limits().m_vars;
                    for &n in &numbers {
                        let ok = match f {
                            Fam::M => n < m_count,
                            Fam::I => n <= 65_535,
                            _ => self.var_read(*f, n).is_ok(),
                        };
                        if !ok {
                            return Err(PowerErr::IllegalParameter);
                        }
                    }
                }
                for n in numbers {
                    self.var_write(*f, n, v).map_err(|e| e.code)?;
                }
            }
            Cmd::IDef(f, sel) => {
                if !matches!(f, Fam::I | Fam::M) {
                    return Err(PowerErr::IllegalCmd);
                }
                let m_count = self.card.model.state.limits().m_vars;
                for n in self.sel_numbers(sel, elems)? {
                    let def = if *f == Fam::M {
                        if n >= m_count {
                            return Err(PowerErr::IllegalParameter);
                        }
                        super::mvars::def_text(self.store, n)
                    } else {
                        elements::ivar_element(n)
                            .map(|(k, st)| elements::name(&k, st))
                            .unwrap_or_default()
                    };
                    let s = if self.th.echo & 4 != 0 {
                        def
                    } else {
                        format!("{}{n}->{def}", f.letter())
                    };
                    self.say(&s);
                }
            }
            Cmd::MDef(sel, src) => {
                let numbers = self.set_numbers(sel, elems)?;
                let m_count = self.card.model.state.limits().m_vars;
                if numbers.iter().any(|&n| n >= m_count) {
                    return Err(PowerErr::IllegalParameter);
                }
                for n in numbers {
                    match src {
                        parse::MDefSrc::Ptr(p) => {
                            super::mvars::define_ptr(&self.card.model, self.store, n, *p)
                        }
                        parse::MDefSrc::Elem(e) => {
                            let k = self.key(e, elems)?;
                            super::mvars::define_element(&self.card.model, self.store, n, e, k)
                        }
                    }
                    .map_err(|e| e.code)?;
                }
            }
            Cmd::ElemQuery(e) => {
                let k = self.key(e, elems)?;
                let v = self.elem_read(e, &k)?;
                let text = self.elem_value_text(&k, e, v);
                let s = if self.th.echo & 1 != 0 {
                    text
                } else {
                    format!("{}={text}", self.elem_name(&k, e))
                };
                self.say(&s);
            }
            Cmd::ElemSet(e, x) => {
                let k = self.key(e, elems)?;
                let v = self.eval(x, elems)?;
                let v = match e.bits {
                    Some((start, width)) => {
                        let old = self.elem_read(
                            &ElemRef {
                                bits: None,
                                ..e.clone()
                            },
                            &k,
                        )?;
                        set_bits(old, start, width, v).ok_or(PowerErr::OutOfRange)?
                    }
                    None => v,
                };
                let th = ldata_thread(self.others, self.th, &k);
                elements::write(&mut self.card.model, self.store, th, &k, v).map_err(|e| e.code)?;
            }
            Cmd::ElemAddr(e) => {
                let k = self.key(e, elems)?;
                let a = self.elem_address(&k);
                let text = if self.th.echo & 8 != 0 {
                    a.to_string()
                } else {
                    format!("${a:X}")
                };
                let s = if self.th.echo & 1 != 0 {
                    text
                } else {
                    format!("{}.a={text}", self.elem_name(&k, e))
                };
                self.say(&s);
            }
            Cmd::AxisQuery(list) => {
                // A motor of the addressed C.S. reports its definition; one of another C.S.
                // is preceded by `&n`, which then holds for the lines after it; a motor of no
                // C.S. belongs to &0 and reports `0` (seed L31662-31690).
                let mut context = self.th.coord;
                for &m in list {
                    let def = self
                        .card
                        .model
                        .run
                        .axes
                        .get(usize::from(m))
                        .cloned()
                        .flatten();
                    let (cs, text) = match def {
                        Some((c, d)) => (c.saturating_sub(1), crate::model::axis_def_text(&d)),
                        None => (0, "0".to_string()),
                    };
                    let prefix = if cs == context {
                        String::new()
                    } else {
                        context = cs;
                        format!("&{cs}")
                    };
                    self.say(&format!("{prefix}#{m}->{text}"));
                }
            }
            Cmd::AxisDef(m, text) => {
                // The definition forms are the classic ones: run as a PMAC command with the
                // model numbering (`#n->0` undefines).
                let line = format!("&{}#{}->{}", self.th.coord + 1, m + 1, text);
                let mut s = Session::with_id(0);
                let r = self.card.command_line(&mut s, line.as_bytes());
                let r = String::from_utf8_lossy(&r).into_owned();
                if r.contains("ERR") {
                    return Err(PowerErr::IllegalParameter);
                }
                if text.is_empty() {
                    let def: String = r
                        .chars()
                        .filter(|c| !c.is_control())
                        .collect::<String>()
                        .trim()
                        .to_string();
                    self.say(&def);
                }
            }
            Cmd::PlcCtl(verb, list) => {
                use crate::domain::ast::PlcVerb;
                let word = match verb {
                    PlcVerb::Enable => "ENABLE",
                    PlcVerb::Disable => "DISABLE",
                    PlcVerb::Pause => "PAUSE",
                    _ => "RESUME",
                };
                for n in list.iter().flat_map(|r| r.first..=r.last) {
                    let line = format!("{word} PLC {n}");
                    let mut s = Session::with_id(0);
                    let r = self.card.command_line(&mut s, line.as_bytes());
                    if String::from_utf8_lossy(&r).contains("ERR") {
                        return Err(PowerErr::IllegalParameter);
                    }
                }
            }
            Cmd::PlcStep(list) => {
                // A PLC that does not exist is passed over without an error (L39016-39017).
                for n in list.iter().flat_map(|r| r.first..=r.last) {
                    let m = &mut self.card.model;
                    if !m.bufs.plcs.contains_key(&(n as u8)) {
                        continue;
                    }
                    if let Some(p) = m.run.plc.get_mut(n as usize) {
                        p.enabled = true;
                        p.paused = true;
                        m.run.plc_step |= 1 << n;
                    }
                }
            }
            Cmd::Motors(..) | Cmd::Coords(..) | Cmd::Motor(_) | Cmd::Cs(_) => {}
        }
        Ok(())
    }

    fn info(&mut self, w: &str) {
        /// `date` \[DECISION\]: the modelled firmware (`vers` 2.6.0.0) answers the seed's
        /// own example date, in the seed's form.
        const POWER_FIRMWARE_DATE: &str = "Jan 30 2008";
        match w {
            "cid" => {
                let s = self
                    .card
                    .model
                    .state
                    .limits()
                    .cid
                    .unwrap_or(604_020)
                    .to_string();
                self.say(&s);
            }
            "vers" => self.say("2.6.0.0"),
            "type" => self.say("PWR PMAC UMAC"),
            "cpu" => {
                let cpu = self.card.model.state.limits().cpu.unwrap_or_default();
                self.say(cpu);
            }
            // The firmware's issue date in the seed's form (L34183-34199: month's first
            // three letters, two-digit day, four-digit year).
            "date" => self.say(POWER_FIRMWARE_DATE),
            "size" | "free" => {
                let used = self.card.model.bufs.used() * 8;
                let total = 16_777_216u64;
                let prog = if w == "size" {
                    total
                } else {
                    total - used.min(total)
                };
                for l in [
                    format!("Program Buffer = {prog}"),
                    "User Buffer = 1048576".to_string(),
                    "Table Buffer = 1048576".to_string(),
                    "Lookahead Buffer = 1048576".to_string(),
                ] {
                    self.say(&l);
                }
            }
            _ => {}
        }
    }

    // ---- variables -------------------------------------------------------------------------

    /// The variable numbers of a query's selection (at most [`MAX_VALUES`] values a line).
    fn sel_numbers(&mut self, sel: &Sel, elems: &[ElemRef]) -> Result<Vec<u32>, PowerErr> {
        let v = self.sel_within(sel, elems, MAX_VALUES)?;
        self.values += v.len();
        if self.values > MAX_VALUES {
            return Err(PowerErr::OutOfRange);
        }
        Ok(v)
    }

    /// The variable numbers of an assignment's or definition's selection: it replies nothing,
    /// so it may be as long as a variable family (`M0..16383->*`, seed L37466), 65,536 at most.
    fn set_numbers(&mut self, sel: &Sel, elems: &[ElemRef]) -> Result<Vec<u32>, PowerErr> {
        self.sel_within(sel, elems, MAX_SET)
    }

    fn sel_within(
        &mut self,
        sel: &Sel,
        elems: &[ElemRef],
        max: usize,
    ) -> Result<Vec<u32>, PowerErr> {
        Ok(match sel {
            Sel::One(ix) => vec![self.index(ix, elems)?],
            Sel::Range(a, b, _) => {
                if (b - a) as usize >= max {
                    return Err(PowerErr::OutOfRange);
                }
                (*a..=*b).collect()
            }
            Sel::List(a, n, step) => {
                if *n as usize > max || *step == 0 {
                    return Err(PowerErr::OutOfRange);
                }
                (0..*n)
                    .map(|k| a.saturating_add(k.saturating_mul(*step)))
                    .collect()
            }
        })
    }

    fn var_query(&mut self, f: Fam, sel: &Sel, elems: &[ElemRef]) -> Result<(), PowerErr> {
        let per_line = match sel {
            Sel::Range(_, _, n) => (*n as usize).max(1),
            _ => 1,
        };
        let numbers = self.sel_numbers(sel, elems)?;
        let mut values = Vec::with_capacity(numbers.len());
        for &n in &numbers {
            values.push(self.var_read(f, n).map_err(|e| e.code)?);
        }
        // `P1..10:5` answers `P1=7,3,5,2,11` then `P6=…` (seed L38087-38089).
        for (numbers, values) in numbers.chunks(per_line).zip(values.chunks(per_line)) {
            let list: Vec<String> = values.iter().map(|v| fmt(*v)).collect();
            let s = if self.th.echo & 2 != 0 {
                list.join(",")
            } else {
                format!("{}{}={}", f.letter(), numbers[0], list.join(","))
            };
            self.say(&s);
        }
        Ok(())
    }

    fn var_read(&mut self, f: Fam, n: u32) -> Result<f64, AccessError> {
        let cs = self.th.coord + 1;
        let st = &mut self.card.model.state;
        match f {
            Fam::P => st.vars.p(n).map_err(|_| ILLEGAL_PARAMETER),
            Fam::Q => st.vars.q(cs, n).map_err(|_| ILLEGAL_PARAMETER),
            Fam::M => super::mvars::read_m(&mut self.card.model, self.store, self.th, n),
            Fam::I => elements::read_ivar(&mut self.card.model, self.store, n),
            _ => {
                let VarKind::Ext(fam) = f.kind() else {
                    return Err(ILLEGAL_PARAMETER);
                };
                self.th.local(fam, n).ok_or(ILLEGAL_PARAMETER)
            }
        }
    }

    fn var_write(&mut self, f: Fam, n: u32, v: f64) -> Result<(), AccessError> {
        let cs = self.th.coord + 1;
        let st = &mut self.card.model.state;
        match f {
            Fam::P => st
                .vars
                .set_p(n, v)
                .map(|_| ())
                .map_err(|_| ILLEGAL_PARAMETER),
            Fam::Q => st
                .vars
                .set_q(cs, n, v)
                .map(|_| ())
                .map_err(|_| ILLEGAL_PARAMETER),
            Fam::M => super::mvars::write_m(&mut self.card.model, self.store, self.th, n, v),
            Fam::I => elements::write_ivar(&mut self.card.model, self.store, n, v),
            _ => {
                let VarKind::Ext(fam) = f.kind() else {
                    return Err(ILLEGAL_PARAMETER);
                };
                if self.th.set_local(fam, n, v) {
                    Ok(())
                } else {
                    Err(ILLEGAL_PARAMETER)
                }
            }
        }
    }

    // ---- elements --------------------------------------------------------------------------

    fn key(&mut self, e: &ElemRef, elems: &[ElemRef]) -> Result<Key, PowerErr> {
        let idx = match &e.idx {
            Some(x) => Some(self.eval(x, elems)?),
            None => None,
        };
        let mut sub = Vec::with_capacity(e.sub.len());
        for x in &e.sub {
            sub.push(self.eval(x, elems)?);
        }
        elements::key(e, idx, &sub).map_err(|e| e.code)
    }

    fn elem_read(&mut self, e: &ElemRef, k: &Key) -> Result<f64, PowerErr> {
        let th = ldata_thread(self.others, self.th, k);
        let v = elements::read(&mut self.card.model, self.store, th, k).map_err(|e| e.code)?;
        Ok(match e.bits {
            Some((start, width)) => get_bits(v, start, width),
            None => v,
        })
    }

    /// The address `name.a` stands for. [DECISION] A ring-IC register (`Gate3[0].MacroOutA
    /// [j][k]` …) has the model's register address, the value Motor pointer elements hold;
    /// any other element its place in the catalogue: structure block, index and entry
    /// (stable, never 0: no function elements are modelled).
    fn elem_address(&self, k: &Key) -> u64 {
        element_address(&self.card.model, k)
    }

    fn elem_name(&self, k: &Key, e: &ElemRef) -> String {
        let mut s = elements::name(k, e.st_name);
        if let Some((start, width)) = e.bits {
            s.push_str(&format!(".{start}.{width}"));
        }
        s
    }

    fn elem_value_text(&self, _k: &Key, e: &ElemRef, v: f64) -> String {
        value_text(&self.card.model, e.def, e.bits, v, self.th.echo & 8 == 0)
    }

    // ---- expressions -----------------------------------------------------------------------

    fn eval(&mut self, e: &Expr, elems: &[ElemRef]) -> Result<f64, PowerErr> {
        let mut env = PowerEnv { cx: self, elems };
        eval::eval(e, &mut env).map_err(|e| {
            if e.code == ErrCode::Data {
                PowerErr::IllegalParameter
            } else {
                PowerErr::IllegalCmd
            }
        })
    }

    fn index(&mut self, ix: &VarIndex, elems: &[ElemRef]) -> Result<u32, PowerErr> {
        match ix {
            VarIndex::Const(n) => Ok(*n),
            VarIndex::Expr(e) => {
                let v = self.eval(e, elems)?.floor();
                if v.is_finite() && (0.0..=f64::from(u32::MAX)).contains(&v) {
                    Ok(v as u32)
                } else {
                    Err(PowerErr::IllegalParameter)
                }
            }
        }
    }

    // ---- motors and coordinate systems -----------------------------------------------------

    fn pmac(&mut self, motor: u16, coord: u16, cmd: &CmdKind) -> Result<Vec<String>, PowerErr> {
        let mut s = Session {
            motor: MotorNum::of(motor + 1),
            coord: CsNum::of(coord + 1),
            ..Session::with_id(0)
        };
        self.card
            .exec_pmac(&mut s, cmd)
            .map_err(PowerErr::from_pmac)
    }

    fn motor_cmd(&mut self, m: &MotorCmd, list: &[u16]) -> Result<(), PowerErr> {
        let coord = self.th.coord;
        let mut report = Vec::new();
        for &x in list {
            let cmd = match m {
                MotorCmd::Jog(kind, trigger) => {
                    // The `*` forms take Power's elements (seed L36030-36066): the target or
                    // distance `Motor[x].ProgJogPos`, the post-trigger distance
                    // `Motor[x].JogOffset`.
                    use crate::domain::ast::JogKind as J;
                    let elem = |name: &str| {
                        elements::kept_or_default(
                            self.store,
                            super::catalog::St::Motor,
                            u32::from(x),
                            name,
                        )
                    };
                    let kind = match kind {
                        J::VarTo => J::To(elem("ProgJogPos")),
                        J::VarRelCommanded => J::RelCommanded(elem("ProgJogPos")),
                        J::VarRelActual => J::RelActual(elem("ProgJogPos")),
                        k => *k,
                    };
                    let trigger = trigger.map(|t| match t {
                        parse::JogTrigger::Offset(v) => v,
                        parse::JogTrigger::JogOffset => elem("JogOffset"),
                    });
                    CmdKind::Jog { kind, trigger }
                }
                MotorCmd::Kill | MotorCmd::DKill => CmdKind::Kill,
                MotorCmd::Home => CmdKind::Home,
                MotorCmd::HomeZ => CmdKind::HomeZ,
                MotorCmd::Enable => CmdKind::MotorInit,
                MotorCmd::Out(v) => CmdKind::OpenLoop(*v),
                MotorCmd::DesPos => {
                    // Seed L33912-33970: the commanded (desired) position, motor units; the
                    // model's following error is desired − actual.
                    let (p, _, fe) = self
                        .card
                        .model
                        .run
                        .report
                        .get(usize::from(x))
                        .copied()
                        .unwrap_or_default();
                    report.push(crate::model::format_position(p + fe));
                    continue;
                }
                MotorCmd::Position => CmdKind::Position,
                MotorCmd::Velocity => CmdKind::Velocity,
                MotorCmd::FollowingError => CmdKind::FollowingError,
                MotorCmd::Status => {
                    let [a, b] = motor_status(&self.card.model, x);
                    report.push(format!("{a:08X}{b:08X}"));
                    continue;
                }
            };
            let lines = self.pmac(x, coord, &cmd)?;
            report.extend(lines);
        }
        if !report.is_empty() {
            let s = report.join(" ");
            self.say(&s);
        }
        Ok(())
    }

    fn cs_cmd(&mut self, c: &CsCmd, list: &[u16]) -> Result<(), PowerErr> {
        let motor = self.th.motor;
        let mut report = Vec::new();
        // Kinematic reports: (index in `report`, C.S., what).
        let mut kin: Vec<(usize, u16, parse::AxisReport)> = Vec::new();
        for &x in list {
            let cmd = match c {
                CsCmd::Run => CmdKind::Run,
                CsCmd::Step => CmdKind::Step,
                CsCmd::Quit => CmdKind::Quit,
                CsCmd::Abort => CmdKind::Abort,
                CsCmd::Hold => CmdKind::Hold,
                CsCmd::Resume => CmdKind::Resume,
                CsCmd::PMatch => CmdKind::PMatch,
                CsCmd::Begin(v) => CmdKind::Begin(crate::domain::ast::Number::dec(*v)),
                CsCmd::Override(v) => {
                    if !(-200.0..=200.0).contains(v) {
                        return Err(PowerErr::OutOfRange);
                    }
                    CmdKind::OverrideSet(v.max(0.0))
                }
                CsCmd::ADisable => {
                    // The abort, then each motor disabled once its stop is over.
                    report.extend(self.pmac(motor, x, &CmdKind::Abort)?);
                    for m in self.card.model.run.motors_in(x + 1) {
                        if let Some(r) = self.card.model.run.motors.get_mut(usize::from(m - 1)) {
                            r.disable_at_rest = true;
                        }
                    }
                    continue;
                }
                CsCmd::DDisable => {
                    // [DECISION] no brake output is modelled (`Motor[x].pBrakeOut` 0): the
                    // delayed disable is immediate, as the seed gives it without a brake.
                    report.extend(self.pmac(motor, x, &CmdKind::Abort)?);
                    for m in self.card.model.run.motors_in(x + 1) {
                        report.extend(self.pmac(m - 1, x, &CmdKind::Kill)?);
                    }
                    continue;
                }
                CsCmd::Stop => {
                    // Calculation stops (the moves already calculated finish); the program
                    // counter goes back to the top of the program.
                    report.extend(self.pmac(motor, x, &CmdKind::Quit)?);
                    let prog = self
                        .card
                        .model
                        .run
                        .cs
                        .get(usize::from(x))
                        .and_then(|r| r.pointer)
                        .map(|(p, _)| p);
                    if let Some(p) = prog {
                        let b = CmdKind::Begin(crate::domain::ast::Number::dec(f64::from(p)));
                        report.extend(self.pmac(motor, x, &b)?);
                    }
                    continue;
                }
                CsCmd::Start(n) => {
                    let prog = n.or_else(|| {
                        self.card
                            .model
                            .run
                            .cs
                            .get(usize::from(x))
                            .and_then(|r| r.pointer)
                            .map(|(p, _)| f64::from(p))
                    });
                    let Some(prog) = prog else {
                        return Err(PowerErr::NotReadyToRun);
                    };
                    if prog.fract() != 0.0 {
                        return Err(PowerErr::IllegalParameter);
                    }
                    let b = CmdKind::Begin(crate::domain::ast::Number::dec(prog));
                    report.extend(self.pmac(motor, x, &b)?);
                    CmdKind::Run
                }
                // [DECISION] The engine keeps no look-ahead buffer to plan a minimum-time
                // stop along the path: `lh\` is a feed hold (`Coord[x].FeedHoldSlew`), after
                // which jogs and `lh>`/`r` work as after `h`; `lh<` holds as `<` does.
                CsCmd::LhStop => CmdKind::Hold,
                CsCmd::LhBack => CmdKind::BackUp,
                CsCmd::LhForward => CmdKind::Resume,
                CsCmd::Servo(on) => {
                    // Every motor assigned to an axis of the C.S.: `$` (closed loop at its
                    // position) or a kill (open loop, amplifier off).
                    let cmd = if *on {
                        CmdKind::MotorInit
                    } else {
                        CmdKind::Kill
                    };
                    for m in self.card.model.run.motors_in(x + 1) {
                        report.extend(self.pmac(m - 1, x, &cmd)?);
                    }
                    continue;
                }
                // Seed L31838-31846: a C.S. with no motor assigned always reports 0.
                CsCmd::OverrideQuery if self.card.model.run.motors_in(x + 1).is_empty() => {
                    report.push("0".to_string());
                    continue;
                }
                CsCmd::OverrideQuery => CmdKind::OverrideQuery,
                CsCmd::Status => {
                    let [a, b] = coord_status(&self.card.model, x);
                    report.push(format!("{a:08X}{b:08X}"));
                    continue;
                }
                CsCmd::DistanceToGo => {
                    let (text, locals) = distance_to_go(&self.card.model, self.store, x);
                    for (n, v) in locals {
                        self.th.set_local(parse::EXT_D, n, v);
                    }
                    report.push(text);
                    continue;
                }
                CsCmd::Axes(what) => {
                    match axis_report(&self.card.model, x, *what) {
                        Ok((text, locals)) => {
                            let base = 256 + u32::from(self.card.model.state.limits().motors);
                            for (n, v) in locals {
                                self.th.set_local(parse::EXT_L, base + n, v);
                            }
                            report.push(text);
                        }
                        Err(_) => {
                            kin.push((report.len(), x, *what));
                            report.push(String::new());
                        }
                    }
                    continue;
                }
            };
            let lines = self.pmac(motor, x, &cmd)?;
            report.extend(lines);
        }
        if !report.is_empty() {
            // Where each kinematic report's text goes in the output.
            let mut at = self.out.len();
            let mut next = kin.into_iter().peekable();
            for (k, piece) in report.iter().enumerate() {
                while let Some(&(slot, x, what)) = next.peek().filter(|(slot, ..)| *slot == k) {
                    let _ = slot;
                    self.kin.push(KinRequest { at, x, what });
                    next.next();
                }
                at += piece.len() + 1;
            }
            let s = report.join(" ");
            self.say(&s);
        }
        Ok(())
    }
}

/// The expression environment of a thread: P/Q/M from the model, I in Power numbering, the
/// thread's own L/R/D/C, and the line's elements.
struct PowerEnv<'c, 'a> {
    cx: &'c mut Ctx<'a>,
    elems: &'c [ElemRef],
}

fn no_var() -> EvalError {
    EvalError {
        code: ErrCode::Data,
        msg: "no such variable",
    }
}

impl Env for PowerEnv<'_, '_> {
    fn var(&mut self, kind: VarKind, n: u32) -> Result<f64, EvalError> {
        match kind {
            VarKind::P => self.cx.var_read(Fam::P, n).map_err(|_| no_var()),
            VarKind::Q => self.cx.var_read(Fam::Q, n).map_err(|_| no_var()),
            VarKind::M => self.cx.var_read(Fam::M, n).map_err(|_| no_var()),
            VarKind::I => Err(no_var()),
            VarKind::Ext(EXT_I) => self.cx.var_read(Fam::I, n).map_err(|_| no_var()),
            VarKind::Ext(parse::EXT_M | parse::EXT_M_SYNC) => {
                self.cx.var_read(Fam::M, n).map_err(|_| no_var())
            }
            VarKind::Ext(f) if f >= EXT_ELEM => {
                let e = self
                    .elems
                    .get(usize::from(f - EXT_ELEM))
                    .ok_or_else(no_var)?
                    .clone();
                let k = self.cx.key(&e, self.elems).map_err(|_| no_var())?;
                if n == parse::ELEM_ADDRESS {
                    // `name.a` in an expression: the element's address.
                    return Ok(self.cx.elem_address(&k) as f64);
                }
                self.cx.elem_read(&e, &k).map_err(|_| no_var())
            }
            VarKind::Ext(f) => self.cx.th.local(f, n).ok_or_else(no_var),
        }
    }

    fn radians(&self) -> bool {
        true
    }

    fn ieee(&self) -> bool {
        true
    }

    fn random(&mut self) -> f64 {
        self.cx.card.model.random()
    }
}

/// An element's value as a reply prints it: a pointer at a ring register as that register's
/// `.a` (seed: `Motor[8].pDac = Gate3[0].MacroOutA[8][0].a`), bit-field and address elements
/// in hex when `hex` (echo bit 3 clear), other values as [`fmt`].
pub(crate) fn value_text(
    card: &CardModel,
    def: usize,
    bits: Option<(u32, u32)>,
    v: f64,
    hex: bool,
) -> String {
    let d = &super::catalog::DEFS[def];
    if bits.is_none() && d.ty == super::catalog::Ty::Addr {
        let out = d.name.starts_with("pDac");
        if let Some(n) = super::macro_ic::register_name(card, v, out) {
            return n;
        }
    }
    if bits.is_none()
        && matches!(d.ty, super::catalog::Ty::Hex | super::catalog::Ty::Addr)
        && hex
        && v.is_finite()
        && v >= 0.0
    {
        format!("${:X}", v as u64)
    } else {
        fmt(v)
    }
}

/// The address `name.a` of element `k` (see `Ctx::elem_address`).
pub(crate) fn element_address(card: &CardModel, k: &Key) -> u64 {
    if let Some(a) = super::macro_ic::register_address(card, k) {
        return u64::from(a);
    }
    0x1000_0000u64
        + (u64::from(k.idx) << 20)
        + ((k.def as u64) << 8)
        + u64::from(k.sub[0] * 4 + k.sub[1])
}

/// A value as replies print it: integers without a point, others with up to 15 significant
/// digits, `nan`, `inf`, `-inf`.
pub(crate) fn fmt(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf" } else { "-inf" }.into();
    }
    if v == v.trunc() && v.abs() < 1e15 {
        return format!("{}", v as i64);
    }
    let mag = v.abs().log10().floor() as i32;
    let decimals = 14 - mag;
    if (0..=20).contains(&decimals) {
        let s = format!("{:.*}", decimals as usize, v);
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:e}")
    }
}

pub(crate) fn get_bits(v: f64, start: u32, width: u32) -> f64 {
    let w = v as i64 as u64;
    let mask = if width >= 64 {
        u64::MAX
    } else {
        (1u64 << width) - 1
    };
    ((w >> start) & mask) as f64
}

pub(crate) fn set_bits(old: f64, start: u32, width: u32, v: f64) -> Option<f64> {
    let mask = if width >= 64 {
        u64::MAX
    } else {
        (1u64 << width) - 1
    };
    if !(v.is_finite() && v >= 0.0 && (v as u64) <= mask) {
        return None;
    }
    let w = old as i64 as u64;
    let w = (w & !(mask << start)) | ((v as u64) << start);
    Some(w as f64)
}

/// `Motor[x].Status[0..1]` (Power bit layout, seed §2.8) from the model's motor flags.
pub(crate) fn motor_status(card: &CardModel, x: u16) -> [u32; 2] {
    let Some(f) = card.state.motors.get(usize::from(x)) else {
        return [0, 0];
    };
    let b = |c: bool, n: u32| u32::from(c) << n;
    let active = card
        .state
        .peek_ivar(100 * (u32::from(x) + 1))
        .unwrap_or(0.0)
        != 0.0;
    let w0 = b(f.trigger_move, 31)
        | b(f.home_search, 30)
        | b(f.neg_limit, 29)
        | b(f.pos_limit, 28)
        | b(f.warning_fe, 27)
        | b(f.fatal_fe, 26)
        | b(f.stopped_on_limit, 25)
        | b(f.amp_fault, 24)
        | b(f.home_complete, 15)
        | b(active && f.desired_velocity_zero, 14)
        | b(active && !f.open_loop, 13)
        | b(f.amp_enabled, 12)
        | b(active && f.in_position, 11)
        | b(f.block_request, 9)
        | b(active, 8);
    let w1 = b(f.backlash_dir, 28);
    [w0, w1]
}

/// `Coord[x].Status[0..1]`: the motor bits ORed (faults) or ANDed (ready states) over the
/// C.S.'s motors, the program state in word 1.
pub(crate) fn coord_status(card: &CardModel, x: u16) -> [u32; 2] {
    const AND_BITS: u32 = (1 << 14) | (1 << 13) | (1 << 12) | (1 << 11);
    let motors = card.run.motors_in(x + 1);
    let (mut or, mut and) = (0u32, if motors.is_empty() { 0 } else { u32::MAX });
    for m in &motors {
        let [w, _] = motor_status(card, m.saturating_sub(1));
        or |= w;
        and &= w;
    }
    let w0 = (or & !AND_BITS & 0xFFFF_0000) | (and & AND_BITS);
    let running = card
        .state
        .coords
        .get(usize::from(x))
        .is_some_and(|f| f.running);
    let w1 = u32::from(running) << 27 | u32::from(running) << 26;
    [w0, w1]
}

/// `Sys.Status`: the global word (no power-on fault is modelled: all clear).
pub(crate) fn global_status(_card: &CardModel) -> u32 {
    0
}
