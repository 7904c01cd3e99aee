//! Sub-grammars of on-line commands: OPEN / LIST / DEFINE / DELETE targets, axis and number
//! lists, PLC control, register access and MACRO commands.

use super::ast::{
    Axis, CmdKind, CompMotor, DefineTarget, DeleteTarget, ListSpan, ListTarget, MemSpace, NumRange,
    OpenTarget, PlcControl, PlcVerb, SlaveCmd, SlaveVar, VarIndex, VarRef,
};
use super::lexer::{to_u32, Cursor};
use super::parse_expr::var_ref;
use super::ParseError;

/// Highest motor number any profile has (HOME / SETPHASE lists).
pub(crate) const MAX_MOTOR: u32 = 32;

/// Most variables one selection may span (`P0..65535`); profile limits are checked later.
pub(crate) const MAX_SPAN: u32 = 65_536;

/// Optional `(axis[,axis...])` after ABS / INC / FRAX / LEARN (spaces allowed).
pub(crate) fn axis_list(c: &mut Cursor, allow_r: bool) -> Result<Option<Vec<Axis>>, ParseError> {
    let mut k = c.clone();
    k.skip_ws();
    if !k.eat(b'(') {
        return Ok(None);
    }
    *c = k;
    let mut list = Vec::new();
    loop {
        c.skip_ws();
        let a = c
            .peek()
            .and_then(Axis::from_letter)
            .filter(|a| a.is_motion_axis() || (allow_r && *a == Axis::R))
            .ok_or_else(|| c.syntax("axis letter expected"))?;
        c.bump();
        if list.contains(&a) {
            return Err(c.syntax("axis listed twice"));
        }
        list.push(a);
        if c.eat_ws(b')') {
            return Ok(Some(list));
        }
        if !c.eat(b',') {
            return Err(c.syntax("',' or ')' expected"));
        }
    }
}

/// Number list `1,3..5,7` (each ≤ `max`); spaces allowed around items.
pub(crate) fn num_list(c: &mut Cursor, max: u32) -> Result<Vec<NumRange>, ParseError> {
    let mut list = Vec::new();
    loop {
        let first = c.req_uint("number expected")?;
        let last = if c.eat_kw("..") {
            c.req_uint("range end expected")?
        } else {
            first
        };
        if last < first || last > max {
            return Err(c.syntax("number out of range"));
        }
        list.push(NumRange { first, last });
        let mut k = c.clone();
        k.skip_ws();
        if !k.eat(b',') {
            return Ok(list);
        }
        *c = k;
    }
}

/// `PLC {list}` / `PLCC {list}` after ENABLE / DISABLE / PAUSE / RESUME.
pub(crate) fn plc_control(c: &mut Cursor, verb: PlcVerb) -> Result<PlcControl, ParseError> {
    c.skip_ws();
    let verb = if c.eat_kw("PLCC") {
        match verb {
            PlcVerb::Enable => PlcVerb::EnableCompiled,
            PlcVerb::Disable => PlcVerb::DisableCompiled,
            _ => return Err(c.syntax("PAUSE/RESUME do not apply to PLCC")),
        }
    } else if c.eat_kw("PLC") {
        verb
    } else {
        return Err(c.syntax("PLC or PLCC expected"));
    };
    Ok(PlcControl {
        verb,
        list: num_list(c, 31)?,
    })
}

/// Optional `TRIGGER` / `TRIG` after GATHER.
pub(crate) fn gather_trigger(c: &mut Cursor) -> bool {
    let mut k = c.clone();
    k.skip_ws();
    if k.eat_kw("TRIGGER") || k.eat_kw("TRIG") {
        *c = k;
        true
    } else {
        false
    }
}

fn kw_ws(c: &mut Cursor, words: &[&str]) -> bool {
    let mut k = c.clone();
    k.skip_ws();
    for w in words {
        if k.eat_kw(w) {
            *c = k;
            return true;
        }
    }
    false
}

/// `OPEN` targets.
pub(crate) fn open_target(c: &mut Cursor) -> Result<OpenTarget, ParseError> {
    if kw_ws(c, &["PROGRAM", "PROG"]) {
        let n = c.req_uint("program number expected")?;
        if !(1..=32767).contains(&n) {
            return Err(c.syntax("program number out of range"));
        }
        Ok(OpenTarget::Prog(n))
    } else if kw_ws(c, &["PLC"]) {
        let n = c.req_uint("PLC number expected")?;
        if n > 31 {
            return Err(c.syntax("PLC number out of range"));
        }
        Ok(OpenTarget::Plc(n))
    } else if kw_ws(c, &["ROTARY", "ROT"]) {
        Ok(OpenTarget::Rotary)
    } else if kw_ws(c, &["BINARY", "BIN"]) {
        if kw_ws(c, &["ROTARY", "ROT"]) {
            Ok(OpenTarget::BinRotary)
        } else {
            Err(c.syntax("ROTARY expected after OPEN BINARY"))
        }
    } else {
        Err(c.syntax("PROG, PLC or ROT expected after OPEN"))
    }
}

