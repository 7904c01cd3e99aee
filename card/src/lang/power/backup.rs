//! `backup {structure}[.]` (seed L33339-33404): the present values of a structure's saved
//! setup elements (or, for `…Status`, its status elements), one `name=value` line each
//! whatever the echo mode, so the text can be sent back to restore them.
//!
//! Forms: `backup` (everything: `Sys.`, every `Motor[x].`, every `Coord[x].`, `Gates`,
//! `Mdefs`), `backup Motor[x].`, `backup Motor[x]..` (x and every higher motor),
//! `backup Motor[x].Servo.`, `backup Motor[x].Status`, `backup Coord[x].`, `backup Coord[x]..`,
//! `backup Coord[x].Status`, `backup Gates`, `backup Gate3[i].` / `Gate2[i].`, `backup Sys.`,
//! `backup Sys.Status`, `backup Mdefs` (`Mn->definition` lines). [DECISION] `Gates` reports
//! `Gate3[0]` (the card's ring IC) and any other IC index a value was written for;
//! `EncTable[n].` and `CompTables` answer error 21: the card models no encoder conversion
//! or compensation tables. Elements whose size the seed does not state report index 0 and
//! every index written. `Sys.I[n]`, `Sys.P`, `Sys.M` (numbered aliases of other values) are
//! not listed.

use super::catalog::{Class, St, Ty, DEFS};
use super::elements::{self, Key, Store};
use super::{exec, mvars, Thread};
use crate::domain::PowerErr;
use crate::model::CardModel;

/// What one `backup` argument names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    /// Elements of `st` index `from..=to` (unindexed: 0..=0); `servo`: only `Servo.` ones;
    /// `status`: status elements instead of saved setup.
    Elems {
        st: St,
        from: u32,
        to: u32,
        servo: bool,
        status: bool,
    },
    /// Every gate IC.
    Gates,
    /// M-variable definitions.
    Mdefs,
}

/// `backup …` alone on its line: the reply (`None` when the line is not `backup`).
pub(crate) fn command(
    card: &mut CardModel,
    store: &Store,
    th: &mut Thread,
    line: &[u8],
) -> Option<Vec<u8>> {
    let text = String::from_utf8_lossy(line).trim().to_ascii_lowercase();
    let arg = match text.strip_prefix("backup") {
        Some("") => None,
        Some(r) if r.starts_with(|c: char| c.is_ascii_whitespace()) => Some(r.trim()),
        _ => return None,
    };
    th.lines += 1;
    let parts = match arg {
        None => Ok(vec![
            elems(St::Sys, 0, 0, false, false),
            elems(St::Motor, 0, count(St::Motor) - 1, false, false),
            elems(St::Coord, 0, count(St::Coord) - 1, false, false),
            Part::Gates,
            Part::Mdefs,
        ]),
        Some(a) => parse(a).map(|p| vec![p]),
    };
    let parts = match parts {
        Ok(p) => p,
        Err(at) => {
            let at = line.len() - line.trim_ascii_start().len() + 7 + at;
            return Some(exec::frame(
                th,
                line,
                Some(super::parse::SyntaxError {
                    at,
                    code: PowerErr::IllegalParameter,
                }),
            ));
        }
    };
    let mut out = Vec::new();
    for p in parts {
        for l in lines(card, store, p) {
            out.extend_from_slice(l.as_bytes());
            out.extend_from_slice(b"\r\n");
        }
    }
    out.extend_from_slice(&exec::frame(th, line, None));
    Some(out)
}

fn elems(st: St, from: u32, to: u32, servo: bool, status: bool) -> Part {
    Part::Elems {
        st,
        from,
        to,
        servo,
        status,
    }
}

fn count(st: St) -> u32 {
    st.count().unwrap_or(1)
}

