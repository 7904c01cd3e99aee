//! DEFINE / DELETE of the DEFINE'd buffers with the memory-stacking rule (§3.2.6, §3.4.4,
//! §9 item 17): define bottom-up, delete top-down (ERR003; ERR007 for `DELETE TBUF`);
//! `DEFINE GATHER` without a size takes all free memory.

use super::exec::Exec;
use super::{Pmac, Session};
use crate::domain::ErrCode;
use crate::lang::pmac::ast::{DefineTarget, DeleteTarget};
use crate::model::{BufId, Rotary};
use crate::model::{CompTable, Layer, TableKind, TBUF_WORDS};

impl Pmac<'_> {
    fn rot_keys(&self) -> Vec<u8> {
        self.model.bufs.rotary.keys().copied().collect()
    }

    fn check_define(&self, l: Layer, extra_words: u64) -> Exec {
        if self
            .bufs
            .defines
            .something_above(l, self.rot_keys().into_iter())
        {
            return Err(ErrCode::Data);
        }
        if extra_words > self.model.bufs.free() {
            return Err(ErrCode::NoRoom);
        }
        Ok(())
    }

    pub(crate) fn define(&mut self, s: &Session, t: &DefineTarget) -> Exec {
        let cs = s.coord.get() as u8;
        let m = s.motor.get() as u8;
        match t {
            DefineTarget::Rotary(n) => {
                let old = self.model.bufs.rotary.get(&cs).map_or(0, |r| r.size);
                if self.mem.open.is_some_and(|o| o.id == BufId::Rot)
                    || self.cs_running(s.coord.get())
                {
                    return Err(ErrCode::Data);
                }
                self.check_define(Layer::Rot(cs), u64::from(n.saturating_sub(old)))?;
                self.model.bufs.rotary.insert(
                    cs,
                    Rotary {
                        size: *n,
                        lines: Vec::new(),
                    },
                );
            }
            DefineTarget::Gather(n) => {
                if self.gathering() {
                    return Err(ErrCode::Data);
                }
                let old = u64::from(self.model.bufs.defines.gather.unwrap_or(0));
                let avail = self.model.bufs.free() + old;
                let want = n.map_or(avail, u64::from);
                if want > avail {
                    return Err(ErrCode::NoRoom);
                }
                self.model.bufs.defines.gather = Some(want as u32);
                self.model.gather.reset();
            }
            DefineTarget::Tbuf(n) => {
                let old = self.model.bufs.defines.tbuf;
                let extra = u64::from(n.saturating_sub(old)) * u64::from(TBUF_WORDS);
                self.check_define(Layer::TBuf, extra)?;
                self.model.bufs.defines.tbuf = *n;
            }
            DefineTarget::Ubuffer(n) => {
                let others = self.model.bufs.defines.layers(self.rot_keys().into_iter());
                if others.iter().any(|l| *l != Layer::UBuffer) {
                    return Err(ErrCode::Data);
                }
                let old = self.model.bufs.defines.ubuffer;
                if u64::from(n.saturating_sub(old)) > self.model.bufs.free() {
                    return Err(ErrCode::NoRoom);
                }
                self.model.bufs.defines.ubuffer = *n;
                self.model.state.ubuffer_words = *n;
            }
            DefineTarget::Comp {
                rows,
                cols,
                motors,
                spans,
            } => {
                let entries = match cols {
                    None => *rows,
                    Some(c) => (rows + 1).saturating_mul(c + 1).saturating_sub(1),
                };
                let max = u32::from(self.model.state.limits().motors);
                if entries == 0 || motors.iter().any(|cm| cm.motor == 0 || cm.motor > max) {
                    return Err(ErrCode::Data);
                }
                let need_spans = if cols.is_some() { 2 } else { 1 };
                if spans.len() != need_spans {
                    return Err(ErrCode::Data);
                }
                self.check_define(Layer::Comp(m), u64::from(entries))?;
                let def = comp_def_text(*rows, *cols, motors, spans, m);
                self.model.bufs.defines.comp.insert(
                    m,
                    CompTable {
                        def,
                        entries,
                        data: Vec::new(),
                    },
                );
                self.mem.pending_table = Some((TableKind::Comp, m));
            }
            DefineTarget::BlComp(n, span) | DefineTarget::TComp(n, span) => {
                let bl = matches!(t, DefineTarget::BlComp(..));
                let layer = if bl {
                    Layer::BlComp(m)
                } else {
                    Layer::TComp(m)
                };
                if *n == 0 {
                    return Err(ErrCode::Data);
                }
                self.check_define(layer, u64::from(*n))?;
                let def = format!("{n},{}", crate::model::format_value(span.value));
                let tab = CompTable {
                    def,
                    entries: *n,
                    data: Vec::new(),
                };
                let kind = if bl {
                    TableKind::BlComp
                } else {
                    TableKind::TComp
                };
                self.model.bufs.defines.tables_mut(kind).insert(m, tab);
                self.mem.pending_table = Some((kind, m));
            }
            DefineTarget::Lookahead(..) => return Err(ErrCode::Data),
        }
        Ok(())
    }

    pub(crate) fn delete(&mut self, s: &Session, t: DeleteTarget) -> Exec {
        let cs = s.coord.get() as u8;
        let m = s.motor.get() as u8;
        let above = |c: &Pmac<'_>, l: Layer| {
            c.model
                .bufs
                .defines
                .something_above(l, c.rot_keys().into_iter())
        };
        match t {
            DeleteTarget::Rotary => {
                if !self.model.bufs.rotary.contains_key(&cs) {
                    return Ok(());
                }
                let busy = self.mem.open.is_some_and(|o| o.id == BufId::Rot)
                    || self.cs_running(s.coord.get());
                if busy || above(self, Layer::Rot(cs)) {
                    return Err(ErrCode::Data);
                }
                self.model.bufs.rotary.remove(&cs);
            }
            DeleteTarget::Gather => {
                if self.gathering() {
                    return Err(ErrCode::Data);
                }
                self.model.bufs.defines.gather = None;
                self.model.gather.reset();
            }
            DeleteTarget::Tbuf => {
                if above(self, Layer::TBuf) {
                    return Err(ErrCode::BufferInUse);
                }
                self.model.bufs.defines.tbuf = 0;
            }
            DeleteTarget::Comp | DeleteTarget::BlComp | DeleteTarget::TComp => {
                let layer = match t {
                    DeleteTarget::Comp => Layer::Comp(m),
                    DeleteTarget::BlComp => Layer::BlComp(m),
                    _ => Layer::TComp(m),
                };
                if above(self, layer) {
                    return Err(ErrCode::Data);
                }
                let d = &mut self.model.bufs.defines;
                match t {
                    DeleteTarget::Comp => d.comp.remove(&m),
                    DeleteTarget::BlComp => d.blcomp.remove(&m),
                    _ => d.tcomp.remove(&m),
                };
            }
            DeleteTarget::Lookahead => return Err(ErrCode::Data),
            DeleteTarget::Plcc(n) if n > 31 => return Err(ErrCode::Data),
            DeleteTarget::Plcc(_) | DeleteTarget::Trace => {}
        }
        Ok(())
    }
}

/// `LIST COMP DEF` text with the defaulted motors filled in.
fn comp_def_text(
    rows: u32,
    cols: Option<u32>,
    motors: &[crate::lang::pmac::ast::CompMotor],
    spans: &[crate::lang::pmac::ast::Number],
    owner: u8,
) -> String {
    use crate::model::format_value;
    let nmot = if cols.is_some() { 3 } else { 2 };
    let mut parts = vec![match cols {
        Some(c) => format!("{rows}.{c}"),
        None => rows.to_string(),
    }];
    for k in 0..nmot {
        parts.push(match motors.get(k) {
            Some(cm) => format!("#{}{}", cm.motor, if cm.desired { "D" } else { "" }),
            None => format!("#{owner}"),
        });
    }
    parts.extend(spans.iter().map(|n| format_value(n.value)));
    parts.join(",")
}
