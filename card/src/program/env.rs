//! Variable access for programs and PLCs: expression environment over the card state for one
//! coordinate system (Q-variables and the ATAN2 cosine come from it), assignments, and the
//! I-variable numbering of the two profiles.

use crate::domain::ast::{AssignOp, BinOp, Cond, Expr, VarKind, VarRef};
use crate::domain::eval::{self, Env, EvalError};
use crate::domain::Profile;
use crate::model::CardModel;
use crate::model::CardState;

/// Expression environment of a program running in (or a PLC addressing) C.S. `cs`.
pub(crate) struct ProgEnv<'a> {
    /// The state.
    pub state: &'a mut CardState,
    /// C.S. of the Q-variables.
    pub cs: u16,
}

impl Env for ProgEnv<'_> {
    fn var(&mut self, kind: VarKind, n: u32) -> Result<f64, EvalError> {
        let r = match kind {
            VarKind::I => self.state.read_ivar(n),
            VarKind::P => self.state.vars.p(n),
            VarKind::Q => self.state.vars.q(self.cs, n),
            VarKind::M => self.state.read_m(n),
        };
        r.map_err(|_| EvalError {
            code: 3,
            msg: "no such variable",
        })
    }

    fn radians(&self) -> bool {
        self.state.peek_ivar(15).unwrap_or(0.0) != 0.0
    }
}

/// Evaluate `e` for C.S. `cs`.
pub(crate) fn value(card: &mut CardModel, cs: u16, e: &Expr) -> Result<f64, EvalError> {
    eval::eval(
        e,
        &mut ProgEnv {
            state: &mut card.state,
            cs,
        },
    )
}

/// Evaluate a condition for C.S. `cs`.
pub(crate) fn test(card: &mut CardModel, cs: u16, c: &Cond) -> Result<bool, EvalError> {
    eval::eval_cond(
        c,
        &mut ProgEnv {
            state: &mut card.state,
            cs,
        },
    )
}

/// The variable number of `v` (computed indices evaluated).
pub(crate) fn var_number(card: &mut CardModel, cs: u16, v: &VarRef) -> Result<u32, EvalError> {
    eval::index(
        &v.index,
        &mut ProgEnv {
            state: &mut card.state,
            cs,
        },
    )
}

/// Write variable `kind` `n` (C.S. `cs` for Q). `false` when the card refused it.
pub(crate) fn write(card: &mut CardModel, cs: u16, kind: VarKind, n: u32, v: f64) -> bool {
    let st = &mut card.state;
    match kind {
        VarKind::I => st.set_ivar(n, v).is_ok(),
        VarKind::P => st.vars.set_p(n, v).is_ok(),
        VarKind::Q => st.vars.set_q(cs, n, v).is_ok(),
        VarKind::M => st.write_m(n, v).is_ok(),
    }
}

/// Apply a synchronous M-variable operation now: `==` stores, `&=`/`|=`/`^=` combine with
/// the present value.
pub(crate) fn apply_sync(card: &mut CardModel, m: u32, op: AssignOp, v: f64) {
    let v = match op {
        AssignOp::SyncAnd | AssignOp::SyncOr | AssignOp::SyncXor => {
            let old = card.state.read_m(m).unwrap_or(0.0);
            let b = match op {
                AssignOp::SyncAnd => BinOp::And,
                AssignOp::SyncOr => BinOp::Or,
                _ => BinOp::Xor,
            };
            eval::binary(b, old, v)
        }
        _ => v,
    };
    let _ = card.state.write_m(m, v);
}

/// Number of C.S. I-variable `nn` (87..99) of C.S. `cs`: Ixnn on PMAC2, Isxnn on Turbo.
pub(crate) fn cs_ivar(profile: Profile, cs: u16, nn: u32) -> u32 {
    match profile {
        Profile::Pmac2 => 100 * u32::from(cs) + nn,
        Profile::Turbo => 5000 + 100 * u32::from(cs) + nn,
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
