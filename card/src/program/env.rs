//! Variable access for programs and PLCs: expression environment over the card state for one
//! coordinate system (Q-variables and the ATAN2 cosine come from it), assignments, and the
//! I-variable numbering of the two profiles.

use crate::domain::ast::{AssignOp, BinOp, Cond, Expr, VarKind, VarRef};
use crate::domain::eval::{self, Env, EvalError};
use crate::domain::ErrCode;
use crate::domain::Profile;
use crate::model::CardModel;

/// Expression environment of a program running in (or a PLC addressing) C.S. `cs`.
pub(crate) struct ProgEnv<'a> {
    /// The card.
    pub card: &'a mut CardModel,
    /// C.S. of the Q-variables.
    pub cs: u16,
}

fn no_var() -> EvalError {
    EvalError {
        code: ErrCode::Data,
        msg: "no such variable",
    }
}

impl Env for ProgEnv<'_> {
    fn var(&mut self, kind: VarKind, n: u32) -> Result<f64, EvalError> {
        let st = &mut self.card.state;
        let r = match kind {
            VarKind::I => st.read_ivar(n),
            VarKind::P => st.vars.p(n),
            VarKind::Q => st.vars.q(self.cs, n),
            VarKind::M => st.read_m(n),
            VarKind::Ext(f) => {
                let at = self.card.exec;
                return self.card.ext_read(&at, f, n).map_err(|_| no_var());
            }
        };
        r.map_err(|_| no_var())
    }

    fn radians(&self) -> bool {
        self.card.state.peek_ivar(15).unwrap_or(0.0) != 0.0
    }

    fn ieee(&self) -> bool {
        self.card.state.limits().sem.ieee
    }

    fn random(&mut self) -> f64 {
        self.card.random()
    }

    fn seed(&mut self, v: f64, n: f64) -> f64 {
        let k = usize::from(n.round() as i64 & 1 != 0);
        if v > 0.0 {
            self.card.rng[k] = v as u64 | 1;
        }
        self.card.rng[k] as f64
    }

    fn store(&mut self, kind: VarKind, index: u32, v: f64) -> Result<(), EvalError> {
        if write(self.card, self.cs, kind, index, v) {
            Ok(())
        } else {
            Err(no_var())
        }
    }
}

/// Evaluate `e` for C.S. `cs`.
pub(crate) fn value(card: &mut CardModel, cs: u16, e: &Expr) -> Result<f64, EvalError> {
    eval::eval(e, &mut ProgEnv { card, cs })
}

/// Evaluate a condition for C.S. `cs`.
pub(crate) fn test(card: &mut CardModel, cs: u16, c: &Cond) -> Result<bool, EvalError> {
    eval::eval_cond(c, &mut ProgEnv { card, cs })
}

/// The variable number of `v` (computed indices evaluated).
pub(crate) fn var_number(card: &mut CardModel, cs: u16, v: &VarRef) -> Result<u32, EvalError> {
    eval::index(&v.index, &mut ProgEnv { card, cs })
}

/// The value of variable `v` (computed indices evaluated) for C.S. `cs`.
pub(crate) fn read(card: &mut CardModel, cs: u16, v: &VarRef) -> Result<f64, EvalError> {
    let n = var_number(card, cs, v)?;
    ProgEnv { card, cs }.var(v.kind, n)
}

/// Write variable `kind` `n` (C.S. `cs` for Q). `false` when the card refused it.
pub(crate) fn write(card: &mut CardModel, cs: u16, kind: VarKind, n: u32, v: f64) -> bool {
    let st = &mut card.state;
    match kind {
        VarKind::I => st.set_ivar(n, v).is_ok(),
        VarKind::P => st.vars.set_p(n, v).is_ok(),
        VarKind::Q => st.vars.set_q(cs, n, v).is_ok(),
        VarKind::M => st.write_m(n, v).is_ok(),
        VarKind::Ext(f) => {
            let at = card.exec;
            card.ext_write(&at, f, n, v).is_ok()
        }
    }
}

/// Apply a synchronous assignment now (C.S. `cs`): `==` stores, the compound forms combine
/// with the present value.
pub(crate) fn apply_sync(
    card: &mut CardModel,
    cs: u16,
    kind: VarKind,
    m: u32,
    op: AssignOp,
    v: f64,
) {
    let b = match op {
        AssignOp::SyncAnd => Some(BinOp::And),
        AssignOp::SyncOr => Some(BinOp::Or),
        AssignOp::SyncXor => Some(BinOp::Xor),
        AssignOp::SyncOp(b) | AssignOp::Op(b) => Some(b),
        AssignOp::Set | AssignOp::SyncSet => None,
    };
    let v = match b {
        Some(b) => {
            let old = ProgEnv { card, cs }.var(kind, m).unwrap_or(0.0);
            combine(card, b, old, v)
        }
        None => v,
    };
    let _ = write(card, cs, kind, m, v);
}

/// `old op v` with the card's arithmetic.
pub(crate) fn combine(card: &CardModel, op: BinOp, old: f64, v: f64) -> f64 {
    if card.state.limits().sem.ieee {
        eval::binary_ieee(op, old, v)
    } else {
        eval::binary(op, old, v)
    }
}

/// Number of C.S. I-variable `nn` (87..99) of C.S. `cs`: Ixnn on PMAC2, Isxnn on Turbo.
pub(crate) fn cs_ivar(profile: Profile, cs: u16, nn: u32) -> u32 {
    match profile {
        Profile::Pmac2 => 100 * u32::from(cs) + nn,
        Profile::Turbo | Profile::Power => 5000 + 100 * u32::from(cs) + nn,
    }
}

/// I-variable value with a default when missing or non-finite.
pub(crate) fn ivar(card: &CardModel, n: u32, dflt: f64) -> f64 {
    card.state
        .peek_ivar(n)
        .ok()
        .filter(|v| v.is_finite())
        .unwrap_or(dflt)
}
