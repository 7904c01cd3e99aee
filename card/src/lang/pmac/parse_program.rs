//! Motion-program and PLC statements (pmac-commands.md §5, §6) and their legality per buffer
//! kind (§5.12).

use super::ast::{
    AssignOp, Axis, AxisExtra, AxisWord, BufferKind, CmdKind, CodeLetter, Display, LetterArg,
    Message, MoveMode, PlcVerb, PreludeCall, SendPort, Stmt, StmtKind, VarKind,
};
use super::lexer::Cursor;
use super::parse_defs::{
    self as defs, axis_list, gather_trigger, num_list, plc_control, MAX_MOTOR,
};
use super::parse_expr::{at_var, data, paren_cond, var_ref};
use super::ParseError;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sk {
    Mode(MoveMode),
    Pvt,
    Abs,
    Inc,
    Frax,
    Ta,
    Ts,
    Tm,
    Dwell,
    Delay,
    HomeZ,
    Home,
    Pset,
    Cc(u8),
    Ccr,
    Normal,
    Tsel,
    Tinit,
    Adis,
    Idis,
    Arot,
    Irot,
    If,
    Else,
    EndIf,
    While,
    EndWhile,
    And,
    Or,
    Wait,
    Stop,
    Return,
    Goto,
    Gosub,
    Call,
    Read,
    Prelude,
    BlockStart,
    BlockStop,
    Command,
    Send(SendPort),
    Display,
    Plc(PlcVerb),
    Address,
    SetPhase,
    Gather,
    EndGather,
    Macro(defs::MacroKw),
}

const KEYWORDS: &[(&str, Sk)] = &[
    ("LINEAR", Sk::Mode(MoveMode::Linear)),
    ("LIN", Sk::Mode(MoveMode::Linear)),
    ("RAPID", Sk::Mode(MoveMode::Rapid)),
    ("RPD", Sk::Mode(MoveMode::Rapid)),
    ("CIRCLE1", Sk::Mode(MoveMode::Circle1)),
    ("CIR1", Sk::Mode(MoveMode::Circle1)),
    ("CIRCLE2", Sk::Mode(MoveMode::Circle2)),
    ("CIR2", Sk::Mode(MoveMode::Circle2)),
    ("SPLINE1", Sk::Mode(MoveMode::Spline1)),
    ("SPLINE2", Sk::Mode(MoveMode::Spline2)),
    ("PVT", Sk::Pvt),
    ("ABS", Sk::Abs),
    ("INC", Sk::Inc),
    ("FRAX", Sk::Frax),
    ("TA", Sk::Ta),
    ("TS", Sk::Ts),
    ("TM", Sk::Tm),
    ("DWELL", Sk::Dwell),
    ("DWE", Sk::Dwell),
    ("DELAY", Sk::Delay),
    ("DLY", Sk::Delay),
    ("HOMEZ", Sk::HomeZ),
    ("HMZ", Sk::HomeZ),
    ("HOME", Sk::Home),
    ("HM", Sk::Home),
    ("PSET", Sk::Pset),
    ("CC0", Sk::Cc(0)),
    ("CC1", Sk::Cc(1)),
    ("CC2", Sk::Cc(2)),
    ("CCR", Sk::Ccr),
    ("NORMAL", Sk::Normal),
    ("NRM", Sk::Normal),
    ("TSELECT", Sk::Tsel),
    ("TSEL", Sk::Tsel),
    ("TINIT", Sk::Tinit),
    ("ADIS", Sk::Adis),
    ("IDIS", Sk::Idis),
    ("AROT", Sk::Arot),
    ("IROT", Sk::Irot),
    ("IF", Sk::If),
    ("ELSE", Sk::Else),
    ("ENDIF", Sk::EndIf),
    ("ENDI", Sk::EndIf),
    ("WHILE", Sk::While),
    ("ENDWHILE", Sk::EndWhile),
    ("ENDW", Sk::EndWhile),
    ("AND", Sk::And),
    ("OR", Sk::Or),
    ("WAIT", Sk::Wait),
    ("STOP", Sk::Stop),
    ("RETURN", Sk::Return),
    ("RET", Sk::Return),
    ("GOTO", Sk::Goto),
    ("GOSUB", Sk::Gosub),
    ("CALL", Sk::Call),
    ("READ", Sk::Read),
    ("PRELUDE", Sk::Prelude),
    ("BLOCKSTART", Sk::BlockStart),
    ("BSTART", Sk::BlockStart),
    ("BLOCKSTOP", Sk::BlockStop),
    ("BSTOP", Sk::BlockStop),
    ("COMMAND", Sk::Command),
    ("CMD", Sk::Command),
    ("SEND", Sk::Send(SendPort::Any)),
    ("SENDS", Sk::Send(SendPort::Serial)),
    ("SENDP", Sk::Send(SendPort::Bus)),
    ("DISPLAY", Sk::Display),
    ("DISP", Sk::Display),
    ("ENABLE", Sk::Plc(PlcVerb::Enable)),
    ("ENA", Sk::Plc(PlcVerb::Enable)),
    ("DISABLE", Sk::Plc(PlcVerb::Disable)),
    ("PAUSE", Sk::Plc(PlcVerb::Pause)),
    ("PAU", Sk::Plc(PlcVerb::Pause)),
    ("RESUME", Sk::Plc(PlcVerb::Resume)),
    ("RES", Sk::Plc(PlcVerb::Resume)),
    ("ADDRESS", Sk::Address),
    ("ADR", Sk::Address),
    ("SETPHASE", Sk::SetPhase),
    ("GATHER", Sk::Gather),
    ("GAT", Sk::Gather),
    ("ENDGATHER", Sk::EndGather),
    ("ENDG", Sk::EndGather),
    ("MACROAUXREAD", Sk::Macro(defs::MacroKw::AuxRead)),
    ("MXR", Sk::Macro(defs::MacroKw::AuxRead)),
    ("MACROAUXWRITE", Sk::Macro(defs::MacroKw::AuxWrite)),
    ("MXW", Sk::Macro(defs::MacroKw::AuxWrite)),
    ("MACROSLVREAD", Sk::Macro(defs::MacroKw::SlaveRead)),
    ("MSR", Sk::Macro(defs::MacroKw::SlaveRead)),
    ("MACROSLVWRITE", Sk::Macro(defs::MacroKw::SlaveWrite)),
    ("MSW", Sk::Macro(defs::MacroKw::SlaveWrite)),
];

