//! Power buffers in the saved image (issue 13, issue 10 item 5): the text of every closed
//! program, subprogram and PLC goes into the image as entered (what `list` shows), and at load
//! each buffer is rebuilt from that text by the Power program parser (so `list` shows it again
//! and elements and L/R/D/C variables resolve as when it was entered). [DECISION] Kept in the
//! interpreter's part of format 2 as an optional field (`sources`, JSON): a file without it
//! (every file before it, and every PMAC2/Turbo card's) loads as before, and a reader of
//! format 2 that does not know the field ignores it — so the format number stays 2.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::listing::{self, Sources};
use super::{program, progvars};
use crate::model::{BufId, CardModel, ImageHooks, ImagePart, PartLoad, ProgLine};

pub(crate) use super::mvars::SavedM;

/// One saved setup element the dialect holds (Power units; the model's own I-variables are
/// saved with the model). [DECISION] The schema is the element's name as the seed spells it,
/// not an internal index: `{"st":"Motor","idx":1,"name":"Servo.Kp","sub":[0,0],"v":2.5}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct SavedElem {
    /// Structure (`Motor`, `Coord`, `Sys`, `Gate3` …).
    pub st: String,
    /// Structure index (0 for `Sys`).
    pub idx: u32,
    /// Element name after the structure.
    pub name: String,
    /// Its own indices.
    pub sub: [u32; 2],
    /// Value.
    pub v: f64,
}

/// The saved setup elements the dialect holds on `card` (none unless it is a Power card).
pub(crate) fn export_elems(card: &CardModel) -> Vec<SavedElem> {
    let Some(pv) = card.ext::<progvars::ProgVars>() else {
        return Vec::new();
    };
    super::elements::saved_values(&pv.store)
        .into_iter()
        .map(|(k, v)| {
            let d = &super::catalog::DEFS[k.def];
            SavedElem {
                st: format!("{:?}", k.st),
                idx: k.idx,
                name: d.name.to_string(),
                sub: k.sub,
                v,
            }
        })
        .collect()
}

/// After a load (`factory`: no image, or `$$$***`): the dialect's setup elements are `saved`
/// (entries naming no element, or out of range, are left out) and the model's I-variables
/// are computed from them (`elements::reset_setup`). Nothing unless it is a Power card.
pub(crate) fn restore_elems(card: &mut CardModel, saved: Vec<SavedElem>, factory: bool) {
    let Some(mut b) = card.take_ext() else {
        return;
    };
    if let Some(pv) = b.as_any_mut().downcast_mut::<progvars::ProgVars>() {
        let keys = saved.into_iter().filter_map(|e| {
            let (st, _) = super::catalog::structure(&e.st)?;
            let def = super::catalog::find(st, &e.name)?;
            let d = &super::catalog::DEFS[def];
            let idx_ok = st.count().map_or(e.idx == 0, |n| e.idx < n);
            let in_range = e.v >= d.min && e.v <= d.max;
            (idx_ok && in_range && d.class == super::catalog::Class::Saved).then_some((
                super::elements::Key {
                    st,
                    idx: e.idx,
                    def,
                    sub: e.sub,
                },
                e.v,
            ))
        });
        let keys: Vec<_> = keys.collect();
        super::elements::reset_setup(card, &mut pv.store, keys, factory);
    }
    card.set_ext(b);
}

/// The M-variable definitions and self-referenced values of `card` (empty unless it is a
/// Power card with the dialect attached). [DECISION] Saved by `save` and restored at power-up
/// and `$$$`, like the PMAC dialect's M-definitions and values; an optional field of format 2
/// (`mvars`), like `sources`. The user buffer itself (`Sys.Idata…`, `user` M-variables) is
/// RAM: not saved.
pub(crate) fn export_m(card: &CardModel) -> SavedM {
    card.ext::<progvars::ProgVars>()
        .map(|pv| super::mvars::export(&pv.store))
        .unwrap_or_default()
}

/// Replace the M-variables of `card` by `saved` (nothing when it is not a Power card).
pub(crate) fn restore_m(card: &mut CardModel, saved: SavedM) {
    let Some(mut b) = card.take_ext() else {
        return;
    };
    if let Some(pv) = b.as_any_mut().downcast_mut::<progvars::ProgVars>() {
        super::mvars::restore(card, &mut pv.store, saved);
    }
    card.set_ext(b);
}

/// One buffer's text in the image.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct SourceText {
    /// `prog`, `subprog` or `plc`.
    pub kind: String,
    /// Its number in the Power numbering.
    pub n: u32,
    /// Its lines as `list` shows them.
    pub lines: Vec<String>,
    /// Its stack offset (`open prog n,{offset}`; absent: the default 256).
    #[serde(default = "default_stack", skip_serializing_if = "is_default_stack")]
    pub stack: u32,
}

fn default_stack() -> u32 {
    crate::model::DEFAULT_STACK_OFFSET
}

fn is_default_stack(v: &u32) -> bool {
    *v == crate::model::DEFAULT_STACK_OFFSET
}

