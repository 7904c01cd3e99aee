//! Expression and condition evaluation with PMAC numeric semantics (pmac-commands.md §5.6,
//! pmac-variables-servo-macro.md §1): f64 arithmetic (rounded to PMAC's 48-bit float format by
//! [`to_pmac48`] when stored), division by zero saturating at ±2^47, `%` flooring toward −∞ (and
//! symmetric for negative divisors), bitwise operators on two's-complement fixed point including
//! fractional bits, trigonometry in degrees or radians per I15, no domain errors.

use super::ast::{BinOp, CmpOp, Cond, Expr, ExprKind, Func, MathFn, VarIndex, VarKind, VarRef};
use super::ErrCode;

/// A variable could not be read (or a computed index is invalid).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct EvalError {
    /// The PMAC refusal (ERR003 for a bad variable number).
    pub code: ErrCode,
    /// Reason.
    pub msg: &'static str,
}

impl EvalError {
    /// No such variable (a bad number or family).
    pub(crate) const NO_VARIABLE: EvalError = EvalError {
        code: ErrCode::Data,
        msg: "no such variable",
    };
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
    /// IEEE double semantics (Power PMAC): division by zero gives ±∞, NaN and ∞ are kept.
    fn ieee(&self) -> bool {
        false
    }
    /// The next pseudo-random number in [0, 1) (`rnd`, `randx`).
    fn random(&mut self) -> f64 {
        0.0
    }
    /// `seed(v, n)`: set seed `n` to `v` when `v` > 0; the seed's value.
    fn seed(&mut self, v: f64, n: f64) -> f64 {
        let _ = n;
        v
    }
    /// Store a value into a variable (`sincos` stores its cosine).
    fn store(&mut self, kind: VarKind, index: u32, v: f64) -> Result<(), EvalError> {
        let _ = (kind, index, v);
        Err(EvalError {
            code: ErrCode::Data,
            msg: "variable cannot be written here",
        })
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
                    code: ErrCode::Data,
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
            code: ErrCode::Data,
            msg: "expression too deep",
        });
    }
    let ieee = env.ieee();
    let v = match &e.kind {
        ExprKind::Num(n) => n.value,
        ExprKind::Var(v) => read_var(v, env)?,
        ExprKind::Neg(i) => -eval_d(i, env, depth + 1)?,
        ExprKind::Bin(op, l, r) => {
            let a = eval_d(l, env, depth + 1)?;
            let b = eval_d(r, env, depth + 1)?;
            if ieee {
                binary_ieee(*op, a, b)
            } else {
                binary(*op, a, b)
            }
        }
        ExprKind::Math(f @ (MathFn::SinCos | MathFn::SinCosD), args) => {
            let a = match args.first() {
                Some(a) => eval_d(a, env, depth + 1)?,
                None => 0.0,
            };
            let rad = if *f == MathFn::SinCosD {
                a.to_radians()
            } else {
                a
            };
            if let Some(ExprKind::Var(v)) = args.get(1).map(|e| &e.kind) {
                let n = index(&v.index, env)?;
                env.store(v.kind, n, rad.cos())?;
            }
            rad.sin()
        }
        ExprKind::Math(MathFn::Rnd, _) => env.random(),
        ExprKind::Math(MathFn::RandX, args) => {
            let x = match args.first() {
                Some(a) => eval_d(a, env, depth + 1)?,
                None => 1.0,
            };
            env.random() * x
        }
        ExprKind::Math(MathFn::Seed, args) => {
            let mut v = [0.0f64; 2];
            for (slot, a) in v.iter_mut().zip(args) {
                *slot = eval_d(a, env, depth + 1)?;
            }
            env.seed(v[0], v[1])
        }
        ExprKind::Math(f, args) => {
            let mut v = [0.0f64; 3];
            for (slot, a) in v.iter_mut().zip(args) {
                *slot = eval_d(a, env, depth + 1)?;
            }
            math(*f, v[0], v[1], v[2])
        }
        ExprKind::BitNot(i) => -eval_d(i, env, depth + 1)? - 1.0,
        ExprKind::Test(c) => {
            if eval_cond_d(c, env, depth + 1)? {
                1.0
            } else {
                0.0
            }
        }
        ExprKind::Strided(parts) => {
            let mut sum = 0.0;
            for (e, stride) in parts {
                sum += eval_d(e, env, depth + 1)?.round() * f64::from(*stride);
            }
            sum
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
    Ok(if ieee { v } else { finite(v) })
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
        BinOp::Shl => a * 2f64.powf(b),
        BinOp::Shr => a / 2f64.powf(b),
        BinOp::FMod => a % b,
    })
}

