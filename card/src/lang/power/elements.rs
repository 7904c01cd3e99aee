//! Reading and writing data-structure elements and I-variables: the model's own values where
//! the model keeps one (I-variable aliases, P/Q/M arrays, thread data, status words), the
//! dialect's store for the rest.

use crate::domain::PowerErr;
use std::collections::HashMap;

use super::catalog::{self, Class, Def, St, Ty, DEFS};
use super::parse::ElemRef;
use super::Thread;
use crate::model::CardModel;

/// Why an element or variable access failed (the error number and text of the reply).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct AccessError {
    /// The refusal.
    pub code: PowerErr,
}

/// Error 21: unknown element, index out of range.
pub(crate) const ILLEGAL_PARAMETER: AccessError = AccessError {
    code: PowerErr::IllegalParameter,
};
/// Error 22: the value is outside the element's range.
pub(crate) const OUT_OF_RANGE: AccessError = AccessError {
    code: PowerErr::OutOfRange,
};
/// Error 23: a write to a read-only (status) element.
pub(crate) const READ_ONLY: AccessError = AccessError {
    code: PowerErr::ReadOnly,
};

/// An element with every index evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Key {
    /// Structure.
    pub st: St,
    /// Structure index (0 for unindexed structures).
    pub idx: u32,
    /// Catalogue entry.
    pub def: usize,
    /// Own indices (unused ones 0).
    pub sub: [u32; 2],
}

/// Values of elements the model does not keep (setup and status with no model equivalent).
#[derive(Debug, Default)]
pub(crate) struct Store {
    values: HashMap<Key, f64>,
    /// The M-variables: definitions, self-referenced values, the memory they point into.
    pub(crate) m: super::mptr::MVars<super::mvars::MElem>,
}

impl Store {
    /// The value kept for `k`.
    pub(crate) fn value(&self, k: &Key) -> Option<f64> {
        self.values.get(k).copied()
    }

    /// Keep `v` for `k` (no checks: for values the card itself produces).
    pub(crate) fn set_value(&mut self, k: Key, v: f64) {
        self.values.insert(k, v);
    }

    /// The indices of structure `st` any kept value belongs to (`backup Gates`).
    pub(crate) fn indices_of(&self, st: super::catalog::St) -> std::collections::BTreeSet<u32> {
        self.values
            .keys()
            .filter(|k| k.st == st)
            .map(|k| k.idx)
            .collect()
    }

    /// The keys of every value kept for element `def` (`backup` reports them).
    pub(crate) fn keys_of(&self, def: usize) -> Vec<Key> {
        let mut v: Vec<Key> = self
            .values
            .keys()
            .filter(|k| k.def == def)
            .copied()
            .collect();
        v.sort_by_key(|k| (k.idx, k.sub));
        v
    }
}

/// Check the indices of `e` (already evaluated as `idx`, `sub`) and build its key.
pub(crate) fn key(e: &ElemRef, idx: Option<f64>, sub: &[f64]) -> Result<Key, AccessError> {
    let d = &DEFS[e.def];
    let idx = match (e.st.count(), idx) {
        (Some(n), Some(i)) => index(i, n)?,
        (None, None) => 0,
        // Another thread's local data: `Coord[x].Ldata.…`, `Plc[i].Ldata.…`.
        (None, Some(i)) if e.st == St::Ldata && e.st_name == "Coord" => {
            LDATA_OF_COORD + index(i, St::Coord.count().unwrap_or(0))?
        }
        (None, Some(i)) if e.st == St::Ldata && e.st_name == "Plc" => {
            LDATA_OF_PLC + index(i, St::Plc.count().unwrap_or(0))?
        }
        _ => return Err(ILLEGAL_PARAMETER),
    };
    if sub.len() != d.dims.len() && !(d.dims.is_empty() && sub.is_empty()) {
        return Err(ILLEGAL_PARAMETER);
    }
    let mut k = [0u32; 2];
    for (j, (v, dim)) in sub.iter().zip(d.dims).enumerate() {
        let lim = if *dim == 0 { 65_536 } else { *dim };
        let x = index(*v, lim)?;
        if j < 2 {
            k[j] = x;
        }
    }
    if d.dims.len() > 2 {
        return Err(ILLEGAL_PARAMETER);
    }
    Ok(Key {
        st: e.st,
        idx,
        def: e.def,
        sub: k,
    })
}

