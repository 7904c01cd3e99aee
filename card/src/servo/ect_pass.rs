//! The encoder conversion table pass of a servo cycle (pmac-variables §6.6): walk the setup
//! words from Y:$0720, convert each parallel-read entry's source (MACRO node register 0 for
//! the Ultralite defaults) with rollover extension and put the 24-bit result in the X word of
//! the entry's last line, where Ix03/Ix04 point.
//!
//! The walk stops at the end marker (`$000000`), at the end of the table area ($073F) or at
//! the first entry of a method this emulator does not convert (documented refusal: entries
//! after it produce no result).

use crate::model::CardState;
use crate::model::Space;
use crate::motion::ect::{EctEntry, EctState};

/// Most words a table area holds (Turbo: $3501-$35C0).
const SLOTS: usize = 0xC0;

/// Running state of every entry, keyed by the entry's first setup address.
#[derive(Debug, Clone)]
pub(super) struct EctPass {
    slots: Vec<Option<(EctEntry, EctState)>>,
}

impl Default for EctPass {
    fn default() -> Self {
        EctPass {
            slots: vec![None; SLOTS],
        }
    }
}

impl EctPass {
    /// Run the table once: read each source, write each result. Returns the number of entries
    /// converted.
    pub(super) fn run(&mut self, st: &mut CardState) -> usize {
        let map = *st.map();
        let turbo = map.ect_ivar.is_some();
        let mut addr = map.ect_start;
        let mut n = 0;
        while addr < map.ect_end {
            let line1 = st.read(Space::Y, addr);
            let line2 = st.read(Space::Y, addr + 1);
            let decoded = if turbo {
                EctEntry::decode_turbo(line1, line2)
            } else {
                EctEntry::decode(line1, line2)
            };
            let Some(entry) = decoded else {
                break;
            };
            let k = (addr - map.ect_start) as usize;
            if k >= SLOTS {
                break;
            }
            let raw = st.read(entry.space, entry.source);
            let slot = &mut self.slots[k];
            // A changed entry starts a fresh conversion (no history from the old source).
            if slot.as_ref().is_none_or(|(e, _)| *e != entry) {
                *slot = Some((entry, EctState::default()));
            }
            if let Some((e, s)) = slot.as_mut() {
                let result = s.process(e, raw);
                st.memory.write(Space::X, addr + 1, result);
            }
            n += 1;
            addr += 2;
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;

    #[test]
    fn default_table_converts_node_feedback_with_rollover() {
        let mut st = CardState::new(Profile::Pmac2);
        let mut ect = EctPass::default();
        // Node 1 (motor 2, Y:$C0A4) just below the 24-bit wrap.
        st.set_node_feedback(1, [0xFF_FFF0, 0, 0, 0]);
        st.set_node_feedback(13, [0x00_0100, 0, 0, 0]);
        assert_eq!(ect.run(&mut st), 8);
        assert_eq!(st.memory.read(Space::X, 0x0723), 0xFF_FFF0);
        assert_eq!(st.memory.read(Space::X, 0x072F), 0x00_0100);
        st.set_node_feedback(1, [0x00_0010, 0, 0, 0]);
        ect.run(&mut st);
        assert_eq!(st.memory.read(Space::X, 0x0723), 0x00_0010);
        // A narrower entry (16-bit whole counts) in place of entry 2 extends the rollover.
        st.memory.write(Space::Y, 0x0722, 0x20C0A4);
        st.memory.write(Space::Y, 0x0723, 0x00_FFFF);
        st.set_node_feedback(1, [0x00_FFFF, 0, 0, 0]);
        ect.run(&mut st);
        assert_eq!(
            st.memory.read(Space::X, 0x0723),
            (-32i32) as u32 & 0xFF_FFFF
        );
        st.set_node_feedback(1, [0x01_0001, 0, 0, 0]);
        ect.run(&mut st);
        assert_eq!(st.memory.read(Space::X, 0x0723), 32);
    }

    #[test]
    fn end_marker_and_unknown_methods_stop_the_walk() {
        let mut st = CardState::new(Profile::Pmac2);
        let mut ect = EctPass::default();
        st.memory.write(Space::Y, 0x0724, 0);
        assert_eq!(ect.run(&mut st), 2);
        st.memory.write(Space::Y, 0x0722, 0x1F_0000);
        assert_eq!(ect.run(&mut st), 1);
    }
}
