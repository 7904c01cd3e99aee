//! Power PMAC program lines (seed §2.10) into `domain::ast` statements the program engine
//! runs: moves and modes, `abs`/`inc`, `F`/`tm`/`ta`/`ts`, `dwell`/`delay`, labels, jumps and
//! calls, assignments (plain, compound, synchronous), and the brace-structured `if`/`else`,
//! `while`, `do … while`, `switch`/`case`. Braces are matched by the caller's [`Blocks`]
//! stack (one per open buffer): `}` ends whatever block is innermost.

use super::parse::{Cur, SyntaxError};
use crate::domain::ast::{
    AssignOp, Axis, AxisWord, BinOp, CmpOp, Cond, Expr, MoveMode, NumRange, PlcControl, PlcVerb,
    Pos, Stmt, StmtKind, VarIndex, VarKind, VarRef,
};

/// Deepest block nesting (seed: conditionals nest 32 levels).
pub(crate) const MAX_BLOCKS: usize = 32;

/// An open brace block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Block {
    /// `if (…) {`
    If,
    /// `} else {`
    Else,
    /// `while (…) {`
    While,
    /// `do {`
    Do,
    /// `switch (…) {`
    Switch,
}

/// The blocks open in a buffer being entered.
pub(crate) type Blocks = Vec<Block>;

type P<T> = Result<T, SyntaxError>;

fn err<T>(at: usize) -> P<T> {
    Err(SyntaxError { at, code: 20 })
}

/// Parse one program line; `blocks` follows the braces.
pub(crate) fn parse_program_line(line: &[u8], blocks: &mut Blocks) -> P<Vec<Stmt>> {
    let mut c = Cur::new(line);
    let mut out = Vec::new();
    loop {
        c.ws();
        while c.eat(b';') {
            c.ws();
        }
        if c.at_end() || c.rest().starts_with(b"//") {
            break;
        }
        statement(&mut c, blocks, &mut out)?;
    }
    if c.has_elems() {
        // Elements and thread-local variables are resolved per thread on-line only.
        return Err(SyntaxError { at: 0, code: 27 });
    }
    Ok(out)
}

fn stmt(kind: StmtKind, at: usize) -> Stmt {
    Stmt {
        kind,
        pos: Pos(at as u32),
    }
}

fn open(blocks: &mut Blocks, b: Block, at: usize) -> P<()> {
    if blocks.len() >= MAX_BLOCKS {
        return Err(SyntaxError { at, code: 21 });
    }
    blocks.push(b);
    Ok(())
}