/// Is `{data}` immediately next (no spaces)?
fn data_next(c: &Cursor) -> bool {
    c.peek() == Some(b'(') || c.at_number()
}

/// An assignment operator at the cursor (after spaces), without consuming it.
fn assign_op_len(c: &Cursor) -> Option<(AssignOp, usize)> {
    let mut k = c.clone();
    k.skip_ws();
    let skipped = k.offset() - c.offset();
    let (op, n) = match (k.peek()?, k.peek_at(1)) {
        (b'=', Some(b'=')) => (AssignOp::SyncSet, 2),
        (b'=', _) => (AssignOp::Set, 1),
        (b'&', Some(b'=')) => (AssignOp::SyncAnd, 2),
        (b'|', Some(b'=')) => (AssignOp::SyncOr, 2),
        (b'^', Some(b'=')) => (AssignOp::SyncXor, 2),
        _ => return None,
    };
    Some((op, skipped + n))
}

/// Parse one statement at the cursor (spaces skipped, not at end). `Ok(None)`: no statement
/// starts here (the caller may try an on-line command). `line_start`: no statement precedes it
/// on this line (labels must start a line). Legality per buffer kind is checked by [`allowed`].
pub(crate) fn statement(
    c: &mut Cursor,
    kind: BufferKind,
    line_start: bool,
) -> Result<Option<Stmt>, ParseError> {
    let pos = c.pos();
    let start = c.offset();
    let Some(first) = c.peek() else {
        return Ok(None);
    };
    // labels
    if matches!(first, b'N' | b'O') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
        if !line_start {
            return Err(c.syntax("a label must start the line"));
        }
        c.bump();
        let n = c.req_uint("label number expected")?;
        if n > 262_143 {
            return Err(c.syntax("label above 262143"));
        }
        return Ok(Some(Stmt {
            kind: StmtKind::Label(n),
            pos,
        }));
    }
    if c.eat_dis_before_plc() {
        let ctl = plc_control(c, PlcVerb::Disable)?;
        return Ok(Some(Stmt {
            kind: StmtKind::Plc(ctl),
            pos,
        }));
    }
    if let Some(sk) = c.eat_longest(KEYWORDS) {
        let k = keyword(c, sk, kind)?;
        return Ok(k.map(|kind| Stmt { kind, pos }));
    }
    // variables: assignment, else I-vector / M-code / on-line query
    if let Some(vk) = at_var(c) {
        let mut k = c.clone();
        let target = var_ref(&mut k)?.ok_or_else(|| c.syntax("variable expected"))?;
        if let Some((op, n)) = assign_op_len(&k) {
            k.advance(n);
            if op != AssignOp::Set && vk != VarKind::M {
                return Err(k.syntax("synchronous assignment needs an M-variable"));
            }
            let value = super::parse_expr::expr(&mut k)?;
            *c = k;
            return Ok(Some(Stmt {
                kind: StmtKind::Assign { target, op, value },
                pos,
            }));
        }
        if k.looking_at("->") || k.looking_at("..") || k.peek() == Some(b',') {
            return Ok(None);
        }
        match vk {
            VarKind::P | VarKind::Q | VarKind::Ext(_) => return Ok(None),
            VarKind::I => {} // circle centre vector, below
            VarKind::M => {
                c.bump();
                let value = data(c)?;
                let args = letter_args(c)?;
                return Ok(Some(Stmt {
                    kind: StmtKind::Code(CodeLetter::M, value, args),
                    pos,
                }));
            }
        }
    }
    c.set_offset(start);
    if Axis::from_letter(first).is_some() && {
        let mut k = c.clone();
        k.bump();
        data_next(&k)
    } {
        return Ok(Some(Stmt {
            kind: StmtKind::Move(axis_words(c, |_| true)?),
            pos,
        }));
    }
    c.bump();
    if !data_next(c) {
        c.set_offset(start);
        return Ok(None);
    }
    let kind = match first {
        b'F' => StmtKind::F(data(c)?),
        b'S' => StmtKind::Spindle(data(c)?),
        b'G' | b'M' | b'T' | b'D' => {
            let letter = match first {
                b'G' => CodeLetter::G,
                b'M' => CodeLetter::M,
                b'T' => CodeLetter::T,
                _ => CodeLetter::D,
            };
            let value = data(c)?;
            StmtKind::Code(letter, value, letter_args(c)?)
        }
        _ => {
            c.set_offset(start);
            return Ok(None);
        }
    };
    Ok(Some(Stmt { kind, pos }))
}

