//! On-line commands (pmac-commands.md §3): dispatch on the first character, keyword table with
//! longest match, then variable / letter forms (§1.4 tokenizer decision).
//!
//! `command` returns `Ok(None)` when the text is not an on-line command (it may be a program
//! statement, which the caller turns into ERR005, or garbage → ERR003).

use super::ast::{Axis, CmdKind, Command, JogKind, MemSpace, VarIndex, VarKind, VarList, VarSel};
use super::lexer::Cursor;
use super::parse_defs::{self as defs, MAX_MOTOR, MAX_SPAN};
use super::parse_expr::{at_var, expr, paren_expr};
use super::ParseError;

/// Tags of the on-line keyword table. `Prog` marks program-only keywords (so that e.g.
/// `DELAY` is not mistaken for `DEL AY`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kw {
    Abs,
    Inc,
    Frax,
    Checksum,
    ClearFault,
    Clear,
    Close,
    Cid,
    Cpu,
    Date,
    Define,
    Delete,
    Disable,
    Enable,
    EaVersion,
    EndGather,
    Gather,
    HomeZ,
    Home,
    Learn,
    List,
    MxRead,
    MxWrite,
    Mx,
    MsRead,
    MsWrite,
    Ms,
    MFlush,
    Open,
    Password,
    Pause,
    PMatch,
    Pc,
    Pe,
    Pr,
    Resume,
    Save,
    SetPhase,
    Size,
    Type,
    Undefine,
    Version,
    Rh,
    Prog,
}

const KEYWORDS: &[(&str, Kw)] = &[
    ("ABS", Kw::Abs),
    ("INC", Kw::Inc),
    ("FRAX", Kw::Frax),
    ("CHECKSUM", Kw::Checksum),
    ("CHKS", Kw::Checksum),
    ("CLEARFAULT", Kw::ClearFault),
    ("CLRF", Kw::ClearFault),
    ("CLEAR", Kw::Clear),
    ("CLR", Kw::Clear),
    ("CLOSE", Kw::Close),
    ("CLS", Kw::Close),
    ("CID", Kw::Cid),
    ("CPU", Kw::Cpu),
    ("DATE", Kw::Date),
    ("DAT", Kw::Date),
    ("DEFINE", Kw::Define),
    ("DEF", Kw::Define),
    ("DELETE", Kw::Delete),
    ("DEL", Kw::Delete),
    ("DISABLE", Kw::Disable),
    ("DIS", Kw::Disable),
    ("ENABLE", Kw::Enable),
    ("ENA", Kw::Enable),
    ("EAVERSION", Kw::EaVersion),
    ("EAVER", Kw::EaVersion),
    ("ENDGATHER", Kw::EndGather),
    ("ENDG", Kw::EndGather),
    ("GATHER", Kw::Gather),
    ("GAT", Kw::Gather),
    ("HOMEZ", Kw::HomeZ),
    ("HMZ", Kw::HomeZ),
    ("HOME", Kw::Home),
    ("HM", Kw::Home),
    ("LEARN", Kw::Learn),
    ("LRN", Kw::Learn),
    ("LIST", Kw::List),
    ("LIS", Kw::List),
    ("MACROAUXREAD", Kw::MxRead),
    ("MXR", Kw::MxRead),
    ("MACROAUXWRITE", Kw::MxWrite),
    ("MXW", Kw::MxWrite),
    ("MACROAUX", Kw::Mx),
    ("MX", Kw::Mx),
    ("MACROSLVREAD", Kw::MsRead),
    ("MSR", Kw::MsRead),
    ("MACROSLVWRITE", Kw::MsWrite),
    ("MSW", Kw::MsWrite),
    ("MACROSLAVE", Kw::Ms),
    ("MACROSLV", Kw::Ms),
    ("MS", Kw::Ms),
    ("MFLUSH", Kw::MFlush),
    ("OPEN", Kw::Open),
    ("PASSWORD", Kw::Password),
    ("PAUSE", Kw::Pause),
    ("PAU", Kw::Pause),
    ("PMATCH", Kw::PMatch),
    ("PC", Kw::Pc),
    ("PE", Kw::Pe),
    ("PR", Kw::Pr),
    ("RESUME", Kw::Resume),
    ("RES", Kw::Resume),
    ("SAVE", Kw::Save),
    ("SETPHASE", Kw::SetPhase),
    ("SIZE", Kw::Size),
    ("TYPE", Kw::Type),
    ("UNDEFINE", Kw::Undefine),
    ("UNDEF", Kw::Undefine),
    ("VERSION", Kw::Version),
    ("VER", Kw::Version),
    ("RH", Kw::Rh),
    // program-only keywords: recognised so they are not split into on-line commands
    ("ADDRESS", Kw::Prog),
    ("ADR", Kw::Prog),
    ("ADIS", Kw::Prog),
    ("AND", Kw::Prog),
    ("AROT", Kw::Prog),
    ("BLOCKSTART", Kw::Prog),
    ("BLOCKSTOP", Kw::Prog),
    ("BSTART", Kw::Prog),
    ("BSTOP", Kw::Prog),
    ("CALL", Kw::Prog),
    ("CC0", Kw::Prog),
    ("CC1", Kw::Prog),
    ("CC2", Kw::Prog),
    ("CCR", Kw::Prog),
    ("CIRCLE1", Kw::Prog),
    ("CIRCLE2", Kw::Prog),
    ("CIR1", Kw::Prog),
    ("CIR2", Kw::Prog),
    ("CMD", Kw::Prog),
    ("COMMAND", Kw::Prog),
    ("DELAY", Kw::Prog),
    ("DLY", Kw::Prog),
    ("DISPLAY", Kw::Prog),
    ("DISP", Kw::Prog),
    ("DWELL", Kw::Prog),
    ("DWE", Kw::Prog),
    ("ELSE", Kw::Prog),
    ("ENDIF", Kw::Prog),
    ("ENDI", Kw::Prog),
    ("ENDWHILE", Kw::Prog),
    ("ENDW", Kw::Prog),
    ("GOSUB", Kw::Prog),
    ("GOTO", Kw::Prog),
    ("IDIS", Kw::Prog),
    ("IF", Kw::Prog),
    ("IROT", Kw::Prog),
    ("LINEAR", Kw::Prog),
    ("LIN", Kw::Prog),
    ("NORMAL", Kw::Prog),
    ("NRM", Kw::Prog),
    ("OR", Kw::Prog),
    ("PRELUDE", Kw::Prog),
    ("PSET", Kw::Prog),
    ("PVT", Kw::Prog),
    ("RAPID", Kw::Prog),
    ("RPD", Kw::Prog),
    ("READ", Kw::Prog),
    ("RETURN", Kw::Prog),
    ("RET", Kw::Prog),
    ("SEND", Kw::Prog),
    ("SPLINE1", Kw::Prog),
    ("SPLINE2", Kw::Prog),
    ("STOP", Kw::Prog),
    ("TA", Kw::Prog),
    ("TINIT", Kw::Prog),
    ("TM", Kw::Prog),
    ("TS", Kw::Prog),
    ("TSEL", Kw::Prog),
    ("TSELECT", Kw::Prog),
    ("WAIT", Kw::Prog),
    ("WHILE", Kw::Prog),
];