/// A binary operator with IEEE double semantics (Power PMAC): `x / 0` is ±∞, `x % 0` NaN,
/// `%` takes the dividend's sign (C `fmod`), bitwise operators act on fixed point including
/// fractional bits.
pub(crate) fn binary_ieee(op: BinOp, a: f64, b: f64) -> f64 {
    match op {
        BinOp::Div => a / b,
        BinOp::Mod | BinOp::FMod => a % b,
        BinOp::And | BinOp::Or | BinOp::Xor if !(a.is_finite() && b.is_finite()) => f64::NAN,
        _ => binary(op, a, b),
    }
}

/// The IEEE functions (the second and third arguments are 0 when not given).
pub(crate) fn math(f: MathFn, x: f64, y: f64, z: f64) -> f64 {
    use MathFn as M;
    match f {
        M::Abs => x.abs(),
        M::Acos => x.acos(),
        M::AcosD => x.acos().to_degrees(),
        M::Acosh => x.acosh(),
        M::Asin => x.asin(),
        M::AsinD => x.asin().to_degrees(),
        M::Asinh => x.asinh(),
        M::Atan => x.atan(),
        M::AtanD => x.atan().to_degrees(),
        M::Atanh => x.atanh(),
        M::Atan2 => x.atan2(y),
        M::Atan2D => x.atan2(y).to_degrees(),
        M::Cbrt => x.cbrt(),
        M::Ceil => x.ceil(),
        M::Cos => x.cos(),
        M::CosD => x.to_radians().cos(),
        M::Cosh => x.cosh(),
        M::Exp => x.exp(),
        M::Exp2 => x.exp2(),
        M::Floor | M::Int => x.floor(),
        M::IsNan => {
            if x.is_nan() {
                1.0
            } else {
                0.0
            }
        }
        M::Ln => x.ln(),
        M::Log2 => x.log2(),
        M::Log10 => x.log10(),
        M::Madd => x.mul_add(y, z),
        M::Pow => x.powf(y),
        M::Qnrt => x.signum() * x.abs().powf(0.2),
        M::Qrrt => x.powf(0.25),
        M::Rem => {
            if y == 0.0 {
                f64::NAN
            } else {
                modulo(x, y)
            }
        }
        M::Rint => (x + 0.5).floor(),
        // Evaluated with the environment (random state, variables) in `eval_d`.
        M::Rnd | M::RandX | M::Seed => 0.0,
        M::SinCos => x.sin(),
        M::SinCosD => x.to_radians().sin(),
        M::Sgn => {
            if x > 0.0 {
                1.0
            } else if x < 0.0 {
                -1.0
            } else {
                0.0
            }
        }
        M::Sin => x.sin(),
        M::SinD => x.to_radians().sin(),
        M::Sinh => x.sinh(),
        M::Sqrt => x.sqrt(),
        M::Tan => x.tan(),
        M::TanD => x.to_radians().tan(),
        M::Tanh => x.tanh(),
    }
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
        CmpOp::Near => (a - b).abs() < 0.5,
        CmpOp::NotNear => (a - b).abs() >= 0.5,
    }
}

/// Evaluate a condition (AND binds tighter than OR; both sides are always evaluated).
pub(crate) fn eval_cond<E: Env + ?Sized>(c: &Cond, env: &mut E) -> Result<bool, EvalError> {
    eval_cond_d(c, env, 0)
}

fn eval_cond_d<E: Env + ?Sized>(c: &Cond, env: &mut E, depth: u32) -> Result<bool, EvalError> {
    if depth > MAX_EVAL_DEPTH {
        return Err(EvalError {
            code: ErrCode::Data,
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
        Cond::Value(e) => {
            let v = eval_d(e, env, depth + 1)?;
            v != 0.0 && !v.is_nan()
        }
        Cond::Not(c) => !eval_cond_d(c, env, depth + 1)?,
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
