//! The card on the ring: each servo tick it latches its activated nodes' feedback registers
//! into the card's MACRO node registers (the read side of Y:$C0A0-$C0BF / X: I/O nodes), runs
//! the servo cycle ([`crate::servo::Servo::tick`]: ECT, motors, programs, aux flag copy) and
//! puts the command side of those registers into its outgoing packets. On a ring fault it
//! stops commanding its slave nodes (zeroed commands, amplifier enables dropped), sets the
//! ring-fault bit of the global status word (X:$0003 bit 4), which stays set until `$$$`, and
//! the servo cycle kills every motor.
//!
//! Ring-mode wiring ([`wire_macro_motors`], applied at start-up before the config's `ivars`):
//! motor x (1-8) whose Ix02 servo node is one of the card's activated nodes gets Ix00 = 1, and
//! those nodes get I1000 bit n (auxiliary flag copy) and I1002 bit n (Type 1 flags in register
//! 3). With the factory Ix02/Ix03/Ix25 and ECT defaults that is the Ultralite's "motor on node"
//! minimum set (spec §6.6), so the default cluster's motors work out of the box.

use std::sync::{Arc, Mutex};

use mcc_ring::core::RingApp;
use mcc_ring::member::RingMember;
use mcc_ring::packet::NodeRegs;

use crate::interp::{Card, Session};
use crate::servo::Servo;

/// Activate motors 1-8 whose Ix02 register belongs to one of `nodes` (servo nodes only) and
/// enable the Type 1 auxiliary flag copy of those nodes (I1000, I1002). Returns the motors
/// activated.
pub fn wire_macro_motors(card: &mut Card, nodes: &[u8]) -> Vec<u16> {
    let mut s = Session::default();
    let mut aux = 0u32;
    let mut motors = Vec::new();
    let max = card.state.limits().motors.min(8);
    for x in 1..=max {
        let ix02 = card.state.peek_ivar(100 * u32::from(x) + 2).unwrap_or(0.0) as u32;
        let Some((node, 0)) =
            crate::state::memory::node_of(crate::state::memory::Space::Y, (ix02 & 0xFFFF) as u16)
        else {
            continue;
        };
        if ix02 & (1 << 19) != 0 || !nodes.contains(&(node as u8)) {
            continue;
        }
        aux |= 1 << node;
        motors.push(x);
    }
    let mut line = format!("I1000=${aux:X} I1002=${aux:X}");
    for x in &motors {
        line.push_str(&format!(" I{x}00=1"));
    }
    let _ = card.command_line(&mut s, line.as_bytes());
    motors
}

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
pub struct CardRingApp {
    card: Arc<Mutex<Card>>,
    nodes: Vec<u8>,
    /// The ring fault has been reported into the card's status word.
    reported: bool,
    /// The card's `$$$` cleared the reported bit: ask the ring core to reset its latch.
    reset_wanted: bool,
    /// Synchronized start: scheduled lines and the program-start record (DRILLS).
    sync: Option<super::sync_start::SyncStart>,
    /// The servo loop (motors, program engine) (SERVOLOOP).
    servo: Servo,
    /// The start-up layer (config settings, motor wiring), applied again after every `$$$` /
    /// `$$$***` (the process start-up applied it the first time).
    startup: Option<StartupLayer>,
    resets_seen: u64,
    /// Host ports, queryables and their runtime: they live as long as the app.
    _resources: Vec<Box<dyn std::any::Any>>,
}

impl std::fmt::Debug for CardRingApp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CardRingApp")
            .field("nodes", &self.nodes)
            .field("reported", &self.reported)
            .field("resets_seen", &self.resets_seen)
            .finish_non_exhaustive()
    }
}

/// What the card's start-up applies on top of its saved (or factory) image, and re-applies
/// after every reset: the cluster config is the card's hardware setup.
pub type StartupLayer = Box<dyn Fn(&mut Card)>;

impl CardRingApp {
    /// A ring app for `card` serving `nodes` (its activated MACRO nodes).
    pub fn new(card: Arc<Mutex<Card>>, nodes: &[u8]) -> Self {
        let (servo, resets_seen) = {
            let c = card.lock().unwrap_or_else(|e| e.into_inner());
            (Servo::new(&c), c.resets())
        };
        CardRingApp {
            servo,
            startup: None,
            resets_seen,
            _resources: Vec::new(),
            card,
            nodes: nodes.iter().copied().filter(|&n| n < 16).collect(),
            reported: false,
            reset_wanted: false,
            sync: None,
        }
    }