/// Parse one on-line command at the cursor (spaces already skipped, not at end).
pub(crate) fn command(c: &mut Cursor) -> Result<Option<Command>, ParseError> {
    let pos = c.pos();
    let start = c.offset();
    let kind = match c.peek() {
        Some(b'#') => {
            c.bump();
            match c.uint()? {
                None => CmdKind::ReportMotor,
                Some(n) if c.eat_kw("->") => super::parse_mdef::axis_def(c, n)?,
                Some(0) => return Err(c.syntax("motor 0 does not exist")),
                Some(n) => CmdKind::AddrMotor(n),
            }
        }
        Some(b'&') => {
            c.bump();
            match c.uint()? {
                None => CmdKind::ReportCoord,
                Some(0) => return Err(c.syntax("coordinate system 0 does not exist")),
                Some(n) => CmdKind::AddrCoord(n),
            }
        }
        Some(b'@') => {
            c.bump();
            if c.eat(b'@') {
                CmdKind::AddrAllCards
            } else if let Some(d) = c.peek().and_then(|d| (d as char).to_digit(16)) {
                c.bump();
                CmdKind::AddrCard(d as u8)
            } else {
                CmdKind::ReportCard
            }
        }
        Some(b'$') => dollar(c)?,
        Some(b'%') => {
            c.bump();
            if c.at_number() {
                let n = c.req_number("override value expected")?;
                if n.value < 0.0 {
                    return Err(c.syntax("negative override"));
                }
                CmdKind::OverrideSet(n.value)
            } else {
                CmdKind::OverrideQuery
            }
        }
        Some(b'?') => {
            let mut n = 0;
            while n < 3 && c.eat(b'?') {
                n += 1;
            }
            [
                CmdKind::MotorStatus,
                CmdKind::CsStatus,
                CmdKind::GlobalStatus,
            ][n - 1]
                .clone()
        }
        Some(b'/') => one(c, CmdKind::StopAtEnd),
        Some(b'\\') => one(c, CmdKind::HoldJog),
        Some(b'<') => one(c, CmdKind::BackUp),
        Some(b'>') => one(c, CmdKind::Resume),
        Some(b'0'..=b'9' | b'.' | b'-') => {
            if c.peek() == Some(b'-') && !c.at_number() {
                return Err(c.syntax("number expected after '-'"));
            }
            CmdKind::BareNumber(c.req_number("number expected")?)
        }
        Some(b'A'..=b'Z') => match letters(c)? {
            Some(k) => k,
            None => {
                c.set_offset(start);
                return Ok(None);
            }
        },
        _ => return Err(c.syntax("illegal command")),
    };
    Ok(Some(Command { kind, pos }))
}

