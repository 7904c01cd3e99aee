//! `MemberCore`: everything one ring member does with bytes and time, without I/O.
//!
//! The runtime (or the in-process [`crate::sim`]) feeds it frames and time and sends what it
//! returns: routing ([`RingMember`]), receive error classes and I995 status ([`RingStatus`]),
//! ring check ([`RingCheck`]), the send-path fault layer ([`FaultLayer`]), the holdover clock
//! ([`HoldoverClock`]), link sequence checks and the ring-fault latch.
//!
//! Cycle flow of a member that is not the synchronizing master: [`MemberCore::on_frame`]
//! returns the frames to forward and, when a sync packet arrived, the cycle to run; the caller
//! sends the frames first, then runs the tick ([`MemberCore::tick_app`] = ring check + app).
//! When no sync packet comes, [`MemberCore::on_holdover`] says which cycle to run. The
//! synchronizing master calls [`MemberCore::start_cycle`] (send, then tick), and
//! [`CoreEvents::cycle_complete`] tells it when its sync packet came back.

use crate::check::{CheckFault, RingCheck, STATION_DEFAULTS};
use crate::control::{MemberKind, MemberStatus};
use crate::fault::{FaultLayer, FaultSpec, Outgoing, Sent};
use crate::frame::Frame;
use crate::holdover::HoldoverClock;
use crate::member::RingMember;
use crate::packet::{Packet, PacketError, PACKET_LEN};
use crate::settings::RingSettings;
use crate::status::{ErrorClass, RingStatus};

/// [`CoreConfig::check_after_lock`]: servo cycles a member must have run locked, in a row, before
/// its ring check starts (the links of a starting cluster settle).
pub const ARM_AFTER_LOCKED: u32 = 64;

/// Synchronizing master: how many cycles old the latest returned sync packet may be for the
/// ring to count as locked.
pub const LOCK_WINDOW: u64 = 8;

/// The card or station logic run once per servo cycle, after forwarding.
pub trait RingApp {
    /// Run the tick of ring cycle `cycle` at (ring) time `time_ns`: read latched feedback
    /// from `regs`, compute, write the registers that go out next cycle. `ring_fault` is the
    /// member's latched ring fault.
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool);

    /// Asked once after every tick: does the application want the ring-fault latch reset
    /// (the card's `$$$`)? The latch clears only if the ring is healthy again.
    fn take_ring_reset(&mut self) -> bool {
        false
    }

    /// Called once before every tick (before the ring check): the application reads and
    /// changes its member's ring settings through `ring` (a card's I995/I996/I1001/I1004/
    /// I1005 are these settings). The default leaves them alone.
    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        let _ = ring;
    }

    /// Told before every tick what the member's ring check saw (stations keep their
    /// MI-variable error counters and localise breaks from it).
    fn on_check(&mut self, _report: &CheckReport) {}

    /// Extra fields for the member's status report, merged over the static ones.
    fn status_extra(&self) -> serde_json::Map<String, serde_json::Value> {
        serde_json::Map::new()
    }

    /// An application fault request ([`crate::control::FaultRequest::App`]): apply it and say
    /// what was done, or refuse it with a message naming the problem. The default refuses:
    /// the member has no application faults.
    fn app_fault(&mut self, fault: &serde_json::Value) -> Result<String, String> {
        let _ = fault;
        Err("this member takes no application faults".into())
    }

    /// `mcc fault clear`: remove every application fault (the send path's are cleared by the
    /// member core). The default has none.
    fn clear_app_faults(&mut self) {}
}

/// What the ring check saw in one servo cycle ([`RingApp::on_check`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CheckReport {
    /// The check ran this cycle (armed, and not still waiting for the first lock).
    pub checked: bool,
    /// The I995-style status bits it read and cleared (errors in bits 0-3, sync in bit 6).
    pub status: u32,
    /// A fault declared this cycle.
    pub fault: Option<CheckFault>,
    /// Checks with a byte violation in the period of the latest fault.
    pub fault_byte_violations: u32,
    /// The ring-fault latch after this cycle's check.
    pub ring_fault: bool,
    /// The last completed check period passed (or nothing checks).
    pub healthy: bool,
}

