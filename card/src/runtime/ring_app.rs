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

use mcc_ring::aux_channel::AUX_NODE;
use mcc_ring::check::RingCheck;
use mcc_ring::core::{RingApp, RingControl};
use mcc_ring::linkfault::LinkFaultSlot;
use mcc_ring::member::RingMember;
use mcc_ring::packet::NodeRegs;
use mcc_ring::settings::RingSettings;

use super::handle::Runner;
use super::startup::wire_macro_motors;
use crate::core::ring_io::{ResetLayer, RingIn, RingVars, NODES};
use crate::core::{CardCore, SLICE_UNITS};
use crate::lang::{Budget, Card};
use crate::model::I995_STATUS_BITS;

/// What the card's start-up applies on top of its saved (or factory) image, and re-applies
/// after every reset: the cluster config is the card's hardware setup.
pub(crate) type StartupLayer = ResetLayer;

/// Convert latched node registers to the card's 24-bit register words (16-bit registers sit in
/// bits 8-23, spec §6.5).
pub(crate) fn regs_to_words(r: NodeRegs) -> [u32; 4] {
    [
        r.r0 & 0xFF_FFFF,
        u32::from(r.r1) << 8,
        u32::from(r.r2) << 8,
        u32::from(r.r3) << 8,
    ]
}

/// Convert the card's command words to node registers.
pub(crate) fn words_to_regs(w: [u32; 4]) -> NodeRegs {
    NodeRegs {
        r0: w[0] & 0xFF_FFFF,
        r1: ((w[1] >> 8) & 0xFFFF) as u16,
        r2: ((w[2] >> 8) & 0xFFFF) as u16,
        r3: ((w[3] >> 8) & 0xFFFF) as u16,
    }
}

/// The card's ring application: owns the card (through its `Runner`) on the ring driver's
/// thread. It only copies values between the ring core and the card core's typed ring input
/// and output (`core::ring_io`); the card core alone writes the card's state. Each tick runs
/// synchronized starts due now, the servo cycle, then a bounded slice of host work.
pub struct CardRingApp {
    runner: Runner,
    /// How long a tick waits for a synchronized start's decision.
    stall: std::time::Duration,
    /// The last ring cycle ticked (application faults start at the next one).
    last_cycle: u64,
    /// The host-link fault its ports consult (`mcc fault CARD link KIND`).
    link: LinkFaultSlot,
    /// Host ports, queryables and their runtime: they live as long as the app.
    _resources: Vec<Box<dyn std::any::Any>>,
}

/// What the ring core holds of the card's ring I-variables (I995 without status bits).
fn ring_vars(ring: &RingControl<'_>) -> RingVars {
    let s = ring.settings();
    let p = ring.check().params();
    RingVars {
        i995: s.i995 & !I995_STATUS_BITS,
        i996: s.i996,
        i1001: p.period,
        i1004: p.error_limit,
        i1005: p.sync_min,
    }
}

impl std::fmt::Debug for CardRingApp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CardRingApp")
            .field("nodes", &self.runner.core.ring_nodes())
            .field("last_cycle", &self.last_cycle)
            .finish_non_exhaustive()
    }
}

impl CardRingApp {
    /// A ring app for the card `runner` owns, serving `nodes` (its activated MACRO nodes).
    pub fn new(mut runner: Runner, nodes: &[u8]) -> Self {
        runner.core.set_ring_nodes(nodes);
        CardRingApp {
            runner,
            _resources: Vec::new(),
            link: LinkFaultSlot::default(),
            stall: std::time::Duration::from_millis(25),
            last_cycle: 0,
        }
    }

    /// A ring app owning `card` directly, without host ports (in-process simulations, tests).
    pub fn for_card(card: Card, nodes: &[u8]) -> Self {
        let (runner, _handle) = super::handle::channel(CardCore::new(card), None);
        CardRingApp::new(runner, nodes)
    }