/// Consecutive `{letter}{data}[:{data}|^{data}]` words whose letter passes `ok`.
fn axis_words(c: &mut Cursor, ok: impl Fn(Axis) -> bool) -> Result<Vec<AxisWord>, ParseError> {
    let mut words = Vec::new();
    loop {
        let mut k = c.clone();
        k.skip_ws();
        let Some(axis) = k.peek().and_then(Axis::from_letter).filter(|a| ok(*a)) else {
            break;
        };
        k.bump();
        if !data_next(&k) {
            break;
        }
        // `I5=...` is an assignment, not a centre word
        let mut probe = k.clone();
        data(&mut probe)?;
        if assign_op_len(&probe).is_some() {
            break;
        }
        let value = data(&mut k)?;
        let extra = if k.eat(b':') {
            Some(AxisExtra::Velocity(data(&mut k)?))
        } else if k.peek() == Some(b'^') && k.peek_at(1) != Some(b'=') {
            k.bump();
            Some(AxisExtra::Trigger(data(&mut k)?))
        } else {
            None
        };
        *c = k;
        words.push(AxisWord { axis, value, extra });
    }
    if words.is_empty() {
        return Err(c.syntax("axis word expected"));
    }
    Ok(words)
}

/// READ arguments after CALL / G / M / T / D: `{letter}{data}` pairs (not N or O).
fn letter_args(c: &mut Cursor) -> Result<Vec<LetterArg>, ParseError> {
    let mut args: Vec<LetterArg> = Vec::new();
    loop {
        let mut k = c.clone();
        k.skip_ws();
        let Some(l) = k
            .peek()
            .filter(|l| l.is_ascii_uppercase() && !matches!(l, b'N' | b'O'))
        else {
            break;
        };
        k.bump();
        if !data_next(&k) {
            break;
        }
        let value = data(&mut k)?;
        if assign_op_len(&k).is_some() || matches!(k.peek(), Some(b':' | b'^')) {
            break;
        }
        *c = k;
        args.push(LetterArg { letter: l, value });
    }
    Ok(args)
}