impl<T: RingApp + ?Sized> RingApp for Box<T> {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        (**self).tick(cycle, time_ns, regs, ring_fault);
    }

    fn take_ring_reset(&mut self) -> bool {
        (**self).take_ring_reset()
    }

    fn on_check(&mut self, report: &CheckReport) {
        (**self).on_check(report);
    }

    fn status_extra(&self) -> serde_json::Map<String, serde_json::Value> {
        (**self).status_extra()
    }

    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        (**self).sync_ring(ring);
    }

    fn app_fault(&mut self, fault: &serde_json::Value) -> Result<String, String> {
        (**self).app_fault(fault)
    }

    fn clear_app_faults(&mut self) {
        (**self).clear_app_faults();
    }
}

/// The part of a member core its application may read and change: the I995/I996 settings,
/// the ring check's parameters, and the I995 status bits latched since the check last read
/// them. The one place each of these settings lives; the application mirrors them.
#[derive(Debug)]
pub struct RingControl<'a> {
    core: &'a mut MemberCore,
}

impl RingControl<'_> {
    /// I995 (configuration bits) and I996.
    pub fn settings(&self) -> RingSettings {
        self.core.member.settings()
    }

    /// Change I995/I996 (routing, sync node, master number) from the next frame on.
    pub fn set_settings(&mut self, settings: RingSettings) {
        self.core.set_settings(settings);
    }

    /// The ring check (I1001 period, I1004 error limit, I1005 sync minimum, armed or not).
    pub fn check(&self) -> &RingCheck {
        &self.core.check
    }

    /// The ring check, to change its parameters ([`RingCheck::set_period`], …) or replace it
    /// (a card reset re-arms it from I1001 > 0).
    pub fn check_mut(&mut self) -> &mut RingCheck {
        &mut self.core.check
    }

    /// I995 status bits (0-3 errors, 6 sync received) latched since the check last read them
    /// (not cleared: the check reads them once per RTI).
    pub fn status_bits(&self) -> u32 {
        self.core.status.peek()
    }
}

/// How a member core is set up.
#[derive(Clone, Debug)]
pub struct CoreConfig {
    /// Member name (`card0`, `station1`, ...).
    pub name: String,
    /// Card or station.
    pub kind: MemberKind,
    /// Position in the ring (0-based); used as the frame sender id.
    pub position: u16,
    /// Position of the upstream neighbour; frames from anyone else are rejected. None = any.
    pub upstream: Option<u16>,
    /// I995/I996.
    pub settings: RingSettings,
    /// The ring check (card: [`RingCheck::card`], station: [`RingCheck::station`]).
    pub check: RingCheck,
    /// Nominal ring cycle period in ns (holdover clock).
    pub period_ns: u64,
    /// How late a sync packet may be before the holdover clock runs a cycle on its own; `None`
    /// = half a period. Paced and lockstep: the frozen-member wait (a member only runs on its
    /// own clock once its upstream has stopped answering or is known dead).
    pub holdover_grace_ns: Option<u64>,
    /// First link sequence number minus one: give a restarted process a larger base (e.g. a
    /// wall-clock ns reading) so its downstream neighbour does not reject it as stale.
    pub seq_base: u64,
    /// Start the ring check only once the member has run [`ARM_AFTER_LOCKED`] servo cycles in a
    /// row locked to the ring (processes joining a ring whose links are still coming up); a ring
    /// that never locks is reported as not locked rather than as a fault. The sync-node
    /// activation rule applies at once.
    pub check_after_lock: bool,
    /// Timing anomalies tolerated before they count as receive errors: a data underrun is
    /// recorded after more than this many consecutive servo cycles without any frame (or
    /// frames without this master's own packets), and a frame arriving before the previous one
    /// was consumed counts as an overrun only when this is 1. Lockstep: 1 (the ring waits, so
    /// a gap is a real break); realtime on a general-purpose OS: more, so scheduling hiccups
    /// show as holdover and late cycles instead of killing the motors.
    pub timing_slack: u32,
    /// Master number of the synchronizing master: only its sync-node packet clocks this
    /// member (other masters' node-15 packets carry their auxiliary channel). None = any
    /// sync-node packet whose address matches (I995/I996 alone).
    pub sync_source: Option<u8>,
}