/// The buffer texts of `card` (none unless it is a Power card with the dialect attached).
pub(crate) fn export(card: &CardModel) -> Vec<SourceText> {
    let Some(pv) = card.ext::<progvars::ProgVars>() else {
        return Vec::new();
    };
    let kin = super::kinematics::export(&pv.kin);
    pv.sources
        .iter()
        .filter_map(|(id, lines)| {
            let (kind, n) = listing::name_of(id)?;
            // Only buffers that exist (a text kept for an erased buffer is not saved).
            card.bufs.program(id)?;
            Some(SourceText {
                kind: kind.to_string(),
                n,
                lines: lines.clone(),
                stack: pv.sources.stack(id),
            })
        })
        .chain(kin)
        .chain(defines(pv))
        .collect()
}

/// The preprocessor's definitions as a saved text (none when there are none).
fn defines(pv: &progvars::ProgVars) -> Option<SourceText> {
    let lines = pv.pre.export();
    (!lines.is_empty()).then(|| SourceText {
        kind: DEFINES.to_string(),
        n: 0,
        lines,
        stack: crate::model::DEFAULT_STACK_OFFSET,
    })
}

/// The saved text kind of the preprocessor's definitions.
const DEFINES: &str = "define";

/// After a load (or a reset that erased the buffers): forget the old texts and rebuild the
/// buffers of `saved` from theirs. A text that no longer parses leaves its buffer out.
pub(crate) fn restore(card: &mut CardModel, saved: Vec<SourceText>) {
    let Some(pv) = card.ext_mut::<progvars::ProgVars>() else {
        return;
    };
    pv.sources = Sources::default();
    pv.kin.clear();
    pv.pre = super::preproc::Preproc::default();
    for s in saved {
        if s.kind == DEFINES {
            if let Some(pv) = card.ext_mut::<progvars::ProgVars>() {
                pv.pre = super::preproc::Preproc::import(&s.lines);
            }
            continue;
        }
        if let Some(pv) = card.ext_mut::<progvars::ProgVars>() {
            if super::kinematics::rebuild(pv, &s.kind, s.n, &s.lines) {
                continue;
            }
        }
        let Some(id) = listing::id_named(&s.kind, s.n) else {
            continue;
        };
        let _ = rebuild(card, id, s.lines, s.stack);
    }
}

fn rebuild(card: &mut CardModel, id: BufId, text: Vec<String>, stack: u32) -> Option<()> {
    let mut blocks = Vec::new();
    let mut lines = Vec::new();
    let mut stored = Vec::new();
    {
        let pv = card.ext_mut::<progvars::ProgVars>()?;
        for t in &text {
            let stmts =
                program::parse_program_line(t.as_bytes(), &mut blocks, &mut pv.elems).ok()?;
            let parts = program::stored_lines(stmts);
            stored.push(parts.len());
            lines.extend(parts.into_iter().map(ProgLine::new));
        }
    }
    if !blocks.is_empty() || lines.is_empty() {
        return None;
    }
    card.bufs.remove(id);
    card.bufs.open(id).ok()?;
    for l in lines {
        if card.bufs.append(id, l).is_err() {
            card.bufs.remove(id);
            return None;
        }
    }
    if card.bufs.close(id).is_err() {
        card.bufs.remove(id);
        return None;
    }
    card.ext_mut::<progvars::ProgVars>()?
        .sources
        .insert(id, text, stored, stack);
    Some(())
}

/// The dialect's part of the saved image: `sources`, `mvars`, `elems` (each only when it
/// holds something, in that order: a PMAC2/Turbo card's image has none of them).
pub(crate) const HOOKS: ImageHooks = ImageHooks {
    export: export_part,
    load: load_part,
};

fn export_part(card: &CardModel) -> ImagePart {
    let mut part = Vec::new();
    let mut add = |name: &str, v: Result<Value, serde_json::Error>| {
        if let Ok(v) = v {
            part.push((name.to_string(), v));
        }
    };
    let sources = export(card);
    if !sources.is_empty() {
        add("sources", serde_json::to_value(sources));
    }
    let m = export_m(card);
    if !m.is_empty() {
        add("mvars", serde_json::to_value(m));
    }
    let elems = export_elems(card);
    if !elems.is_empty() {
        add("elems", serde_json::to_value(elems));
    }
    ImagePart(part)
}

/// Field `name` of `part` as a `T` (absent or unreadable: `T`'s default).
fn field<T: for<'de> Deserialize<'de> + Default>(part: &ImagePart, name: &str) -> T {
    part.get(name)
        .and_then(|v| T::deserialize(v).ok())
        .unwrap_or_default()
}

fn load_part(card: &mut CardModel, how: PartLoad) {
    match how {
        PartLoad::Factory => {
            restore(card, Vec::new());
            restore_m(card, SavedM::default());
            restore_elems(card, Vec::new(), true);
        }
        PartLoad::Reinit => {
            restore(card, Vec::new());
            restore_elems(card, Vec::new(), true);
        }
        PartLoad::Image(part) => {
            restore(card, field(&part, "sources"));
            restore_m(card, field(&part, "mvars"));
            restore_elems(card, field(&part, "elems"), false);
        }
    }
}