/// The part `a` (lower case, trimmed) names; `Err(offset)` where it stops making sense.
fn parse(a: &str) -> Result<Part, usize> {
    match a {
        "gates" => return Ok(Part::Gates),
        "mdefs" => return Ok(Part::Mdefs),
        "sys." | "sys" => return Ok(elems(St::Sys, 0, 0, false, false)),
        "sys.status" => return Ok(elems(St::Sys, 0, 0, false, true)),
        _ => {}
    }
    const START: usize = 0;
    let open = a.find('[').ok_or(START)?;
    let st = match &a[..open] {
        "motor" => St::Motor,
        "coord" => St::Coord,
        "gate3" | "acc5e3" | "acc24e3" | "acc59e3" | "powerbrick" => St::Gate3,
        "gate2" | "acc5e" => St::Gate2,
        "gate1" | "acc24e2" | "acc24e2a" | "acc24e2s" | "acc51e" | "acc24c2" | "acc24c2a"
        | "acc51c" => St::Gate1,
        _ => return Err(START),
    };
    let close = a.find(']').ok_or(open)?;
    let idx: u32 = a[open + 1..close].trim().parse().map_err(|_| open + 1)?;
    let n = count(st);
    if idx >= n {
        return Err(open + 1);
    }
    let tail = &a[close + 1..];
    let gate = matches!(st, St::Gate3 | St::Gate2 | St::Gate1);
    Ok(match tail {
        "." => elems(st, idx, idx, false, false),
        ".." => elems(st, idx, n - 1, false, false),
        ".servo." if st == St::Motor => elems(st, idx, idx, true, false),
        ".status" if !gate => elems(st, idx, idx, false, true),
        _ => return Err(close + 1),
    })
}

/// The lines of `p`.
fn lines(card: &mut CardModel, store: &Store, p: Part) -> Vec<String> {
    match p {
        Part::Mdefs => store
            .m
            .defined()
            .into_iter()
            .map(|(n, _)| format!("M{n}->{}", mvars::def_text(store, n)))
            .collect(),
        Part::Gates => {
            let mut v = Vec::new();
            for st in [St::Gate3, St::Gate2, St::Gate1] {
                let written = store.indices_of(st);
                for i in 0..count(st) {
                    if (st == St::Gate3 && i == 0) || written.contains(&i) {
                        v.extend(lines(card, store, elems(st, i, i, false, false)));
                    }
                }
            }
            v
        }
        Part::Elems {
            st,
            from,
            to,
            servo,
            status,
        } => {
            let th = Thread::default();
            let mut v = Vec::new();
            let st_name = st_name(st);
            for i in from..=to {
                for (d, def) in DEFS.iter().enumerate() {
                    let wanted = if status {
                        def.class == Class::Status
                    } else {
                        def.class == Class::Saved
                    };
                    if def.st != st
                        || !wanted
                        || def.ty == Ty::Struct
                        || (servo && !def.name.starts_with("Servo."))
                        || (st == St::Sys && matches!(def.name, "I" | "P" | "M"))
                    {
                        continue;
                    }
                    for k in keys(store, st, i, d) {
                        let Ok(x) = elements::read(card, store, &th, &k) else {
                            continue;
                        };
                        let value = exec::value_text(card, d, None, x, true);
                        v.push(format!("{}={value}", elements::name(&k, st_name)));
                    }
                }
            }
            v
        }
    }
}

fn st_name(st: St) -> &'static str {
    match st {
        St::Motor => "Motor",
        St::Coord => "Coord",
        St::Sys => "Sys",
        St::Gate3 => "Gate3",
        St::Gate2 => "Gate2",
        St::Gate1 => "Gate1",
        St::Gather => "Gather",
        St::Ldata => "Ldata",
        St::Macro => "Macro",
        St::Plc => "Plc",
    }
}

/// Every index of element `d` of `st[i]` to report.
fn keys(store: &Store, st: St, i: u32, d: usize) -> Vec<Key> {
    let def = &DEFS[d];
    let key = |a: u32, b: u32| Key {
        st,
        idx: i,
        def: d,
        sub: [a, b],
    };
    match def.dims {
        [] => vec![key(0, 0)],
        [n] if (1..=64).contains(n) => (0..*n).map(|a| key(a, 0)).collect(),
        [n, m] if (1..=64).contains(n) && (1..=64).contains(m) => (0..*n)
            .flat_map(|a| (0..*m).map(move |b| key(a, b)))
            .collect(),
        _ => {
            let mut v = vec![key(0, 0)];
            for k in store.keys_of(d) {
                if k.st == st && k.idx == i && !v.contains(&k) {
                    v.push(k);
                }
            }
            v
        }
    }
}
