//! Expressions, `{data}`, variable references and conditions (pmac-commands.md §5.6).
//!
//! Grammar (two precedence levels, left-associative):
//! `expr := term (('+'|'-'|'|'|'^') term)*`, `term := unary (('*'|'/'|'%'|'&') unary)*`,
//! `unary := '-' unary | primary`, `primary := number | var | func '(' expr ')' | '(' expr ')'`.
//! Conditions: `cond := and ('OR' and)*`, `and := atom ('AND' atom)*`,
//! `atom := expr cmp expr | '(' cond ')'`.

use super::ast::{BinOp, CmpOp, Cond, Expr, ExprKind, Func, VarIndex, VarKind, VarRef};
use super::lexer::Cursor;
use super::ParseError;

const FUNCS: &[(&str, Func)] = &[
    ("SIN", Func::Sin),
    ("COS", Func::Cos),
    ("TAN", Func::Tan),
    ("ASIN", Func::Asin),
    ("ACOS", Func::Acos),
    ("ATAN", Func::Atan),
    ("ATAN2", Func::Atan2),
    ("LN", Func::Ln),
    ("EXP", Func::Exp),
    ("SQRT", Func::Sqrt),
    ("ABS", Func::Abs),
    ("INT", Func::Int),
];

/// Variable family letter at the cursor if it starts a variable reference (`P5`, `P(..)`).
pub(crate) fn at_var(c: &Cursor) -> Option<VarKind> {
    let kind = match c.peek()? {
        b'I' => VarKind::I,
        b'P' => VarKind::P,
        b'Q' => VarKind::Q,
        b'M' => VarKind::M,
        _ => return None,
    };
    match c.peek_at(1) {
        Some(d) if d.is_ascii_digit() || d == b'(' => Some(kind),
        _ => None,
    }
}

/// A single variable reference `P12` / `P(expr)`; `None` if none starts here.
pub(crate) fn var_ref(c: &mut Cursor) -> Result<Option<VarRef>, ParseError> {
    let Some(kind) = at_var(c) else {
        return Ok(None);
    };
    let pos = c.pos();
    c.bump();
    let index = if c.peek() == Some(b'(') {
        VarIndex::Expr(Box::new(paren_expr(c)?))
    } else {
        VarIndex::Const(
            c.uint()?
                .ok_or_else(|| c.syntax("variable number expected"))?,
        )
    };
    Ok(Some(VarRef { kind, index, pos }))
}

/// `'(' expr ')'` at the cursor (spaces allowed inside).
pub(crate) fn paren_expr(c: &mut Cursor) -> Result<Expr, ParseError> {
    c.skip_ws();
    if !c.eat(b'(') {
        return Err(c.syntax("'(' expected"));
    }
    c.enter()?;
    let e = expr(c)?;
    if !c.eat_ws(b')') {
        return Err(c.syntax("')' expected"));
    }
    c.leave();
    Ok(e)
}

/// `{data}`: a literal (optionally negative) or a parenthesised expression. Spaces before it
/// are allowed.
pub(crate) fn data(c: &mut Cursor) -> Result<Expr, ParseError> {
    c.skip_ws();
    let pos = c.pos();
    if c.peek() == Some(b'(') {
        return paren_expr(c);
    }
    if c.peek() == Some(b'+') {
        return Err(c.syntax("unary plus is not allowed"));
    }
    match c.number()? {
        Some(n) => Ok(Expr {
            kind: ExprKind::Num(n),
            pos,
        }),
        None => Err(c.syntax("constant or (expression) expected")),
    }
}

/// A full expression.
pub(crate) fn expr(c: &mut Cursor) -> Result<Expr, ParseError> {
    let first = unary(c)?;
    expr_from(c, first)
}

fn high_op(c: &mut Cursor) -> Option<BinOp> {
    let mut k = c.clone();
    k.skip_ws();
    let op = match k.peek()? {
        b'*' => BinOp::Mul,
        b'/' => BinOp::Div,
        b'%' => BinOp::Mod,
        b'&' if k.peek_at(1) != Some(b'=') => BinOp::And,
        _ => return None,
    };
    k.bump();
    *c = k;
    Some(op)
}

fn low_op(c: &mut Cursor) -> Option<BinOp> {
    let mut k = c.clone();
    k.skip_ws();
    let op = match k.peek()? {
        b'+' => BinOp::Add,
        b'-' => BinOp::Sub,
        b'|' if k.peek_at(1) != Some(b'=') => BinOp::Or,
        b'^' if k.peek_at(1) != Some(b'=') => BinOp::Xor,
        _ => return None,
    };
    k.bump();
    *c = k;
    Some(op)
}

/// Continue an expression whose first operand (a unary) is already parsed.
fn expr_from(c: &mut Cursor, first: Expr) -> Result<Expr, ParseError> {
    let mut lhs = term_from(c, first)?;
    while let Some(op) = low_op(c) {
        let first = unary(c)?;
        let rhs = term_from(c, first)?;
        let pos = lhs.pos;
        lhs = Expr {
            kind: ExprKind::Bin(op, Box::new(lhs), Box::new(rhs)),
            pos,
        };
    }
    Ok(lhs)
}

fn term_from(c: &mut Cursor, first: Expr) -> Result<Expr, ParseError> {
    let mut lhs = first;
    while let Some(op) = high_op(c) {
        let rhs = unary(c)?;
        let pos = lhs.pos;
        lhs = Expr {
            kind: ExprKind::Bin(op, Box::new(lhs), Box::new(rhs)),
            pos,
        };
    }
    Ok(lhs)
}