fn index(v: f64, n: u32) -> Result<u32, AccessError> {
    let r = v.floor();
    if r.is_finite() && r >= 0.0 && r < f64::from(n) {
        Ok(r as u32)
    } else {
        Err(ILLEGAL_PARAMETER)
    }
}

/// `Key::idx` of `Coord[x].Ldata.…` (+ x) and of `Plc[i].Ldata.…` (+ i); 0 is the thread's
/// own `Ldata`.
const LDATA_OF_COORD: u32 = 0x100;
const LDATA_OF_PLC: u32 = 0x200;

/// The program thread whose local data `Ldata` key `k` names (`None`: the thread's own).
pub(crate) fn ldata_owner(k: &Key) -> Option<crate::model::Thread> {
    if k.st != St::Ldata {
        return None;
    }
    match k.idx {
        i if (LDATA_OF_PLC..LDATA_OF_PLC + 32).contains(&i) => {
            Some(crate::model::Thread::Plc((i - LDATA_OF_PLC) as u8))
        }
        // Power C.S. x is the model's x + 1.
        i if (LDATA_OF_COORD..LDATA_OF_COORD + 32).contains(&i) => {
            Some(crate::model::Thread::Cs((i - LDATA_OF_COORD) as u16 + 1))
        }
        _ => None,
    }
}

/// The local data of a program thread that has not run yet: its own C.S. (a motion
/// program), motor and C.S. 0 (a PLC).
pub(crate) fn fresh_thread(t: crate::model::Thread) -> Thread {
    match t {
        crate::model::Thread::Cs(x) => Thread {
            coord: x.saturating_sub(1),
            ..Thread::default()
        },
        _ => Thread::default(),
    }
}

/// The name of element `k` as replies print it (`Motor[1].JogSpeed`, `Acc5E3[0].MacroInA[2][3]`).
pub(crate) fn name(k: &Key, st_name: &str) -> String {
    let d = &DEFS[k.def];
    let mut s = String::from(st_name);
    if k.st.count().is_some() {
        s.push_str(&format!("[{}]", k.idx));
    }
    if k.st == St::Ldata && k.idx != 0 {
        let n = if k.idx >= LDATA_OF_PLC {
            k.idx - LDATA_OF_PLC
        } else {
            k.idx - LDATA_OF_COORD
        };
        s.push_str(&format!("[{n}].Ldata"));
    }
    s.push('.');
    // `Chan[]` holds the first index inside the name (`Gate3[0].Chan[1].EncCtrl`).
    let mut j = 0;
    match d.name.split_once("[]") {
        Some((a, b)) => {
            s.push_str(&format!("{a}[{}]{b}", k.sub[0]));
            j = 1;
        }
        None => s.push_str(d.name),
    }
    for j in j..d.dims.len().min(2) {
        s.push_str(&format!("[{}]", k.sub[j]));
    }
    s
}

/// The power-on value of element `k` where the seed gives one per index: a Gate3 channel
/// captures on its own flags (`CaptFlagChan` = j) and compares into its own output
/// (`EquOutMask` = 1 << j), seed L10913, L11083-11090.
fn default_of(k: &Key, d: &Def) -> f64 {
    match (k.st, d.name) {
        (St::Gate3, "Chan[].CaptFlagChan") => f64::from(k.sub[0]),
        (St::Gate3, "Chan[].EquOutMask") => f64::from(1u32 << k.sub[0].min(3)),
        _ => d.default,
    }
}