/// `[,[start][,[len]]]` (PROG/PLC: `leading_comma`), or `[start][,len]` (ROT/GATHER).
fn span(c: &mut Cursor, leading_comma: bool) -> Result<ListSpan, ParseError> {
    let mut s = ListSpan::default();
    let mut k = c.clone();
    k.skip_ws();
    if leading_comma {
        if !k.eat(b',') {
            return Ok(s);
        }
        s.offsets = true;
    }
    k.skip_ws();
    s.start = k.uint()?;
    if !leading_comma && s.start.is_some() {
        s.offsets = true;
    }
    let mut k2 = k.clone();
    k2.skip_ws();
    if k2.eat(b',') {
        s.offsets = true;
        k2.skip_ws();
        s.len = k2.uint()?;
        k = k2;
    }
    *c = k;
    Ok(s)
}

/// `LIST` targets.
pub(crate) fn list_target(c: &mut Cursor) -> Result<ListTarget, ParseError> {
    let def = |c: &mut Cursor| kw_ws(c, &["DEF"]);
    Ok(if kw_ws(c, &["PROGRAM", "PROG"]) {
        let n = c.req_uint("program number expected")?;
        ListTarget::Prog(n, span(c, true)?)
    } else if kw_ws(c, &["PLC"]) {
        let n = c.req_uint("PLC number expected")?;
        ListTarget::Plc(n, span(c, true)?)
    } else if kw_ws(c, &["ROTARY", "ROT"]) {
        ListTarget::Rotary(span(c, false)?)
    } else if kw_ws(c, &["GATHER", "GAT"]) {
        ListTarget::Gather(span(c, false)?)
    } else if kw_ws(c, &["PC"]) {
        ListTarget::Pc(pc_span(c)?)
    } else if kw_ws(c, &["PE"]) {
        ListTarget::Pe(pc_span(c)?)
    } else if kw_ws(c, &["BLCOMP"]) {
        ListTarget::BlComp(def(c))
    } else if kw_ws(c, &["TCOMP"]) {
        ListTarget::TComp(def(c))
    } else if kw_ws(c, &["COMP"]) {
        ListTarget::Comp(def(c))
    } else if kw_ws(c, &["LINK"]) {
        ListTarget::Link
    } else {
        ListTarget::Open
    })
}

fn pc_span(c: &mut Cursor) -> Result<ListSpan, ParseError> {
    let mut k = c.clone();
    k.skip_ws();
    if !k.eat(b',') {
        return Ok(ListSpan::default());
    }
    k.skip_ws();
    let len = k.uint()?;
    *c = k;
    Ok(ListSpan {
        offsets: true,
        start: None,
        len,
    })
}