impl CoreConfig {
    /// A config with the kind's default check (card: unarmed, I1001 = 0; station: the
    /// station defaults), any upstream accepted and sequence base 0.
    pub fn new(
        name: &str,
        kind: MemberKind,
        position: u16,
        settings: RingSettings,
        period_ns: u64,
    ) -> Self {
        let check = match kind {
            MemberKind::Card => RingCheck::card(0, 0, 0, 2),
            MemberKind::Station => RingCheck::with_params(STATION_DEFAULTS),
        };
        CoreConfig {
            name: name.to_string(),
            kind,
            position,
            upstream: None,
            settings,
            check,
            period_ns,
            holdover_grace_ns: None,
            seq_base: 0,
            check_after_lock: false,
            timing_slack: 1,
            sync_source: None,
        }
    }
}

/// What one received frame produced.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CoreEvents {
    /// Frames to put on the link now (after the fault layer).
    pub outgoing: Vec<Outgoing>,
    /// A sync packet for a new cycle arrived: run this cycle's tick (after sending).
    pub sync: Option<u64>,
    /// A frame of a new cycle arrived without a sync packet (dropped, or a dark frame): run
    /// this cycle's tick unlocked (after sending). The ring keeps its cadence; the ring check
    /// counts the missing sync packets and the errors.
    pub unlocked: Option<u64>,
    /// Synchronizing master: its sync packet for this cycle came back.
    pub cycle_complete: Option<u64>,
    /// Synchronizing master: a frame of this ring cycle came back around (with or without its
    /// sync packet, light or dark): the cycle has gone round the ring.
    pub returned: Option<u64>,
    /// When the synchronizing master started the frame's ring cycle (see `Frame::origin_ns`).
    pub origin_ns: u64,
    /// The frame was rejected before packet parsing (counted in `bad_frames`): why.
    pub rejected: Option<String>,
    /// Receive errors found in the frame's packets.
    pub errors: Vec<ErrorClass>,
}

/// One ring member's pure core.
#[derive(Debug)]
pub struct MemberCore {
    name: String,
    kind: MemberKind,
    position: u16,
    upstream: Option<u16>,
    member: RingMember,
    status: RingStatus,
    check: RingCheck,
    faults: FaultLayer,
    holdover: HoldoverClock,
    tx_seq: u64,
    last_rx_seq: Option<u64>,
    last_rx_cycle: Option<u64>,
    rx_frames: u64,
    rx_packets: u64,
    sync_count: u64,
    cycle: u64,
    last_tick: Option<u64>,
    awaiting: Option<u64>,
    /// Synchronizing master: latest cycle whose sync packet came back.
    last_return: Option<u64>,
    locked: bool,
    /// A frame arrived since the last servo tick.
    rx_since_tick: bool,
    /// Consecutive servo ticks without any frame from upstream.
    silent_ticks: u32,
    /// Ring cycle of the frame into which this master last put command packets.
    sent_cycle: Option<u64>,
    /// This master's own packets have come back at least once (the path around works).
    own_seen: bool,
    /// Consecutive frames without this master's own packets.
    own_missing: u32,
    /// The member has been phase-locked at least once.
    ever_locked: bool,
    /// [`CoreConfig::check_after_lock`].
    check_after_lock: bool,
    /// Consecutive servo cycles run while locked.
    locked_streak: u32,
    /// [`CoreConfig::timing_slack`].
    timing_slack: u32,
    /// The link into this member carries no light (dark frames, or the upstream member is
    /// known dead): a byte violation every cycle.
    dark: bool,
    /// First cycle run with a dark input.
    dark_since: Option<u64>,
    /// The last dark spell that ended: first and last cycle without light.
    last_dark: Option<(u64, u64)>,
    /// Latest cycle in which the link into this member delivered bad data.
    link_error_cycle: Option<u64>,
    ring_fault: bool,
    ring_fault_count: u64,
    ring_fault_cycle: Option<u64>,
    /// `dark_since` when the fault latched (see `MemberStatus::ring_fault_dark_since`).
    ring_fault_dark_since: Option<u64>,
    last_fault: Option<CheckFault>,
    holdover_cycles: u64,
    late_cycles: u64,
    /// The ring check read the status bits in the latest servo cycle.
    checked_now: bool,
}