    /// A ring app owning `card`, and a handle to send it host requests as a port would
    /// (in-process simulations: the request is served at the next tick).
    pub fn with_handle(card: Card, nodes: &[u8]) -> (Self, super::handle::CardHandle) {
        let (runner, handle) = super::handle::channel(CardCore::new(card), None);
        (CardRingApp::new(runner, nodes), handle)
    }

    /// The card core (tests, tools).
    pub fn core(&mut self) -> &mut CardCore {
        &mut self.runner.core
    }

    /// Re-apply [`wire_macro_motors`] after every `$$$` / `$$$***` (factory I-variables would
    /// deactivate motors 2-8 and the flag copy); the start-up wires them the first time.
    pub fn with_wiring(self, on: bool) -> Self {
        if !on {
            return self;
        }
        let nodes = self.runner.core.ring_nodes().to_vec();
        self.with_startup(Box::new(move |card: &mut Card| {
            if let Err(e) = wire_macro_motors(card, &nodes) {
                tracing::error!("re-applying the motor wiring after a reset: {e}");
            }
        }))
    }

    /// Re-apply `layer` after every `$$$` / `$$$***` (replaces [`Self::with_wiring`]).
    pub fn with_startup(mut self, layer: StartupLayer) -> Self {
        self.runner.core.set_reset_layer(layer);
        self
    }

    /// Keep `r` alive as long as the app (ports, queryables, runtimes).
    pub fn with_resource(mut self, r: Box<dyn std::any::Any>) -> Self {
        self._resources.push(r);
        self
    }

    /// The host-link fault slot the card's ports consult (installed by `app_fault`).
    pub fn with_link_faults(mut self, link: LinkFaultSlot) -> Self {
        self.link = link;
        self
    }

    /// A tick waits at most `stall` for a synchronized start's commit.
    pub fn with_sync_stall(mut self, stall: std::time::Duration) -> Self {
        self.stall = stall;
        self
    }
}