/// The model I-variable a Power I-variable number stands for (`None`: no model equivalent).
pub(crate) fn model_ivar(n: u32) -> Option<u32> {
    match n {
        0..=3199 => Some(n + 100),
        5000..=6599 => Some(n + 100),
        8000..=8099 => Some(n - 8000),
        _ => None,
    }
}

/// The element Power I-variable `n` is a numbered alias of, and its structure name.
pub(crate) fn ivar_element(n: u32) -> Option<(Key, &'static str)> {
    let (st, idx, inum, st_name) = match n {
        0..=3199 => (St::Motor, n / 100, n % 100, "Motor"),
        5000..=6599 => (St::Coord, (n - 5000) / 100, n % 100, "Coord"),
        8000..=8099 => (St::Sys, 0, n - 8000, "Sys"),
        6800..=7199 => (St::Gate2, (n - 6800) / 100, n % 100, "Gate2"),
        _ => return None,
    };
    let def = catalog::by_inum(st, inum)?;
    Some((
        Key {
            st,
            idx,
            def,
            sub: [0, 0],
        },
        st_name,
    ))
}

/// The model I-variable holding element `k`, if the model keeps it.
fn model_slot(k: &Key, d: &Def) -> Option<u32> {
    if k.st == St::Coord {
        // `Coord[x].Gprog/Mprog/Tprog/Dprog` have no I-number in the seed; the program engine
        // finds the G/M/T/D subprograms in the model's Isx40-Isx43 (profile docs).
        let code = ["Gprog", "Mprog", "Tprog", "Dprog"]
            .iter()
            .position(|n| *n == d.name);
        if let Some(j) = code {
            let base = u32::from(crate::domain::profile::POWER_CODE_PROG_IVAR);
            return Some(5000 + 100 * (k.idx + 1) + base + j as u32);
        }
    }
    let inum = d.inum?;
    match k.st {
        St::Motor => Some(100 * (k.idx + 1) + inum),
        St::Coord => Some(5000 + 100 * (k.idx + 1) + inum),
        St::Sys if inum < 100 => Some(inum),
        _ => None,
    }
}

/// Servo period of the model in ms (model I10 is in 1/8,388,608 ms).
const I10_UNIT: f64 = 8_388_608.0;

/// The servo period in ms (`Sys.ServoPeriod`, from the model's I10).
pub(super) fn servo_period_ms(card: &CardModel) -> f64 {
    card.state.peek_ivar(10).unwrap_or(3_713_707.0) / I10_UNIT
}

