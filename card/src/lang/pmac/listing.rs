//! Canonical text of stored statements (what `LIST PROG` prints), M-variable definitions and
//! motor axis definitions. Short keywords when `long` is false (I9 = 0 or 2), long keywords when
//! true (I9 = 1 or 3), pmac-commands.md §1.8 / §2.4. Guarantee: re-parsing the listing of a
//! statement gives an equal statement (`parse(list(s)) == s`).
//!
//! The word-count model of stored statements is the domain's (`crate::domain::words`).

use std::fmt::Write;

#[cfg(test)]
use super::ast::AxisDef;

use super::ast::{
    AssignOp, Axis, AxisExtra, AxisWord, BinOp, CmpOp, CodeLetter, Cond, Display, Expr, ExprKind,
    Func, LetterArg, Message, MoveMode, NumRange, Number, PlcVerb, PreludeCall, SendPort, SlaveVar,
    Stmt, StmtKind, VarIndex, VarKind, VarRef,
};

/// A literal as written: `$hex` kept, decimals in shortest round-trip form, never exponent.
pub(crate) fn number(n: &Number) -> String {
    if n.hex && n.value.fract() == 0.0 && n.value.abs() < 2f64.powi(48) {
        let sign = if n.value < 0.0 { "-" } else { "" };
        format!("{sign}${:X}", n.value.abs() as u64)
    } else {
        format!("{}", n.value)
    }
}

/// `P12`, `P(P1+2)`.
pub(crate) fn var(v: &VarRef) -> String {
    let l = match v.kind {
        VarKind::I => 'I',
        VarKind::P => 'P',
        VarKind::Q => 'Q',
        VarKind::M => 'M',
        // Families of another dialect never reach a PMAC listing.
        VarKind::Ext(_) => 'X',
    };
    match &v.index {
        VarIndex::Const(n) => format!("{l}{n}"),
        VarIndex::Expr(e) => format!("{l}({})", expr(e)),
    }
}

fn func_name(f: Func) -> &'static str {
    match f {
        Func::Sin => "SIN",
        Func::Cos => "COS",
        Func::Tan => "TAN",
        Func::Asin => "ASIN",
        Func::Acos => "ACOS",
        Func::Atan => "ATAN",
        Func::Atan2 => "ATAN2",
        Func::Ln => "LN",
        Func::Exp => "EXP",
        Func::Sqrt => "SQRT",
        Func::Abs => "ABS",
        Func::Int => "INT",
    }
}

fn op_char(op: BinOp) -> char {
    match op {
        BinOp::Mul => '*',
        BinOp::Div => '/',
        BinOp::Mod => '%',
        BinOp::And => '&',
        BinOp::Add => '+',
        BinOp::Sub => '-',
        BinOp::Or => '|',
        BinOp::Xor => '^',
        // Not PMAC operators (another dialect's programs are listed by that dialect).
        BinOp::Shl | BinOp::Shr | BinOp::FMod => '?',
    }
}

/// An expression with the minimum parentheses that re-parse to the same tree.
pub(crate) fn expr(e: &Expr) -> String {
    let mut s = String::new();
    write_expr(&mut s, e);
    s
}

fn write_expr(s: &mut String, e: &Expr) {
    match &e.kind {
        ExprKind::Num(n) => s.push_str(&number(n)),
        ExprKind::Var(v) => s.push_str(&var(v)),
        ExprKind::Call(f, a) => {
            let _ = write!(s, "{}(", func_name(*f));
            write_expr(s, a);
            s.push(')');
        }
        ExprKind::Neg(inner) => {
            s.push('-');
            let paren = matches!(inner.kind, ExprKind::Bin(..) | ExprKind::Num(_));
            wrap(s, inner, paren);
        }
        ExprKind::Bin(op, l, r) => {
            let p = op.precedence();
            let lp = matches!(&l.kind, ExprKind::Bin(o, ..) if o.precedence() < p);
            let rp = matches!(&r.kind, ExprKind::Bin(o, ..) if o.precedence() <= p);
            wrap(s, l, lp);
            s.push(op_char(*op));
            wrap(s, r, rp);
        }
        // Not PMAC expressions (another dialect's programs are listed by that dialect).
        ExprKind::Math(..) | ExprKind::BitNot(_) | ExprKind::Test(_) | ExprKind::Strided(_) => {
            s.push('?')
        }
    }
}

fn wrap(s: &mut String, e: &Expr, paren: bool) {
    if paren {
        s.push('(');
        write_expr(s, e);
        s.push(')');
    } else {
        write_expr(s, e);
    }
}