impl MemberCore {
    /// A member core from its config.
    pub fn new(cfg: CoreConfig) -> Self {
        let mut member = RingMember::new(cfg.settings);
        member.set_sync_source(cfg.sync_source);
        MemberCore {
            faults: FaultLayer::new(cfg.settings.sync_node()),
            member,
            name: cfg.name,
            kind: cfg.kind,
            position: cfg.position,
            upstream: cfg.upstream,
            status: RingStatus::new(),
            check: cfg.check,
            holdover: match cfg.holdover_grace_ns {
                Some(g) => HoldoverClock::with_grace(cfg.period_ns, g),
                None => HoldoverClock::new(cfg.period_ns),
            },
            tx_seq: cfg.seq_base,
            last_rx_seq: None,
            last_rx_cycle: None,
            rx_frames: 0,
            rx_packets: 0,
            sync_count: 0,
            cycle: 0,
            last_tick: None,
            awaiting: None,
            last_return: None,
            locked: false,
            rx_since_tick: false,
            silent_ticks: 0,
            sent_cycle: None,
            own_seen: false,
            own_missing: 0,
            ever_locked: false,
            check_after_lock: cfg.check_after_lock,
            locked_streak: 0,
            timing_slack: cfg.timing_slack.max(1),
            dark: false,
            dark_since: None,
            last_dark: None,
            link_error_cycle: None,
            ring_fault: false,
            ring_fault_count: 0,
            ring_fault_cycle: None,
            ring_fault_dark_since: None,
            last_fault: None,
            holdover_cycles: 0,
            late_cycles: 0,
            checked_now: false,
        }
    }

    /// Member name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Ring position.
    pub fn position(&self) -> u16 {
        self.position
    }

    /// Is this the synchronizing master?
    pub fn is_sync_master(&self) -> bool {
        self.member.settings().is_sync_master()
    }

    /// Routing state and node registers.
    pub fn member(&self) -> &RingMember {
        &self.member
    }

    /// Routing state and node registers, mutable.
    pub fn member_mut(&mut self) -> &mut RingMember {
        &mut self.member
    }

    /// Change I995/I996 at run time.
    pub fn set_settings(&mut self, settings: RingSettings) {
        self.member.set_settings(settings);
        self.faults.set_sync_node(settings.sync_node());
    }

    /// The I995 status latch (a host I995 read goes through `read_and_clear`).
    pub fn ring_status_mut(&mut self) -> &mut RingStatus {
        &mut self.status
    }

    /// The ring check.
    pub fn check(&self) -> &RingCheck {
        &self.check
    }

    /// The ring check, mutable (I1001/I1004/I1005 changes, re-arm on `$$$`).
    pub fn check_mut(&mut self) -> &mut RingCheck {
        &mut self.check
    }

    /// Inject a fault on this member's send path.
    pub fn inject_fault(&mut self, spec: FaultSpec) -> Result<(), crate::fault::FaultError> {
        self.faults.inject(spec)
    }

    /// Remove every injected fault.
    pub fn clear_faults(&mut self) {
        self.faults.clear();
    }

    /// Latest ring cycle known.
    pub fn cycle(&self) -> u64 {
        self.cycle
    }

    /// Ring fault latched.
    pub fn ring_fault(&self) -> bool {
        self.ring_fault
    }

    /// Why the latest ring fault was declared.
    pub fn last_fault(&self) -> Option<CheckFault> {
        self.last_fault
    }

    /// Whole packets received from upstream so far (a MACRO cycle carries one per node
    /// address: more in one cycle means copies passed on beside each other).
    pub fn rx_packets(&self) -> u64 {
        self.rx_packets
    }

    /// Ring cycle of the last frame received from upstream.
    pub fn last_rx_cycle(&self) -> Option<u64> {
        self.last_rx_cycle
    }

    /// Realtime runtime: a cycle started late (real-time interrupt warning).
    pub fn note_late(&mut self) {
        self.late_cycles += 1;
    }

    /// Runtime: a frame arrived while the previous one was still waiting (receive backlog).
    pub fn note_overrun(&mut self) {
        self.status.record(ErrorClass::Overrun);
    }

    fn next_seq(&mut self) -> u64 {
        self.tx_seq = self.tx_seq.wrapping_add(1);
        self.tx_seq
    }

    /// Stamp the link sequence numbers (in sending order) and encode.
    fn emit(&mut self, sent: Vec<Sent>) -> Vec<Outgoing> {
        sent.into_iter()
            .map(|mut s| {
                s.frame.seq = self.next_seq();
                Outgoing {
                    frame_bytes: s.frame.encode(),
                    delay_us: s.delay_us,
                }
            })
            .collect()
    }

    /// Synchronizing master: the latest cycle whose own sync packet came back round the ring.
    pub fn last_sync_return(&self) -> Option<u64> {
        self.last_return
    }

    /// The link into this member is dark (loss of light).
    pub fn is_dark(&self) -> bool {
        self.dark
    }