/// `DEFINE` targets.
pub(crate) fn define_target(c: &mut Cursor) -> Result<DefineTarget, ParseError> {
    let comma = |c: &mut Cursor| -> Result<(), ParseError> {
        if c.eat_ws(b',') {
            Ok(())
        } else {
            Err(c.syntax("',' expected"))
        }
    };
    Ok(if kw_ws(c, &["ROTARY", "ROT"]) {
        DefineTarget::Rotary(c.req_uint("size expected")?)
    } else if kw_ws(c, &["GATHER", "GAT"]) {
        let mut k = c.clone();
        k.skip_ws();
        let n = k.uint()?;
        if n.is_some() {
            *c = k;
        }
        DefineTarget::Gather(n)
    } else if kw_ws(c, &["TBUF"]) {
        DefineTarget::Tbuf(c.req_uint("count expected")?)
    } else if kw_ws(c, &["UBUFFER", "UBUF"]) {
        DefineTarget::Ubuffer(c.req_uint("size expected")?)
    } else if kw_ws(c, &["LOOKAHEAD", "LOOK"]) {
        let a = c.req_uint("size expected")?;
        comma(c)?;
        DefineTarget::Lookahead(a, c.req_uint("size expected")?)
    } else if kw_ws(c, &["BLCOMP"]) {
        let n = c.req_uint("entries expected")?;
        comma(c)?;
        DefineTarget::BlComp(n, c.req_number("span expected")?)
    } else if kw_ws(c, &["TCOMP"]) {
        let n = c.req_uint("entries expected")?;
        comma(c)?;
        DefineTarget::TComp(n, c.req_number("span expected")?)
    } else if kw_ws(c, &["COMP"]) {
        let rows = c.req_uint("entries expected")?;
        let cols = if c.eat(b'.') {
            Some(c.req_uint("columns expected")?)
        } else {
            None
        };
        let mut motors = Vec::new();
        let mut spans = Vec::new();
        while c.eat_ws(b',') {
            c.skip_ws();
            if c.eat(b'#') {
                if !spans.is_empty() {
                    return Err(c.syntax("motors come before spans"));
                }
                let motor = c.req_uint("motor number expected")?;
                motors.push(CompMotor {
                    motor,
                    desired: c.eat(b'D'),
                });
            } else if c.peek() == Some(b',') {
                continue; // empty item: default motor
            } else {
                spans.push(c.req_number("span expected")?);
            }
        }
        if spans.is_empty() || spans.len() > 2 || motors.len() > 3 {
            return Err(c.syntax("bad DEFINE COMP"));
        }
        DefineTarget::Comp {
            rows,
            cols,
            motors,
            spans,
        }
    } else {
        return Err(c.syntax("unknown DEFINE target"));
    })
}

/// `DELETE` targets.
pub(crate) fn delete_target(c: &mut Cursor) -> Result<DeleteTarget, ParseError> {
    Ok(if kw_ws(c, &["ROTARY", "ROT"]) {
        DeleteTarget::Rotary
    } else if kw_ws(c, &["GATHER", "GAT"]) {
        DeleteTarget::Gather
    } else if kw_ws(c, &["TBUF"]) {
        DeleteTarget::Tbuf
    } else if kw_ws(c, &["BLCOMP"]) {
        DeleteTarget::BlComp
    } else if kw_ws(c, &["TCOMP"]) {
        DeleteTarget::TComp
    } else if kw_ws(c, &["COMP"]) {
        DeleteTarget::Comp
    } else if kw_ws(c, &["LOOKAHEAD", "LOOK"]) {
        DeleteTarget::Lookahead
    } else if kw_ws(c, &["PLCC"]) {
        let n = c.req_uint("PLCC number expected")?;
        if n > 31 {
            return Err(c.syntax("PLCC number out of range"));
        }
        DeleteTarget::Plcc(n)
    } else if kw_ws(c, &["TRACE", "TRAC"]) {
        DeleteTarget::Trace
    } else {
        return Err(c.syntax("unknown DELETE target"));
    })
}

/// `{addr}[,{count}]` of `R`/`RH` (the space letter is consumed).
pub(crate) fn mem_addr_count(c: &mut Cursor) -> Result<(u32, u32), ParseError> {
    let addr = c.req_uint("address expected")?;
    let count = if c.eat_ws(b',') {
        c.req_uint("count expected")?
    } else {
        1
    };
    // The profile's own limit (PMAC2 $FFFF, Turbo $7FFFF) is checked when it executes.
    if !(1..=16).contains(&count) || addr > 0xFF_FFFF {
        return Err(c.syntax("address above $FFFFFF or count outside 1..16"));
    }
    Ok((addr, count))
}

/// `W{space}{addr},{value}[,{value}...]` (the space letter is consumed).
pub(crate) fn write_mem(c: &mut Cursor, space: MemSpace) -> Result<CmdKind, ParseError> {
    let addr = c.req_uint("address expected")?;
    if addr > 0xFF_FFFF {
        return Err(c.syntax("address above $FFFFFF"));
    }
    let mut values = Vec::new();
    while c.eat_ws(b',') {
        values.push(c.req_number("value expected")?);
        if values.len() > 16 {
            return Err(c.syntax("at most 16 values"));
        }
    }
    if values.is_empty() {
        return Err(c.syntax("value expected"));
    }
    Ok(CmdKind::WriteMem {
        space,
        addr,
        values,
    })
}

/// Which MACRO keyword introduced the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MacroKw {
    Aux,
    AuxRead,
    AuxWrite,
    Slave,
    SlaveRead,
    SlaveWrite,
}

fn node(c: &mut Cursor) -> Result<u32, ParseError> {
    let n = c.req_uint("node number expected")?;
    if n > 15 {
        return Err(c.syntax("node number 0..15"));
    }
    Ok(n)
}