fn statement(c: &mut Cur<'_>, blocks: &mut Blocks, out: &mut Vec<Stmt>) -> P<()> {
    let at = c.i;
    if c.eat(b'}') {
        c.ws();
        let b = blocks.pop().ok_or(SyntaxError { at, code: 20 })?;
        match b {
            Block::If if c.eat_word("else") => {
                c.ws();
                if !c.eat(b'{') {
                    return err(c.i);
                }
                out.push(stmt(StmtKind::Else(Vec::new()), at));
                open(blocks, Block::Else, at)?;
            }
            Block::If | Block::Else => out.push(stmt(StmtKind::EndIf, at)),
            Block::While => out.push(stmt(StmtKind::EndWhile, at)),
            Block::Switch => out.push(stmt(StmtKind::EndSwitch, at)),
            Block::Do => {
                if !c.eat_word("while") {
                    return err(c.i);
                }
                let cond = paren_cond(c)?;
                out.push(stmt(StmtKind::DoWhile(cond), at));
            }
        }
        return Ok(());
    }
    let Some(ch) = c.peek() else {
        return err(at);
    };
    // Labels: `N10:` jump label, `N10` sync label; also `O10:`.
    if (ch == b'n' || ch == b'o') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
        c.i += 1;
        let n = c.uint().unwrap_or(u32::MAX);
        if n > 999_999_999 {
            return Err(SyntaxError { at, code: 21 });
        }
        let kind = if c.eat(b':') {
            StmtKind::Label(n)
        } else {
            StmtKind::SyncLabel(n)
        };
        out.push(stmt(kind, at));
        return Ok(());
    }
    // Variables: assignment.
    if let Some(kind) = match ch {
        b'p' => Some(VarKind::P),
        b'q' => Some(VarKind::Q),
        b'm' => Some(VarKind::M),
        _ => None,
    } {
        if c.peek_at(1)
            .is_some_and(|d| d.is_ascii_digit() || d == b'(')
        {
            c.i += 1;
            let index = c.var_index(0)?;
            let target = VarRef {
                kind,
                index,
                pos: Pos(at as u32),
            };
            return assignment(c, target, at, out);
        }
    }
    // Axis words.
    let starts_value = |d: u8| d.is_ascii_digit() || matches!(d, b'(' | b'-' | b'.' | b'$');
    if axis_of(ch).is_some() && c.peek_at(1).is_some_and(starts_value) {
        let mut words = Vec::new();
        while let Some(a) = c.peek().and_then(axis_of) {
            if !c.peek_at(1).is_some_and(starts_value) {
                break;
            }
            c.i += 1;
            let value = data(c)?;
            words.push(AxisWord {
                axis: a,
                value,
                extra: None,
            });
            c.ws();
        }
        out.push(stmt(StmtKind::Move(words), at));
        return Ok(());
    }
    let Some(w) = c.word_lower() else {
        return err(at);
    };
    let kind = match w.as_str() {
        "if" => {
            let cond = paren_cond(c)?;
            c.ws();
            if c.eat(b'{') {
                open(blocks, Block::If, at)?;
                StmtKind::If(cond)
            } else {
                let mut body = Vec::new();
                let mut none = Vec::new();
                statement(c, &mut none, &mut body)?;
                StmtKind::IfLine(cond, body)
            }
        }
        "while" => {
            let cond = paren_cond(c)?;
            c.ws();
            if c.eat(b'{') {
                open(blocks, Block::While, at)?;
                StmtKind::While(cond)
            } else {
                let mut body = Vec::new();
                let mut none = Vec::new();
                statement(c, &mut none, &mut body)?;
                StmtKind::WhileLine(cond, body)
            }
        }
        "do" => {
            c.ws();
            if !c.eat(b'{') {
                return err(c.i);
            }
            open(blocks, Block::Do, at)?;
            StmtKind::Do
        }
        "switch" => {
            c.ws();
            if !c.eat(b'(') {
                return err(c.i);
            }
            let e = c.expr(0)?;
            c.ws();
            if !c.eat(b')') {
                return err(c.i);
            }
            c.ws();
            if !c.eat(b'{') {
                return err(c.i);
            }
            open(blocks, Block::Switch, at)?;
            StmtKind::Switch(e)
        }
        "case" => {
            c.ws();
            let v = c.signed_number().ok_or(SyntaxError { at: c.i, code: 20 })?;
            c.ws();
            if !c.eat(b':') {
                return err(c.i);
            }
            if !blocks.contains(&Block::Switch) {
                return err(at);
            }
            StmtKind::Case(v)
        }
        "default" => {
            c.ws();
            if !c.eat(b':') || !blocks.contains(&Block::Switch) {
                return err(c.i);
            }
            StmtKind::Default
        }
        "break" => StmtKind::Break,
        "continue" => StmtKind::Continue,
        "return" => StmtKind::Return,
        "stop" => StmtKind::Stop,
        "goto" => StmtKind::Goto(data(c)?),
        "gosub" => StmtKind::Gosub(data(c)?),
        "callsub" => StmtKind::CallSub(data(c)?),
        "call" => StmtKind::Call(data(c)?, Vec::new()),
        "linear" => StmtKind::Mode(MoveMode::Linear),
        "rapid" => StmtKind::Mode(MoveMode::Rapid),
        "circle1" => StmtKind::Mode(MoveMode::Circle1),
        "circle2" => StmtKind::Mode(MoveMode::Circle2),
        "abs" => StmtKind::Abs(None),
        "inc" => StmtKind::Inc(None),
        "f" => StmtKind::F(data(c)?),
        "tm" => StmtKind::Tm(data(c)?),
        "ta" => StmtKind::Ta(data(c)?),
        "ts" => StmtKind::Ts(data(c)?),
        "dwell" => StmtKind::Dwell(data(c)?),
        "delay" => StmtKind::Delay(data(c)?),
        "enable" | "disable" | "pause" | "resume" => {
            c.ws();
            if !c.eat_word("plc") {
                return err(c.i);
            }
            c.ws();
            let n = match c.uint() {
                Some(n) if n <= 31 => n,
                _ => return Err(SyntaxError { at: c.i, code: 21 }),
            };
            let verb = match w.as_str() {
                "enable" => PlcVerb::Enable,
                "disable" => PlcVerb::Disable,
                "pause" => PlcVerb::Pause,
                _ => PlcVerb::Resume,
            };
            StmtKind::Plc(PlcControl {
                verb,
                list: vec![NumRange { first: n, last: n }],
            })
        }
        // Passing text to the operating system is not something an emulated card does.
        "system" => return Err(SyntaxError { at, code: 27 }),
        _ => return err(at),
    };
    out.push(stmt(kind, at));
    Ok(())
}

