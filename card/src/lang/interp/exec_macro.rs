//! MACRO auxiliary commands (§3.5). Without a ring connection there is never an answer from a
//! station: after the argument checks (ERR003), every access fails with ERR008, sets `???`
//! word 1 bit 5 and X:$0798 = $010000 (timeout), as the spec gives for a timeout.

use super::exec::{Exec, Out};
use super::{Pmac, Session};
use crate::lang::ast::{CmdKind, SlaveVar, VarIndex, VarRef};
use crate::model::Space;
use crate::model::AUX_ERROR_VALUE;

/// X:$0798 value for an auxiliary timeout.
pub(super) const AUX_TIMEOUT: u32 = 0x01_0000;

fn node_ok(node: u32) -> Exec {
    if node <= 15 {
        Ok(())
    } else {
        Err(3)
    }
}

fn var_ok(card: &Pmac<'_>, v: &VarRef) -> Exec {
    match &v.index {
        VarIndex::Const(n) if *n < u32::from(card.state.limits().vars) => Ok(()),
        VarIndex::Const(_) => Err(3),
        VarIndex::Expr(_) => Ok(()),
    }
}

fn slave_var_ok(v: &SlaveVar) -> Exec {
    match v {
        SlaveVar::Mi(n) | SlaveVar::Mc(n) if *n <= 1023 => Ok(()),
        _ => Err(3),
    }
}

impl Pmac<'_> {
    pub(crate) fn exec_macro(&mut self, _s: &mut Session, cmd: &CmdKind, _out: &mut Out) -> Exec {
        // The error bit is cleared at the start of each auxiliary command.
        self.model.state.global.macro_aux_error = false;
        match cmd {
            CmdKind::MacroAux { node, param, value } => {
                node_ok(*node)?;
                if *param > 65_535 {
                    return Err(3);
                }
                if let Some(v) = value {
                    if !(2..=254).contains(param) || !(-32_768.0..=32_767.0).contains(&v.value) {
                        return Err(3);
                    }
                }
            }
            CmdKind::MacroAuxRead { node, param, var }
            | CmdKind::MacroAuxWrite { node, param, var } => {
                node_ok(*node)?;
                if *param > 65_535 {
                    return Err(3);
                }
                var_ok(self, var)?;
            }
            CmdKind::MacroSlaveCmd { node, .. } => node_ok(*node)?,
            CmdKind::MacroSlaveVar { node, var, .. } => {
                node_ok(*node)?;
                slave_var_ok(var)?;
            }
            CmdKind::MacroSlaveRead { node, var, dest: v }
            | CmdKind::MacroSlaveWrite { node, var, src: v } => {
                node_ok(*node)?;
                slave_var_ok(var)?;
                var_ok(self, v)?;
            }
            _ => return Err(3),
        }
        self.macro_failed();
        Err(8)
    }

    /// Record an auxiliary failure (timeout) in the status bit and X:$0798.
    fn macro_failed(&mut self) {
        self.model.state.global.macro_aux_error = true;
        self.model
            .state
            .write(Space::X, AUX_ERROR_VALUE, AUX_TIMEOUT);
    }
}