fn slave_var(c: &mut Cursor) -> Result<SlaveVar, ParseError> {
    c.skip_ws();
    if c.eat_kw("MI") || c.eat(b'I') {
        Ok(SlaveVar::Mi(
            c.req_uint("station variable number expected")?,
        ))
    } else if c.eat_kw("MC") || c.eat(b'C') {
        Ok(SlaveVar::Mc(c.req_uint("station command number expected")?))
    } else {
        Err(c.syntax("MI{n} or MC{n} expected"))
    }
}

fn pmac_var(c: &mut Cursor) -> Result<VarRef, ParseError> {
    c.skip_ws();
    match var_ref(c)? {
        Some(v) if matches!(v.index, VarIndex::Const(_)) => Ok(v),
        _ => Err(c.syntax("I, P, Q or M variable expected")),
    }
}

/// MACRO ring commands (§3.5); the keyword is consumed.
pub(crate) fn macro_cmd(c: &mut Cursor, kw: MacroKw) -> Result<CmdKind, ParseError> {
    let comma = |c: &mut Cursor| -> Result<(), ParseError> {
        if c.eat_ws(b',') {
            Ok(())
        } else {
            Err(c.syntax("',' expected"))
        }
    };
    let value = |c: &mut Cursor| -> Result<Option<super::ast::Number>, ParseError> {
        if c.eat_ws(b'=') {
            Ok(Some(c.req_number("value expected")?))
        } else {
            Ok(None)
        }
    };
    match kw {
        MacroKw::Aux | MacroKw::AuxRead | MacroKw::AuxWrite => {
            let node = node(c)?;
            comma(c)?;
            let param = c.req_uint("parameter number expected")?;
            if param > 65535 {
                return Err(c.syntax("parameter 0..65535"));
            }
            Ok(match kw {
                MacroKw::Aux => CmdKind::MacroAux {
                    node,
                    param,
                    value: value(c)?,
                },
                MacroKw::AuxRead => {
                    comma(c)?;
                    CmdKind::MacroAuxRead {
                        node,
                        param,
                        var: pmac_var(c)?,
                    }
                }
                _ => {
                    comma(c)?;
                    CmdKind::MacroAuxWrite {
                        node,
                        param,
                        var: pmac_var(c)?,
                    }
                }
            })
        }
        MacroKw::Slave => {
            c.skip_ws();
            let cmd = if c.eat_kw("$$$***") {
                Some(SlaveCmd::Reinit)
            } else if c.eat_kw("$$$") {
                Some(SlaveCmd::Reset)
            } else if c.eat_kw("CLRF") {
                Some(SlaveCmd::ClearFault)
            } else if c.eat_kw("CONFIG") {
                Some(SlaveCmd::Config(None))
            } else if c.eat_kw("DATE") {
                Some(SlaveCmd::Date)
            } else if c.eat_kw("SAVE") {
                Some(SlaveCmd::Save)
            } else if c.eat_kw("VERSION") || c.eat_kw("VER") {
                Some(SlaveCmd::Version)
            } else {
                None
            };
            if let Some(mut cmd) = cmd {
                let node = node(c)?;
                if cmd == SlaveCmd::Config(None) {
                    if let Some(v) = value(c)? {
                        cmd = SlaveCmd::Config(Some(
                            to_u32(v.value).ok_or_else(|| c.syntax("bad CONFIG value"))?,
                        ));
                    }
                }
                return Ok(CmdKind::MacroSlaveCmd { cmd, node });
            }
            let node = node(c)?;
            comma(c)?;
            let var = slave_var(c)?;
            if let SlaveVar::Mi(first) = var {
                if c.eat_ws(b'.') {
                    if !c.eat(b'.') {
                        return Err(c.syntax("'..' expected"));
                    }
                    let last = c.req_uint("last station variable number expected")?;
                    return Ok(CmdKind::MacroSlaveRange { node, first, last });
                }
            }
            Ok(CmdKind::MacroSlaveVar {
                node,
                var,
                value: value(c)?,
            })
        }
        MacroKw::SlaveRead | MacroKw::SlaveWrite => {
            let node = node(c)?;
            comma(c)?;
            let var = slave_var(c)?;
            comma(c)?;
            let pv = pmac_var(c)?;
            Ok(if kw == MacroKw::SlaveRead {
                CmdKind::MacroSlaveRead {
                    node,
                    var,
                    dest: pv,
                }
            } else {
                CmdKind::MacroSlaveWrite { node, var, src: pv }
            })
        }
    }
}
