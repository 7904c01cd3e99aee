//! Expression and condition evaluation with PMAC numeric semantics (pmac-commands.md §5.6,
//! pmac-variables-servo-macro.md §1): f64 arithmetic (rounded to PMAC's 48-bit float format by
//! [`to_pmac48`] when stored), division by zero saturating at ±2^47, `%` flooring toward −∞ (and
//! symmetric for negative divisors), bitwise operators on two's-complement fixed point including
//! fractional bits, trigonometry in degrees or radians per I15, no domain errors.

use super::ast::{BinOp, CmpOp, Cond, Expr, ExprKind, Func, VarIndex, VarKind, VarRef};

/// A variable could not be read (or a computed index is invalid).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct EvalError {
    /// PMAC error number (ERR003 for a bad variable number).
    pub code: u8,
    /// Reason.
    pub msg: &'static str,
}

/// What an expression needs from the card.
pub(crate) trait Env {
    /// Value of variable `kind` number `index` (Q in the evaluating C.S.).
    fn var(&mut self, kind: VarKind, index: u32) -> Result<f64, EvalError>;
    /// I15 = 1: trigonometry in radians (else degrees).
    fn radians(&self) -> bool;
    /// The "cosine" argument of ATAN2: Q0 of the evaluating coordinate system.
    fn atan2_cos(&mut self) -> Result<f64, EvalError> {
        self.var(VarKind::Q, 0)
    }
}

/// Result of `x / 0`.
pub(crate) const DIV_ZERO: f64 = 140_737_488_355_328.0; // 2^47

/// Maximum nesting the evaluator accepts (the parser limits depth well below this).
const MAX_EVAL_DEPTH: u32 = 256;

/// Evaluate an expression.
pub(crate) fn eval<E: Env + ?Sized>(e: &Expr, env: &mut E) -> Result<f64, EvalError> {
    eval_d(e, env, 0)
}

/// Evaluate a variable index (`P(expr)` is rounded to the nearest integer, must be ≥ 0).
pub(crate) fn index<E: Env + ?Sized>(i: &VarIndex, env: &mut E) -> Result<u32, EvalError> {
    match i {
        VarIndex::Const(n) => Ok(*n),
        VarIndex::Expr(e) => {
            let v = eval(e, env)?.round();
            if (0.0..=f64::from(u32::MAX)).contains(&v) {
                Ok(v as u32)
            } else {
                Err(EvalError {
                    code: 3,
                    msg: "computed variable number out of range",
                })
            }
        }
    }
}

/// Read a variable reference.
pub(crate) fn read_var<E: Env + ?Sized>(v: &VarRef, env: &mut E) -> Result<f64, EvalError> {
    let n = index(&v.index, env)?;
    env.var(v.kind, n)
}

fn eval_d<E: Env + ?Sized>(e: &Expr, env: &mut E, depth: u32) -> Result<f64, EvalError> {
    if depth > MAX_EVAL_DEPTH {
        return Err(EvalError {
            code: 3,
            msg: "expression too deep",
        });
    }
    let v = match &e.kind {
        ExprKind::Num(n) => n.value,
        ExprKind::Var(v) => read_var(v, env)?,
        ExprKind::Neg(i) => -eval_d(i, env, depth + 1)?,
        ExprKind::Bin(op, l, r) => {
            let a = eval_d(l, env, depth + 1)?;
            let b = eval_d(r, env, depth + 1)?;
            binary(*op, a, b)
        }
        ExprKind::Call(f, a) => {
            let x = eval_d(a, env, depth + 1)?;
            let cos = if *f == Func::Atan2 {
                env.atan2_cos()?
            } else {
                0.0
            };
            function(*f, x, cos, env.radians())
        }
    };
    Ok(finite(v))
}

/// NaN → 0, ±∞ → ±f64::MAX (PMAC has no non-finite values).
fn finite(v: f64) -> f64 {
    if v.is_nan() {
        0.0
    } else if v.is_infinite() {
        f64::MAX.copysign(v)
    } else {
        v
    }
}

/// A binary operator with PMAC semantics.
pub(crate) fn binary(op: BinOp, a: f64, b: f64) -> f64 {
    finite(match op {
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Mul => a * b,
        BinOp::Div => {
            if b == 0.0 {
                if a < 0.0 {
                    -DIV_ZERO
                } else {
                    DIV_ZERO
                }
            } else {
                a / b
            }
        }
        BinOp::Mod => modulo(a, b),
        BinOp::And => from_fixed(to_fixed(a) & to_fixed(b)),
        BinOp::Or => from_fixed(to_fixed(a) | to_fixed(b)),
        BinOp::Xor => from_fixed(to_fixed(a) ^ to_fixed(b)),
    })
}

