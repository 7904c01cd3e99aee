//! The Power dialect's variables as the program engine sees them (`model::ExtVars`): I-
//! variables in Power numbering, the L/R/D/C locals of each program thread (a C.S.'s motion
//! program, a PLC), data-structure elements named in program text, and the values of elements
//! the model does not keep (`elements::Store`, shared with the on-line threads). Installed in
//! the model of every Power card ([`install`]); the on-line executor borrows it ([`with`]).
//!
//! Locals of a program thread follow the seed's stack (L39883-39890): one stack of 8,192
//! doubles per thread, a frame sees `L(n)` at stack slot `base + n` and `R(n)` at
//! `base + offset + n` (`ExtAt::base`, its buffer's stack offset, default 256), so the
//! caller's `R0` is the callee's `L0`. D- and C-
//! variables are one set per thread (D receives `read()` arguments, seed §2.10).

use crate::domain::PowerErr;
use std::any::Any;
use std::collections::HashMap;

use super::elements::{self, Key, Store};
use super::parse::{
    ElemRef, ELEM_ADDRESS, EXT_C, EXT_CFLAGS, EXT_D, EXT_I, EXT_L, EXT_M, EXT_M_SYNC, EXT_R,
};
use super::{Thread, LOCALS};
use crate::domain::ast::{Expr, VarKind};
use crate::domain::eval::{self, Env, EvalError};
use crate::lang::Card;
use crate::model::{BufId, CardModel, ExtAt, ExtError, ExtVars, Thread as ExecThread};

/// Element `k` of the program element table is `Ext(EXT_PELEM + k)`.
pub(crate) const EXT_PELEM: u16 = 1000;
/// Most distinct elements program text may name (the table is never shrunk while the card
/// runs: entries are shared by every buffer).
pub(crate) const MAX_PELEMS: usize = (u16::MAX - EXT_PELEM) as usize;

/// The dialect's program-side state, installed in the card model.
#[derive(Debug, Default)]
pub(crate) struct ProgVars {
    /// Element values the model does not keep.
    pub(crate) store: Store,
    /// Elements named in program text (`Ext(EXT_PELEM + k)`).
    pub(crate) elems: Vec<ElemRef>,
    /// Locals of each program thread.
    threads: HashMap<ExecThread, Thread>,
    /// The text of every closed buffer, as `list` shows it (saved in the image).
    pub(crate) sources: super::listing::Sources,
    /// The kinematic routines (`open forward|inverse`).
    pub(crate) kin: super::kinematics::Routines,
    /// `#define`s and PLC identifiers (`preproc`).
    pub(crate) pre: super::preproc::Preproc,
}

/// Install the dialect's variables in `card` (a Power card's model), unless already there.
pub(crate) fn install(card: &mut CardModel) {
    if card.ext::<ProgVars>().is_none() {
        // Power-on: the setup elements at the seed's defaults, in the model's units too.
        let mut pv = ProgVars::default();
        elements::reset_setup(card, &mut pv.store, Vec::new(), true);
        card.set_ext(Box::new(pv));
    }
}

/// Run `f` with the card and the dialect's variables borrowed apart (the model has no
/// extension meanwhile).
pub(crate) fn with<R>(card: &mut Card, f: impl FnOnce(&mut Card, &mut ProgVars) -> R) -> R {
    install(&mut card.model);
    let mut b = card
        .model
        .take_ext()
        .unwrap_or_else(|| Box::new(ProgVars::default()));
    let r = match b.as_any_mut().downcast_mut::<ProgVars>() {
        Some(pv) => f(card, pv),
        None => {
            let mut pv = ProgVars::default();
            let r = f(card, &mut pv);
            b = Box::new(pv);
            r
        }
    };
    card.model.set_ext(b);
    r
}

impl ProgVars {
    /// Lend a command thread's locals to the program side (`cx`): program statements then
    /// see them as thread `t`'s. Take them back with [`ProgVars::leave`].
    pub(crate) fn enter(&mut self, t: ExecThread, th: Thread) {
        self.threads.insert(t, th);
    }

    /// The locals lent with [`ProgVars::enter`].
    pub(crate) fn leave(&mut self, t: ExecThread) -> Option<Thread> {
        self.threads.remove(&t)
    }

    /// A `cmd` text program thread `t` issued has run: `status` is 0 or minus its error
    /// number (`Ldata.CmdStatus`), and `Ldata.CmdCount` counts it.
    pub(crate) fn command_done(&mut self, t: ExecThread, status: f64) {
        let th = self.threads.entry(t).or_default();
        th.cmd_status = status;
        th.cmd_count += 1.0;
    }