fn message(c: &mut Cursor) -> Result<Message, ParseError> {
    c.skip_ws();
    if c.eat(b'^') {
        let l = c
            .peek()
            .filter(|l| (0x40..=0x5F).contains(l))
            .ok_or_else(|| c.syntax("control letter expected"))?;
        c.bump();
        return Ok(Message::Ctrl(l));
    }
    Ok(Message::Text(quoted(c)?))
}

fn quoted(c: &mut Cursor) -> Result<Vec<u8>, ParseError> {
    if !c.eat(b'"') {
        return Err(c.syntax("'\"' expected"));
    }
    let rest = c.rest();
    let Some(end) = rest.iter().position(|b| *b == b'"') else {
        return Err(c.syntax("unterminated string"));
    };
    let text = rest[..end].to_vec();
    c.advance(end + 1);
    Ok(text)
}

/// Statements of a one-line IF / WHILE / ELSE body, up to end of line or `ELSE`.
fn body(c: &mut Cursor, kind: BufferKind) -> Result<Vec<Stmt>, ParseError> {
    let mut out = Vec::new();
    while !c.at_end() && !c.looking_at("ELSE") {
        let s = statement(c, kind, false)?.ok_or_else(|| c.syntax("statement expected"))?;
        if !allowed(&s.kind, kind) {
            return Err(super::ParseError {
                pos: s.pos.0 as usize,
                ..c.syntax("statement not allowed here")
            });
        }
        out.push(s);
    }
    if out.is_empty() {
        return Err(c.syntax("statement expected"));
    }
    Ok(out)
}