/// `= expr`, a compound `op= expr`, `++`/`--`, or a synchronous `==`/`op==` form.
fn assignment(c: &mut Cur<'_>, target: VarRef, at: usize, out: &mut Vec<Stmt>) -> P<()> {
    c.ws();
    let ops: [(&str, Option<BinOp>); 10] = [
        ("+", Some(BinOp::Add)),
        ("-", Some(BinOp::Sub)),
        ("*", Some(BinOp::Mul)),
        ("/", Some(BinOp::Div)),
        ("%", Some(BinOp::Mod)),
        ("&", Some(BinOp::And)),
        ("|", Some(BinOp::Or)),
        ("^", Some(BinOp::Xor)),
        ("<<", Some(BinOp::Shl)),
        (">>", Some(BinOp::Shr)),
    ];
    let one = || Expr::num(1.0);
    let (op, value) = if c.eat_str("++") {
        (AssignOp::Op(BinOp::Add), one())
    } else if c.eat_str("--") {
        (AssignOp::Op(BinOp::Sub), one())
    } else {
        let mut found = None;
        for (t, b) in ops {
            if c.eat_str(&format!("{t}==")) {
                found = Some(AssignOp::SyncOp(b.unwrap_or(BinOp::Add)));
                break;
            }
            if c.eat_str(&format!("{t}=")) {
                found = Some(AssignOp::Op(b.unwrap_or(BinOp::Add)));
                break;
            }
        }
        let op = match found {
            Some(o) => o,
            None if c.eat_str("==") => AssignOp::SyncSet,
            None if c.eat_str("=") => AssignOp::Set,
            None => return err(c.i),
        };
        c.ws();
        (op, c.expr(0)?)
    };
    out.push(stmt(StmtKind::Assign { target, op, value }, at));
    Ok(())
}

/// `{data}`: a number or an expression (parenthesised or not).
fn data(c: &mut Cur<'_>) -> P<Expr> {
    c.ws();
    c.expr(0)
}

fn axis_of(ch: u8) -> Option<Axis> {
    Some(match ch {
        b'x' => Axis::X,
        b'y' => Axis::Y,
        b'z' => Axis::Z,
        b'a' => Axis::A,
        b'b' => Axis::B,
        b'c' => Axis::C,
        b'u' => Axis::U,
        b'v' => Axis::V,
        b'w' => Axis::W,
        _ => return None,
    })
}

/// `( condition )`.
fn paren_cond(c: &mut Cur<'_>) -> P<Cond> {
    c.ws();
    if !c.eat(b'(') {
        return err(c.i);
    }
    let k = cond_or(c, 0)?;
    c.ws();
    if !c.eat(b')') {
        return err(c.i);
    }
    Ok(k)
}

fn cond_or(c: &mut Cur<'_>, depth: u32) -> P<Cond> {
    let mut l = cond_and(c, depth + 1)?;
    loop {
        c.ws();
        if c.eat_str("||") || c.eat_word("or") {
            let r = cond_and(c, depth + 1)?;
            l = Cond::Or(Box::new(l), Box::new(r));
        } else {
            return Ok(l);
        }
    }
}

fn cond_and(c: &mut Cur<'_>, depth: u32) -> P<Cond> {
    let mut l = cond_unary(c, depth + 1)?;
    loop {
        c.ws();
        if c.eat_str("&&") || c.eat_word("and") {
            let r = cond_unary(c, depth + 1)?;
            l = Cond::And(Box::new(l), Box::new(r));
        } else {
            return Ok(l);
        }
    }
}

fn cond_unary(c: &mut Cur<'_>, depth: u32) -> P<Cond> {
    if depth > 64 {
        return err(c.i);
    }
    c.ws();
    if c.peek() == Some(b'!') && c.peek_at(1) != Some(b'=') {
        c.i += 1;
        let k = cond_unary(c, depth + 1)?;
        return Ok(Cond::Not(Box::new(k)));
    }
    let save = c.i;
    if let Ok(k) = comparison(c) {
        return Ok(k);
    }
    c.i = save;
    if c.eat(b'(') {
        let k = cond_or(c, depth + 1)?;
        c.ws();
        if !c.eat(b')') {
            return err(c.i);
        }
        return Ok(k);
    }
    err(save)
}

fn comparison(c: &mut Cur<'_>) -> P<Cond> {
    let lhs = c.expr(0)?;
    c.ws();
    let ops: [(&str, CmpOp); 12] = [
        ("==", CmpOp::Eq),
        ("!=", CmpOp::Ne),
        ("<>", CmpOp::Ne),
        ("<=", CmpOp::NotGt),
        (">=", CmpOp::NotLt),
        ("!>", CmpOp::NotGt),
        ("!<", CmpOp::NotLt),
        ("!~", CmpOp::NotNear),
        ("<", CmpOp::Lt),
        (">", CmpOp::Gt),
        ("~", CmpOp::Near),
        ("=", CmpOp::Eq),
    ];
    for (t, op) in ops {
        if c.eat_str(t) {
            c.ws();
            let rhs = c.expr(0)?;
            return Ok(Cond::Cmp { lhs, op, rhs });
        }
    }
    Ok(Cond::Value(lhs))
}

/// A constant index of a variable reference (for callers that need one).
#[allow(dead_code)]
pub(crate) fn const_index(v: &VarRef) -> Option<u32> {
    match v.index {
        VarIndex::Const(n) => Some(n),
        VarIndex::Expr(_) => None,
    }
}