    /// The addressed motor and C.S. (`Ldata.Motor`, `Ldata.Coord`) of program thread `t`, once
    /// it has used its thread data.
    pub(crate) fn addressing(&self, t: ExecThread) -> Option<(u16, u16)> {
        self.threads.get(&t).map(|th| (th.motor, th.coord))
    }

    fn thread(&mut self, at: &ExtAt) -> &mut Thread {
        self.parts(at).1
    }

    /// The element store and the thread of `at`, borrowed apart (no copy of the thread's
    /// 8,192-slot stacks per access).
    fn parts(&mut self, at: &ExtAt) -> (&mut Store, &mut Thread) {
        let th = self.threads.entry(at.thread).or_insert_with(|| Thread {
            motor: at.motor.saturating_sub(1),
            coord: at.coord.saturating_sub(1),
            ..Thread::default()
        });
        (&mut self.store, th)
    }

    /// The element store and the thread whose local data element `k` reads: another program
    /// thread's for `Coord[x].Ldata.…`/`Plc[i].Ldata.…`, else the thread of `at`.
    fn parts_for(&mut self, at: &ExtAt, k: &Key) -> (&mut Store, &mut Thread) {
        match elements::ldata_owner(k) {
            Some(t) => {
                let th = self
                    .threads
                    .entry(t)
                    .or_insert_with(|| elements::fresh_thread(t));
                (&mut self.store, th)
            }
            None => self.parts(at),
        }
    }

    /// The program threads' local data, for an on-line thread reading `Plc[i].Ldata.…`.
    pub(crate) fn split_threads(&mut self) -> (&mut Store, &mut HashMap<ExecThread, Thread>) {
        (&mut self.store, &mut self.threads)
    }

    /// The stack slot of `L(n)` / `R(n)` for `at`: `L` from its frame's base, `R` past its
    /// program's stack offset (the `L` of a subroutine it calls).
    fn slot(at: &ExtAt, family: u16, n: u32) -> Option<u32> {
        let base = if family == EXT_R {
            at.base.checked_add(at.offset)?
        } else {
            at.base
        };
        let s = base.checked_add(n)?;
        (s < LOCALS as u32).then_some(s)
    }

    /// Program element of family `f` and its key as seen from `at`.
    fn element(
        &mut self,
        card: &mut CardModel,
        at: &ExtAt,
        f: u16,
    ) -> Result<(ElemRef, Key), ExtError> {
        let e = self
            .elems
            .get(usize::from(f - EXT_PELEM))
            .cloned()
            .ok_or(ExtError::NoSuch)?;
        let k = self.key(card, at, &e)?;
        Ok((e, k))
    }

    fn key(&mut self, card: &mut CardModel, at: &ExtAt, e: &ElemRef) -> Result<Key, ExtError> {
        let idx = match &e.idx {
            Some(x) => Some(self.eval(card, at, x)?),
            None => None,
        };
        let mut sub = Vec::with_capacity(e.sub.len());
        for x in &e.sub {
            sub.push(self.eval(card, at, x)?);
        }
        elements::key(e, idx, &sub).map_err(|_| ExtError::NoSuch)
    }

    fn eval(&mut self, card: &mut CardModel, at: &ExtAt, e: &Expr) -> Result<f64, ExtError> {
        let mut env = IndexEnv { pv: self, card, at };
        eval::eval(e, &mut env).map_err(|_| ExtError::NoSuch)
    }
}

/// The key of `Coord[x].Cflags` of the C.S. of `at`.
fn cflags(at: &ExtAt) -> Result<Key, ExtError> {
    let def = super::catalog::find(super::catalog::St::Coord, "Cflags").ok_or(ExtError::NoSuch)?;
    Ok(Key {
        st: super::catalog::St::Coord,
        idx: u32::from(at.coord.saturating_sub(1)),
        def,
        sub: [0, 0],
    })
}

fn access(e: elements::AccessError) -> ExtError {
    match e.code {
        PowerErr::ReadOnly => ExtError::ReadOnly,
        PowerErr::OutOfRange => ExtError::Range,
        _ => ExtError::NoSuch,
    }
}