    /// Synchronizing master: start ring cycle `cycle` — the frame with the sync packet, the
    /// packets held from last cycle, and one command packet per activated node. The caller
    /// sends it, then runs the tick. Returns nothing on a member that is not the sync master.
    pub fn start_cycle(&mut self, cycle: u64, now_ns: u64) -> Vec<Outgoing> {
        if !self.is_sync_master() {
            return Vec::new();
        }
        // Locked while sync packets keep coming back; in realtime a ring longer than one period
        // returns each cycle's sync packet during a later cycle, which is still locked.
        self.locked = self
            .last_return
            .is_some_and(|r| cycle.saturating_sub(r) <= LOCK_WINDOW);
        self.awaiting = Some(cycle);
        self.cycle = cycle;
        self.last_tick = Some(cycle);
        let mut packets = vec![self.member.sync_packet(cycle)];
        packets.extend(self.member.take_held());
        packets.extend(self.member.command_packets(cycle));
        let frame = Frame::with_packets(self.position, 0, now_ns, cycle, &packets);
        let sent = self.faults.on_send(cycle, frame);
        self.emit(sent)
    }

    fn reject(&mut self, why: String) -> CoreEvents {
        self.status.record_bad_frame();
        CoreEvents {
            rejected: Some(why),
            ..Default::default()
        }
    }

    /// A frame arrived from upstream at `now_ns`.
    pub fn on_frame(&mut self, bytes: &[u8], now_ns: u64) -> CoreEvents {
        let frame = match Frame::decode(bytes) {
            Ok(f) => f,
            Err(e) => return self.reject(e.to_string()),
        };
        if let Some(up) = self.upstream.filter(|up| *up != frame.sender) {
            return self.reject(format!(
                "frame from ring position {}, upstream is {up}",
                frame.sender
            ));
        }
        if let Some(last) = self.last_rx_seq.filter(|last| frame.seq <= *last) {
            return self.reject(format!(
                "stale or duplicate frame: sequence {} after {last}",
                frame.seq
            ));
        }
        self.last_rx_seq = Some(frame.seq);
        self.rx_frames += 1;
        self.process(frame, now_ns)
    }

    /// Loss of light on this member's input for ring cycle `cycle` (its upstream member is
    /// known dead, or stopped answering): what a dark frame of that cycle would do — a byte
    /// violation, a dark frame forwarded (or, on the synchronizing master, the cycle counted
    /// as returned). The caller runs the tick of a cycle it got from [`Self::on_holdover`] or
    /// started itself; a newer cycle is run unlocked.
    pub fn dark_input(&mut self, cycle: u64, now_ns: u64) -> CoreEvents {
        let up = self.upstream.unwrap_or(self.position);
        self.process(Frame::dark(up, 0, now_ns, cycle, 0), now_ns)
    }

