//! The card's buffer-memory model: how many words a stored statement occupies (project model
//! reproducing seed 004's examples: `LINEAR` 1, `F10` 1, `X10Y10` 2, `RETURN` 1, `P1=0` 1,
//! `WHILE(P1<1000)` 2, `P1=P1+1` 3, `ENDWHILE` 1). Offsets of `LIST PROG n,`, `PC`, `PE` and the
//! free space `SIZE` reports follow from it.

use super::ast::{
    AxisExtra, AxisWord, Cond, Display, Expr, ExprKind, Message, Stmt, StmtKind, VarIndex, VarRef,
};

fn expr_words(e: &Expr) -> u32 {
    match &e.kind {
        ExprKind::Num(_)
        | ExprKind::Var(VarRef {
            index: VarIndex::Const(_),
            ..
        }) => 0,
        ExprKind::Var(VarRef {
            index: VarIndex::Expr(i),
            ..
        }) => 1 + expr_words(i),
        ExprKind::Neg(i) | ExprKind::Call(_, i) | ExprKind::BitNot(i) => 1 + expr_words(i),
        ExprKind::Bin(_, l, r) => 2 + expr_words(l) + expr_words(r),
        ExprKind::Math(_, args) => 1 + args.iter().map(expr_words).sum::<u32>(),
        ExprKind::Strided(parts) => parts.iter().map(|(e, _)| 1 + expr_words(e)).sum::<u32>(),
        ExprKind::Test(c) => cond_words(c),
    }
}

fn cond_words(c: &Cond) -> u32 {
    match c {
        Cond::Cmp { lhs, rhs, .. } => 1 + expr_words(lhs) + expr_words(rhs),
        Cond::And(a, b) | Cond::Or(a, b) => 1 + cond_words(a) + cond_words(b),
        Cond::Value(e) => 1 + expr_words(e),
        Cond::Not(c) => 1 + cond_words(c),
    }
}

fn text_words(n: usize) -> u32 {
    1 + (n as u32).div_ceil(3)
}

/// Buffer words a statement occupies (project model reproducing seed 004's examples: `LINEAR`
/// 1, `F10` 1, `X10Y10` 2, `RETURN` 1, `P1=0` 1, `WHILE(P1<1000)` 2, `P1=P1+1` 3, `ENDWHILE` 1).
pub(crate) fn word_count(s: &Stmt) -> u32 {
    use StmtKind as S;
    let body = |b: &[Stmt]| b.iter().map(word_count).sum::<u32>();
    let w = |ws: &[AxisWord]| {
        ws.iter()
            .map(|x| {
                1 + expr_words(&x.value)
                    + match &x.extra {
                        Some(AxisExtra::Velocity(e) | AxisExtra::Trigger(e)) => 1 + expr_words(e),
                        None => 0,
                    }
            })
            .sum::<u32>()
    };
    match &s.kind {
        S::Assign { value, .. } => 1 + expr_words(value),
        S::Move(ws) => w(ws),
        S::Pset(ws) | S::Normal(ws) => 1 + w(ws),
        S::Pmatch | S::Pstore | S::Pload => 1,
        S::Pvt(d) | S::Ta(d) | S::Ts(d) | S::Tm(d) | S::F(d) | S::Dwell(d) | S::Delay(d) => {
            1 + expr_words(d)
        }
        S::Td(d) | S::Spline(d) => 1 + expr_words(d),
        S::SendFormat { text, args, .. } | S::CommandFormat { text, args } => {
            text_words(text.len()) + args.iter().map(expr_words).sum::<u32>()
        }
        S::CutterRadius(d) | S::Goto(d) | S::Spindle(d) => 1 + expr_words(d),
        S::Switch(d) => 1 + expr_words(d),
        S::If(c) | S::While(c) | S::AndCond(c) | S::OrCond(c) | S::DoWhile(c) => 1 + cond_words(c),
        S::IfLine(c, b) | S::WhileLine(c, b) => 1 + cond_words(c) + body(b),
        S::Else(b) => 1 + body(b),
        S::Call(d, a) | S::Code(_, d, a) | S::Gosub(d, a) | S::CallSub(d, a) => {
            1 + expr_words(d) + a.iter().map(|x| 1 + expr_words(&x.value)).sum::<u32>()
        }
        S::Command(Message::Text(t)) | S::Send(_, Message::Text(t)) => text_words(t.len()),
        S::Display(Display::Text { text, .. }) => text_words(text.len()),
        _ => 1,
    }
}