/// `{data}`: a literal as is, anything else in parentheses.
pub(crate) fn data(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Num(n) => number(n),
        _ => format!("({})", expr(e)),
    }
}

fn cmp_str(op: CmpOp) -> &'static str {
    match op {
        CmpOp::Eq => "=",
        CmpOp::Ne => "!=",
        CmpOp::Gt => ">",
        CmpOp::NotGt => "!>",
        CmpOp::Lt => "<",
        CmpOp::NotLt => "!<",
        CmpOp::Approx => "~",
        CmpOp::NotApprox => "!~",
        CmpOp::Near => "~",
        CmpOp::NotNear => "!~",
    }
}

/// A condition without its outer parentheses.
pub(crate) fn cond(c: &Cond) -> String {
    match c {
        Cond::Cmp { lhs, op, rhs } => format!("{}{}{}", expr(lhs), cmp_str(*op), expr(rhs)),
        Cond::And(a, b) => {
            let pa = matches!(**a, Cond::Or(..));
            let pb = matches!(**b, Cond::Or(..) | Cond::And(..));
            format!("{} AND {}", group(a, pa), group(b, pb))
        }
        Cond::Or(a, b) => format!("{} OR {}", cond(a), group(b, matches!(**b, Cond::Or(..)))),
        Cond::Value(e) => expr(e),
        Cond::Not(c) => format!("!({})", cond(c)),
    }
}

fn group(c: &Cond, paren: bool) -> String {
    if paren {
        format!("({})", cond(c))
    } else {
        cond(c)
    }
}

fn axis_word(w: &AxisWord) -> String {
    let mut s = format!("{}{}", w.axis.letter(), data(&w.value));
    match &w.extra {
        Some(AxisExtra::Velocity(v)) => {
            let _ = write!(s, ":{}", data(v));
        }
        Some(AxisExtra::Trigger(t)) => {
            let _ = write!(s, "^{}", data(t));
        }
        None => {}
    }
    s
}

fn words(ws: &[AxisWord]) -> String {
    ws.iter().map(axis_word).collect::<Vec<_>>().join(" ")
}

fn args(a: &[LetterArg]) -> String {
    a.iter()
        .map(|x| format!(" {}{}", x.letter as char, data(&x.value)))
        .collect()
}

fn num_list(l: &[NumRange]) -> String {
    l.iter()
        .map(|r| {
            if r.first == r.last {
                r.first.to_string()
            } else {
                format!("{}..{}", r.first, r.last)
            }
        })
        .collect::<Vec<_>>()
        .join(",")
}

fn axes(l: &Option<Vec<Axis>>) -> String {
    match l {
        None => String::new(),
        Some(v) => format!(
            "({})",
            v.iter()
                .map(|a| a.letter().to_string())
                .collect::<Vec<_>>()
                .join(",")
        ),
    }
}

fn message(m: &Message) -> String {
    match m {
        Message::Text(t) => format!("\"{}\"", String::from_utf8_lossy(t)),
        Message::Ctrl(c) => format!("^{}", *c as char),
    }
}

fn code_letter(l: CodeLetter) -> char {
    match l {
        CodeLetter::G => 'G',
        CodeLetter::M => 'M',
        CodeLetter::T => 'T',
        CodeLetter::D => 'D',
    }
}

fn slave_var(v: &SlaveVar) -> String {
    match v {
        SlaveVar::Mi(n) => format!("MI{n}"),
        SlaveVar::Mc(n) => format!("MC{n}"),
    }
}