fn one(c: &mut Cursor, k: CmdKind) -> CmdKind {
    c.bump();
    k
}

fn dollar(c: &mut Cursor) -> Result<CmdKind, ParseError> {
    if c.eat_kw("$$$***") {
        return Ok(CmdKind::Reinit);
    }
    if c.eat_kw("$$$") {
        return Ok(CmdKind::Reset);
    }
    if c.eat_kw("$*") {
        return Ok(CmdKind::MotorAbsRead);
    }
    if c.peek_at(1).is_some_and(|d| d.is_ascii_hexdigit()) {
        return Ok(CmdKind::BareNumber(c.req_number("hex constant expected")?));
    }
    c.bump();
    Ok(CmdKind::MotorInit)
}

/// Is `{data}` (digit, `.`, `$`, `-`, `(`) *immediately* next?
fn data_next(c: &Cursor) -> bool {
    c.peek() == Some(b'(') || c.at_number()
}

/// Letter-initial commands. `Ok(None)` = a program statement / not on-line.
fn letters(c: &mut Cursor) -> Result<Option<CmdKind>, ParseError> {
    let save = c.offset();
    if c.eat_dis_before_plc() {
        return keyword(c, Kw::Disable);
    }
    if let Some(kw) = c.eat_longest(KEYWORDS) {
        return keyword(c, kw);
    }
    c.set_offset(save);
    if let Some(kind) = at_var(c) {
        return var_command(c, kind);
    }
    let l = c.peek().unwrap_or(b' ');
    c.bump();
    // `{axis}={constant}` rename (not `==`)
    if let Some(ax) = Axis::from_letter(l).filter(|a| a.is_motion_axis()) {
        let mut k = c.clone();
        k.skip_ws();
        if k.peek() == Some(b'=') && k.peek_at(1) != Some(b'=') {
            k.bump();
            *c = k;
            let n = c.req_number("constant expected after '='")?;
            return Ok(Some(CmdKind::AxisRename(ax, n.value)));
        }
    }
    let with_data = data_next(c);
    Ok(Some(match l {
        b'A' if !with_data => CmdKind::Abort,
        b'B' if with_data => {
            let n = c
                .number()?
                .ok_or_else(|| c.syntax("constant expected after B"))?;
            CmdKind::Begin(n)
        }
        b'F' if !with_data => CmdKind::FollowingError,
        b'H' if !with_data => CmdKind::Hold,
        b'J' => jog(c)?,
        b'K' if !with_data => CmdKind::Kill,
        b'O' if with_data => {
            let n = c
                .number()?
                .ok_or_else(|| c.syntax("constant expected after O"))?;
            CmdKind::OpenLoop(n.value)
        }
        b'P' => CmdKind::Position,
        b'Q' => CmdKind::Quit,
        b'R' => match mem_space(c) {
            Some(space) => {
                let (addr, count) = defs::mem_addr_count(c)?;
                CmdKind::ReadMem {
                    hex: false,
                    space,
                    addr,
                    count,
                }
            }
            None if with_data => return Ok(None),
            None => CmdKind::Run,
        },
        b'S' if !with_data => CmdKind::Step,
        b'V' if !with_data => CmdKind::Velocity,
        b'W' => match mem_space(c) {
            Some(space) => defs::write_mem(c, space)?,
            None if with_data => return Ok(None),
            None => return Err(c.syntax("W needs X:, Y: or L: and an address")),
        },
        b'Z' if !with_data => CmdKind::ZeroAxes,
        // letter + data on-line = a program statement (→ ERR005 by the caller)
        _ if with_data => return Ok(None),
        _ => {
            return Err(ParseError {
                pos: save,
                ..c.syntax("unrecognised command")
            })
        }
    }))
}

