//! Power PMAC program lines (seed §2.10) into `domain::ast` statements the program engine
//! runs: moves and modes, `abs`/`inc`, `F`/`tm`/`ta`/`ts`, `dwell`/`delay`, labels, jumps and
//! calls, assignments (plain, compound, synchronous), and the brace-structured `if`/`else`,
//! `while`, `do … while`, `switch`/`case`. Braces are matched by the caller's [`Blocks`]
//! stack (one per open buffer): `}` ends whatever block is innermost.

use super::catalog;
use super::parse::{Cur, ElemRef, Fam, SyntaxError, EXT_CFLAGS};
use crate::domain::ast::{
    AssignOp, Axis, AxisExtra, AxisWord, BinOp, CmpOp, CodeLetter, Cond, Expr, ExprKind, LetterArg,
    MoveMode, PlcControl, Pos, Stmt, StmtKind, VarIndex, VarKind, VarRef,
};
use crate::domain::PowerErr;

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
    /// A `do` body ended (`}` or a one-line `do dwell 0`) without its `while`: the next
    /// statement must be `while ({condition})` (seed L40925-40942).
    DoWhile,
}

/// The blocks open in a buffer being entered.
pub(crate) type Blocks = Vec<Block>;

type P<T> = Result<T, SyntaxError>;

fn err<T>(at: usize) -> P<T> {
    Err(SyntaxError {
        at,
        code: PowerErr::IllegalCmd,
    })
}

/// Parse one program line; `blocks` follows the braces, `table` is the card's program
/// element table (elements named in the line are added to it).
pub(crate) fn parse_program_line(
    line: &[u8],
    blocks: &mut Blocks,
    table: &mut Vec<ElemRef>,
) -> P<Vec<Stmt>> {
    let mut c = Cur::for_program(line, std::mem::take(table));
    let r = statements_to(&mut c, blocks, false);
    *table = c.into_table();
    r
}

/// The statements up to the end of the line (`body`: or up to a `}` closing an outer block,
/// which ends a one-line body).
///
/// A move's own `F`, `tm`, `ta`, `td` and `ts` written after its axis words in the same
/// statement (`X25 Y15 F10 ta100 td200 ts50;`, seed L23523; `X100 F20;` "move out" at F20,
/// L40938) govern that move: they are stored before it. After a `;` they are the next
/// statement's, as written.
fn statements_to(c: &mut Cur<'_>, blocks: &mut Blocks, body: bool) -> P<Vec<Stmt>> {
    let mut out = Vec::new();
    let mut mv: Option<usize> = None;
    loop {
        c.ws();
        while c.eat(b';') {
            c.ws();
            mv = None;
        }
        if c.at_end() || c.rest().starts_with(b"//") || (body && c.peek() == Some(b'}')) {
            break;
        }
        let n = out.len();
        statement(c, blocks, &mut out)?;
        let one = out.len() == n + 1;
        mv = match (one, mv, out.get(n).map(|s| &s.kind)) {
            (true, _, Some(StmtKind::Move(_))) => Some(n),
            (
                true,
                Some(i),
                Some(
                    StmtKind::F(_)
                    | StmtKind::Tm(_)
                    | StmtKind::Ta(_)
                    | StmtKind::Td(_)
                    | StmtKind::Ts(_),
                ),
            ) => {
                let s = out.remove(n);
                out.insert(i, s);
                Some(i + 1)
            }
            _ => None,
        };
    }
    Ok(out)
}