/// Read element `k` for thread `th`.
pub(crate) fn read(
    card: &mut CardModel,
    store: &Store,
    th: &Thread,
    k: &Key,
) -> Result<f64, AccessError> {
    if let Some(v) = super::macro_ic::read(card, k) {
        return Ok(v);
    }
    if let Some(v) = super::mvars::read_user_data(store, k) {
        return Ok(v);
    }
    let d = &DEFS[k.def];
    let nm = d.name;
    if d.class == Class::Status {
        if let Some(v) = super::status_elems::read(card, k, nm) {
            return Ok(v);
        }
    }
    let st = &mut card.state;
    let v = match (k.st, nm) {
        (St::Ldata, "Motor") => f64::from(th.motor),
        (St::Ldata, "Coord") => f64::from(th.coord),
        (St::Ldata, "CmdStatus") => th.cmd_status,
        (St::Ldata, "CmdCount") => th.cmd_count,
        (St::Ldata, "L") => th.local(super::parse::EXT_L, k.sub[0]).unwrap_or(0.0),
        (St::Ldata, "R") => th.local(super::parse::EXT_R, k.sub[0]).unwrap_or(0.0),
        (St::Ldata, "D") => th.local(super::parse::EXT_D, k.sub[0]).unwrap_or(0.0),
        (St::Ldata, "C") => th.local(super::parse::EXT_C, k.sub[0]).unwrap_or(0.0),
        (St::Sys, "P") => st.vars.p(k.sub[0]).map_err(|_| ILLEGAL_PARAMETER)?,
        (St::Sys, "M") => super::mvars::read_m(card, store, th, k.sub[0])?,
        (St::Sys, "I") => read_ivar(card, store, k.sub[0])?,
        (St::Coord, "Q") => st
            .vars
            .q(k.idx as u16 + 1, k.sub[0])
            .map_err(|_| ILLEGAL_PARAMETER)?,
        (St::Sys, "ServoPeriod") => servo_period_ms(card),
        (St::Sys, "MaxMotors") => f64::from(st.limits().motors),
        (St::Sys, "Status") => f64::from(super::exec::global_status(card)),
        (St::Motor, "Status") => {
            f64::from(super::exec::motor_status(card, k.idx as u16)[k.sub[0].min(1) as usize])
        }
        (St::Coord, "Status") => {
            f64::from(super::exec::coord_status(card, k.idx as u16)[k.sub[0].min(1) as usize])
        }
        // [DECISION] a C.S. stopped by a run-time error of the engine (a kinematic routine
        // that failed or ran too long, a move it could not compute) reads RunTimeError 1,
        // ErrorStatus 16 (seed L20168, L25240-25290), 64 (RadiusError) for an impossible circle.
        (St::Coord, "RunTimeError" | "ErrorStatus") => {
            let f = st.coords.get(k.idx as usize).filter(|f| f.runtime_error);
            match (f, nm) {
                (None, _) => 0.0,
                (Some(_), "RunTimeError") => 1.0,
                (Some(f), _) if f.circle_radius_error => 64.0,
                (Some(_), _) => 16.0,
            }
        }
        (St::Motor, "Status[0]" | "Status[1]") => {
            let w = usize::from(nm.ends_with("[1]"));
            f64::from(super::exec::motor_status(card, k.idx as u16)[w])
        }
        (St::Coord, "Status[0]" | "Status[1]") => {
            let w = usize::from(nm.ends_with("[1]"));
            f64::from(super::exec::coord_status(card, k.idx as u16)[w])
        }
        _ if super::units::held(k.st, nm) => store.values.get(k).copied().unwrap_or(d.default),
        _ => match (store.values.get(k), model_slot(k, d)) {
            (Some(v), _) => *v,
            (None, Some(n)) => st.read_ivar(n).map_err(|_| ILLEGAL_PARAMETER)?,
            (None, None) => default_of(k, d),
        },
    };
    Ok(v)
}