    /// A frame that passed the link checks (or a synthesized dark one).
    fn process(&mut self, frame: Frame, now_ns: u64) -> CoreEvents {
        let mut ev = CoreEvents {
            origin_ns: frame.origin_ns,
            ..Default::default()
        };
        self.rx_since_tick = true;
        // Stepped clocks: data out of its cycle's order is an overrun — a frame no newer than
        // the last one received (a delayed frame released late, a repeat). Frames of new
        // cycles arriving faster than this member ticks (a sync master on its own clock
        // meeting a descheduled member) are no ring error: only ring content is. A frame
        // after loss of light may renumber the ring (a restarted sync master).
        if self.timing_slack <= 1
            && !frame.is_dark()
            && !self.dark
            && self.last_rx_cycle.is_some_and(|l| frame.cycle <= l)
        {
            ev.errors.push(ErrorClass::Overrun);
        }
        if self.is_sync_master() {
            ev.returned = Some(frame.cycle);
        }
        if frame.is_dark() {
            return self.on_dark(&frame, now_ns, ev);
        }
        self.last_rx_cycle = Some(frame.cycle);
        // Light again: a newly started sync master's numbering may be adopted (see on_sync).
        let was_dark = std::mem::take(&mut self.dark);
        if let Some(from) = self.dark_since.take() {
            self.last_dark = Some((from, frame.cycle.saturating_sub(1).max(from)));
        }

        let intact = usize::from(frame.declared) * PACKET_LEN;
        let whole = usize::from(frame.declared).min(frame.packets.len() / PACKET_LEN);
        self.rx_packets += whole as u64;
        let mut forwards = Vec::with_capacity(whole);
        let mut own_returned = 0usize;
        let mut sync = None;
        for chunk in frame.packets.chunks_exact(PACKET_LEN).take(whole) {
            let p = match Packet::decode(chunk) {
                Ok(p) => p,
                Err(PacketError::ByteViolation(_)) => {
                    ev.errors.push(ErrorClass::ByteViolation);
                    continue;
                }
                Err(PacketError::Checksum { .. }) => {
                    ev.errors.push(ErrorClass::Checksum);
                    continue;
                }
                Err(PacketError::Truncated(_)) => {
                    ev.errors.push(ErrorClass::Underrun);
                    continue;
                }
            };
            let own = self.member.is_master()
                && p.master & 0x0F == self.member.settings().master_number()
                && !(self.is_sync_master() && p.node & 0x0F == self.member.settings().sync_node());
            let r = self.member.route(p);
            if own && r.forward.is_none() {
                own_returned += 1;
            }
            if let Some(c) = r.own_sync_return {
                self.status.set_sync_received();
                self.sync_count += 1;
                self.last_return = self.last_return.max(Some(c));
                if self.cycle.saturating_sub(c) <= LOCK_WINDOW {
                    self.locked = true;
                }
                if self.awaiting == Some(c) {
                    self.awaiting = None;
                    ev.cycle_complete = Some(c);
                }
            }
            if let Some(c) = r.sync {
                self.status.set_sync_received();
                self.sync_count += 1;
                sync = Some(c);
            }
            forwards.extend(r.forward);
        }
        let mut own_missing_error = 0;
        // A master's command packets of the previous cycle come back in this cycle's frame; a
        // frame without them is missing its packets (data underrun): the ring is broken
        // somewhere downstream of this master.
        // (From the second frame in a row without them: a lockstep cycle the sync master had to
        // time out shifts the packets by one frame once, which is not a broken ring.)
        if own_returned > 0 {
            self.own_seen = true;
            self.own_missing = 0;
        } else if !self.is_sync_master()
            && self.own_seen
            && self.sent_cycle.is_some_and(|c| c + 1 == frame.cycle)
        {
            self.own_missing = self.own_missing.saturating_add(1);
            if self.own_missing > self.timing_slack {
                ev.errors.push(ErrorClass::Underrun);
                own_missing_error = 1;
            }
        }
        if frame.packets.len() < intact {
            ev.errors.push(ErrorClass::Underrun);
        } else if frame.packets.len() > intact {
            ev.errors.push(ErrorClass::Overrun);
        }
        // Everything but this master's own packets missing is wrong with the link into it.
        if ev.errors.len() > own_missing_error {
            self.link_error_cycle = Some(frame.cycle.max(self.cycle));
        }
        for e in &ev.errors {
            self.status.record(*e);
        }

        if let Some(c) = sync {
            self.on_sync(c, now_ns, was_dark, &mut ev);
        } else {
            self.on_cycle_without_sync(frame.cycle, now_ns, &mut ev);
        }
        if self.is_sync_master() {
            // The cycle ends here: other masters' packets go out again next cycle.
            self.member.hold(forwards);
            return ev;
        }
        let commands = self.member.command_packets(frame.cycle);
        self.sent_cycle = (!commands.is_empty()).then_some(frame.cycle);
        forwards.extend(commands);
        let mut out = Frame::with_packets(self.position, 0, now_ns, frame.cycle, &forwards);
        out.origin_ns = frame.origin_ns;
        let sent = self.faults.on_send(self.cycle, out);
        ev.outgoing = self.emit(sent);
        ev
    }

    /// A dark frame: a byte violation (the receiver reads zeros), the cycle run unlocked, and
    /// darkness passed on (a member that receives no light sends none).
    fn on_dark(&mut self, frame: &Frame, now_ns: u64, mut ev: CoreEvents) -> CoreEvents {
        ev.errors.push(ErrorClass::ByteViolation);
        self.status.record(ErrorClass::ByteViolation);
        self.link_error_cycle = Some(frame.cycle.max(self.cycle));
        if !self.dark {
            self.dark = true;
            self.dark_since = Some(frame.cycle);
        }
        if self.is_sync_master() {
            return ev;
        }
        self.on_cycle_without_sync(frame.cycle, now_ns, &mut ev);
        let dark = Frame::dark(self.position, 0, now_ns, frame.cycle, frame.origin_ns);
        let sent = self.faults.on_send(self.cycle, dark);
        ev.outgoing = self.emit(sent);
        ev
    }

