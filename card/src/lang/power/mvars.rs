//! M-variables of a Power card on the dialect's store (definitions in `mptr`): reading and
//! writing through a definition of any form, `Mn->` replies, the user-buffer elements
//! `Sys.Idata/Udata/Fdata/Ddata` (the same memory the `user` bank reaches), and the saved
//! image's part (definitions as text, self-referenced values).

use serde::{Deserialize, Serialize};

use super::catalog::{St, DEFS};
use super::elements::{self, AccessError, Key, Store, ILLEGAL_PARAMETER, OUT_OF_RANGE};
use super::mptr::{self, Bank, Def, Fmt, Ptr};
use super::parse::ElemRef;
use super::Thread;
use crate::model::CardModel;

/// An M-variable defined as a data-structure element (`M162->Motor[1].ActPos`), its indices
/// evaluated when it was defined.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MElem {
    /// The element.
    pub key: Key,
    /// Its structure as written (`Acc5E3`), for the reply.
    pub st_name: &'static str,
    /// A bit range `.start.width`.
    pub bits: Option<(u32, u32)>,
}

/// M-variables a card has (M0-M16383: seed L36838).
fn count(card: &CardModel) -> u32 {
    card.state.limits().m_vars
}

/// Value of M`n`.
pub(crate) fn read_m(
    card: &mut CardModel,
    store: &Store,
    th: &Thread,
    n: u32,
) -> Result<f64, AccessError> {
    if n >= count(card) {
        return Err(ILLEGAL_PARAMETER);
    }
    if let Some(v) = store.m.read(n) {
        return Ok(v);
    }
    let Def::Elem(e) = store.m.def(n) else {
        return Ok(0.0);
    };
    let v = elements::read(card, store, th, &e.key)?;
    Ok(match e.bits {
        Some((start, width)) => super::exec::get_bits(v, start, width),
        None => v,
    })
}

/// Assign M`n`.
pub(crate) fn write_m(
    card: &mut CardModel,
    store: &mut Store,
    th: &mut Thread,
    n: u32,
    v: f64,
) -> Result<(), AccessError> {
    if n >= count(card) {
        return Err(ILLEGAL_PARAMETER);
    }
    match store.m.write(n, v) {
        Some(true) => return Ok(()),
        Some(false) => return Err(OUT_OF_RANGE),
        None => {}
    }
    let Def::Elem(e) = store.m.def(n) else {
        return Ok(());
    };
    let v = match e.bits {
        Some((start, width)) => {
            let old = elements::read(card, store, th, &e.key)?;
            super::exec::set_bits(old, start, width, v).ok_or(OUT_OF_RANGE)?
        }
        None => v,
    };
    elements::write(card, store, th, &e.key, v)
}

/// Whether M`n` is self-referenced (a synchronous assignment to it does nothing: seed
/// L37058-37064).
pub(crate) fn is_self_referenced(store: &Store, n: u32) -> bool {
    matches!(store.m.def(n), Def::Ptr(Ptr::SelfRef { .. }))
}

/// Define M`n` as the element `e` (key `k`). [DECISION] An element that is itself an
/// M-variable (`Sys.M[k]`) or a substructure is refused (error 21): a pointer at a pointer
/// would read through itself.
pub(crate) fn define_element(
    card: &CardModel,
    store: &mut Store,
    n: u32,
    e: &ElemRef,
    k: Key,
) -> Result<(), AccessError> {
    if n >= count(card) {
        return Err(ILLEGAL_PARAMETER);
    }
    let d = &DEFS[k.def];
    if (k.st == St::Sys && d.name == "M") || d.ty == super::catalog::Ty::Struct {
        return Err(ILLEGAL_PARAMETER);
    }
    store.m.define(
        n,
        Def::Elem(MElem {
            key: k,
            st_name: e.st_name,
            bits: e.bits,
        }),
    );
    Ok(())
}

