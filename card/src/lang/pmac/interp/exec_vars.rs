//! Variable commands (§3.2.3) and register access (§3.2.4): queries, assignments, ranges,
//! `=*`, M-variable definitions, bare numbers, `R`/`RH`/`W`.

use super::exec::{Exec, Out};
use super::{Pmac, Session};
use crate::domain::ErrCode;
use crate::lang::pmac::ast::{CmdKind, Expr, MemSpace, VarIndex, VarKind, VarList, VarSel};
use crate::model::format_value;
use crate::model::CardState;
use crate::model::Space;

/// Most variables one on-line command may address (a whole Turbo family).
const MAX_SELECTION: usize = 8192;

/// Expression environment over the card state for one coordinate system (Q-variables and
/// the ATAN2 cosine part come from that C.S.).
pub(crate) struct VarEnv<'a> {
    /// The state.
    pub state: &'a mut CardState,
    /// Coordinate system for Q-variables.
    pub cs: u16,
}

impl VarEnv<'_> {
    /// Read one variable (`None` when the number is out of range).
    pub(super) fn get(&mut self, kind: VarKind, n: u32) -> Option<f64> {
        match kind {
            VarKind::I => self.state.read_ivar(n).ok(),
            VarKind::P => self.state.vars.p(n).ok(),
            VarKind::Q => self.state.vars.q(self.cs, n).ok(),
            VarKind::M => self.state.read_m(n).ok(),
            VarKind::Ext(_) => None,
        }
    }

    /// Write one variable; `Err(code)` on rejection.
    pub(super) fn set(&mut self, kind: VarKind, n: u32, v: f64) -> Exec {
        let r = match kind {
            VarKind::I => self.state.set_ivar(n, v).map(|_| ()),
            VarKind::P => self.state.vars.set_p(n, v).map(|_| ()),
            VarKind::Q => self.state.vars.set_q(self.cs, n, v).map(|_| ()),
            VarKind::M => self.state.write_m(n, v),
            VarKind::Ext(_) => return Err(ErrCode::Data),
        };
        r.map_err(|e| e.err_code())
    }
}

impl crate::domain::eval::Env for VarEnv<'_> {
    fn var(&mut self, kind: VarKind, index: u32) -> Result<f64, crate::domain::eval::EvalError> {
        self.get(kind, index).ok_or(crate::domain::eval::EvalError {
            code: ErrCode::Data,
            msg: "no such variable",
        })
    }

    fn radians(&self) -> bool {
        self.state.peek_ivar(15).unwrap_or(0.0) != 0.0
    }
}