/// `X`/`Y`/`L` (with optional `:`) followed by an address.
fn mem_space(c: &mut Cursor) -> Option<MemSpace> {
    let space = match c.peek()? {
        b'X' => MemSpace::X,
        b'Y' => MemSpace::Y,
        b'L' => MemSpace::L,
        _ => return None,
    };
    let mut k = c.clone();
    k.bump();
    k.eat(b':');
    if k.at_unsigned_number() {
        *c = k;
        Some(space)
    } else {
        None
    }
}

fn keyword(c: &mut Cursor, kw: Kw) -> Result<Option<CmdKind>, ParseError> {
    Ok(Some(match kw {
        Kw::Prog => return Ok(None),
        Kw::Abs => CmdKind::Abs(defs::axis_list(c, true)?),
        Kw::Inc => CmdKind::Inc(defs::axis_list(c, true)?),
        Kw::Frax => CmdKind::Frax(defs::axis_list(c, false)?),
        Kw::Learn => CmdKind::Learn(defs::axis_list(c, false)?),
        Kw::Checksum => CmdKind::Checksum,
        Kw::ClearFault => CmdKind::ClearFault,
        Kw::Clear => CmdKind::Clear,
        Kw::Close => CmdKind::Close,
        Kw::Cid => CmdKind::Cid,
        Kw::Cpu => CmdKind::Cpu,
        Kw::Date => CmdKind::Date,
        Kw::Define => CmdKind::Define(defs::define_target(c)?),
        Kw::Delete => CmdKind::Delete(defs::delete_target(c)?),
        Kw::Disable | Kw::Enable | Kw::Pause | Kw::Resume => {
            CmdKind::Plc(defs::plc_control(c, kw_verb(kw))?)
        }
        Kw::EaVersion => CmdKind::EaVersion,
        Kw::EndGather => CmdKind::EndGather,
        Kw::Gather => CmdKind::Gather {
            trigger: defs::gather_trigger(c),
        },
        Kw::HomeZ | Kw::Home => {
            if data_next(c) {
                return Ok(None); // HOME{list} is the program statement
            }
            if kw == Kw::Home {
                CmdKind::Home
            } else {
                CmdKind::HomeZ
            }
        }
        Kw::List => CmdKind::List(defs::list_target(c)?),
        Kw::Mx | Kw::MxRead | Kw::MxWrite | Kw::Ms | Kw::MsRead | Kw::MsWrite => {
            defs::macro_cmd(c, kw_macro(kw))?
        }
        Kw::MFlush => CmdKind::MFlush,
        Kw::Open => CmdKind::Open(defs::open_target(c)?),
        Kw::Password => {
            if !c.eat_ws(b'=') {
                return Err(c.syntax("'=' expected after PASSWORD"));
            }
            let mut text = c.rest().to_vec();
            while text.last().is_some_and(|b| *b == b'\r' || *b == b'\n') {
                text.pop();
            }
            c.advance(c.rest().len());
            CmdKind::Password(text)
        }
        Kw::PMatch => CmdKind::PMatch,
        Kw::Pc => CmdKind::ProgCounter,
        Kw::Pe => CmdKind::ExecPointer,
        Kw::Pr => CmdKind::RotaryRemaining,
        Kw::Save => CmdKind::Save,
        Kw::SetPhase => CmdKind::SetPhase(defs::num_list(c, MAX_MOTOR)?),
        Kw::Size => CmdKind::Size,
        Kw::Type => CmdKind::Type,
        Kw::Undefine => {
            let mut k = c.clone();
            k.skip_ws();
            if k.eat_kw("ALL") {
                *c = k;
                CmdKind::UndefineAll
            } else {
                CmdKind::Undefine
            }
        }
        Kw::Version => CmdKind::Version,
        Kw::Rh => match mem_space(c) {
            Some(space) => {
                let (addr, count) = defs::mem_addr_count(c)?;
                CmdKind::ReadMem {
                    hex: true,
                    space,
                    addr,
                    count,
                }
            }
            None => return Err(c.syntax("RH needs X:, Y: or L: and an address")),
        },
    }))
}

