//! Data gathering (pmac-variables §2 I19-I45, pmac-commands `DEFINE GATHER`, `GATHER`,
//! `ENDGATHER`, `DELETE GATHER`, `LIST GATHER`).
//!
//! - `DEFINE GATHER [n]` reserves n long words (the size lives in the interpreter's DEFINE'd
//!   buffers, `Card::bufs.defines.gather`) and resets the storage pointer (data cleared).
//! - `GATHER` sets `???` word 1 bit 19 (gathering on) and arms a sample for the next servo
//!   cycle; from then on one sample every I19 servo cycles (I19 = 0: that one sample only,
//!   then gathering turns off). `GATHER` while gathering re-synchronises the period.
//! - A sample is one long word per source enabled in I20 (bit k → I(21+k)), in source order.
//!   A source's top hex digit selects the word: 0 = Y, 4 = X (the 24-bit value sits in the low
//!   half of the long word), 8 or C = the 48-bit X:Y pair (X high).
//! - When a whole sample no longer fits, gathering stops (bit 19 clears) unless I45 bit 0
//!   (wrap) is set, in which case the oldest words are overwritten from the buffer start.
//! - `LIST GATHER [start][,len]`: long words as 12 hex digits, space-separated, 16 per line.
//! - Turbo numbering: I5049 period, I5050 mask, I5001-I5024 sources, I5000 bit 0 wrap (I20-I23
//!   are MACRO IC addresses there).

use crate::model::CardModel;
use crate::model::CardState;
use crate::model::Space;

/// `???` word 1 bit 19: data gathering on.
pub(super) const GATHER_ON: u32 = 1 << 19;

/// `???` word 1 bit 17: gathering armed to start on the rising edge of machine input MI2
/// (`GATHER TRIGGER`, seed 7062, 8173).
pub(super) const GATHER_ON_TRIGGER: u32 = 1 << 17;

/// Long words per `LIST GATHER` line.
pub(super) const WORDS_PER_LINE: usize = 16;

/// The gathered data and the sampling clock.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GatherBuffer {
    data: Vec<u64>,
    /// Next index to write when wrapping.
    write: usize,
    /// A `GATHER` asked for a sample at the next servo cycle.
    pending: bool,
    /// Servo cycles since the last sample.
    timer: u32,
    /// MI2 as seen at the previous servo cycle (for its rising edge).
    mi2_was: bool,
}

impl GatherBuffer {
    /// `DEFINE GATHER`: storage pointer back to the start (old data no longer listed).
    pub fn reset(&mut self) {
        self.data.clear();
        self.write = 0;
        self.pending = false;
        self.timer = 0;
    }

    /// `GATHER`: sample at the next servo cycle, then every I19 cycles.
    pub fn start(&mut self) {
        self.pending = true;
        self.timer = 0;
    }

    /// The words gathered so far, in buffer order.
    pub fn words(&self) -> &[u64] {
        &self.data
    }