/// `a % n`: n > 0 → [0, n); n < 0 → [n, −n); n = 0 → 0.
pub(crate) fn modulo(a: f64, n: f64) -> f64 {
    if n == 0.0 {
        0.0
    } else if n > 0.0 {
        a - n * (a / n).floor()
    } else {
        let m = 2.0 * n.abs();
        a - m * ((a + n.abs()) / m).floor()
    }
}

const FRAC_BITS: i32 = 40;

fn to_fixed(x: f64) -> i128 {
    (x * 2f64.powi(FRAC_BITS)).round() as i128
}

fn from_fixed(v: i128) -> f64 {
    v as f64 / 2f64.powi(FRAC_BITS)
}

/// A function with PMAC semantics; `cos` is the ATAN2 cosine part.
pub(crate) fn function(f: Func, x: f64, cos: f64, radians: bool) -> f64 {
    let to_rad = |v: f64| if radians { v } else { v.to_radians() };
    let from_rad = |v: f64| if radians { v } else { v.to_degrees() };
    finite(match f {
        Func::Sin => to_rad(x).sin(),
        Func::Cos => to_rad(x).cos(),
        Func::Tan => to_rad(x).tan(),
        Func::Asin => from_rad(x.clamp(-1.0, 1.0).asin()),
        Func::Acos => from_rad(x.clamp(-1.0, 1.0).acos()),
        Func::Atan => from_rad(x.atan()),
        Func::Atan2 => from_rad(x.atan2(cos)),
        Func::Ln => {
            if x > 0.0 {
                x.ln()
            } else {
                0.0
            }
        }
        Func::Exp => x.exp(),
        Func::Sqrt => {
            if x > 0.0 {
                x.sqrt()
            } else {
                0.0
            }
        }
        Func::Abs => x.abs(),
        Func::Int => x.floor(),
    })
}

/// Compare two values.
pub(crate) fn compare(op: CmpOp, a: f64, b: f64) -> bool {
    match op {
        CmpOp::Eq => a == b,
        CmpOp::Ne => a != b,
        CmpOp::Gt => a > b,
        CmpOp::NotGt => a <= b,
        CmpOp::Lt => a < b,
        CmpOp::NotLt => a >= b,
        CmpOp::Approx => (a - b).abs() <= 1.0,
        CmpOp::NotApprox => (a - b).abs() > 1.0,
    }
}

/// Evaluate a condition (AND binds tighter than OR; both sides are always evaluated).
pub(crate) fn eval_cond<E: Env + ?Sized>(c: &Cond, env: &mut E) -> Result<bool, EvalError> {
    eval_cond_d(c, env, 0)
}

fn eval_cond_d<E: Env + ?Sized>(c: &Cond, env: &mut E, depth: u32) -> Result<bool, EvalError> {
    if depth > MAX_EVAL_DEPTH {
        return Err(EvalError {
            code: 3,
            msg: "condition too deep",
        });
    }
    Ok(match c {
        Cond::Cmp { lhs, op, rhs } => {
            let a = eval(lhs, env)?;
            let b = eval(rhs, env)?;
            compare(*op, a, b)
        }
        Cond::And(a, b) => {
            let x = eval_cond_d(a, env, depth + 1)?;
            let y = eval_cond_d(b, env, depth + 1)?;
            x && y
        }
        Cond::Or(a, b) => {
            let x = eval_cond_d(a, env, depth + 1)?;
            let y = eval_cond_d(b, env, depth + 1)?;
            x || y
        }
    })
}

/// Round to PMAC's 48-bit floating-point format (36-bit two's-complement mantissa, i.e. 35
/// significant bits after the sign). Use when storing P/Q/L-format values.
#[cfg(test)]
pub(crate) fn to_pmac48(x: f64) -> f64 {
    let x = finite(x);
    if x == 0.0 {
        return 0.0;
    }
    let e = x.abs().log2().floor() as i32 + 1; // |x| = m·2^e with m in [0.5, 1)
    let scale = 2f64.powi(35 - e);
    if !scale.is_finite() || scale == 0.0 {
        return x;
    }
    (x * scale).round() / scale
}

/// Round for an integer-format store (`M1=10*2/3` → 7): nearest, halves away from zero.
#[cfg(test)]
pub(crate) fn to_integer(x: f64) -> f64 {
    finite(x).round()
}