impl Pmac<'_> {
    /// Evaluate an expression in the context of C.S. `cs`.
    pub(crate) fn eval(&mut self, cs: u16, e: &Expr) -> Result<f64, ErrCode> {
        let mut env = VarEnv {
            state: &mut self.model.state,
            cs,
        };
        crate::domain::eval::eval(e, &mut env).map_err(|e| e.code)
    }

    /// The variable numbers of a selection (computed indices evaluated and rounded).
    pub(crate) fn indices(&mut self, cs: u16, v: &VarList) -> Result<Vec<u32>, ErrCode> {
        let list = match &v.sel {
            VarSel::One(VarIndex::Expr(e)) => {
                let x = self.eval(cs, e)?.round();
                if !(0.0..=f64::from(u32::MAX)).contains(&x) {
                    return Err(ErrCode::Data);
                }
                vec![x as u32]
            }
            VarSel::Strided { count, .. } if *count as usize > MAX_SELECTION => {
                return Err(ErrCode::Data)
            }
            VarSel::Range { first, last }
                if (last.saturating_sub(*first) as usize) >= MAX_SELECTION =>
            {
                return Err(ErrCode::Data)
            }
            _ => v.constant_indices().unwrap_or_default(),
        };
        let n = u32::from(self.model.state.limits().vars);
        if list.is_empty() || list.iter().any(|&k| k >= n) {
            return Err(ErrCode::Data);
        }
        Ok(list)
    }

    pub(crate) fn exec_vars(&mut self, s: &mut Session, cmd: &CmdKind, out: &mut Out) -> Exec {
        let cs = s.coord.get();
        match cmd {
            CmdKind::VarQuery(v) => {
                for n in self.indices(cs, v)? {
                    out.line(self.query_var(v.kind, cs, n)?);
                }
                Ok(())
            }
            CmdKind::VarAssign(v, e) => {
                let idx = self.indices(cs, v)?;
                let val = self.eval(cs, e)?;
                let mut env = VarEnv {
                    state: &mut self.model.state,
                    cs,
                };
                for n in idx {
                    env.set(v.kind, n, val)?;
                }
                self.after_ivar_write(v.kind);
                Ok(())
            }
            CmdKind::VarDefault(v) => {
                if v.kind != VarKind::I {
                    return Err(ErrCode::Data);
                }
                for n in self.indices(cs, v)? {
                    self.model.state.default_ivar(n).map_err(|e| e.err_code())?;
                }
                self.after_ivar_write(VarKind::I);
                Ok(())
            }
            CmdKind::MDefQuery(v) => {
                if v.kind != VarKind::M {
                    return Err(ErrCode::Data);
                }
                for n in self.indices(cs, v)? {
                    out.line(self.model.state.mdef_text(n).map_err(|e| e.err_code())?);
                }
                Ok(())
            }
            CmdKind::MDefine(v, def) => {
                if v.kind != VarKind::M {
                    return Err(ErrCode::Data);
                }
                for n in self.indices(cs, v)? {
                    self.model
                        .state
                        .set_mdef(n, *def)
                        .map_err(|e| e.err_code())?;
                }
                Ok(())
            }
            CmdKind::BareNumber(num) => {
                if let Some((kind, m)) = self.mem.pending_table {
                    // Entries of a just-defined compensation table (§3.4.4), integers.
                    match self.model.bufs.defines.tables_mut(kind).get_mut(&m) {
                        Some(t) if (t.data.len() as u32) < t.entries => {
                            t.data.push(num.value.round() as i64);
                            if t.data.len() as u32 >= t.entries {
                                self.mem.pending_table = None;
                            }
                            return Ok(());
                        }
                        _ => self.mem.pending_table = None,
                    }
                }
                self.model
                    .state
                    .vars
                    .set_p(0, num.value)
                    .map_err(|e| e.err_code())?;
                Ok(())
            }
            CmdKind::ReadMem {
                hex,
                space,
                addr,
                count,
            } => self.read_mem(*hex, *space, *addr, *count, out),
            CmdKind::WriteMem {
                space,
                addr,
                values,
            } => {
                let a = self.mem_addr(*addr)?;
                if values.is_empty() || values.len() > 16 {
                    return Err(ErrCode::Data);
                }
                for (k, v) in values.iter().enumerate() {
                    let at = (a + k as u32) & self.model.state.map().max_addr;
                    let i = v.value.round().clamp(-(2f64.powi(47)), 2f64.powi(48)) as i64;
                    match space {
                        MemSpace::X => self.model.state.write(Space::X, at, (i as u32) & 0xFF_FFFF),
                        MemSpace::Y => self.model.state.write(Space::Y, at, (i as u32) & 0xFF_FFFF),
                        MemSpace::L => self
                            .model
                            .state
                            .write_long(at, (i as u64) & 0xFFFF_FFFF_FFFF),
                    }
                }
                Ok(())
            }
            _ => Err(ErrCode::Data),
        }
    }

    /// The reply text of one variable query (`In` per I9, `Pn`, `Qn` of C.S. `cs`, `Mn`).
    pub(crate) fn query_var(&mut self, kind: VarKind, cs: u16, n: u32) -> Result<String, ErrCode> {
        Ok(match kind {
            VarKind::I => self.model.state.ivar_text(n).map_err(|e| e.err_code())?,
            k => {
                let mut env = VarEnv {
                    state: &mut self.model.state,
                    cs,
                };
                format_value(env.get(k, n).ok_or(ErrCode::Data)?)
            }
        })
    }

    /// Writes to I-variables may change what the interpreter caches (I18 buffer warning).
    /// A `R`/`W` address inside the profile's map (PMAC2 $FFFF, Turbo $7FFFF), else ERR003.
    fn mem_addr(&self, addr: u32) -> Result<u32, ErrCode> {
        if addr > self.model.state.map().max_addr {
            return Err(ErrCode::Data);
        }
        Ok(addr)
    }

    fn after_ivar_write(&mut self, kind: VarKind) {
        if kind == VarKind::I {
            self.sync_global_flags();
        }
    }

    fn read_mem(
        &mut self,
        hex: bool,
        space: MemSpace,
        addr: u32,
        count: u32,
        out: &mut Out,
    ) -> Exec {
        let a = self.mem_addr(addr)?;
        if !(1..=16).contains(&count) {
            return Err(ErrCode::Data);
        }
        let mut words = Vec::with_capacity(count as usize);
        for k in 0..count {
            let at = (a + k) & self.model.state.map().max_addr;
            let text = match space {
                MemSpace::X | MemSpace::Y => {
                    let sp = if space == MemSpace::X {
                        Space::X
                    } else {
                        Space::Y
                    };
                    let w = self.model.state.read(sp, at);
                    if hex {
                        format!("{w:06X}")
                    } else {
                        (((w << 8) as i32) >> 8).to_string()
                    }
                }
                MemSpace::L => {
                    let w = self.model.state.read_long(at) & 0xFFFF_FFFF_FFFF;
                    if hex {
                        format!("{w:012X}")
                    } else {
                        (((w << 16) as i64) >> 16).to_string()
                    }
                }
            };
            words.push(text);
        }
        out.line(words.join(" "));
        Ok(())
    }
}
