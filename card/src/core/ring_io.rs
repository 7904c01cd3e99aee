//! The card's typed ring input and output: what the runtime's ring app hands the core at each
//! tick ([`RingIn`]: the cycle, the ring fault, the activated nodes' feedback registers, the
//! auxiliary registers as they came back) and what the core hands back ([`RingOut`]: the
//! nodes' command registers and the auxiliary registers to send), and the ring I-variables
//! (I995, I996, I1001, I1004, I1005; Turbo I6840, I6841, I80, I81, I82) the card and its ring
//! core share ([`RingVars`]). The core alone writes the card's state for them; the ring app only
//! copies values between these types and the ring core (`runtime/ring_app.rs`).
//!
//! The ring I-variables live in the ring core (its settings and its ring check); the card's
//! I-variables mirror them, synchronised before every tick in both directions:
//! [`CardCore::ring_settings`] says what the ring core should hold, the runtime applies it,
//! [`CardCore::ring_mirror`] shows the card what the ring core holds then.

use super::CardCore;
use crate::lang::Card;
use crate::model::I995_STATUS_BITS;

/// MACRO nodes of one card's ring interface (IC 0: nodes 0-15).
pub(crate) const NODES: usize = 16;

/// Applied to the card after every `$$$` / `$$$***` (the process start-up layer: config
/// settings, motor wiring).
pub type ResetLayer = Box<dyn Fn(&mut Card) + Send>;

/// The ring I-variables' values (I995 without its status bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RingVars {
    /// I995 (MACRO ring configuration), status bits clear.
    pub i995: u32,
    /// I996 (node activation).
    pub i996: u32,
    /// I1001 (ring check period).
    pub i1001: u32,
    /// I1004 (ring error limit).
    pub i1004: u32,
    /// I1005 (sync packets required).
    pub i1005: u32,
}

impl RingVars {
    fn of_card(card: &Card) -> Self {
        let i = |n: u32| card.state.peek_ivar(n).unwrap_or(0.0).max(0.0) as u32;
        let rv = card.state.ring_ivars();
        RingVars {
            i995: i(rv.cfg) & !I995_STATUS_BITS,
            i996: i(rv.nodes),
            i1001: i(rv.check_period),
            i1004: i(rv.error_limit),
            i1005: i(rv.sync_min),
        }
    }

    /// Field by field: a value the card changed since `last` wins, otherwise the ring core's.
    fn merge(card: RingVars, ring: RingVars, last: RingVars) -> RingVars {
        let pick = |c: u32, r: u32, l: u32| if c != l { c } else { r };
        RingVars {
            i995: pick(card.i995, ring.i995, last.i995),
            i996: pick(card.i996, ring.i996, last.i996),
            i1001: pick(card.i1001, ring.i1001, last.i1001),
            i1004: pick(card.i1004, ring.i1004, last.i1004),
            i1005: pick(card.i1005, ring.i1005, last.i1005),
        }
    }
}

/// What the card asks of its ring core before a tick ([`CardCore::ring_settings`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RingWanted {
    /// The values the ring core should hold (its settings; its check's parameters).
    pub vars: RingVars,
    /// Build the ring check anew from `vars` and this I8 (a reset that arms or disarms it: I1001
    /// going from 0 to > 0, or back, takes effect at a reset only); `None`: change the
    /// parameters that differ in place.
    pub rearm: Option<u32>,
}

/// One tick's ring input.
#[derive(Debug, Clone, Copy)]
pub struct RingIn {
    /// The ring cycle.
    pub cycle: u64,
    /// The ring core reports a ring fault.
    pub fault: bool,
    /// Feedback register words of each node (only the card's activated nodes are read).
    pub feedback: [[u32; 4]; NODES],
    /// Registers 2 and 3 of this card's auxiliary node packet as it came back around the ring.
    pub aux_back: (u16, u16),
}

/// One tick's ring output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RingOut {
    /// Command register words of each activated node (zero while the ring fault is latched).
    pub commands: [[u32; 4]; NODES],
    /// Registers 2 and 3 of this card's auxiliary node packet.
    pub aux: (u16, u16),
}

/// The core's side of the ring link.
pub(crate) struct RingLink {
    /// The activated nodes (below [`NODES`]).
    pub(crate) nodes: Vec<u8>,
    /// The ring fault has been reported into the card's status word.
    reported: bool,
    /// The card's `$$$` cleared the reported bit: ask the ring core to reset its latch.
    reset_wanted: bool,
    layer: Option<ResetLayer>,
    /// The card's reset count the layer was last applied for.
    resets_seen: u64,
    /// The ring settings the card and its ring core last agreed on (`None`: not yet).
    vars: Option<RingVars>,
}

impl RingLink {
    /// The link of a card that has been reset `resets` times (the start-up layer is applied).
    pub(crate) fn new(resets: u64) -> Self {
        RingLink {
            nodes: Vec::new(),
            reported: false,
            reset_wanted: false,
            layer: None,
            resets_seen: resets,
            vars: None,
        }
    }
}

