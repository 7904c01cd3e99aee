//! DEFINE'd buffers and their memory-stacking rule (spec §3.2.6, §3.4.4, §9 item 17):
//! bottom to top `UBUFFER` < `COMP` (motor max … 1) < `TCOMP` < `BLCOMP` < `TBUF` <
//! `ROTARY` (&max … &1) < `LOOKAHEAD` < `GATHER`. A DEFINE is refused (ERR003) when anything
//! above it exists; a DELETE is refused when anything above it still exists (ERR003, except
//! `DELETE TBUF` → ERR007 as printed).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One compensation table (leadscrew / torque / backlash) owned by a motor.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct CompTable {
    /// The definition as it is listed by `LIST COMP DEF` (e.g. `100,#2,#2,100000`).
    pub def: String,
    /// Number of entries expected.
    pub entries: u32,
    /// Entries received so far (1/16 count units).
    pub data: Vec<i64>,
}

/// Which compensation-table family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableKind {
    /// Leadscrew (`COMP`).
    Comp,
    /// Backlash (`BLCOMP`).
    BlComp,
    /// Torque (`TCOMP`).
    TComp,
}

impl Defines {
    /// The tables of one family.
    pub fn tables_mut(&mut self, k: TableKind) -> &mut BTreeMap<u8, CompTable> {
        match k {
            TableKind::Comp => &mut self.comp,
            TableKind::BlComp => &mut self.blcomp,
            TableKind::TComp => &mut self.tcomp,
        }
    }
}

/// Kinds of DEFINE'd buffer, in stacking order (bottom first).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Layer {
    /// `DEFINE UBUFFER`.
    UBuffer,
    /// `DEFINE COMP` of a motor.
    Comp(u8),
    /// `DEFINE TCOMP` of a motor.
    TComp(u8),
    /// `DEFINE BLCOMP` of a motor.
    BlComp(u8),
    /// `DEFINE TBUF`.
    TBuf,
    /// `DEFINE ROT` of a coordinate system.
    Rot(u8),
    /// `DEFINE GATHER`.
    Gather,
}

impl Layer {
    /// Position in the stack: higher = above. Motors/C.S.s are stacked from the highest
    /// number (bottom) to 1 (top).
    pub fn rank(self) -> (u8, u8) {
        match self {
            Layer::UBuffer => (0, 0),
            Layer::Comp(m) => (1, 255 - m),
            Layer::TComp(m) => (2, 255 - m),
            Layer::BlComp(m) => (3, 255 - m),
            Layer::TBuf => (4, 0),
            Layer::Rot(c) => (5, 255 - c),
            Layer::Gather => (7, 0),
        }
    }
}

/// The non-program DEFINE'd buffers (the rotary buffers live with the programs but take part in
/// the stacking through the `rot` argument of [`Defines::check_define`]).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Defines {
    /// `DEFINE UBUFFER n` (0 = none).
    pub ubuffer: u32,
    /// Leadscrew tables by motor.
    pub comp: BTreeMap<u8, CompTable>,
    /// Torque tables by motor.
    pub tcomp: BTreeMap<u8, CompTable>,
    /// Backlash tables by motor.
    pub blcomp: BTreeMap<u8, CompTable>,
    /// Number of transformation matrices (`DEFINE TBUF n`, 21 words each).
    pub tbuf: u32,
    /// Gather buffer size in words.
    pub gather: Option<u32>,
}

/// Words per transformation matrix.
pub(crate) const TBUF_WORDS: u32 = 21;

impl Defines {
    /// Words used by these buffers.
    pub fn words(&self) -> u64 {
        let tables =
            |m: &BTreeMap<u8, CompTable>| -> u64 { m.values().map(|t| u64::from(t.entries)).sum() };
        u64::from(self.ubuffer)
            + tables(&self.comp)
            + tables(&self.tcomp)
            + tables(&self.blcomp)
            + u64::from(self.tbuf) * u64::from(TBUF_WORDS)
            + u64::from(self.gather.unwrap_or(0))
    }

    /// Every existing layer (rotary layers come from `rot`, the C.S.s with a rotary buffer).
    pub fn layers(&self, rot: impl Iterator<Item = u8>) -> Vec<Layer> {
        let mut v = Vec::new();
        if self.ubuffer > 0 {
            v.push(Layer::UBuffer);
        }
        v.extend(self.comp.keys().map(|&m| Layer::Comp(m)));
        v.extend(self.tcomp.keys().map(|&m| Layer::TComp(m)));
        v.extend(self.blcomp.keys().map(|&m| Layer::BlComp(m)));
        if self.tbuf > 0 {
            v.push(Layer::TBuf);
        }
        v.extend(rot.map(Layer::Rot));
        if self.gather.is_some() {
            v.push(Layer::Gather);
        }
        v
    }

    /// True when some existing layer other than `l` itself sits above `l`.
    pub fn something_above(&self, l: Layer, rot: impl Iterator<Item = u8>) -> bool {
        self.layers(rot)
            .into_iter()
            .any(|x| x != l && x.rank() > l.rank())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stacking_order_and_words() {
        let mut d = Defines::default();
        assert!(!d.something_above(Layer::TBuf, std::iter::empty()));
        d.gather = Some(100);
        assert!(d.something_above(Layer::TBuf, std::iter::empty()));
        assert!(!d.something_above(Layer::Gather, std::iter::empty()));
        d.gather = None;
        // A rotary buffer of &1 is above &2's.
        assert!(d.something_above(Layer::Rot(2), [1u8].into_iter()));
        assert!(!d.something_above(Layer::Rot(1), [2u8].into_iter()));
        // COMP of motor 1 is above COMP of motor 8, below TBUF.
        d.comp.insert(
            8,
            CompTable {
                def: String::new(),
                entries: 10,
                data: vec![],
            },
        );
        assert!(d.something_above(Layer::UBuffer, std::iter::empty()));
        assert!(!d.something_above(Layer::Comp(1), std::iter::empty()));
        d.tbuf = 2;
        assert_eq!(d.words(), 10 + 42);
        assert!(d.something_above(Layer::Comp(1), std::iter::empty()));
    }
}
