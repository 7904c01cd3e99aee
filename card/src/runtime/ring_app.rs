//! The card on the ring: each servo tick it latches its activated nodes' feedback registers
//! into the card's MACRO node registers (the read side of Y:$C0A0-$C0BF / X: I/O nodes) and puts
//! the command side of those registers into its outgoing packets. On a ring fault it stops
//! commanding its slave nodes (zeroed commands, amplifier enables dropped) and sets the ring-
//! fault bit of the global status word (X:$0003 bit 4), which stays set until `$$$`.

use std::sync::{Arc, Mutex};

use mcc_ring::core::RingApp;
use mcc_ring::member::RingMember;
use mcc_ring::packet::NodeRegs;

use crate::interp::Card;

/// Convert latched node registers to the card's 24-bit register words (16-bit registers sit in
/// bits 8-23, spec §6.5).
pub fn regs_to_words(r: NodeRegs) -> [u32; 4] {
    [
        r.r0 & 0xFF_FFFF,
        u32::from(r.r1) << 8,
        u32::from(r.r2) << 8,
        u32::from(r.r3) << 8,
    ]
}

/// Convert the card's command words to node registers.
pub fn words_to_regs(w: [u32; 4]) -> NodeRegs {
    NodeRegs {
        r0: w[0] & 0xFF_FFFF,
        r1: ((w[1] >> 8) & 0xFFFF) as u16,
        r2: ((w[2] >> 8) & 0xFFFF) as u16,
        r3: ((w[3] >> 8) & 0xFFFF) as u16,
    }
}

/// The card's ring application.
#[derive(Debug)]
pub struct CardRingApp {
    card: Arc<Mutex<Card>>,
    nodes: Vec<u8>,
    /// The ring fault has been reported into the card's status word.
    reported: bool,
    /// The card's `$$$` cleared the reported bit: ask the ring core to reset its latch.
    reset_wanted: bool,
}

impl CardRingApp {
    /// A ring app for `card` serving `nodes` (its activated MACRO nodes).
    pub fn new(card: Arc<Mutex<Card>>, nodes: &[u8]) -> Self {
        CardRingApp {
            card,
            nodes: nodes.iter().copied().filter(|&n| n < 16).collect(),
            reported: false,
            reset_wanted: false,
        }
    }
}

impl RingApp for CardRingApp {
    fn tick(&mut self, _cycle: u64, _time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        let mut card = self.card.lock().unwrap_or_else(|e| e.into_inner());
        if self.reported && !card.state.global.ring_fault {
            // `$$$` cleared the bit: the ring core's latch follows if the ring is healthy,
            // otherwise the next tick reports the fault again.
            self.reported = false;
            self.reset_wanted = true;
        } else if ring_fault {
            card.state.global.ring_fault = true;
            self.reported = true;
        }
        let latched = card.state.global.ring_fault;
        for &n in &self.nodes {
            card.state
                .set_node_feedback(usize::from(n), regs_to_words(regs.read_regs(n)));
            *regs.write_regs_mut(n) = if latched {
                NodeRegs::default()
            } else {
                words_to_regs(card.state.node_command(usize::from(n)))
            };
        }
    }

    fn take_ring_reset(&mut self) -> bool {
        std::mem::take(&mut self.reset_wanted)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interp::Profile;
    use mcc_ring::settings::RingSettings;

    #[test]
    fn register_words_round_trip() {
        let r = NodeRegs {
            r0: 0x12_3456,
            r1: 0xABCD,
            r2: 0x0102,
            r3: 0x8001,
        };
        assert_eq!(
            regs_to_words(r),
            [0x12_3456, 0xAB_CD00, 0x01_0200, 0x80_0100]
        );
        assert_eq!(words_to_regs(regs_to_words(r)), r);
    }

    #[test]
    fn tick_latches_feedback_and_sends_commands_until_a_ring_fault() {
        let card = Arc::new(Mutex::new(Card::new(Profile::Pmac2)));
        let mut app = CardRingApp::new(Arc::clone(&card), &[0, 1]);
        let mut member = RingMember::new(RingSettings::new(0x30, 0x3));
        card.lock()
            .unwrap()
            .state
            .write(crate::state::memory::Space::Y, 0xC0A0, 0x00_1234);
        app.tick(1, 0, &mut member, false);
        assert_eq!(member.write_regs_mut(0).r0, 0x1234);
        app.tick(2, 0, &mut member, true);
        assert_eq!(*member.write_regs_mut(0), NodeRegs::default());
        assert!(card.lock().unwrap().state.global.ring_fault);
        // Latched: a healthy tick does not command again until `$$$` clears the bit.
        app.tick(3, 0, &mut member, false);
        assert_eq!(member.write_regs_mut(0).r0, 0);
        assert!(!app.take_ring_reset());
        // `$$$` clears the bit: the app asks the ring core to reset its latch and commands again.
        card.lock().unwrap().state.global.ring_fault = false;
        app.tick(4, 0, &mut member, false);
        assert!(app.take_ring_reset());
        assert!(!app.take_ring_reset());
        assert_eq!(member.write_regs_mut(0).r0, 0x1234);
    }
}