fn kw_verb(kw: Kw) -> super::ast::PlcVerb {
    use super::ast::PlcVerb;
    match kw {
        Kw::Disable => PlcVerb::Disable,
        Kw::Enable => PlcVerb::Enable,
        Kw::Pause => PlcVerb::Pause,
        _ => PlcVerb::Resume,
    }
}

fn kw_macro(kw: Kw) -> defs::MacroKw {
    match kw {
        Kw::Mx => defs::MacroKw::Aux,
        Kw::MxRead => defs::MacroKw::AuxRead,
        Kw::MxWrite => defs::MacroKw::AuxWrite,
        Kw::Ms => defs::MacroKw::Slave,
        Kw::MsRead => defs::MacroKw::SlaveRead,
        _ => defs::MacroKw::SlaveWrite,
    }
}

/// `I/P/Q/M` selection and what follows it (query, `=expr`, `=*`, `->`, `->def`).
fn var_command(c: &mut Cursor, kind: VarKind) -> Result<Option<CmdKind>, ParseError> {
    let pos = c.pos();
    c.bump();
    let sel = if c.peek() == Some(b'(') {
        VarSel::One(VarIndex::Expr(Box::new(paren_expr(c)?)))
    } else {
        let first = c
            .uint()?
            .ok_or_else(|| c.syntax("variable number expected"))?;
        if c.eat_kw("..") {
            let last = c.uint()?.ok_or_else(|| c.syntax("range end expected"))?;
            if last < first || last - first >= MAX_SPAN {
                return Err(c.syntax("range end below start or range too long"));
            }
            VarSel::Range { first, last }
        } else if c.peek() == Some(b',') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
            c.bump();
            let count = c.uint()?.unwrap_or(0);
            let step = if c.peek() == Some(b',') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit())
            {
                c.bump();
                c.uint()?.unwrap_or(0)
            } else {
                1
            };
            if count == 0 || step == 0 || count > MAX_SPAN {
                return Err(c.syntax("count and step must be at least 1"));
            }
            VarSel::Strided { first, count, step }
        } else {
            VarSel::One(VarIndex::Const(first))
        }
    };
    let list = VarList { kind, sel, pos };
    if kind == VarKind::M && c.eat_kw("->") {
        return Ok(Some(match super::parse_mdef::mdef(c)? {
            Some(d) => CmdKind::MDefine(list, d),
            None => CmdKind::MDefQuery(list),
        }));
    }
    let mut k = c.clone();
    k.skip_ws();
    match (k.peek(), k.peek_at(1)) {
        (Some(b'='), Some(b'=')) | (Some(b'&' | b'|' | b'^'), Some(b'=')) => Ok(None),
        (Some(b'='), _) => {
            k.bump();
            *c = k;
            let mut s = c.clone();
            s.skip_ws();
            if s.eat(b'*') {
                *c = s;
                return Ok(Some(CmdKind::VarDefault(list)));
            }
            let e = expr(c)?;
            Ok(Some(CmdKind::VarAssign(list, e)))
        }
        _ => Ok(Some(CmdKind::VarQuery(list))),
    }
}

/// `J` forms (the `J` is consumed).
fn jog(c: &mut Cursor) -> Result<CmdKind, ParseError> {
    let value = |c: &mut Cursor| -> Result<f64, ParseError> {
        Ok(c.req_number("jog distance expected")?.value)
    };
    let kind = if c.eat(b'+') {
        JogKind::Plus
    } else if c.eat(b'-') {
        JogKind::Minus
    } else if c.eat(b'/') {
        JogKind::Stop
    } else if c.eat(b'!') {
        JogKind::Round
    } else if c.eat_kw("==") {
        JogKind::ToAndSetPreJog(value(c)?)
    } else if c.eat(b'=') {
        if c.eat(b'*') {
            JogKind::VarTo
        } else if c.at_number() {
            JogKind::To(value(c)?)
        } else {
            JogKind::PreJog
        }
    } else if c.eat(b':') {
        if c.eat(b'*') {
            JogKind::VarRelCommanded
        } else {
            JogKind::RelCommanded(value(c)?)
        }
    } else if c.eat(b'^') {
        if c.eat(b'*') {
            JogKind::VarRelActual
        } else {
            JogKind::RelActual(value(c)?)
        }
    } else {
        return Err(c.syntax("jog form expected after J"));
    };
    let definite = !matches!(
        kind,
        JogKind::Plus | JogKind::Minus | JogKind::Stop | JogKind::Round
    );
    let trigger = if definite && c.eat(b'^') {
        Some(value(c)?)
    } else {
        None
    };
    Ok(CmdKind::Jog { kind, trigger })
}