impl RingApp for CardRingApp {
    /// The ring I-variables, both ways ([`CardCore::ring_settings`], then
    /// [`CardCore::ring_mirror`]): the ring core takes what the card asks, the card mirrors
    /// what the ring core holds then. I995's status bits latched by the ring are ORed into the
    /// card's I995 (cleared when a host reads it; the ring check reads its own).
    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        let core = &mut self.runner.core;
        let held = ring_vars(ring);
        let want = core.ring_settings(held, ring.check().armed());
        let new = want.vars;
        if (new.i995, new.i996) != (held.i995, held.i996) {
            let status = ring.settings().i995 & I995_STATUS_BITS;
            ring.set_settings(RingSettings::new(new.i995 | status, new.i996));
        }
        if let Some(i8) = want.rearm {
            *ring.check_mut() = RingCheck::card(new.i1001, new.i1004, new.i1005, i8);
        } else {
            let check = ring.check_mut();
            if new.i1001 != held.i1001 {
                check.set_period(new.i1001);
            }
            if new.i1004 != held.i1004 {
                check.set_error_limit(new.i1004);
            }
            if new.i1005 != held.i1005 {
                check.set_sync_min(new.i1005);
            }
        }
        core.ring_mirror(ring_vars(ring), ring.status_bits());
    }

    fn tick(&mut self, cycle: u64, _time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        self.last_cycle = cycle;
        self.runner.sync_tick_start(cycle, self.stall);
        // The MACRO auxiliary channel (MS/MX, PLC MSR/MSW): registers 2-3 of this card's
        // node-15 packet, read from its copy as it came back around the ring.
        let me = regs.settings().master_number();
        let aux_back = regs
            .latched_copy(me, AUX_NODE)
            .map_or((0, 0), |r| (r.r2, r.r3));
        let mut input = RingIn {
            cycle,
            fault: ring_fault,
            feedback: [[0; 4]; NODES],
            aux_back,
        };
        let core = &mut self.runner.core;
        for &n in core.ring_nodes() {
            if let Some(slot) = input.feedback.get_mut(usize::from(n)) {
                *slot = regs_to_words(regs.read_regs(n));
            }
        }
        let out = core.ring_tick(&input);
        let w = regs.write_regs_mut(AUX_NODE);
        (w.r2, w.r3) = out.aux;
        for &n in core.ring_nodes() {
            if let Some(words) = out.commands.get(usize::from(n)) {
                *regs.write_regs_mut(n) = words_to_regs(*words);
            }
        }
        self.runner.sync_tick_end();
        // Host work after the tick, in a bounded slice: it never delays the next one.
        self.runner.pump(&mut Budget::new(SLICE_UNITS));
    }

    fn take_ring_reset(&mut self) -> bool {
        self.runner.core.take_ring_reset()
    }

    /// The card's application faults, by request: `{"family": "input", …}`
    /// (`runtime::input_fault`, [`crate::InputFaultRequest`]) or `{"link": …}` (host-link
    /// faults, `runtime::app_faults`).
    fn app_fault(&mut self, fault: &serde_json::Value) -> Result<String, String> {
        if fault.get("link").is_some() {
            return super::app_faults::apply(&self.link, fault);
        }
        match fault.get("family").and_then(|f| f.as_str()) {
            Some(super::input_fault::FAMILY) => {
                super::input_fault::apply(&mut self.runner.core, fault, self.last_cycle + 1)
            }
            f => Err(format!(
                "a card has no {f:?} faults (families: {}, link)",
                super::input_fault::FAMILY
            )),
        }
    }

    fn clear_app_faults(&mut self) {
        self.runner.core.inputs.clear();
        self.link.clear();
    }

    /// `inputs`: the hardware stop inputs held active ([`crate::CardInputs`]); `link_fault`:
    /// the host-link fault of its ports.
    fn status_extra(&self) -> serde_json::Map<String, serde_json::Value> {
        let core = &self.runner.core;
        let mut m = super::app_faults::status(&self.link);
        m.insert("inputs".into(), core.inputs.status(core.card.profile()));
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;
    use crate::service::handle::channel;
    use mcc_ring::settings::RingSettings;

    fn app(card: Card, nodes: &[u8]) -> (CardRingApp, crate::service::handle::CardHandle) {
        let (runner, handle) = channel(CardCore::new(card), None);
        (CardRingApp::new(runner, nodes), handle)
    }

    fn ask(app: &mut CardRingApp, line: &[u8]) -> Vec<u8> {
        let mut s = crate::lang::Session::with_id(999);
        app.core().card.command_line(&mut s, line)
    }

    #[test]
    fn the_startup_layer_is_applied_again_after_every_reset() {
        let layer = |card: &mut Card| {
            let mut s = crate::lang::Session::default();
            let _ = card.command_line(&mut s, b"I0=3 I1001=16");
        };
        let mut card = Card::new(Profile::Pmac2);
        layer(&mut card);
        let (app, _h) = app(card, &[0]);
        let mut app = app.with_startup(Box::new(layer));
        let mut member = RingMember::new(RingSettings::new(0x30, 0x1));
        let before = ask(&mut app, b"I0 I1001");
        let text = String::from_utf8_lossy(&before).to_string();
        assert!(text.contains('3') && text.contains("16"), "{text:?}");
        ask(&mut app, b"$$$");
        assert_ne!(
            ask(&mut app, b"I0 I1001"),
            before,
            "$$$ reloads the (unsaved) factory image"
        );
        app.tick(1, 0, &mut member, false);
        assert_eq!(
            ask(&mut app, b"I0 I1001"),
            before,
            "the tick after the reset re-applies the layer"
        );
    }

    #[test]
    fn wiring_activates_the_motors_of_the_nodes() {
        let mut card = Card::new(Profile::Pmac2);
        assert_eq!(
            wire_macro_motors(&mut card, &[0, 1, 4, 5, 8, 9, 12, 13, 15]).unwrap(),
            [1, 2, 3, 4, 5, 6, 7, 8]
        );
        assert_eq!(card.state.peek_ivar(1000), Ok(f64::from(0x3333)));
        assert_eq!(card.state.peek_ivar(1002), Ok(f64::from(0x3333)));
        assert_eq!(card.state.peek_ivar(800), Ok(1.0));
        let mut card = Card::new(Profile::Pmac2);
        assert_eq!(wire_macro_motors(&mut card, &[4, 2]).unwrap(), [3]);
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
        let (mut app, _h) = app(Card::new(Profile::Pmac2), &[0, 1]);
        let mut member = RingMember::new(RingSettings::new(0x30, 0x3));
        {
            // Motor 1 deactivated: the servo loop no longer owns its output register.
            ask(&mut app, b"I100=0");
            app.core()
                .card
                .state
                .write(crate::model::Space::Y, 0xC0A0, 0x00_1234);
        }
        app.tick(1, 0, &mut member, false);
        assert_eq!(member.write_regs_mut(0).r0, 0x1234);
        app.tick(2, 0, &mut member, true);
        assert_eq!(*member.write_regs_mut(0), NodeRegs::default());
        assert!(app.core().card.state.global.ring_fault);
        // Latched: a healthy tick does not command again until `$$$` clears the bit.
        app.tick(3, 0, &mut member, false);
        assert_eq!(member.write_regs_mut(0).r0, 0);
        assert!(!app.take_ring_reset());
        // `$$$` clears the bit: the app asks the ring core to reset its latch and commands again.
        app.core().card.state.global.ring_fault = false;
        app.tick(4, 0, &mut member, false);
        assert!(app.take_ring_reset());
        assert!(!app.take_ring_reset());
        assert_eq!(member.write_regs_mut(0).r0, 0x1234);
    }

    #[test]
    fn host_lines_reach_the_card_through_the_handle_between_ticks() {
        let (mut app, h) = app(Card::new(Profile::Pmac2), &[0]);
        let conn = h.new_conn();
        let t = std::thread::spawn(move || {
            h.host(
                conn,
                crate::core::HostRequest::Line(b"I3=2 P1=7 P1".to_vec()),
            )
        });
        let mut member = RingMember::new(RingSettings::new(0x30, 0x1));
        let mut cycle = 1;
        while !t.is_finished() {
            app.tick(cycle, 0, &mut member, false);
            cycle += 1;
            std::thread::sleep(std::time::Duration::from_millis(1));
            assert!(cycle < 100_000, "no reply");
        }
        assert_eq!(t.join().unwrap().bytes, b"7\r\x06");
    }

    #[test]
    fn ring_ivars_are_the_ring_cores_settings_both_ways() {
        use mcc_ring::control::MemberKind;
        use mcc_ring::core::{CoreConfig, MemberCore};
        let mut card = Card::new(Profile::Pmac2);
        ask_card(&mut card, b"I995=$30 I996=$F0001 I1001=16 I1004=2 I1005=4");
        let (mut app, _h) = app(card, &[0]);
        let mut cfg = CoreConfig::new(
            "card0",
            MemberKind::Card,
            0,
            RingSettings::new(0x30, 0x0F_0001),
            1_000_000,
        );
        cfg.check = RingCheck::card(16, 2, 4, 2);
        let mut core = MemberCore::new(cfg);
        core.tick_app(&mut app, 1, 0);
        // A host writes I1001 and I996 on the card: the ring core's check and routing follow.
        assert_eq!(ask(&mut app, b"I3=2 I1001=32 I996=$F0003"), b"\x06");
        core.tick_app(&mut app, 2, 0);
        assert_eq!(core.check().params().period, 32);
        assert_eq!(core.member().settings().i996, 0x0F_0003);
        // The ring core's settings changed from the other side: the card's I-variables show it.
        core.check_mut().set_error_limit(7);
        core.set_settings(RingSettings::new(0x30, 0x0F_0013));
        core.tick_app(&mut app, 3, 0);
        assert_eq!(ask(&mut app, b"I1004 I996"), b"7\r$F0013\r\x06");
        // I1001 from 0 to > 0 arms the check only at a reset (spec §6.8).
        assert_eq!(ask(&mut app, b"I1001=0"), b"\x06");
        core.tick_app(&mut app, 4, 0);
        assert!(
            core.check().armed(),
            "armed at reset: stays armed, period 0"
        );
        assert_eq!(core.check().params().period, 0);
    }

    fn ask_card(card: &mut Card, line: &[u8]) {
        let r = card.command_line(&mut crate::lang::Session::default(), line);
        assert!(!r.contains(&7), "{:?}", String::from_utf8_lossy(&r));
    }
}