/// The stored lines of one program line: a block statement (`if (…) {`, `} else {`, `}`,
/// `while (…) {`) starts a stored line of its own (after any labels before it), as the
/// card's buffer structure check expects one block statement per stored line at its start.
pub(crate) fn stored_lines(stmts: Vec<Stmt>) -> Vec<Vec<Stmt>> {
    let mut out = Vec::new();
    let mut cur: Vec<Stmt> = Vec::new();
    for s in stmts {
        let block = match &s.kind {
            StmtKind::If(_) | StmtKind::EndIf | StmtKind::While(_) | StmtKind::EndWhile => true,
            StmtKind::Else(body) => body.is_empty(),
            _ => false,
        };
        if block && cur.iter().any(|x| !matches!(x.kind, StmtKind::Label(_))) {
            out.push(std::mem::take(&mut cur));
        }
        cur.push(s);
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

fn stmt(kind: StmtKind, at: usize) -> Stmt {
    Stmt {
        kind,
        pos: Pos(at as u32),
    }
}

fn open(blocks: &mut Blocks, b: Block, at: usize) -> P<()> {
    if blocks.len() >= MAX_BLOCKS {
        return Err(SyntaxError {
            at,
            code: PowerErr::IllegalParameter,
        });
    }
    blocks.push(b);
    Ok(())
}

fn statement(c: &mut Cur<'_>, blocks: &mut Blocks, out: &mut Vec<Stmt>) -> P<()> {
    let at = c.i;
    if blocks.last() == Some(&Block::DoWhile) {
        if !c.eat_word("while") {
            return err(at);
        }
        blocks.pop();
        let cond = paren_cond(c)?;
        out.push(stmt(StmtKind::DoWhile(cond), at));
        return Ok(());
    }
    if c.eat(b'}') {
        c.ws();
        let b = blocks.pop().ok_or(SyntaxError {
            at,
            code: PowerErr::IllegalCmd,
        })?;
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
                    // `}` alone: the `while` opens the next line.
                    if c.at_end() || c.peek() == Some(b';') {
                        blocks.push(Block::DoWhile);
                        return Ok(());
                    }
                    return err(c.i);
                }
                let cond = paren_cond(c)?;
                out.push(stmt(StmtKind::DoWhile(cond), at));
            }
            Block::DoWhile => return err(at),
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
            return Err(SyntaxError {
                at,
                code: PowerErr::IllegalParameter,
            });
        }
        let kind = if c.eat(b':') {
            StmtKind::Label(n)
        } else {
            StmtKind::SyncLabel(n)
        };
        out.push(stmt(kind, at));
        return Ok(());
    }
    // Variables (P Q M I L R D C): assignment; `M3`/`D2` without one are codes, `C10` an
    // axis word.
    if let Some(f) = Fam::of(ch) {
        if c.peek_at(1)
            .is_some_and(|d| d.is_ascii_digit() || d == b'(')
        {
            let save = c.i;
            c.i += 1;
            if let Ok(index) = c.var_index(0) {
                if let VarIndex::Const(first) = index {
                    let before = c.i;
                    if let Some(numbers) = selection(c, first) {
                        if is_assign(c) {
                            return range_assignment(c, f, &numbers, at, out);
                        }
                    }
                    c.i = before;
                }
                if is_assign(c) {
                    if let VarIndex::Const(n) = index {
                        if !in_range(f, n) {
                            return Err(SyntaxError {
                                at,
                                code: PowerErr::IllegalParameter,
                            });
                        }
                    }
                    let target = VarRef {
                        kind: f.kind(),
                        index,
                        pos: Pos(at as u32),
                    };
                    return assignment(c, target, at, out);
                }
            }
            c.i = save;
        }
    }
    // G/M/T/D codes: `call Coord[x].Gprog` … at label code × 1000, with letter arguments.
    if let Some(l) = code_letter(ch) {
        if c.peek_at(1)
            .is_some_and(|d| d.is_ascii_digit() || d == b'(')
        {
            c.i += 1;
            let value = data(c)?;
            let args = letter_args(c)?;
            out.push(stmt(StmtKind::Code(l, value, args), at));
            return Ok(());
        }
    }
    // Data-structure elements: assignment.
    if ch.is_ascii_alphabetic() {
        let save = c.i;
        let word = c.word_lower();
        c.i = save;
        if word
            .as_deref()
            .is_some_and(|w| catalog::structure(w).is_some())
        {
            let e = c.element(0)?;
            let d = &catalog::DEFS[e.def];
            let watch = e.st == catalog::St::Ldata && matches!(d.name, "CmdStatus" | "CmdCount");
            if d.class == catalog::Class::Status && !watch {
                return Err(SyntaxError {
                    at,
                    code: PowerErr::ReadOnly,
                });
            }
            if !is_assign(c) {
                return err(c.i);
            }
            let fam = c.add_elem(e).ok_or(SyntaxError {
                at,
                code: PowerErr::IllegalParameter,
            })?;
            let target = VarRef {
                kind: VarKind::Ext(fam),
                index: VarIndex::Const(0),
                pos: Pos(at as u32),
            };
            return assignment(c, target, at, out);
        }
    }
    // Axis words.
    let starts_value = |d: u8| d.is_ascii_digit() || matches!(d, b'(' | b'-' | b'.' | b'$');
    // A move may also be circle-centre words alone (`J10`: a full circle of radius 10 in the
    // XY plane, seed L39646).
    // (An `I…` assignment was taken above as an I-variable's.)
    let centre_only = matches!(ch, b'i' | b'j' | b'k');
    if (axis_of(ch).is_some() || centre_only) && c.peek_at(1).is_some_and(starts_value) {
        let mut words = Vec::new();
        // After the first word, circle centre (`I J K`) and radius (`R`) words too.
        while let Some(a) = c.peek().and_then(|x| {
            axis_of(x).or_else(|| circle_of(x).filter(|_| !words.is_empty() || centre_only))
        }) {
            if !c.peek_at(1).is_some_and(starts_value) {
                break;
            }
            let save = c.i;
            let is_axis = c.peek().and_then(axis_of).is_some();
            c.i += 1;
            let value = data(c)?;
            if is_assign(c) {
                // `X10 I5=3`: the move ends before an assignment.
                c.i = save;
                break;
            }
            // `X{pos}:{vel}`: a PVT move's end velocity (seed L39448-39484).
            let extra = if is_axis && c.eat(b':') {
                Some(AxisExtra::Velocity(data(c)?))
            } else {
                None
            };
            words.push(AxisWord {
                axis: a,
                value,
                extra,
            });
            c.ws();
        }
        out.push(stmt(StmtKind::Move(words), at));
        return Ok(());
    }
    let Some(mut w) = c.word_lower() else {
        return err(at);
    };
    // A number glued to its keyword (`tm200`, `F5`, `dwell50`, `call1000.01`).
    const GLUED: [&str; 40] = [
        "f", "tm", "ta", "ts", "td", "pvt", "spline", "send", "dwell", "delay", "goto", "gosub",
        "callsub", "call", "circle", "cset", "cclr", "cexe", "cexec", "cskip", "abort", "hold",
        "run", "step", "pause", "resume", "enable", "disable", "kill", "dkill", "home", "homez",
        "cout", "jog", "jogret", "adisable", "ddisable", "stop", "begin", "start",
    ];
    if let Some(k) = w.find(|ch: char| ch.is_ascii_digit()) {
        if k > 0 && GLUED.contains(&&w[..k]) && w[k..].bytes().all(|b| b.is_ascii_digit()) {
            let known = matches!(w.as_str(), "circle1" | "circle2");
            if !known {
                c.i -= w.len() - k;
                w.truncate(k);
            }
        }
    }
    let kind = match w.as_str() {
        "if" => {
            let cond = paren_cond(c)?;
            c.ws();
            if c.eat(b'{') {
                open(blocks, Block::If, at)?;
                StmtKind::If(cond)
            } else {
                // The rest of the line is the body (seed: `cx while (P100<40) P(P100)=0
                // P100++`).
                let mut none = Vec::new();
                let body = statements_to(c, &mut none, true)?;
                if body.is_empty() || !none.is_empty() {
                    return err(c.i);
                }
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
                // The rest of the line is the body (seed: `cx while (P100<40) P(P100)=0
                // P100++`).
                let mut none = Vec::new();
                let body = statements_to(c, &mut none, true)?;
                if body.is_empty() || !none.is_empty() {
                    return err(c.i);
                }
                StmtKind::WhileLine(cond, body)
            }
        }
        "do" => {
            c.ws();
            if !c.eat(b'{') {
                return do_line(c, blocks, at, out);
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
            let v = c.signed_number().ok_or(SyntaxError {
                at: c.i,
                code: PowerErr::IllegalCmd,
            })?;
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
        "goto" => StmtKind::Goto(data(c)?),
        // `gosub 5000 E5`, `callsub 5000 E5` (L39964, L41477): letter arguments for `read`.
        "gosub" => {
            let target = data(c)?;
            StmtKind::Gosub(target, letter_args(c)?)
        }
        "callsub" => {
            let target = data(c)?;
            StmtKind::CallSub(target, letter_args(c)?)
        }
        "call" => {
            let target = data(c)?;
            StmtKind::Call(target, letter_args(c)?)
        }
        "read" => StmtKind::Read(read_letters(c)?),
        "cmd" => {
            let text = quoted(c)?;
            super::moves::cmd(c, text)?
        }
        // `send n,"fmt",expr…` to software port n (0-4), printf-style.
        "send" => super::moves::send(c)?,
        "pvt" => super::moves::pvt(c)?,
        "spline" => super::moves::spline(c)?,
        "td" => super::moves::td(c)?,
        // The queues of `send`/`cmd` are flushed at the end of every scan anyway.
        "sendall" | "sendallcmds" => return Ok(()),
        "cset" | "cclr" | "cexe" | "cexec" | "cskip" => return cond_exec(c, &w, at, out),
        "bstart" => StmtKind::BlockStart,
        "bstop" => StmtKind::BlockStop,

        "linear" => StmtKind::Mode(MoveMode::Linear),
        "rapid" => StmtKind::Mode(MoveMode::Rapid),
        "circle1" => StmtKind::Mode(MoveMode::Circle1),
        "circle2" => StmtKind::Mode(MoveMode::Circle2),
        "abs" => StmtKind::Abs(axis_list(c)?),
        "inc" => StmtKind::Inc(axis_list(c)?),
        // `normal K-1` (seed L42969-42975): the plane's normal vector, I/J/K components.
        "normal" => StmtKind::Normal(letter_words(c, |ch| {
            circle_of(ch).filter(|a| *a != Axis::R)
        })?),
        // `pset X10 Y20` (seed L43310-43311): the axes' present positions redefined.
        "pset" => StmtKind::Pset(letter_words(c, axis_of)?),
        // `pmatch` (L545): the axes' start positions from the motors'; `pclr` (L704): every
        // axis's present position 0 (a `pset` of each).
        "pmatch" => StmtKind::Pmatch,
        "pstore" => StmtKind::Pstore,
        "pload" => StmtKind::Pload,
        "pclr" => StmtKind::Pset(
            b"xyzabcuvw"
                .iter()
                .filter_map(|&ch| axis_of(ch))
                .map(|axis| AxisWord {
                    axis,
                    value: Expr::num(0.0),
                    extra: None,
                })
                .collect(),
        ),
        "f" => StmtKind::F(data(c)?),
        "tm" => StmtKind::Tm(data(c)?),
        "ta" => StmtKind::Ta(data(c)?),
        "ts" => StmtKind::Ts(data(c)?),
        "dwell" => StmtKind::Dwell(data(c)?),
        "delay" => StmtKind::Delay(data(c)?),
        // `lhpurge` (seed L42676-42698): the look-ahead buffer emptied, which pauses the
        // commanded motion as a `dwell 0` does (this engine calculates no further ahead).
        "lhpurge" => StmtKind::Dwell(Expr::num(0.0)),
        // `step plc {list}` (seed L38993-39025): run as the on-line command.
        "step"
            if {
                let save = c.i;
                c.ws();
                let plc = c.eat_word("plc");
                c.i = save;
                plc
            } =>
        {
            c.ws();
            let _ = c.eat_word("plc");
            c.ws();
            let rest = c.rest();
            let from = c.i;
            super::parse::plc_list(c)?;
            let mut text = b"step plc ".to_vec();
            text.extend_from_slice(&rest[..c.i - from]);
            StmtKind::Command(crate::domain::ast::Message::Text(text))
        }
        "enable" | "disable" | "pause" | "resume"
            if {
                let save = c.i;
                c.ws();
                let plc = c.eat_word("plc");
                c.i = save;
                plc
            } =>
        {
            c.ws();
            let _ = c.eat_word("plc");
            c.ws();
            // `2,4,6`, `7..10`, `11,13..16,20` (seed L38716-38720, L40797-40801).
            let list = super::parse::plc_list(c)?;
            let verb = super::parse::plc_verb(&w);
            StmtKind::Plc(PlcControl { verb, list })
        }
        // Passing text to the operating system is not something an emulated card does.
        "system" | "sendallsystemcmds" => {
            return Err(SyntaxError {
                at,
                code: PowerErr::NotSupported,
            })
        }
        _ => match super::direct::statement(c, &w) {
            Some(k) => k?,
            None => return err(at),
        },
    };
    out.push(stmt(kind, at));
    Ok(())
}

/// `do {statements} while ({condition})` on one line (seed L40935: `do dwell 50 while (M1 ==
/// 0);`): the body runs, then again while the condition holds.
fn do_line(c: &mut Cur<'_>, blocks: &mut Blocks, at: usize, out: &mut Vec<Stmt>) -> P<()> {
    let mut body = Vec::new();
    let mut none = Vec::new();
    loop {
        c.ws();
        while c.eat(b';') {
            c.ws();
        }
        let save = c.i;
        if c.eat_word("while") {
            if body.is_empty() {
                return err(save);
            }
            break;
        }
        if c.at_end() {
            // `do dwell 0` with its `while` on the next line (seed L42702-42703).
            if body.is_empty() {
                return err(c.i);
            }
            open(blocks, Block::DoWhile, at)?;
            out.push(stmt(StmtKind::Do, at));
            out.extend(body);
            return Ok(());
        }
        statement(c, &mut none, &mut body)?;
        if !none.is_empty() {
            return err(c.i);
        }
    }
    let cond = paren_cond(c)?;
    out.push(stmt(StmtKind::Do, at));
    out.extend(body);
    out.push(stmt(StmtKind::DoWhile(cond), at));
    Ok(())
}

/// `cset n` / `cclr n` set / clear conditional-execution flag n (0-31) of the C.S.
/// (`Coord[x].Cflags` bit n); `cexe n` / `cskip n` run / skip the rest of the line when it is
/// set (seed L39999-40030, L40134-40160, L25130-25150).
fn cond_exec(c: &mut Cur<'_>, w: &str, at: usize, out: &mut Vec<Stmt>) -> P<()> {
    c.ws();
    let n = match c.uint() {
        Some(n) if n <= 31 => n,
        _ => {
            return Err(SyntaxError {
                at: c.i,
                code: PowerErr::IllegalParameter,
            })
        }
    };
    let flags = || Expr {
        kind: ExprKind::Var(VarRef {
            kind: VarKind::Ext(EXT_CFLAGS),
            index: VarIndex::Const(0),
            pos: Pos(at as u32),
        }),
        pos: Pos(at as u32),
    };
    let bit = f64::from(1u32 << n);
    let target = VarRef {
        kind: VarKind::Ext(EXT_CFLAGS),
        index: VarIndex::Const(0),
        pos: Pos(at as u32),
    };
    let kind = match w {
        "cset" => StmtKind::Assign {
            target,
            op: AssignOp::Op(BinOp::Or),
            value: Expr::num(bit),
        },
        "cclr" => StmtKind::Assign {
            target,
            op: AssignOp::Op(BinOp::And),
            value: Expr::num(f64::from(!(1u32 << n))),
        },
        _ => {
            let set = Cond::Value(Expr {
                kind: ExprKind::Bin(BinOp::And, Box::new(flags()), Box::new(Expr::num(bit))),
                pos: Pos(at as u32),
            });
            let cond = if w == "cskip" {
                Cond::Not(Box::new(set))
            } else {
                set
            };
            let mut none = Vec::new();
            let body = statements_to(c, &mut none, true)?;
            if !none.is_empty() {
                return err(c.i);
            }
            StmtKind::IfLine(cond, body)
        }
    };
    out.push(stmt(kind, at));
    Ok(())
}

/// After the first number `first` of a variable: `..last` or `,count[,step]` (seed
/// L38644-38646, L43085-43086), the variables it names; `None`: no selection here.
fn selection(c: &mut Cur<'_>, first: u32) -> Option<Vec<u32>> {
    let digit_after = |c: &Cur<'_>, k: usize| c.peek_at(k).is_some_and(|d| d.is_ascii_digit());
    if c.rest().starts_with(b"..") && digit_after(c, 2) {
        c.i += 2;
        let last = c.uint()?;
        return (last >= first).then(|| (first..=last).collect());
    }
    if c.peek() == Some(b',') && digit_after(c, 1) {
        c.i += 1;
        let n = c.uint()?;
        let step = if c.peek() == Some(b',') && digit_after(c, 1) {
            c.i += 1;
            c.uint()?
        } else {
            1
        };
        if n == 0 || step == 0 {
            return None;
        }
        return (0..n)
            .map(|k| first.checked_add(k.checked_mul(step)?))
            .collect();
    }
    None
}

/// Most variables one program assignment may name (each becomes a statement of its own).
const MAX_RANGE_ASSIGN: usize = 1024;

/// `P10..12 = P1+5`, `C0,64 = 0.0`, `P20,5,10++`: the same assignment to each variable of the
/// selection, in order, as one stored line. Every one must exist (else 21, nothing stored).
fn range_assignment(
    c: &mut Cur<'_>,
    f: Fam,
    numbers: &[u32],
    at: usize,
    out: &mut Vec<Stmt>,
) -> P<()> {
    if numbers.len() > MAX_RANGE_ASSIGN || !numbers.iter().all(|&n| in_range(f, n)) {
        return Err(SyntaxError {
            at,
            code: PowerErr::IllegalParameter,
        });
    }
    let mut one = Vec::new();
    let target = |n: u32| VarRef {
        kind: f.kind(),
        index: VarIndex::Const(n),
        pos: Pos(at as u32),
    };
    assignment(c, target(numbers[0]), at, &mut one)?;
    let [first] = one.as_slice() else {
        return err(at);
    };
    for &n in numbers {
        let mut s = first.clone();
        if let StmtKind::Assign { target: t, .. } = &mut s.kind {
            *t = target(n);
        }
        out.push(s);
    }
    Ok(())
}

/// Variable `n` of family `f` exists (seed §2.2 ranges).
fn in_range(f: Fam, n: u32) -> bool {
    let lim = crate::domain::profile::limits(crate::domain::Profile::Power);
    match f {
        Fam::P => n < lim.p_vars,
        Fam::Q => n < lim.q_vars,
        Fam::M => n < lim.m_vars,
        Fam::I => n <= 65_535,
        Fam::L | Fam::R => (n as usize) < super::LOCALS,
        Fam::D => (n as usize) < super::DVARS,
        Fam::C => (n as usize) < super::CVARS,
    }
}

/// An assignment operator follows (after white space): `=`, `==`, `op=`, `op==`, `++`, `--`.
fn is_assign(c: &mut Cur<'_>) -> bool {
    let save = c.i;
    c.ws();
    let r = c.rest();
    let yes = match r {
        [b'=', ..] => true,
        [b'+', b'+', ..] | [b'-', b'-', ..] => true,
        [b'<', b'<', b'=', ..] | [b'>', b'>', b'=', ..] => true,
        [op, b'=', ..] => b"+-*/%&|^".contains(op),
        _ => false,
    };
    c.i = save;
    yes
}

/// The code letter `G`/`M`/`T`/`D`.
fn code_letter(ch: u8) -> Option<CodeLetter> {
    Some(match ch {
        b'g' => CodeLetter::G,
        b'm' => CodeLetter::M,
        b't' => CodeLetter::T,
        b'd' => CodeLetter::D,
        _ => return None,
    })
}

/// The letter arguments after `call`/`G`/`M`/`T`/`D`: `{letter}{data}` words (not N or O),
/// up to the first that is not one (the seed's `read` scan, L43517-43563). Letters are
/// stored upper-case.
fn letter_args(c: &mut Cur<'_>) -> P<Vec<LetterArg>> {
    let mut args = Vec::new();
    loop {
        let save = c.i;
        c.ws();
        let Some(l) = c
            .peek()
            .filter(|l| l.is_ascii_lowercase() && !matches!(l, b'n' | b'o'))
        else {
            c.i = save;
            break;
        };
        let starts = |d: u8| d.is_ascii_digit() || matches!(d, b'(' | b'-' | b'.' | b'$');
        // A double letter (`DD50`) is kept as the lower-case letter.
        let (len, letter) = if c.peek_at(1) == Some(l) {
            (2, l)
        } else {
            (1, l.to_ascii_uppercase())
        };
        if !c.peek_at(len).is_some_and(starts) {
            c.i = save;
            break;
        }
        c.i += len;
        let value = data(c)?;
        if is_assign(c) {
            c.i = save;
            break;
        }
        args.push(LetterArg { letter, value });
    }
    Ok(args)
}

/// `read(A,B,…)`: the letters (not N or O), upper-case.
fn read_letters(c: &mut Cur<'_>) -> P<Vec<u8>> {
    c.ws();
    if !c.eat(b'(') {
        return err(c.i);
    }
    let mut letters = Vec::new();
    loop {
        c.ws();
        match c.peek() {
            Some(l) if l.is_ascii_lowercase() && !matches!(l, b'n' | b'o') => {
                // A double letter (AA … ZZ → D27 … D52) is kept as the lower-case letter.
                if c.peek_at(1) == Some(l) {
                    c.i += 2;
                    letters.push(l);
                } else {
                    c.i += 1;
                    letters.push(l.to_ascii_uppercase());
                }
            }
            _ => return err(c.i),
        }
        c.ws();
        if c.eat(b')') {
            return Ok(letters);
        }
        if !c.eat(b',') {
            return err(c.i);
        }
    }
}

/// `"text"` (case kept).
fn quoted(c: &mut Cur<'_>) -> P<Vec<u8>> {
    c.ws();
    if !c.eat(b'"') {
        return err(c.i);
    }
    let r = c.rest();
    let Some(end) = r.iter().position(|&b| b == b'"') else {
        return err(c.i);
    };
    let text = r[..end].to_vec();
    c.i += end + 1;
    Ok(text)
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
    // `I388++=`, `M50--=` (seed L41743-41750): incremented or decremented with the next move.
    let (op, value) = if c.eat_str("++=") {
        (AssignOp::SyncOp(BinOp::Add), one())
    } else if c.eat_str("--=") {
        (AssignOp::SyncOp(BinOp::Sub), one())
    } else if c.eat_str("++") {
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
    let mut target = target;
    if matches!(op, AssignOp::SyncSet | AssignOp::SyncOp(_))
        && target.kind == VarKind::Ext(super::parse::EXT_M)
    {
        target.kind = VarKind::Ext(super::parse::EXT_M_SYNC);
    }
    out.push(stmt(StmtKind::Assign { target, op, value }, at));
    Ok(())
}

/// `{data}`: a number or an expression (parenthesised or not).
fn data(c: &mut Cur<'_>) -> P<Expr> {
    c.ws();
    c.expr(0)
}

fn circle_of(ch: u8) -> Option<Axis> {
    Some(match ch {
        b'i' => Axis::I,
        b'j' => Axis::J,
        b'k' => Axis::K,
        b'r' => Axis::R,
        _ => return None,
    })
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

/// `(X,Y)`, `(I..K)` after `abs`/`inc` (seed L39311-39346, L41864-41866): the axes named,
/// `a..b` within X Y Z A B C U V W or within I J K; `None` without parentheses. Double-letter
/// axes (`KK`) are not modelled (21).
fn axis_list(c: &mut Cur<'_>) -> P<Option<Vec<Axis>>> {
    const GROUPS: [&[u8]; 2] = [b"xyzabcuvw", b"ijk"];
    let save = c.i;
    c.ws();
    if !c.eat(b'(') {
        c.i = save;
        return Ok(None);
    }
    let letter = |c: &mut Cur<'_>| -> P<(usize, usize)> {
        c.ws();
        let at = c.i;
        let ch = c.peek().ok_or(SyntaxError {
            at,
            code: PowerErr::IllegalCmd,
        })?;
        let pos = GROUPS
            .iter()
            .enumerate()
            .find_map(|(g, l)| l.iter().position(|x| *x == ch).map(|k| (g, k)))
            .ok_or(SyntaxError {
                at,
                code: PowerErr::IllegalCmd,
            })?;
        c.i += 1;
        if c.peek().is_some_and(|d| d.is_ascii_alphabetic()) {
            return Err(SyntaxError {
                at,
                code: PowerErr::IllegalParameter,
            });
        }
        Ok(pos)
    };
    let mut axes = Vec::new();
    loop {
        let (g, a) = letter(c)?;
        let (g2, b) = if c.eat_str("..") { letter(c)? } else { (g, a) };
        if g2 != g || b < a {
            return Err(SyntaxError {
                at: c.i,
                code: PowerErr::IllegalParameter,
            });
        }
        for &ch in &GROUPS[g][a..=b] {
            let axis = axis_of(ch).or_else(|| circle_of(ch));
            axes.push(axis.ok_or(SyntaxError {
                at: c.i,
                code: PowerErr::IllegalCmd,
            })?);
        }
        c.ws();
        if c.eat(b')') {
            return Ok(Some(axes));
        }
        if !c.eat(b',') {
            return err(c.i);
        }
    }
}

/// `{letter}{data}` words after `normal`/`pset`, the letters `of` allows; at least one.
fn letter_words(c: &mut Cur<'_>, of: fn(u8) -> Option<Axis>) -> P<Vec<AxisWord>> {
    let mut words = Vec::new();
    loop {
        c.ws();
        let at = c.i;
        let Some(axis) = c.peek().and_then(of) else {
            break;
        };
        c.i += 1;
        if c.peek().is_some_and(|d| d.is_ascii_alphabetic()) {
            return Err(SyntaxError {
                at,
                code: PowerErr::IllegalParameter,
            });
        }
        let value = data(c)?;
        words.push(AxisWord {
            axis,
            value,
            extra: None,
        });
    }
    if words.is_empty() {
        return err(c.i);
    }
    Ok(words)
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