/// Write element `k` for thread `th`.
pub(crate) fn write(
    card: &mut CardModel,
    store: &mut Store,
    th: &mut Thread,
    k: &Key,
    v: f64,
) -> Result<(), AccessError> {
    let d = &DEFS[k.def];
    // Seed L40290-40325: status elements a program sets to watch its `cmd` texts run.
    match (k.st, d.name) {
        (St::Ldata, "CmdStatus") if v.is_finite() => {
            th.cmd_status = v.trunc();
            return Ok(());
        }
        (St::Ldata, "CmdCount") if v.is_finite() && v >= 0.0 => {
            th.cmd_count = v.trunc();
            return Ok(());
        }
        _ => {}
    }
    if d.class == Class::Status {
        return Err(READ_ONLY);
    }
    if matches!(d.ty, Ty::Struct) {
        return Err(ILLEGAL_PARAMETER);
    }
    if let Some(r) = super::macro_ic::write(card, k, v) {
        return r;
    }
    if let Some(r) = super::mvars::write_user_data(store, k, v) {
        return r;
    }
    let nm = d.name;
    let in_range = v.is_nan() && d.ty == Ty::Float || (v >= d.min && v <= d.max);
    let st = &mut card.state;
    match (k.st, nm) {
        (St::Ldata, "Motor") => {
            th.motor = index(v, u32::from(st.limits().motors)).map_err(|_| OUT_OF_RANGE)? as u16
        }
        (St::Ldata, "Coord") => {
            th.coord = index(v, u32::from(st.limits().coords)).map_err(|_| OUT_OF_RANGE)? as u16
        }
        (St::Ldata, "L" | "R" | "D" | "C") => {
            let f = match nm {
                "L" => super::parse::EXT_L,
                "R" => super::parse::EXT_R,
                "D" => super::parse::EXT_D,
                _ => super::parse::EXT_C,
            };
            if !th.set_local(f, k.sub[0], v) {
                return Err(ILLEGAL_PARAMETER);
            }
        }
        (St::Sys, "P") => {
            st.vars.set_p(k.sub[0], v).map_err(|_| ILLEGAL_PARAMETER)?;
        }
        (St::Sys, "M") => super::mvars::write_m(card, store, th, k.sub[0], v)?,
        (St::Sys, "I") => write_ivar(card, store, k.sub[0], v)?,
        (St::Coord, "Q") => {
            st.vars
                .set_q(k.idx as u16 + 1, k.sub[0], v)
                .map_err(|_| ILLEGAL_PARAMETER)?;
        }
        (St::Sys, "ServoPeriod") => {
            if !(v > 0.0 && v.is_finite()) {
                return Err(OUT_OF_RANGE);
            }
            st.set_ivar(10, (v * I10_UNIT).round())
                .map_err(|_| OUT_OF_RANGE)?;
        }
        (St::Sys, "MaxMotors") => return Err(OUT_OF_RANGE),
        _ => {
            if !in_range {
                return Err(OUT_OF_RANGE);
            }
            let v = if matches!(d.ty, Ty::Int | Ty::Bool | Ty::Hex | Ty::Addr) {
                v.trunc()
            } else {
                v
            };
            if super::units::held(k.st, nm) {
                store.values.insert(*k, v);
            } else {
                // The seed's range is the rule; a value the model's (Turbo) variable cannot
                // hold is kept by the dialect, which then answers with it.
                match model_slot(k, d).map(|n| st.set_ivar(n, v)) {
                    Some(Ok(_)) => {
                        store.values.remove(k);
                    }
                    _ => {
                        store.values.insert(*k, v);
                    }
                }
            }
            // Held elements depend on each other and on two aliases (`JogSpeed`, `MaxSpeed`).
            if super::units::affects_model(k.st, nm) {
                match k.st {
                    St::Motor => project_motor(card, store, k.idx),
                    St::Coord => project_coord(card, store, k.idx),
                    _ => {}
                }
            }
        }
    }
    Ok(())
}

/// The value the dialect keeps for element `name` of `st[idx]` (no own indices), or its seed
/// default; 0 for a name the catalogue lacks.
pub(crate) fn kept_or_default(store: &Store, st: St, idx: u32, name: &str) -> f64 {
    let Some(def) = catalog::find(st, name) else {
        return 0.0;
    };
    let k = Key {
        st,
        idx,
        def,
        sub: [0, 0],
    };
    store.values.get(&k).copied().unwrap_or(DEFS[def].default)
}

/// Assign model I-variable `n`, clamped into its range (a converted value the model cannot
/// hold exactly is held by the dialect anyway: the host reads the Power value).
fn set_clamped(st: &mut crate::model::CardState, n: u32, v: f64) {
    let Ok(s) = st.ivar_spec(n) else { return };
    let v = if v.is_nan() {
        s.default
    } else {
        v.clamp(s.min, s.max)
    };
    let _ = st.set_ivar(n, v);
}

/// Motor `idx`'s held elements into its model I-variables (`units::motor_model`).
pub(crate) fn project_motor(card: &mut CardModel, store: &Store, idx: u32) {
    let base = 100 * (idx + 1);
    let servo_ms = servo_period_ms(card);
    let st = &mut card.state;
    let peek = |n: u32| st.peek_ivar(base + n).unwrap_or(0.0);
    let ctx = super::units::MotorCtx {
        i08: peek(8),
        i09: peek(9),
        jog_speed: peek(22),
        max_speed: peek(16),
        servo_ms,
    };
    let get = |name: &str| kept_or_default(store, St::Motor, idx, name);
    for (n, v) in super::units::motor_model(get, &ctx) {
        set_clamped(st, base + n, v);
    }
}