    /// Re-apply [`wire_macro_motors`] after every `$$$` / `$$$***` (factory I-variables would
    /// deactivate motors 2-8 and the flag copy); the start-up wires them the first time.
    pub fn with_wiring(self, on: bool) -> Self {
        if !on {
            return self;
        }
        let nodes = self.nodes.clone();
        self.with_startup(Box::new(move |card: &mut Card| {
            wire_macro_motors(card, &nodes);
        }))
    }

    /// Re-apply `layer` after every `$$$` / `$$$***` (replaces [`Self::with_wiring`]).
    pub fn with_startup(mut self, layer: StartupLayer) -> Self {
        self.startup = Some(layer);
        self
    }

    /// Keep `r` alive as long as the app (ports, queryables, runtimes).
    pub fn with_resource(mut self, r: Box<dyn std::any::Any>) -> Self {
        self._resources.push(r);
        self
    }

    /// Run `sync`'s scheduled lines at the start of each tick (synchronized start).
    pub fn with_sync_start(mut self, sync: super::sync_start::SyncStart) -> Self {
        self.sync = Some(sync);
        self
    }
}

impl RingApp for CardRingApp {
    fn tick(&mut self, cycle: u64, _time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        let mut card = self.card.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = &self.sync {
            s.tick_start(&mut card, cycle);
        }
        if self.reported && !card.state.global.ring_fault {
            // `$$$` cleared the bit: the ring core's latch follows if the ring is healthy,
            // otherwise the next tick reports the fault again.
            self.reported = false;
            self.reset_wanted = true;
        } else if ring_fault {
            card.state.global.ring_fault = true;
            self.reported = true;
        }
        if card.resets() != self.resets_seen {
            self.resets_seen = card.resets();
            if let Some(layer) = &self.startup {
                layer(&mut card);
            }
        }
        for &n in &self.nodes {
            card.state
                .set_node_feedback(usize::from(n), regs_to_words(regs.read_regs(n)));
        }
        self.servo.tick(&mut card, cycle);
        let latched = card.state.global.ring_fault;
        for &n in &self.nodes {
            *regs.write_regs_mut(n) = if latched {
                NodeRegs::default()
            } else {
                words_to_regs(card.state.node_command(usize::from(n)))
            };
        }
        if let Some(s) = &self.sync {
            s.tick_end(&card);
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
    fn the_startup_layer_is_applied_again_after_every_reset() {
        let card = Arc::new(Mutex::new(Card::new(Profile::Pmac2)));
        let layer = |card: &mut Card| {
            let mut s = crate::interp::Session::default();
            let _ = card.command_line(&mut s, b"I0=3 I1001=16");
        };
        layer(&mut card.lock().unwrap());
        let mut app = CardRingApp::new(Arc::clone(&card), &[0]).with_startup(Box::new(layer));
        let mut member = RingMember::new(RingSettings::new(0x30, 0x1));
        let ask = |line: &[u8]| {
            let mut s = crate::interp::Session::default();
            card.lock().unwrap().command_line(&mut s, line)
        };
        let before = ask(b"I0 I1001");
        let text = String::from_utf8_lossy(&before).to_string();
        assert!(text.contains('3') && text.contains("16"), "{text:?}");
        ask(b"$$$");
        assert_ne!(
            ask(b"I0 I1001"),
            before,
            "$$$ reloads the (unsaved) factory image"
        );
        app.tick(1, 0, &mut member, false);
        assert_eq!(
            ask(b"I0 I1001"),
            before,
            "the tick after the reset re-applies the layer"
        );
    }

    #[test]
    fn wiring_activates_the_motors_of_the_nodes() {
        let mut card = Card::new(Profile::Pmac2);
        assert_eq!(
            wire_macro_motors(&mut card, &[0, 1, 4, 5, 8, 9, 12, 13, 15]),
            [1, 2, 3, 4, 5, 6, 7, 8]
        );
        assert_eq!(card.state.peek_ivar(1000), Ok(f64::from(0x3333)));
        assert_eq!(card.state.peek_ivar(1002), Ok(f64::from(0x3333)));
        assert_eq!(card.state.peek_ivar(800), Ok(1.0));
        let mut card = Card::new(Profile::Pmac2);
        assert_eq!(wire_macro_motors(&mut card, &[4, 2]), [3]);
        assert_eq!(card.state.peek_ivar(1000), Ok(16.0));
        assert_eq!(card.state.peek_ivar(200), Ok(0.0));
    }

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
        {
            // Motor 1 deactivated: the servo loop no longer owns its output register.
            let mut c = card.lock().unwrap();
            c.command_line(&mut crate::interp::Session::default(), b"I100=0");
            c.state
                .write(crate::state::memory::Space::Y, 0xC0A0, 0x00_1234);
        }
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