fn keyword(c: &mut Cursor, sk: Sk, kind: BufferKind) -> Result<Option<StmtKind>, ParseError> {
    let uint = |c: &mut Cursor| c.req_uint("number expected");
    Ok(Some(match sk {
        Sk::Mode(m) => StmtKind::Mode(m),
        Sk::Pvt => StmtKind::Pvt(data(c)?),
        Sk::Abs => StmtKind::Abs(axis_list(c, true)?),
        Sk::Inc => StmtKind::Inc(axis_list(c, true)?),
        Sk::Frax => StmtKind::Frax(axis_list(c, false)?),
        Sk::Ta => StmtKind::Ta(data(c)?),
        Sk::Ts => StmtKind::Ts(data(c)?),
        Sk::Tm => StmtKind::Tm(data(c)?),
        Sk::Dwell => StmtKind::Dwell(data(c)?),
        Sk::Delay => StmtKind::Delay(data(c)?),
        Sk::Home | Sk::HomeZ => {
            let mut k = c.clone();
            k.skip_ws();
            if !k.at_digit() {
                return Ok(None); // bare HOME: the on-line command
            }
            let list = num_list(c, MAX_MOTOR)?;
            if sk == Sk::Home {
                StmtKind::Home(list)
            } else {
                StmtKind::HomeZ(list)
            }
        }
        Sk::Pset => StmtKind::Pset(axis_words(c, Axis::is_motion_axis)?),
        Sk::Cc(n) => StmtKind::CutterComp(n),
        Sk::Ccr => StmtKind::CutterRadius(data(c)?),
        Sk::Normal => {
            StmtKind::Normal(axis_words(c, |a| matches!(a, Axis::I | Axis::J | Axis::K))?)
        }
        Sk::Tsel => StmtKind::Tsel(uint(c)?),
        Sk::Tinit => StmtKind::Tinit,
        Sk::Adis => StmtKind::Adis(uint(c)?),
        Sk::Idis => StmtKind::Idis(uint(c)?),
        Sk::Arot => StmtKind::Arot(uint(c)?),
        Sk::Irot => StmtKind::Irot(uint(c)?),
        Sk::If => {
            let cond = paren_cond(c)?;
            if c.at_end() || matches!(kind, BufferKind::Plc(_)) {
                StmtKind::If(cond)
            } else {
                StmtKind::IfLine(cond, body(c, kind)?)
            }
        }
        Sk::Else => {
            if c.at_end() || matches!(kind, BufferKind::Plc(_)) {
                StmtKind::Else(Vec::new())
            } else {
                StmtKind::Else(body(c, kind)?)
            }
        }
        Sk::EndIf => StmtKind::EndIf,
        Sk::While => {
            let cond = paren_cond(c)?;
            if c.at_end() || matches!(kind, BufferKind::Plc(_)) {
                StmtKind::While(cond)
            } else {
                StmtKind::WhileLine(cond, body(c, kind)?)
            }
        }
        Sk::EndWhile => StmtKind::EndWhile,
        Sk::And => StmtKind::AndCond(paren_cond(c)?),
        Sk::Or => StmtKind::OrCond(paren_cond(c)?),
        Sk::Wait => StmtKind::Wait,
        Sk::Stop => StmtKind::Stop,
        Sk::Return => StmtKind::Return,
        Sk::Goto => StmtKind::Goto(data(c)?),
        Sk::Gosub => StmtKind::Gosub(data(c)?, Vec::new()),
        Sk::Call => {
            let target = data(c)?;
            StmtKind::Call(target, letter_args(c)?)
        }
        Sk::Read => {
            if !c.eat_ws(b'(') {
                return Err(c.syntax("'(' expected after READ"));
            }
            let mut letters = Vec::new();
            loop {
                c.skip_ws();
                let l = c
                    .peek()
                    .filter(|l| l.is_ascii_uppercase() && !matches!(l, b'N' | b'O'))
                    .ok_or_else(|| c.syntax("letter expected"))?;
                c.bump();
                letters.push(l);
                if c.eat_ws(b')') {
                    break;
                }
                if !c.eat(b',') {
                    return Err(c.syntax("',' or ')' expected"));
                }
            }
            StmtKind::Read(letters)
        }
        Sk::Prelude => {
            if c.eat(b'0') {
                StmtKind::Prelude(None)
            } else if c.eat(b'1') {
                c.skip_ws();
                let call = if c.eat_kw("CALL") {
                    PreludeCall::Call(c.req_number("constant expected")?)
                } else {
                    let l = match c.peek() {
                        Some(b'G') => CodeLetter::G,
                        Some(b'M') => CodeLetter::M,
                        Some(b'T') => CodeLetter::T,
                        Some(b'D') => CodeLetter::D,
                        _ => return Err(c.syntax("CALL, G, M, T or D expected")),
                    };
                    c.bump();
                    PreludeCall::Code(l, c.number()?.ok_or_else(|| c.syntax("constant expected"))?)
                };
                StmtKind::Prelude(Some(call))
            } else {
                return Err(c.syntax("PRELUDE0 or PRELUDE1 expected"));
            }
        }
        Sk::BlockStart => StmtKind::BlockStart,
        Sk::BlockStop => StmtKind::BlockStop,
        Sk::Command => StmtKind::Command(message(c)?),
        Sk::Send(p) => StmtKind::Send(p, message(c)?),
        Sk::Display => StmtKind::Display(display(c)?),
        Sk::Plc(v) => StmtKind::Plc(plc_control(c, v)?),
        Sk::Address => {
            // Either order (seed 10345: `ADDRESS &2#2`), each part at most once.
            let (mut motor, mut coord) = (None, None);
            for _ in 0..2 {
                if motor.is_none() && c.eat_ws(b'#') {
                    motor = Some(uint(c)?);
                } else if coord.is_none() && c.eat_ws(b'&') {
                    coord = Some(uint(c)?);
                }
            }
            if motor.is_none() && coord.is_none() || motor == Some(0) || coord == Some(0) {
                return Err(c.syntax("#motor and/or &cs expected"));
            }
            StmtKind::Address { motor, coord }
        }
        Sk::SetPhase => StmtKind::SetPhase(num_list(c, MAX_MOTOR)?),
        Sk::Gather => StmtKind::Gather {
            trigger: gather_trigger(c),
        },
        Sk::EndGather => StmtKind::EndGather,
        Sk::Macro(m) => match defs::macro_cmd(c, m)? {
            CmdKind::MacroAuxRead { node, param, var } => {
                StmtKind::MacroAuxRead { node, param, var }
            }
            CmdKind::MacroAuxWrite { node, param, var } => {
                StmtKind::MacroAuxWrite { node, param, var }
            }
            CmdKind::MacroSlaveRead { node, var, dest } => {
                StmtKind::MacroSlaveRead { node, var, dest }
            }
            CmdKind::MacroSlaveWrite { node, var, src } => {
                StmtKind::MacroSlaveWrite { node, var, src }
            }
            _ => return Err(c.syntax("MACRO copy command expected")),
        },
    }))
}