/// Issue 13 item 6: a Power card as the ring's synchronizing master, set up as the card
/// process sets it up (start-up layer, config ring-check keys), latches its own ring fault.
#[cfg(test)]
mod power_sync_master_tests {
    use super::*;
    use crate::domain::Profile;
    use mcc_contracts::config::IVarValue;
    use mcc_ring::control::MemberKind;
    use mcc_ring::core::{CoreConfig, MemberCore};

    #[test]
    fn a_power_sync_master_latches_its_ring_fault_on_loss_of_light() {
        let nodes = [0u8, 1, 4, 5, 8, 9, 12, 13];
        let ivars: std::collections::BTreeMap<String, IVarValue> =
            [("I1001", 16), ("I1004", 2), ("I1005", 4)]
                .into_iter()
                .map(|(k, v)| (k.to_string(), IVarValue::Int(v)))
                .collect();
        let (i995, i996) = (0x30u32, 0x0F_3333u32);
        let layer = {
            let ivars = ivars.clone();
            move |card: &mut Card| {
                super::super::startup::ring_startup(card, Some((i995, i996)), &nodes, true)
                    .expect("start-up");
                super::super::apply_ivars(card, &ivars).expect("ivars");
            }
        };
        let mut card = Card::new(Profile::Power);
        layer(&mut card);
        let mut app = CardRingApp::for_card(card, &nodes).with_startup(Box::new(layer));
        let mut cfg = CoreConfig::new(
            "card0",
            MemberKind::Card,
            0,
            RingSettings::new(i995, i996),
            1_000_000,
        );
        cfg.check = mcc_ring::runtime::process::card_check(&ivars);
        let mut core = MemberCore::new(cfg);
        assert!(core.is_sync_master());
        // Healthy cycles: the master's frames come back with their sync packet.
        let mut cycle = 0;
        for _ in 0..40 {
            cycle += 1;
            let out = core.start_cycle(cycle, cycle * 1_000_000);
            for o in out {
                let ev = core.on_frame(&o.frame_bytes, cycle * 1_000_000);
                assert!(ev.errors.is_empty(), "cycle {cycle}: {ev:?}");
            }
            assert_eq!(core.tick_app(&mut app, cycle, cycle * 1_000_000), None);
        }
        let p = core.check().params();
        assert!(core.check().armed(), "{p:?}");
        assert_eq!((p.period, p.error_limit, p.sync_min), (16, 2, 4), "{p:?}");
        // Loss of light on the master's input: the check latches within one check period.
        let cut = cycle;
        while !core.ring_fault() {
            cycle += 1;
            assert!(
                cycle < cut + 20,
                "no ring fault latched: {:?}",
                core.status()
            );
            let _ = core.start_cycle(cycle, cycle * 1_000_000);
            let _ = core.dark_input(cycle, cycle * 1_000_000);
            core.tick_app(&mut app, cycle, cycle * 1_000_000);
        }
        assert!(core.status().fault_reason.is_some());
    }
}