/// Define M`n` by address or as self-referenced.
pub(crate) fn define_ptr(
    card: &CardModel,
    store: &mut Store,
    n: u32,
    p: Ptr,
) -> Result<(), AccessError> {
    if n >= count(card) {
        return Err(ILLEGAL_PARAMETER);
    }
    store.m.define(n, Def::Ptr(p));
    Ok(())
}

/// The definition of M`n` as `Mn->` reports it (without the `Mn->`).
pub(crate) fn def_text(store: &Store, n: u32) -> String {
    match store.m.def(n) {
        Def::Ptr(p) => mptr::text(&p),
        Def::Elem(e) => {
            let mut s = elements::name(&e.key, e.st_name);
            if let Some((start, width)) = e.bits {
                s.push_str(&format!(".{start}.{width}"));
            }
            s
        }
    }
}

/// The user-buffer word an element `Sys.Idata[n]`/`Udata`/`Fdata`/`Ddata` is (`None`: not
/// one of them).
fn user_ptr(k: &Key) -> Option<Ptr> {
    if k.st != St::Sys {
        return None;
    }
    let n = k.sub[0];
    let (fmt, bytes) = match DEFS[k.def].name {
        "Idata" => (Fmt::I, 4),
        "Udata" => (Fmt::U, 4),
        "Fdata" => (Fmt::F, 4),
        "Ddata" => (Fmt::D, 8),
        _ => return None,
    };
    let offset = n.checked_mul(bytes)?;
    (offset + bytes <= mptr::USER_BYTES).then_some(Ptr::Addr {
        fmt,
        bank: Bank::User,
        offset,
        bit: 0,
        width: 32,
    })
}

/// Read a user-buffer element (`None`: `k` is not one).
pub(crate) fn read_user_data(store: &Store, k: &Key) -> Option<f64> {
    user_ptr(k).map(|p| store.m.mem.read(&p))
}

/// Write a user-buffer element (`None`: `k` is not one).
pub(crate) fn write_user_data(
    store: &mut Store,
    k: &Key,
    v: f64,
) -> Option<Result<(), AccessError>> {
    let p = user_ptr(k)?;
    Some(if store.m.mem.write(&p, v) {
        Ok(())
    } else {
        Err(OUT_OF_RANGE)
    })
}

/// The M-variables in the saved image: every definition other than `*` as its `Mn->` text,
/// every self-referenced value other than 0.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct SavedM {
    /// (n, definition text).
    pub defs: Vec<(u32, String)>,
    /// (n, value) of self-referenced M-variables.
    pub values: Vec<(u32, f64)>,
}

impl SavedM {
    /// Nothing to save.
    pub(crate) fn is_empty(&self) -> bool {
        self.defs.is_empty() && self.values.is_empty()
    }
}

/// The M-variables of `store` for the image.
pub(crate) fn export(store: &Store) -> SavedM {
    SavedM {
        defs: store
            .m
            .defined()
            .into_iter()
            .map(|(n, _)| (n, def_text(store, n)))
            .collect(),
        values: store.m.self_values(),
    }
}

/// Replace the M-variables of `store` by the image's (a definition that no longer parses is
/// left self-referenced).
pub(crate) fn restore(card: &CardModel, store: &mut Store, saved: SavedM) {
    store.m = mptr::MVars::default();
    for (n, text) in saved.defs {
        let t = text.as_bytes();
        match mptr::parse(t) {
            Ok(Some((p, len))) if len == t.len() => {
                let _ = define_ptr(card, store, n, p);
            }
            Ok(None) => {
                let mut c = super::parse::Cur::new(t);
                let Ok(e) = c.element(0) else { continue };
                if !c.at_end() {
                    continue;
                }
                if let Some(Ok(k)) = super::parse::literal_key(&e) {
                    let _ = define_element(card, store, n, &e, k);
                }
            }
            _ => {}
        }
    }
    for (n, v) in saved.values {
        if is_self_referenced(store, n) && n < count(card) {
            let _ = store.m.write(n, v);
        }
    }
}