fn display(c: &mut Cursor) -> Result<Display, ParseError> {
    c.skip_ws();
    let pos = if c.at_digit() {
        Some(c.req_uint("position expected")?)
    } else {
        None
    };
    let mut k = c.clone();
    k.skip_ws();
    if k.peek() == Some(b'"') {
        *c = k;
        return Ok(Display::Text {
            pos,
            text: quoted(c)?,
        });
    }
    let pos = pos.ok_or_else(|| c.syntax("position expected"))?;
    if !c.eat_ws(b',') {
        return Err(c.syntax("',' expected"));
    }
    let width = c.req_uint("width expected")?;
    let decimals = if c.eat(b'.') {
        c.req_uint("decimals expected")?
    } else {
        0
    };
    if !c.eat_ws(b',') {
        return Err(c.syntax("',' expected"));
    }
    c.skip_ws();
    let var = var_ref(c)?.ok_or_else(|| c.syntax("variable expected"))?;
    if pos > 79 || !(2..=16).contains(&width) || decimals > 9 || decimals + 2 > width {
        return Err(c.syntax("DISPLAY position/format out of range"));
    }
    Ok(Display::Var {
        pos,
        width,
        decimals,
        var,
    })
}

/// May `s` be stored in a buffer of kind `kind` (pmac-commands.md §5.12, §6.6)?
pub(crate) fn allowed(s: &StmtKind, kind: BufferKind) -> bool {
    use StmtKind as S;
    let prog = kind == BufferKind::Prog;
    let motion = matches!(kind, BufferKind::Prog | BufferKind::Rotary);
    let plc = matches!(kind, BufferKind::Plc(_));
    let bg_plc = matches!(kind, BufferKind::Plc(n) if n > 0);
    match s {
        S::Assign { op, .. } => *op == AssignOp::Set || motion,
        S::Command(_) | S::Send(..) | S::Display(_) | S::Plc(_) | S::SetPhase(_) => true,
        S::Gather { .. } | S::EndGather => true,
        S::If(_) | S::EndIf | S::While(_) | S::EndWhile => prog || plc,
        S::Else(b) => {
            if b.is_empty() {
                prog || plc
            } else {
                prog
            }
        }
        S::AndCond(_) | S::OrCond(_) => plc,
        S::Goto(_) | S::Gosub(..) | S::Read(_) | S::Return | S::Stop => prog,
        S::Address { .. } => bg_plc,
        S::MacroAuxRead { .. }
        | S::MacroAuxWrite { .. }
        | S::MacroSlaveRead { .. }
        | S::MacroSlaveWrite { .. } => bg_plc,
        _ => motion,
    }
}