impl ExtVars for ProgVars {
    fn read(
        &mut self,
        card: &mut CardModel,
        at: &ExtAt,
        family: u16,
        index: u32,
    ) -> Result<f64, ExtError> {
        match family {
            EXT_I => elements::read_ivar(card, &self.store, index).map_err(access),
            EXT_M | EXT_M_SYNC => {
                let (store, th) = self.parts(at);
                super::mvars::read_m(card, store, th, index).map_err(access)
            }
            EXT_L | EXT_R => {
                let s = Self::slot(at, family, index).ok_or(ExtError::NoSuch)?;
                self.thread(at).local(EXT_L, s).ok_or(ExtError::NoSuch)
            }
            EXT_D | EXT_C => self.thread(at).local(family, index).ok_or(ExtError::NoSuch),
            EXT_CFLAGS => Ok(self.store.value(&cflags(at)?).unwrap_or(0.0)),
            f if f >= EXT_PELEM => {
                let (e, k) = self.element(card, at, f)?;
                if index == ELEM_ADDRESS {
                    return Ok(super::exec::element_address(card, &k) as f64);
                }
                let (store, th) = self.parts_for(at, &k);
                let v = elements::read(card, store, th, &k).map_err(access)?;
                Ok(match e.bits {
                    Some((start, width)) => super::exec::get_bits(v, start, width),
                    None => v,
                })
            }
            _ => Err(ExtError::NoSuch),
        }
    }

    fn write(
        &mut self,
        card: &mut CardModel,
        at: &ExtAt,
        family: u16,
        index: u32,
        v: f64,
    ) -> Result<(), ExtError> {
        match family {
            EXT_I => elements::write_ivar(card, &mut self.store, index, v).map_err(access),
            // Seed L37058-37064: a synchronous assignment to a self-referenced M-variable is
            // a no-op, without error.
            EXT_M_SYNC if super::mvars::is_self_referenced(&self.store, index) => Ok(()),
            EXT_M | EXT_M_SYNC => {
                let (store, th) = self.parts(at);
                super::mvars::write_m(card, store, th, index, v).map_err(access)
            }
            EXT_L | EXT_R => {
                let s = Self::slot(at, family, index).ok_or(ExtError::NoSuch)?;
                self.thread(at)
                    .set_local(EXT_L, s, v)
                    .then_some(())
                    .ok_or(ExtError::NoSuch)
            }
            EXT_D | EXT_C => self
                .thread(at)
                .set_local(family, index, v)
                .then_some(())
                .ok_or(ExtError::NoSuch),
            // `cset`/`cclr`: the C.S.'s status word `Coord[x].Cflags` (a status element to
            // hosts, written by programs).
            EXT_CFLAGS => {
                self.store.set_value(cflags(at)?, v);
                Ok(())
            }
            f if f >= EXT_PELEM && index != ELEM_ADDRESS => {
                let (e, k) = self.element(card, at, f)?;
                let (store, th) = self.parts_for(at, &k);
                let v = match e.bits {
                    Some((start, width)) => {
                        let old = elements::read(card, store, th, &k).map_err(access)?;
                        super::exec::set_bits(old, start, width, v).ok_or(ExtError::Range)?
                    }
                    None => v,
                };
                elements::write(card, store, th, &k, v).map_err(access)
            }
            _ => Err(ExtError::NoSuch),
        }
    }

    fn kinematics(&self, cs: u16, inverse: bool) -> Option<crate::model::KinRoutine> {
        self.kin.get(&(cs, inverse)).map(|k| k.routine.clone())
    }

    fn stack_offset(&self, code: crate::model::StackOf) -> u32 {
        self.sources.stack(match code {
            crate::model::StackOf::Prog(n) => BufId::Prog(n),
            crate::model::StackOf::Plc(n) => BufId::Plc(n),
        })
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn image_hooks(&self) -> Option<crate::model::ImageHooks> {
        Some(super::saved::HOOKS)
    }
}

/// Evaluating an element's indices inside an extension access (the extension is out of the
/// model meanwhile: its own variables are reached directly).
struct IndexEnv<'a> {
    pv: &'a mut ProgVars,
    card: &'a mut CardModel,
    at: &'a ExtAt,
}

impl Env for IndexEnv<'_> {
    fn var(&mut self, kind: VarKind, n: u32) -> Result<f64, EvalError> {
        let st = &mut self.card.state;
        match kind {
            VarKind::P => st.vars.p(n).map_err(|_| EvalError::NO_VARIABLE),
            VarKind::Q => st
                .vars
                .q(self.at.coord, n)
                .map_err(|_| EvalError::NO_VARIABLE),
            VarKind::M => st.read_m(n).map_err(|_| EvalError::NO_VARIABLE),
            VarKind::I => Err(EvalError::NO_VARIABLE),
            VarKind::Ext(f) => self
                .pv
                .read(self.card, self.at, f, n)
                .map_err(|_| EvalError::NO_VARIABLE),
        }
    }

    fn radians(&self) -> bool {
        true
    }

    fn ieee(&self) -> bool {
        true
    }
}