    /// A frame of ring cycle `c` without a sync packet: a follower runs a newer cycle
    /// unlocked (the ring keeps its cadence; the check counts the missing sync packets).
    fn on_cycle_without_sync(&mut self, c: u64, now_ns: u64, ev: &mut CoreEvents) {
        if self.is_sync_master() || !self.member.settings().phase_lock() {
            return;
        }
        if self.last_tick.is_some_and(|t| c <= t) {
            return;
        }
        self.locked = false;
        self.holdover_cycles += 1;
        self.cycle = c;
        self.last_tick = Some(c);
        self.holdover.on_sync(c, now_ns);
        ev.unlocked = Some(c);
    }

    fn on_sync(&mut self, c: u64, now_ns: u64, was_dark: bool, ev: &mut CoreEvents) {
        if !self.member.settings().phase_lock() {
            // Not phase-locked (I995 bit 7 clear): run on the own clock, started from the
            // first sync packet's cycle number.
            if self.holdover.last_cycle().is_none() {
                self.holdover.start(
                    c.saturating_sub(1),
                    now_ns.saturating_sub(self.holdover.period_ns()),
                );
            }
            return;
        }
        if self.last_tick == Some(c) {
            // The holdover clock ran this cycle just before its sync packet arrived: not run
            // again, but the clock re-aligns to the packet so the next one is on time.
            self.holdover.on_sync(c, now_ns);
            self.locked = true;
            return;
        }
        // A delayed sync packet of an old cycle is latched, not run — unless the input was
        // dark until now: after loss of light the member locks to whatever numbering the
        // (possibly restarted) synchronizing master sends.
        if self.last_tick.is_some_and(|t| c < t) && !was_dark {
            return;
        }
        self.cycle = c;
        self.last_tick = Some(c);
        self.locked = true;
        self.holdover.on_sync(c, now_ns);
        ev.sync = Some(c);
    }

    /// No sync packet in time: the cycle to run now on the holdover clock, if one is due.
    /// Never for the synchronizing master (its own cycles come from `start_cycle`).
    pub fn on_holdover(&mut self, now_ns: u64) -> Option<u64> {
        if self.is_sync_master() {
            return None;
        }
        let c = self.holdover.poll(now_ns)?;
        if self.last_tick.is_some_and(|t| c <= t) {
            return None;
        }
        if self.member.settings().phase_lock() {
            self.locked = false;
            self.holdover_cycles += 1;
        }
        self.cycle = c;
        self.last_tick = Some(c);
        Some(c)
    }

    /// The upstream member is known dead: run the holdover clock now rather than after its
    /// grace (nothing will come).
    pub fn expedite_holdover(&mut self, now_ns: u64) {
        if !self.is_sync_master() {
            self.holdover.expedite(now_ns);
        }
    }

    /// When the holdover clock next wants to run a cycle (for the runtime's timer).
    pub fn holdover_due_ns(&self) -> Option<u64> {
        if self.is_sync_master() {
            None
        } else {
            self.holdover.due_ns()
        }
    }

    /// Frames the fault layer releases without a new frame to send (delayed frames).
    pub fn poll_faults(&mut self) -> Vec<Outgoing> {
        let sent = self.faults.poll(self.cycle);
        self.emit(sent)
    }