/// Statements of one line, separated by single spaces.
pub(crate) fn line(stmts: &[Stmt], long: bool) -> String {
    stmts
        .iter()
        .map(|s| stmt(s, long))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Canonical text of one statement.
pub(crate) fn stmt(s: &Stmt, long: bool) -> String {
    let kw = |l: &'static str, sh: &'static str| if long { l } else { sh };
    use StmtKind as S;
    match &s.kind {
        S::Label(n) => format!("N{n}"),
        // Statements of another dialect (listed by that dialect).
        S::Do
        | S::DoWhile(_)
        | S::Break
        | S::Continue
        | S::Switch(_)
        | S::Case(_)
        | S::Default
        | S::EndSwitch
        | S::CallSub(..)
        | S::SyncLabel(_) => "?".into(),
        S::Assign { target, op, value } => {
            let o = match op {
                AssignOp::Set => "=",
                AssignOp::SyncSet => "==",
                AssignOp::SyncAnd => "&=",
                AssignOp::SyncOr => "|=",
                AssignOp::SyncXor => "^=",
                // Not PMAC assignments (another dialect's programs are listed by it).
                AssignOp::Op(_) | AssignOp::SyncOp(_) => "?=",
            };
            format!("{}{o}{}", var(target), expr(value))
        }
        S::Move(w) => words(w),
        S::Mode(m) => match m {
            MoveMode::Linear => kw("LINEAR", "LIN"),
            MoveMode::Rapid => kw("RAPID", "RPD"),
            MoveMode::Circle1 => kw("CIRCLE1", "CIR1"),
            MoveMode::Circle2 => kw("CIRCLE2", "CIR2"),
            MoveMode::Spline1 => "SPLINE1",
            MoveMode::Spline2 => "SPLINE2",
        }
        .to_string(),
        S::Pvt(d) => format!("PVT{}", data(d)),
        // Power statements (that dialect lists its programs from their text).
        S::Spline(d) => format!("SPLINE{}", data(d)),
        S::Td(d) => format!("TD{}", data(d)),
        S::SendFormat { text, args, .. } | S::CommandFormat { text, args } => {
            let head = match &s.kind {
                S::SendFormat { port, .. } => format!("SEND{port},"),
                _ => "CMD".to_string(),
            };
            let mut t = format!("{head}\"{}\"", String::from_utf8_lossy(text));
            for a in args {
                t.push(',');
                t.push_str(&data(a));
            }
            t
        }
        S::Abs(l) => format!("ABS{}", axes(l)),
        S::Inc(l) => format!("INC{}", axes(l)),
        S::Frax(l) => format!("FRAX{}", axes(l)),
        S::Ta(d) => format!("TA{}", data(d)),
        S::Ts(d) => format!("TS{}", data(d)),
        S::Tm(d) => format!("TM{}", data(d)),
        S::F(d) => format!("F{}", data(d)),
        S::Dwell(d) => format!("{}{}", kw("DWELL", "DWE"), data(d)),
        S::Delay(d) => format!("{}{}", kw("DELAY", "DLY"), data(d)),
        S::Home(l) => format!("{}{}", kw("HOME", "HM"), num_list(l)),
        S::HomeZ(l) => format!("{}{}", kw("HOMEZ", "HMZ"), num_list(l)),
        S::Pset(w) => format!("PSET {}", words(w)),
        S::Pmatch => "PMATCH".into(),
        S::Pstore => "PSTORE".into(),
        S::Pload => "PLOAD".into(),
        S::CutterComp(n) => format!("CC{n}"),
        S::CutterRadius(d) => format!("CCR{}", data(d)),
        S::Normal(w) => format!("{} {}", kw("NORMAL", "NRM"), words(w)),
        S::Tsel(n) => format!("{}{n}", kw("TSELECT", "TSEL")),
        S::Tinit => "TINIT".into(),
        S::Adis(n) => format!("ADIS{n}"),
        S::Idis(n) => format!("IDIS{n}"),
        S::Arot(n) => format!("AROT{n}"),
        S::Irot(n) => format!("IROT{n}"),
        S::If(c) => format!("IF ({})", cond(c)),
        S::IfLine(c, b) => format!("IF ({}) {}", cond(c), line(b, long)),
        S::Else(b) if b.is_empty() => "ELSE".into(),
        S::Else(b) => format!("ELSE {}", line(b, long)),
        S::EndIf => kw("ENDIF", "ENDI").into(),
        S::While(c) => format!("WHILE ({})", cond(c)),
        S::WhileLine(c, b) => format!("WHILE ({}) {}", cond(c), line(b, long)),
        S::EndWhile => kw("ENDWHILE", "ENDW").into(),
        S::AndCond(c) => format!("AND ({})", cond(c)),
        S::OrCond(c) => format!("OR ({})", cond(c)),
        S::Wait => "WAIT".into(),
        S::Stop => "STOP".into(),
        S::Return => kw("RETURN", "RET").into(),
        S::Goto(d) => format!("GOTO{}", data(d)),
        S::Gosub(d, a) => format!("GOSUB{}{}", data(d), args(a)),
        S::Call(d, a) => format!("CALL{}{}", data(d), args(a)),
        S::Code(l, d, a) => format!("{}{}{}", code_letter(*l), data(d), args(a)),
        S::Read(l) => format!(
            "READ({})",
            l.iter()
                .map(|c| (*c as char).to_string())
                .collect::<Vec<_>>()
                .join(",")
        ),
        S::Prelude(None) => "PRELUDE0".into(),
        S::Prelude(Some(PreludeCall::Call(n))) => format!("PRELUDE1 CALL{}", number(n)),
        S::Prelude(Some(PreludeCall::Code(l, n))) => {
            format!("PRELUDE1 {}{}", code_letter(*l), number(n))
        }
        S::Spindle(d) => format!("S{}", data(d)),
        S::BlockStart => kw("BLOCKSTART", "BSTART").into(),
        S::BlockStop => kw("BLOCKSTOP", "BSTOP").into(),
        S::Command(m) => format!("{}{}", kw("COMMAND", "CMD"), message(m)),
        S::Send(p, m) => {
            let k = match p {
                SendPort::Any => "SEND",
                SendPort::Serial => "SENDS",
                SendPort::Bus => "SENDP",
            };
            format!("{k}{}", message(m))
        }
        S::Display(d) => {
            let k = kw("DISPLAY", "DISP");
            match d {
                Display::Text { pos: Some(p), text } => {
                    format!("{k} {p} \"{}\"", String::from_utf8_lossy(text))
                }
                Display::Text { pos: None, text } => {
                    format!("{k} \"{}\"", String::from_utf8_lossy(text))
                }
                Display::Var {
                    pos,
                    width,
                    decimals,
                    var: v,
                } => format!("{k} {pos},{width}.{decimals},{}", var(v)),
            }
        }
        S::Plc(p) => {
            let v = match p.verb {
                PlcVerb::Enable => kw("ENABLE PLC", "ENA PLC"),
                PlcVerb::Disable => kw("DISABLE PLC", "DIS PLC"),
                PlcVerb::Pause => kw("PAUSE PLC", "PAU PLC"),
                PlcVerb::Resume => kw("RESUME PLC", "RES PLC"),
                PlcVerb::EnableCompiled => kw("ENABLE PLCC", "ENA PLCC"),
                PlcVerb::DisableCompiled => kw("DISABLE PLCC", "DIS PLCC"),
            };
            format!("{v} {}", num_list(&p.list))
        }
        S::Address { motor, coord } => {
            let mut t = kw("ADDRESS", "ADR").to_string();
            if let Some(m) = motor {
                let _ = write!(t, "#{m}");
            }
            if let Some(c) = coord {
                let _ = write!(t, "&{c}");
            }
            t
        }
        S::SetPhase(l) => format!("SETPHASE{}", num_list(l)),
        S::Gather { trigger } => {
            format!(
                "{}{}",
                kw("GATHER", "GAT"),
                if *trigger {
                    kw(" TRIGGER", " TRIG")
                } else {
                    ""
                }
            )
        }
        S::EndGather => kw("ENDGATHER", "ENDG").into(),
        S::MacroAuxRead {
            node,
            param,
            var: v,
        } => format!("{}{node},{param},{}", kw("MACROAUXREAD", "MXR"), var(v)),
        S::MacroAuxWrite {
            node,
            param,
            var: v,
        } => {
            format!("{}{node},{param},{}", kw("MACROAUXWRITE", "MXW"), var(v))
        }
        S::MacroSlaveRead {
            node,
            var: sv,
            dest,
        } => {
            format!(
                "{}{node},{},{}",
                kw("MACROSLVREAD", "MSR"),
                slave_var(sv),
                var(dest)
            )
        }
        S::MacroSlaveWrite { node, var: sv, src } => {
            format!(
                "{}{node},{},{}",
                kw("MACROSLVWRITE", "MSW"),
                slave_var(sv),
                var(src)
            )
        }
    }
}

/// `#n->` reply body: `10000X`, `8660X-5000Y`, `5000X+8660Y+5000`, `X` for scale 1.
#[cfg(test)]
pub(crate) fn axis_def(d: &AxisDef) -> String {
    let mut s = String::new();
    for (i, t) in d.terms.iter().enumerate() {
        let mag = t.scale.abs();
        if t.scale < 0.0 {
            s.push('-');
        } else if i > 0 {
            s.push('+');
        }
        if mag != 1.0 {
            let _ = write!(s, "{mag}");
        }
        s.push(t.axis.letter());
    }
    if d.offset != 0.0 {
        let _ = write!(
            s,
            "{}{}",
            if d.offset < 0.0 { '-' } else { '+' },
            d.offset.abs()
        );
    }
    s
}