impl std::fmt::Debug for RingLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RingLink")
            .field("nodes", &self.nodes)
            .field("reported", &self.reported)
            .field("vars", &self.vars)
            .finish_non_exhaustive()
    }
}

impl CardCore {
    /// Serve MACRO nodes `nodes` (those below 16) on the ring.
    pub fn set_ring_nodes(&mut self, nodes: &[u8]) {
        self.ring.nodes = nodes
            .iter()
            .copied()
            .filter(|&n| usize::from(n) < NODES)
            .collect();
    }

    /// The activated nodes.
    pub fn ring_nodes(&self) -> &[u8] {
        &self.ring.nodes
    }

    /// Apply `layer` again after every `$$$` / `$$$***` (the process start-up applied it the
    /// first time).
    pub fn set_reset_layer(&mut self, layer: ResetLayer) {
        self.ring.layer = Some(layer);
    }

    /// A reset since the last look: the reset layer is applied (once per reset).
    fn after_reset(&mut self) -> bool {
        let resets = self.card.resets();
        if resets == self.ring.resets_seen {
            return false;
        }
        self.ring.resets_seen = resets;
        if let Some(layer) = &self.ring.layer {
            layer(&mut self.card);
        }
        true
    }

    /// The ring I-variables before a tick, given what the ring core holds (`ring`) and
    /// whether its check is armed: after a reset (and at the start) the reset layer is
    /// applied first, I995/I996 stay as the ring core has them (the cluster config is the
    /// card's jumpers: a reset does not take the card off the ring) and the check is re-armed
    /// from I1001 > 0 as the card's reset does; otherwise a value the card changed since the
    /// last tick (a host `I1001=32`) goes to the ring core, else the core's value stays.
    pub fn ring_settings(&mut self, ring: RingVars, armed: bool) -> RingWanted {
        let reset = self.after_reset() || self.ring.vars.is_none();
        let c = RingVars::of_card(&self.card);
        let vars = match self.ring.vars {
            Some(last) if !reset => RingVars::merge(c, ring, last),
            _ => RingVars {
                i995: ring.i995,
                i996: ring.i996,
                ..c
            },
        };
        let rearm = (reset && armed != (vars.i1001 > 0)).then(|| {
            let i8 = self.card.state.peek_ivar(8).unwrap_or(2.0).max(0.0);
            i8 as u32
        });
        RingWanted { vars, rearm }
    }

    /// The card mirrors what its ring core holds now (`ring`), and latches the ring's status
    /// bits (`status`) into I995 (cleared when a host reads it).
    pub fn ring_mirror(&mut self, ring: RingVars, status: u32) {
        let c = RingVars::of_card(&self.card);
        let state = &mut self.card.state;
        let rv = state.ring_ivars();
        let held = state.peek_ivar(rv.cfg).unwrap_or(0.0) as u32 & I995_STATUS_BITS;
        for (n, v, now) in [
            (rv.cfg, ring.i995 | held, c.i995 | held),
            (rv.nodes, ring.i996, c.i996),
            (rv.check_period, ring.i1001, c.i1001),
            (rv.error_limit, ring.i1004, c.i1004),
            (rv.sync_min, ring.i1005, c.i1005),
        ] {
            if v != now {
                let _ = state.set_ivar(n, f64::from(v));
            }
        }
        state.latch_ring_status(status);
        self.ring.vars = Some(ring);
    }

    /// One ring tick: the ring fault is latched into the global status word (until `$$$`
    /// clears it), the activated nodes' feedback latched, the servo cycle run, the auxiliary
    /// channel stepped, and the nodes' commands read (zero while the fault is latched).
    pub fn ring_tick(&mut self, input: &RingIn) -> RingOut {
        let global = &mut self.card.state.global;
        if self.ring.reported && !global.ring_fault {
            // `$$$` cleared the bit: the ring core's latch follows if the ring is healthy,
            // otherwise the next tick reports the fault again.
            self.ring.reported = false;
            self.ring.reset_wanted = true;
        } else if input.fault {
            global.ring_fault = true;
            self.ring.reported = true;
        }
        // (Without a ring core asking for the settings first, e.g. a bare tick in a test.)
        self.after_reset();
        for &n in &self.ring.nodes {
            let n = usize::from(n);
            if let Some(words) = input.feedback.get(n) {
                self.card.state.set_node_feedback(n, *words);
            }
        }
        self.tick(input.cycle);
        let aux = self.aux_tick(input.aux_back);
        let mut out = RingOut {
            commands: [[0; 4]; NODES],
            aux,
        };
        if !self.card.state.global.ring_fault {
            for &n in &self.ring.nodes {
                let n = usize::from(n);
                if let Some(slot) = out.commands.get_mut(n) {
                    *slot = self.card.state.node_command(n);
                }
            }
        }
        out
    }

    /// The card's `$$$` cleared the ring fault it reported: the ring core should reset its
    /// latch (asked once).
    pub fn take_ring_reset(&mut self) -> bool {
        std::mem::take(&mut self.ring.reset_wanted)
    }
}