    /// Run the ring check for one servo cycle; latches the ring fault.
    pub fn run_check(&mut self) -> Option<CheckFault> {
        self.checked_now = false;
        self.locked_streak = if self.locked {
            self.locked_streak.saturating_add(1)
        } else {
            0
        };
        self.ever_locked |= !self.check_after_lock || self.locked_streak >= ARM_AFTER_LOCKED;
        let settings = self.member.settings();
        let node = settings.sync_node();
        let fault = if self.kind == MemberKind::Card
            && self.check.armed()
            && !settings.is_sync_master()
            && !settings.node_active(node)
        {
            CheckFault::SyncNodeInactive { node }
        } else if self.check_after_lock && !self.ever_locked {
            // Still coming up: nothing to check against yet (a ring that never locks is
            // reported as not locked, not as a ring fault). Consume the start-up status bits.
            self.status.read_and_clear();
            self.rx_since_tick = false;
            return None;
        } else {
            // No data at all from upstream for a second servo cycle in a row: data underrun
            // (the link into this member is dead). One late frame alone is not an error.
            if self.rx_since_tick {
                self.silent_ticks = 0;
            } else if self.last_rx_cycle.is_some() {
                self.silent_ticks = self.silent_ticks.saturating_add(1);
                if self.silent_ticks > self.timing_slack {
                    // No light at all: a MACRO station's receiver sees byte violations (what
                    // its break localisation counts); a card records a data underrun.
                    self.status.record(match self.kind {
                        MemberKind::Station => ErrorClass::ByteViolation,
                        MemberKind::Card => ErrorClass::Underrun,
                    });
                    self.link_error_cycle = Some(self.cycle);
                }
            }
            self.rx_since_tick = false;
            let f = self.check.on_servo_cycle(&mut self.status);
            self.checked_now = self.check.just_checked();
            f?
        };
        if !self.ring_fault {
            // The cycle at which the fault latched (later failing checks keep the latch).
            self.ring_fault = true;
            self.ring_fault_count += 1;
            self.ring_fault_cycle = Some(self.cycle);
            self.ring_fault_dark_since = if self.dark { self.dark_since } else { None };
        }
        self.last_fault = Some(fault);
        Some(fault)
    }

    /// One servo cycle: ring check, then the app's tick with the (possibly new) fault latch.
    pub fn tick_app(
        &mut self,
        app: &mut dyn RingApp,
        cycle: u64,
        time_ns: u64,
    ) -> Option<CheckFault> {
        app.sync_ring(&mut RingControl { core: self });
        let fault = self.run_check();
        app.on_check(&CheckReport {
            checked: self.checked_now,
            status: if self.checked_now {
                self.check.last_status()
            } else {
                0
            },
            fault,
            fault_byte_violations: self.check.fault_byte_violations(),
            ring_fault: self.ring_fault,
            healthy: self.healthy(),
        });
        app.tick(cycle, time_ns, &mut self.member, self.ring_fault);
        if app.take_ring_reset() {
            self.reset();
        }
        fault
    }

    /// The ring is healthy: the last completed check period passed (or nothing checks it).
    pub fn healthy(&self) -> bool {
        !self.check.armed() || self.check.last_period_ok() == Some(true)
    }

    /// `$$$`: clear the ring-fault latch if the ring is healthy again. Returns whether the
    /// latch is clear afterwards.
    pub fn reset(&mut self) -> bool {
        if self.ring_fault && self.healthy() {
            self.ring_fault = false;
            self.ring_fault_cycle = None;
            self.ring_fault_dark_since = None;
            self.last_fault = None;
        }
        !self.ring_fault
    }

    /// Injected faults still active.
    pub fn faults(&self) -> Vec<crate::fault::ActiveFault> {
        self.faults.active()
    }

    /// The ring fields of the member's status report (pid and extras are the runtime's).
    pub fn status(&self) -> MemberStatus {
        MemberStatus {
            name: self.name.clone(),
            kind: Some(self.kind),
            pid: 0,
            ring_position: usize::from(self.position),
            sync_master: self.is_sync_master(),
            // A member that arms its check after lock reports locked only once the check runs:
            // `mcc up` (and anyone waiting for a locked ring) then knows that a fault injected
            // from now on is detected, however soon it comes.
            locked: self.locked && (self.ever_locked || !self.check_after_lock),
            cycle: self.cycle,
            sync_count: self.sync_count,
            rx_frames: self.rx_frames,
            last_rx_cycle: self.last_rx_cycle,
            errors: self.status.counters(),
            ring_fault: self.ring_fault,
            ring_fault_count: self.ring_fault_count,
            ring_fault_cycle: self.ring_fault_cycle,
            holdover_cycles: self.holdover_cycles,
            late_cycles: self.late_cycles,
            dark: self.dark,
            dark_since_cycle: self.dark_since,
            last_dark_spell: self.last_dark,
            ring_fault_dark_since: self.ring_fault_dark_since,
            link_error_cycle: self.link_error_cycle,
            fault_reason: self
                .ring_fault
                .then(|| self.last_fault.map(|f| f.to_string()))
                .flatten(),
            faults: self.faults.active(),
            clock: None,
            sched: None,
            host_id: None,
            link_matched: None,
            cpu_percent: None,
            extra: serde_json::Map::new(),
        }
    }
}

#[cfg(test)]
#[path = "core_tests.rs"]
mod tests;