fn unary(c: &mut Cursor) -> Result<Expr, ParseError> {
    c.skip_ws();
    let pos = c.pos();
    match c.peek() {
        Some(b'-') => {
            if let Some(n) = c.number()? {
                return Ok(Expr {
                    kind: ExprKind::Num(n),
                    pos,
                });
            }
            c.bump();
            c.enter()?;
            let inner = unary(c)?;
            c.leave();
            Ok(Expr {
                kind: ExprKind::Neg(Box::new(inner)),
                pos,
            })
        }
        Some(b'+') => Err(c.syntax("unary plus is not allowed")),
        _ => primary(c),
    }
}

fn primary(c: &mut Cursor) -> Result<Expr, ParseError> {
    c.skip_ws();
    let pos = c.pos();
    if c.peek() == Some(b'(') {
        return paren_expr(c);
    }
    if let Some(n) = c.unsigned_number()? {
        return Ok(Expr {
            kind: ExprKind::Num(n),
            pos,
        });
    }
    if let Some(v) = var_ref(c)? {
        return Ok(Expr {
            kind: ExprKind::Var(v),
            pos,
        });
    }
    let save = c.offset();
    if let Some(f) = c.eat_longest(FUNCS) {
        c.skip_ws();
        if c.peek() == Some(b'(') {
            c.enter()?;
            let arg = paren_expr(c)?;
            c.leave();
            return Ok(Expr {
                kind: ExprKind::Call(f, Box::new(arg)),
                pos,
            });
        }
        c.set_offset(save);
    }
    Err(c.syntax("operand expected"))
}

/// A comparator, if next.
fn cmp_op(c: &mut Cursor) -> Option<CmpOp> {
    let mut k = c.clone();
    k.skip_ws();
    let op = match (k.peek()?, k.peek_at(1)) {
        (b'!', Some(b'=')) => CmpOp::Ne,
        (b'!', Some(b'>')) => CmpOp::NotGt,
        (b'!', Some(b'<')) => CmpOp::NotLt,
        (b'!', Some(b'~')) => CmpOp::NotApprox,
        (b'=', _) => CmpOp::Eq,
        (b'>', _) => CmpOp::Gt,
        (b'<', _) => CmpOp::Lt,
        (b'~', _) => CmpOp::Approx,
        _ => return None,
    };
    k.advance(if k.peek() == Some(b'!') { 2 } else { 1 });
    *c = k;
    Some(op)
}

enum CondOrExpr {
    Cond(Cond),
    Expr(Expr),
}

/// An atom of a condition, or (inside parentheses) a plain expression.
fn atom_or_expr(c: &mut Cursor) -> Result<CondOrExpr, ParseError> {
    c.skip_ws();
    let lhs = if c.peek() == Some(b'(') {
        c.bump();
        c.enter()?;
        let inner = cond_or_expr(c)?;
        if !c.eat_ws(b')') {
            return Err(c.syntax("')' expected"));
        }
        c.leave();
        match inner {
            CondOrExpr::Cond(k) => return Ok(CondOrExpr::Cond(k)),
            CondOrExpr::Expr(e) => expr_from(c, e)?,
        }
    } else {
        expr(c)?
    };
    match cmp_op(c) {
        Some(op) => {
            let rhs = expr(c)?;
            Ok(CondOrExpr::Cond(Cond::Cmp { lhs, op, rhs }))
        }
        None => Ok(CondOrExpr::Expr(lhs)),
    }
}

fn cond_atom(c: &mut Cursor) -> Result<Cond, ParseError> {
    match atom_or_expr(c)? {
        CondOrExpr::Cond(k) => Ok(k),
        CondOrExpr::Expr(_) => Err(c.syntax("comparison expected")),
    }
}

fn eat_logic(c: &mut Cursor, kw: &str) -> bool {
    let mut k = c.clone();
    k.skip_ws();
    if k.eat_kw(kw) {
        *c = k;
        true
    } else {
        false
    }
}

fn chain(c: &mut Cursor, first: Cond) -> Result<Cond, ParseError> {
    let mut and = first;
    while eat_logic(c, "AND") {
        and = Cond::And(Box::new(and), Box::new(cond_atom(c)?));
    }
    let mut or = and;
    while eat_logic(c, "OR") {
        let mut and = cond_atom(c)?;
        while eat_logic(c, "AND") {
            and = Cond::And(Box::new(and), Box::new(cond_atom(c)?));
        }
        or = Cond::Or(Box::new(or), Box::new(and));
    }
    Ok(or)
}

fn cond_or_expr(c: &mut Cursor) -> Result<CondOrExpr, ParseError> {
    match atom_or_expr(c)? {
        CondOrExpr::Cond(k) => Ok(CondOrExpr::Cond(chain(c, k)?)),
        e => Ok(e),
    }
}

/// `'(' cond ')'` as after IF / WHILE / AND / OR.
pub(crate) fn paren_cond(c: &mut Cursor) -> Result<Cond, ParseError> {
    c.skip_ws();
    if !c.eat(b'(') {
        return Err(c.syntax("'(' expected before condition"));
    }
    c.enter()?;
    let k = match cond_or_expr(c)? {
        CondOrExpr::Cond(k) => k,
        CondOrExpr::Expr(_) => return Err(c.syntax("comparison expected")),
    };
    if !c.eat_ws(b')') {
        return Err(c.syntax("')' expected after condition"));
    }
    c.leave();
    Ok(k)
}