    /// `LIST GATHER` lines for words `start..start+len` (to the end when `len` is `None`).
    pub fn list_lines(&self, start: Option<u32>, len: Option<u32>) -> Vec<String> {
        let from = (start.unwrap_or(0) as usize).min(self.data.len());
        let to = match len {
            Some(n) => from.saturating_add(n as usize).min(self.data.len()),
            None => self.data.len(),
        };
        self.data[from..to]
            .chunks(WORDS_PER_LINE)
            .map(|c| {
                c.iter()
                    .map(|w| format!("{:012X}", w & 0xFFFF_FFFF_FFFF))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect()
    }

    /// One servo cycle: take a sample if one is due. `capacity` is the defined buffer size in
    /// long words (`None`: no buffer). Returns whether a sample was taken.
    pub fn on_servo_cycle(&mut self, st: &mut CardState, capacity: Option<u32>) -> bool {
        // MI2: bit 1 of the machine-input word (PMAC2 Y:$FFC2, Turbo Y:$078802).
        let mi2 = st.read(Space::Y, st.map().machine_inputs) & 2 != 0;
        let rose = mi2 && !self.mi2_was;
        self.mi2_was = mi2;
        if st.global.word1_other & GATHER_ON_TRIGGER != 0 && rose {
            st.global.word1_other &= !GATHER_ON_TRIGGER;
            st.global.word1_other |= GATHER_ON;
            self.start();
        }
        if st.global.word1_other & GATHER_ON == 0 {
            self.pending = false;
            return false;
        }
        let Some(cap) = capacity else {
            return false;
        };
        let period = st.vars.i(gather_ivars(st).0).unwrap_or(0.0).max(0.0) as u32;
        let due = if self.pending {
            true
        } else if period > 0 {
            self.timer = self.timer.saturating_add(1);
            self.timer >= period
        } else {
            false
        };
        if !due {
            return false;
        }
        self.pending = false;
        self.timer = 0;
        let sample = read_sample(st);
        let cap = cap as usize;
        let wrap = st.vars.i(gather_ivars(st).3).unwrap_or(0.0) as u32 & 1 != 0;
        if sample.len() > cap || (!wrap && self.data.len() + sample.len() > cap) {
            st.global.word1_other &= !GATHER_ON;
            return false;
        }
        for w in sample {
            if self.data.len() < cap {
                self.data.push(w);
                self.write = self.data.len() % cap.max(1);
            } else {
                if let Some(slot) = self.data.get_mut(self.write) {
                    *slot = w;
                }
                self.write = (self.write + 1) % cap.max(1);
            }
        }
        if period == 0 {
            st.global.word1_other &= !GATHER_ON;
        }
        true
    }
}

/// The gather I-variables of the card's profile: (period, mask, first source, wrap mode).
fn gather_ivars(st: &CardState) -> (u32, u32, u32, u32) {
    match st.profile() {
        crate::domain::Profile::Turbo => (5049, 5050, 5001, 5000),
        _ => (19, 20, 21, 45),
    }
}

/// Read one sample: every source enabled in the mask (I20, Turbo I5050), as long words.
pub(super) fn read_sample(st: &mut CardState) -> Vec<u64> {
    let (_, mask_var, first, _) = gather_ivars(st);
    let mask = st.vars.i(mask_var).unwrap_or(0.0).max(0.0) as u32;
    let mut v = Vec::new();
    for k in 0..24u32 {
        if mask & (1 << k) == 0 {
            continue;
        }
        let src = st.vars.i(first + k).unwrap_or(0.0).max(0.0) as u32;
        let addr = src & st.map().max_addr;
        let w = if src & (1 << 23) != 0 {
            (u64::from(st.read(Space::X, addr)) << 24) | u64::from(st.read(Space::Y, addr))
        } else if src & (1 << 22) != 0 {
            u64::from(st.read(Space::X, addr))
        } else {
            u64::from(st.read(Space::Y, addr))
        };
        v.push(w);
    }
    v
}

/// The card's gathering step of one servo cycle.
pub(crate) fn gather_tick(card: &mut CardModel) -> bool {
    let cap = card.bufs.defines.gather;
    card.gather.on_servo_cycle(&mut card.state, cap)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;

    fn state() -> CardState {
        let mut st = CardState::new(Profile::Pmac2);
        st.set_ivar(20, 3.0).unwrap();
        st.set_ivar(21, 0x0770 as f64).unwrap(); // Y:$0770
        st.set_ivar(22, 0x80_0771 as f64).unwrap(); // L:$0771
        st.memory.write(Space::Y, 0x0770, 0x12_3456);
        st.memory.write(Space::X, 0x0771, 0xAB_CDEF);
        st.memory.write(Space::Y, 0x0771, 0x00_0001);
        st
    }

    #[test]
    fn samples_every_i19_cycles_until_full() {
        let mut st = state();
        st.set_ivar(19, 2.0).unwrap();
        let mut g = GatherBuffer::default();
        // Not on: nothing.
        assert!(!g.on_servo_cycle(&mut st, Some(5)));
        st.global.word1_other |= GATHER_ON;
        g.start();
        let taken: Vec<bool> = (0..6).map(|_| g.on_servo_cycle(&mut st, Some(5))).collect();
        // First cycle, then cycle 3 (two cycles later); the third sample would not fit in 5.
        assert_eq!(taken, [true, false, true, false, false, false]);
        assert_eq!(
            g.words(),
            [0x12_3456, 0xABCD_EF00_0001, 0x12_3456, 0xABCD_EF00_0001]
        );
        assert_eq!(st.global.word1_other & GATHER_ON, 0, "full: gathering off");
        assert_eq!(
            g.list_lines(None, None),
            ["000000123456 ABCDEF000001 000000123456 ABCDEF000001"]
        );
        assert_eq!(
            g.list_lines(Some(1), Some(2)),
            ["ABCDEF000001 000000123456"]
        );
        assert_eq!(g.list_lines(Some(9), None), Vec::<String>::new());
    }

    #[test]
    fn i19_zero_takes_one_sample_per_gather_and_wrap_overwrites() {
        let mut st = state();
        st.global.word1_other |= GATHER_ON;
        let mut g = GatherBuffer::default();
        g.start();
        assert!(g.on_servo_cycle(&mut st, Some(100)));
        assert!(!g.on_servo_cycle(&mut st, Some(100)));
        assert_eq!(g.words().len(), 2);
        assert_eq!(st.global.word1_other & GATHER_ON, 0);
        // Wrap mode: a 3-word buffer takes samples forever, overwriting from the start.
        st.set_ivar(45, 1.0).unwrap();
        st.set_ivar(19, 1.0).unwrap();
        st.global.word1_other |= GATHER_ON;
        g.reset();
        g.start();
        st.memory.write(Space::Y, 0x0770, 1);
        g.on_servo_cycle(&mut st, Some(3));
        st.memory.write(Space::Y, 0x0770, 2);
        g.on_servo_cycle(&mut st, Some(3));
        // [1, L] then 2 fills the last word and L overwrites the first.
        assert_eq!(g.words(), [0xABCD_EF00_0001, 0xABCD_EF00_0001, 2]);
        assert_ne!(st.global.word1_other & GATHER_ON, 0);
    }

    #[test]
    fn lines_hold_sixteen_words() {
        let g = GatherBuffer {
            data: (0..20).collect(),
            ..GatherBuffer::default()
        };
        let l = g.list_lines(None, None);
        assert_eq!(l.len(), 2);
        assert_eq!(l[0].split(' ').count(), 16);
        assert_eq!(l[1], "000000000010 000000000011 000000000012 000000000013");
    }
}