/// C.S. `idx`'s held elements into its model I-variables (`units::coord_model`).
pub(crate) fn project_coord(card: &mut CardModel, store: &Store, idx: u32) {
    let base = 5000 + 100 * (idx + 1);
    let get = |name: &str| kept_or_default(store, St::Coord, idx, name);
    for (n, v) in super::units::coord_model(get) {
        set_clamped(&mut card.state, base + n, v);
    }
}

/// Power-on, `$$$` and `$$$***`: the dialect's setup values are `saved` (the image's, none at
/// factory), the aliased elements of `Motor[x]`/`Coord[x]` take their Power defaults when
/// `factory` (an image brings the model's own), and every motor's and C.S.'s model
/// I-variables are computed again from the held elements.
pub(crate) fn reset_setup(
    card: &mut CardModel,
    store: &mut Store,
    saved: impl IntoIterator<Item = (Key, f64)>,
    factory: bool,
) {
    store
        .values
        .retain(|k, _| DEFS[k.def].class == Class::Status);
    store.values.extend(saved);
    for st in [St::Motor, St::Coord] {
        let n = st.count().unwrap_or(0);
        for (def, d) in DEFS.iter().enumerate() {
            let alias = d.st == st
                && d.inum.is_some()
                && d.class != Class::Status
                && !matches!(d.ty, Ty::Addr | Ty::Struct)
                && !super::units::held(st, d.name);
            if !(factory && alias) {
                continue;
            }
            for idx in 0..n {
                let k = Key {
                    st,
                    idx,
                    def,
                    sub: [0, 0],
                };
                if let Some(slot) = model_slot(&k, d) {
                    if card.state.peek_ivar(slot).ok() != Some(d.default) {
                        set_clamped(&mut card.state, slot, d.default);
                    }
                }
            }
        }
        for idx in 0..n {
            match st {
                St::Motor => project_motor(card, store, idx),
                _ => project_coord(card, store, idx),
            }
        }
    }
}

/// The dialect's values of saved setup elements (`save` writes them).
pub(crate) fn saved_values(store: &Store) -> Vec<(Key, f64)> {
    let mut v: Vec<(Key, f64)> = store
        .values
        .iter()
        .filter(|(k, v)| DEFS[k.def].class == Class::Saved && v.is_finite())
        .map(|(k, v)| (*k, *v))
        .collect();
    v.sort_by_key(|(k, _)| (k.def, k.idx, k.sub));
    v
}

/// Power I-variable `n`.
pub(crate) fn read_ivar(card: &mut CardModel, store: &Store, n: u32) -> Result<f64, AccessError> {
    if n > 65_535 {
        return Err(ILLEGAL_PARAMETER);
    }
    if let Some((k, _)) = ivar_element(n) {
        let th = Thread::default();
        return read(card, store, &th, &k);
    }
    match model_ivar(n) {
        Some(m) => card.state.read_ivar(m).map_err(|_| ILLEGAL_PARAMETER),
        None => Ok(0.0),
    }
}

/// Assign Power I-variable `n`.
pub(crate) fn write_ivar(
    card: &mut CardModel,
    store: &mut Store,
    n: u32,
    v: f64,
) -> Result<(), AccessError> {
    if n > 65_535 {
        return Err(ILLEGAL_PARAMETER);
    }
    if let Some((k, _)) = ivar_element(n) {
        let mut th = Thread::default();
        return write(card, store, &mut th, &k, v);
    }
    match model_ivar(n) {
        Some(m) => card
            .state
            .set_ivar(m, v)
            .map(|_| ())
            .map_err(|_| OUT_OF_RANGE),
        // Numbers with no element behind them read 0 and accept nothing.
        None => Err(ILLEGAL_PARAMETER),
    }
}
