//! Unit tests of [`crate::core::MemberCore`]: link bookkeeping, error classification, ticks.

use proptest::prelude::*;

use crate::check::{CheckFault, RingCheck};
use crate::control::MemberKind;
use crate::core::{CoreConfig, MemberCore};
use crate::frame::{Frame, FORMAT_VERSION};
use crate::packet::{NodeRegs, Packet};
use crate::settings::RingSettings;
use crate::status::{STATUS_OVERRUN, STATUS_SYNC_RECEIVED, STATUS_UNDERRUN};

const P: u64 = 1_000_000;

/// A slave station at position 1 (upstream 0) with node 1 active, master 0, sync node 15.
fn slave(i995: u32) -> MemberCore {
    let mut cfg = CoreConfig::new(
        "s",
        MemberKind::Station,
        1,
        RingSettings::new(i995, 0x0F_8002),
        P,
    );
    cfg.upstream = Some(0);
    cfg.check = RingCheck::card(0, 0, 0, 0); // not checking
    MemberCore::new(cfg)
}

fn frame(seq: u64, cycle: u64, packets: &[Packet]) -> Frame {
    Frame::with_packets(0, seq, 0, cycle, packets)
}

fn cmd(r0: u32) -> Packet {
    Packet::new(
        0,
        1,
        NodeRegs {
            r0,
            ..Default::default()
        },
    )
}

#[test]
fn slave_forwards_substitutes_and_ticks_on_sync() {
    let mut s = slave(0x80);
    s.member_mut().write_regs_mut(1).r0 = 77;
    let ev = s.on_frame(&frame(1, 5, &[Packet::sync(0, 15, 5), cmd(3)]).encode(), 10);
    assert_eq!(ev.sync, Some(5));
    assert_eq!(ev.rejected, None);
    assert_eq!(ev.outgoing.len(), 1);
    let out = Frame::decode(&ev.outgoing[0].frame_bytes).unwrap();
    assert_eq!(
        (out.sender, out.seq, out.cycle, out.declared, out.sent_ns),
        (1, 1, 5, 2, 10)
    );
    assert_eq!(out.packets[..12], Packet::sync(0, 15, 5).encode());
    assert_eq!(Packet::decode(&out.packets[12..]).unwrap(), cmd(77));
    assert_eq!(s.member().read_regs(1).r0, 3);
    assert_eq!(s.cycle(), 5);
    assert_eq!(s.ring_status_mut().read_and_clear(), STATUS_SYNC_RECEIVED);
}

#[test]
fn bad_frames_rejected_and_counted() {
    let mut s = slave(0x80);
    let good = frame(5, 1, &[cmd(1)]);
    assert!(s.on_frame(&good.encode(), 0).rejected.is_none());
    // duplicate, then older
    let ev = s.on_frame(&good.encode(), 0);
    assert_eq!(
        ev.rejected.as_deref(),
        Some("stale or duplicate frame: sequence 5 after 5")
    );
    assert!(ev.outgoing.is_empty());
    assert!(s.on_frame(&frame(4, 1, &[]).encode(), 0).rejected.is_some());
    // wrong sender
    let mut f = frame(9, 1, &[]);
    f.sender = 3;
    assert_eq!(
        s.on_frame(&f.encode(), 0).rejected.as_deref(),
        Some("frame from ring position 3, upstream is 0")
    );
    // wrong version, garbage
    f = frame(10, 1, &[]);
    f.version = FORMAT_VERSION + 1;
    assert!(s
        .on_frame(&f.encode(), 0)
        .rejected
        .unwrap()
        .contains("version 3"));
    assert!(s
        .on_frame(&[0xFF; 3], 0)
        .rejected
        .unwrap()
        .starts_with("malformed frame"));
    let st = s.status();
    assert_eq!(st.errors.bad_frames, 5);
    assert_eq!(st.rx_frames, 1);
    assert_eq!(
        s.ring_status_mut().read_and_clear(),
        0,
        "bad frames latch no I995 bit"
    );
    // a rejected frame did not advance the sequence: 6 is still accepted
    assert!(s.on_frame(&frame(6, 2, &[]).encode(), 0).rejected.is_none());
}

#[test]
fn underrun_and_overrun_of_frame_bytes() {
    let mut s = slave(0x80);
    let mut f = frame(1, 1, &[cmd(1), cmd(2)]);
    f.declared = 3; // a packet missing
    let ev = s.on_frame(&f.encode(), 0);
    assert_eq!(ev.errors, vec![crate::status::ErrorClass::Underrun]);
    // both whole packets were still routed and forwarded
    assert_eq!(
        Frame::decode(&ev.outgoing[0].frame_bytes).unwrap().declared,
        2
    );
    s.run_check();
    let mut f = frame(2, 2, &[cmd(1)]);
    f.packets.extend_from_slice(&cmd(9).encode()); // beyond the declared packet
    let ev = s.on_frame(&f.encode(), 0);
    assert_eq!(ev.errors, vec![crate::status::ErrorClass::Overrun]);
    assert_eq!(
        Frame::decode(&ev.outgoing[0].frame_bytes).unwrap().declared,
        1
    );
    assert_eq!(
        s.ring_status_mut().read_and_clear(),
        STATUS_UNDERRUN | STATUS_OVERRUN
    );
}

/// A second frame of the same cycle (a delayed frame released late) is an overrun.
#[test]
fn frame_before_previous_consumed_is_overrun() {
    let mut s = slave(0x80);
    assert!(s.on_frame(&frame(1, 1, &[]).encode(), 0).errors.is_empty());
    let ev = s.on_frame(&frame(2, 1, &[]).encode(), 0);
    assert_eq!(ev.errors, vec![crate::status::ErrorClass::Overrun]);
    s.run_check();
    assert!(s.on_frame(&frame(3, 2, &[]).encode(), 0).errors.is_empty());
    assert_eq!(s.status().errors.overrun, 1);
}

#[test]
fn late_sync_is_not_run_twice_and_holdover_fills_gaps() {
    let mut s = slave(0x80);
    let sync = |s: &mut MemberCore, seq, c, now| {
        s.on_frame(&frame(seq, c, &[Packet::sync(0, 15, c)]).encode(), now)
            .sync
    };
    assert_eq!(sync(&mut s, 1, 3, 0), Some(3));
    assert_eq!(s.on_holdover(P), None);
    assert_eq!(s.on_holdover(P + P / 2), Some(4));
    // sync 4 arrives just after holdover ran cycle 4: not run again; the clock re-aligns.
    assert_eq!(sync(&mut s, 2, 4, 2 * P), None);
    assert_eq!(
        s.on_holdover(3 * P),
        None,
        "due at 3.5 P after re-alignment"
    );
    // a delayed sync packet of an older cycle is ignored
    assert_eq!(sync(&mut s, 3, 2, 3 * P), None);
    assert_eq!(sync(&mut s, 4, 5, 3 * P), Some(5));
    let st = s.status();
    assert_eq!(
        (st.sync_count, st.holdover_cycles, st.cycle, st.locked),
        (4, 1, 5, true)
    );
}

#[test]
fn without_phase_lock_the_own_clock_runs() {
    let mut s = slave(0x00);
    let ev = s.on_frame(&frame(1, 7, &[Packet::sync(0, 15, 7)]).encode(), 10 * P);
    assert_eq!(ev.sync, None);
    assert_eq!(s.on_holdover(10 * P + P / 2), Some(7));
    assert_eq!(s.on_holdover(11 * P + P / 2), Some(8));
}

#[test]
fn sync_master_cycle_and_hold() {
    let mut cfg = CoreConfig::new(
        "c",
        MemberKind::Card,
        0,
        RingSettings::new(0x30, 0x0F_0001),
        P,
    );
    cfg.check = RingCheck::card(4, 2, 2, 0);
    let mut m = MemberCore::new(cfg);
    m.member_mut().write_regs_mut(0).r0 = 11;
    let out = m.start_cycle(1, 0);
    let f = Frame::decode(&out[0].frame_bytes).unwrap();
    assert_eq!((f.sender, f.seq, f.cycle, f.declared), (0, 1, 1, 2));
    // back around with master 2's packet: held and re-sent after the next sync packet
    let other = Packet::new(
        2,
        3,
        NodeRegs {
            r0: 5,
            ..Default::default()
        },
    );
    let back = Frame::with_packets(
        0,
        1,
        0,
        1,
        &[
            Packet::sync(0, 15, 1),
            other,
            Packet::new(
                0,
                0,
                NodeRegs {
                    r0: 99,
                    ..Default::default()
                },
            ),
        ],
    );
    let ev = m.on_frame(&back.encode(), 1);
    assert_eq!((ev.cycle_complete, ev.sync), (Some(1), None));
    assert!(ev.outgoing.is_empty());
    assert_eq!(m.member().read_regs(0).r0, 99);
    let f = Frame::decode(&m.start_cycle(2, 2)[0].frame_bytes).unwrap();
    let p: Vec<Packet> = f
        .packets
        .chunks(12)
        .map(|c| Packet::decode(c).unwrap())
        .collect();
    assert_eq!(
        p,
        vec![
            Packet::sync(0, 15, 2),
            other,
            Packet::new(
                0,
                0,
                NodeRegs {
                    r0: 11,
                    ..Default::default()
                }
            )
        ]
    );
    assert!(m.status().locked && m.status().sync_master);
    // a slave core never starts a cycle
    assert!(slave(0x80).start_cycle(1, 0).is_empty());
}

#[test]
fn fault_latch_and_reset() {
    let mut cfg = CoreConfig::new(
        "c",
        MemberKind::Card,
        0,
        RingSettings::new(0x30, 0x0F_0001),
        P,
    );
    cfg.check = RingCheck::card(2, 2, 2, 0);
    let mut m = MemberCore::new(cfg);
    assert_eq!(m.run_check(), None);
    assert_eq!(
        m.run_check(),
        Some(CheckFault::MissingSyncs {
            syncs: 0,
            required: 2
        })
    );
    assert!(m.ring_fault() && !m.reset());
    // two good checks (own sync returned each cycle): healthy, reset clears
    for c in 1..=2 {
        m.start_cycle(c, 0);
        m.on_frame(
            &Frame::with_packets(0, c, 0, c, &[Packet::sync(0, 15, c)]).encode(),
            0,
        );
        assert_eq!(m.run_check(), None);
    }
    assert!(m.ring_fault());
    assert_eq!(m.status().ring_fault_cycle, Some(0));
    assert!(m.status().fault_reason.unwrap().contains("sync packets"));
    assert!(m.reset() && !m.ring_fault());
    assert_eq!(m.status().ring_fault_count, 1);
    // The reset forgets the latch's cycle and reason (the count stays).
    assert_eq!(m.status().ring_fault_cycle, None);
    assert_eq!(m.status().fault_reason, None);
}

#[test]
fn a_frame_without_its_sync_packet_still_runs_the_cycle_unlocked() {
    let mut s = slave(0x80);
    let ev = s.on_frame(&frame(1, 3, &[Packet::sync(0, 15, 3), cmd(1)]).encode(), 0);
    assert_eq!((ev.sync, ev.unlocked), (Some(3), None));
    // sync dropped upstream: the frame of cycle 4 still drives the tick, unlocked.
    let ev = s.on_frame(&frame(2, 4, &[cmd(2)]).encode(), P);
    assert_eq!((ev.sync, ev.unlocked), (None, Some(4)));
    assert_eq!(ev.outgoing.len(), 1, "forwarded");
    let st = s.status();
    assert!(
        !st.locked && st.cycle == 4 && st.holdover_cycles == 1,
        "{st:?}"
    );
    // An old frame does not tick again.
    let ev = s.on_frame(&frame(3, 4, &[cmd(2)]).encode(), P);
    assert_eq!((ev.sync, ev.unlocked), (None, None));
    assert_eq!(
        s.on_frame(&frame(4, 5, &[Packet::sync(0, 15, 5)]).encode(), P)
            .sync,
        Some(5)
    );
    assert!(s.status().locked);
}

#[test]
fn a_dark_frame_is_a_byte_violation_passed_on_dark() {
    let mut s = slave(0x80);
    s.member_mut().write_regs_mut(1).r0 = 9;
    s.on_frame(&frame(1, 3, &[Packet::sync(0, 15, 3), cmd(1)]).encode(), 0);
    s.run_check();
    s.ring_status_mut().read_and_clear();
    let ev = s.on_frame(&Frame::dark(0, 2, 0, 4, 0).encode(), P);
    assert_eq!(ev.errors, vec![crate::status::ErrorClass::ByteViolation]);
    assert_eq!((ev.sync, ev.unlocked), (None, Some(4)));
    // Darkness goes on: no light, no packets of this member either.
    let out = Frame::decode(&ev.outgoing[0].frame_bytes).unwrap();
    assert!(
        out.is_dark() && out.cycle == 4 && out.sender == 1,
        "{out:?}"
    );
    let st = s.status();
    assert!(st.dark && !st.locked, "{st:?}");
    assert_eq!(st.dark_since_cycle, Some(4));
    // last_rx_cycle is the last frame with light.
    assert_eq!(st.last_rx_cycle, Some(3));
    assert_eq!(st.errors.byte_violation, 1);
    // Light again.
    s.on_frame(&frame(3, 5, &[Packet::sync(0, 15, 5)]).encode(), 2 * P);
    let st = s.status();
    assert!(
        !st.dark && st.dark_since_cycle.is_none() && st.locked,
        "{st:?}"
    );
    // The spell is remembered once it is over.
    assert_eq!(st.last_dark_spell, Some((4, 4)));
}

#[test]
fn bad_data_on_the_input_link_is_dated_but_lost_own_packets_are_not() {
    // A master (card 1) downstream of the sync master: its command packets for node 1 come
    // back one cycle after it sent them.
    let mut cfg = CoreConfig::new(
        "c1",
        MemberKind::Card,
        1,
        RingSettings::new(0x8090, 0x1F_8002),
        P,
    );
    cfg.upstream = Some(0);
    let mut m = MemberCore::new(cfg);
    let own = Packet::new(1, 1, NodeRegs::default());
    let f = |seq, c, p: &[Packet]| frame(seq, c, p).encode();
    m.on_frame(&f(1, 1, &[Packet::sync(0, 15, 1)]), 0);
    m.run_check();
    m.on_frame(&f(2, 2, &[Packet::sync(0, 15, 2), own]), 0);
    m.run_check();
    assert_eq!(m.status().link_error_cycle, None);
    // Its own packets stop coming back: underruns, but nothing wrong with the link into it.
    for c in 3..6 {
        let ev = m.on_frame(&f(c, c, &[Packet::sync(0, 15, c)]), 0);
        m.run_check();
        if c > 3 {
            assert_eq!(ev.errors, vec![crate::status::ErrorClass::Underrun], "{c}");
        }
    }
    assert_eq!(m.status().link_error_cycle, None);
    // A corrupt packet on the link: dated with its cycle.
    let mut bad = frame(6, 6, &[Packet::sync(0, 15, 6), own]);
    bad.packets[23] ^= 0xFF;
    let ev = m.on_frame(&bad.encode(), 0);
    // (the corrupted packet was its own: still missing)
    assert_eq!(
        ev.errors,
        vec![
            crate::status::ErrorClass::Checksum,
            crate::status::ErrorClass::Underrun
        ]
    );
    assert_eq!(m.status().link_error_cycle, Some(6));
    m.run_check();
    // So is a dark frame.
    m.on_frame(&Frame::dark(0, 7, 0, 7, 0).encode(), 0);
    assert_eq!(m.status().link_error_cycle, Some(7));
}

#[test]
fn after_loss_of_light_a_new_sync_masters_count_is_taken() {
    let mut s = slave(0x80);
    let sync = |s: &mut MemberCore, seq, c| {
        s.on_frame(&frame(seq, c, &[Packet::sync(0, 15, c)]).encode(), 0)
            .sync
    };
    assert_eq!(sync(&mut s, 1, 5000), Some(5000));
    // While locked, an older sync packet is a delayed one: not run.
    assert_eq!(sync(&mut s, 2, 10), None);
    // The upstream died: loss of light on the holdover clock.
    let ev = s.dark_input(5001, P);
    assert!(Frame::decode(&ev.outgoing[0].frame_bytes)
        .unwrap()
        .is_dark());
    assert_eq!(ev.unlocked, Some(5001));
    assert!(s.status().dark);
    // A restarted sync master counts from 0: after the dark spell its count is taken.
    assert_eq!(sync(&mut s, 3, 0), Some(0));
    assert_eq!(sync(&mut s, 4, 1), Some(1));
    let st = s.status();
    assert!(st.locked && !st.dark && st.cycle == 1, "{st:?}");
}

#[test]
fn sync_master_sees_every_returned_frame_and_dark_input() {
    let mut cfg = CoreConfig::new(
        "c",
        MemberKind::Card,
        0,
        RingSettings::new(0x30, 0x0F_0001),
        P,
    );
    cfg.upstream = Some(2);
    let mut m = MemberCore::new(cfg);
    m.start_cycle(1, 0);
    // The frame came back without the sync packet (dropped): returned, not complete.
    let f = Frame::with_packets(2, 1, 0, 1, &[]);
    let ev = m.on_frame(&f.encode(), 0);
    assert_eq!((ev.returned, ev.cycle_complete), (Some(1), None));
    m.run_check();
    m.start_cycle(2, 0);
    let ev = m.on_frame(&Frame::dark(2, 2, 0, 2, 0).encode(), 0);
    assert_eq!(ev.returned, Some(2));
    assert_eq!(ev.errors, vec![crate::status::ErrorClass::ByteViolation]);
    m.run_check();
    m.start_cycle(3, 0);
    let ev = m.dark_input(3, 0);
    assert_eq!(ev.returned, Some(3));
    assert!(ev.outgoing.is_empty());
    assert!(m.status().dark && m.status().errors.byte_violation == 2);
}

proptest! {
    #[test]
    fn any_bytes_never_panic(b in proptest::collection::vec(any::<u8>(), 0..120)) {
        let mut s = slave(0x80);
        let _ = s.on_frame(&b, 0);
    }

    #[test]
    fn any_packet_bytes_never_panic(declared: u16, bytes in proptest::collection::vec(any::<u8>(), 0..120)) {
        let mut s = slave(0x80);
        let f = Frame { version: FORMAT_VERSION, sender: 0, seq: 1, sent_ns: 0, cycle: 0, origin_ns: 0, declared, packets: bytes };
        let ev = s.on_frame(&f.encode(), 0);
        prop_assert!(ev.rejected.is_none());
    }
}

#[test]
fn card_with_inactive_sync_node_faults_at_once() {
    // card master 1, sync node 15 not activated, check armed
    let mut cfg = CoreConfig::new(
        "c1",
        MemberKind::Card,
        1,
        RingSettings::new(0x8090, 0x1F_0002),
        P,
    );
    cfg.check = RingCheck::card(8, 2, 2, 0);
    let mut m = MemberCore::new(cfg);
    assert_eq!(
        m.run_check(),
        Some(CheckFault::SyncNodeInactive { node: 15 })
    );
    assert!(m.ring_fault());
    // activated: no fault on the first check
    let mut cfg = CoreConfig::new(
        "c1",
        MemberKind::Card,
        1,
        RingSettings::new(0x8090, 0x1F_8002),
        P,
    );
    cfg.check = RingCheck::card(8, 2, 2, 0);
    assert_eq!(MemberCore::new(cfg).run_check(), None);
}

#[test]
fn check_after_lock_waits_for_the_first_lock() {
    let make = |after_lock| {
        let mut cfg = CoreConfig::new(
            "c",
            MemberKind::Card,
            0,
            RingSettings::new(0x30, 0x0F_0001),
            P,
        );
        cfg.check = RingCheck::card(2, 2, 2, 0);
        cfg.check_after_lock = after_lock;
        MemberCore::new(cfg)
    };
    // Checked from the start: no sync packet in the first period is a fault.
    let mut m = make(false);
    assert_eq!(m.run_check(), None);
    assert!(m.run_check().is_some());
    // Checked after lock: nothing while the ring comes up ...
    let mut m = make(true);
    for _ in 0..10 {
        assert_eq!(m.run_check(), None);
    }
    assert!(!m.ring_fault());
    // ... then sync packets come back: locked; after ARM_AFTER_LOCKED locked cycles the check
    // runs, and from then on a lost ring faults.
    for c in 1..=u64::from(crate::core::ARM_AFTER_LOCKED) {
        m.start_cycle(c, 0);
        let ev = m.on_frame(
            &Frame::with_packets(0, c, 0, c, &[Packet::sync(0, 15, c)]).encode(),
            0,
        );
        assert_eq!(ev.cycle_complete, Some(c));
        // Reported locked only once the check is armed: a fault injected by someone who
        // waited for a locked ring is never missed (the last cycle of the streak arms it).
        assert!(!m.status().locked, "cycle {c}");
        assert_eq!(m.run_check(), None, "cycle {c}");
    }
    assert!(m.status().locked);
    let faults: Vec<_> = (0..6).filter_map(|_| m.run_check()).collect();
    assert!(!faults.is_empty());
    assert!(m.ring_fault());
}

#[test]
fn timing_slack_tolerates_silence_and_backlog_before_counting_errors() {
    let make = |slack, kind| {
        let mut cfg = CoreConfig::new("s", kind, 1, RingSettings::new(0x80, 0x0F_8001), P);
        cfg.check = RingCheck::card(0, 0, 0, 0);
        cfg.timing_slack = slack;
        MemberCore::new(cfg)
    };
    for (slack, kind) in [
        (1u32, MemberKind::Station),
        (8, MemberKind::Station),
        (1, MemberKind::Card),
        (8, MemberKind::Card),
    ] {
        let mut m = make(slack, kind);
        // Two frames of new cycles before a tick: a backlog (a sync master on its own clock
        // meeting a descheduled member), no ring error.
        m.on_frame(&frame(1, 1, &[cmd(1)]).encode(), 0);
        let ev = m.on_frame(&frame(2, 2, &[cmd(1)]).encode(), 0);
        assert!(!ev.errors.contains(&crate::status::ErrorClass::Overrun));
        // A frame no newer than the last one (a delayed frame released late): an overrun
        // without slack.
        let ev = m.on_frame(&frame(3, 1, &[cmd(1)]).encode(), 0);
        let late = ev.errors.contains(&crate::status::ErrorClass::Overrun);
        assert_eq!(late, slack == 1, "slack {slack}");
        m.run_check();
        // Silent ticks: an error once more than `slack` in a row went by: a card records a
        // data underrun, a station (no light) a byte violation.
        let mut first = None;
        for t in 1..=12u32 {
            m.run_check();
            let e = m.status().errors;
            let n = match kind {
                MemberKind::Card => e.underrun,
                MemberKind::Station => e.byte_violation,
            };
            if first.is_none() && n > 0 {
                first = Some(t);
            }
        }
        assert_eq!(first, Some(slack + 1), "slack {slack}");
    }
}

/// An application that rewrites its member's ring settings through [`crate::core::RingControl`]
/// and records what it saw.
struct Tuner {
    seen: Vec<(u32, u32, u32)>,
}

impl crate::core::RingApp for Tuner {
    fn tick(&mut self, _: u64, _: u64, _: &mut crate::member::RingMember, _: bool) {}

    fn sync_ring(&mut self, ring: &mut crate::core::RingControl<'_>) {
        let s = ring.settings();
        self.seen
            .push((s.i995, ring.check().params().period, ring.status_bits()));
        ring.set_settings(RingSettings::new(s.i995 | 0x80, s.i996));
        ring.check_mut().set_period(32);
    }
}

#[test]
fn the_application_reads_and_changes_the_ring_settings_before_each_tick() {
    let mut cfg = CoreConfig::new(
        "c",
        MemberKind::Card,
        0,
        RingSettings::new(0x10, 0x0F_8001),
        P,
    );
    cfg.check = RingCheck::card(16, 2, 4, 2);
    let mut core = MemberCore::new(cfg);
    let mut app = Tuner { seen: Vec::new() };
    core.ring_status_mut().set_sync_received();
    core.tick_app(&mut app, 1, 0);
    core.tick_app(&mut app, 2, 0);
    assert_eq!(app.seen[0], (0x10, 16, STATUS_SYNC_RECEIVED));
    assert_eq!(app.seen[1].0, 0x90, "I995 written by the app is the core's");
    assert_eq!(
        app.seen[1].1, 32,
        "I1001 written by the app is the check's period"
    );
    assert_eq!(core.member().settings().i995, 0x90);
    assert_eq!(core.check().params().period, 32);
}

/// A member that latches while its input is dark keeps the spell's first cycle with the latch
/// (`ring_fault_dark_since`), in the numbering of the latch, whatever comes after: a
/// restarted sync master renumbering the ring, a later dark spell. A reset forgets it.
#[test]
fn a_latch_in_the_dark_keeps_the_spell_s_onset() {
    let mut cfg = CoreConfig::new(
        "s",
        MemberKind::Station,
        1,
        RingSettings::new(0x80, 0x0F_8002),
        P,
    );
    cfg.upstream = Some(0);
    cfg.check = RingCheck::card(2, 2, 2, 0);
    let mut s = MemberCore::new(cfg);
    for c in 800_000..800_004 {
        s.on_frame(&frame(c, c, &[Packet::sync(0, 15, c)]).encode(), 0);
        assert_eq!(s.run_check(), None);
    }
    // The sync master died at cycle 800,004: dark from there, latched a few checks later.
    let mut latched = None;
    for c in 800_004..800_020 {
        s.dark_input(c, P);
        if s.run_check().is_some() && latched.is_none() {
            latched = Some(c);
        }
    }
    let st = s.status();
    assert!(st.ring_fault && latched.is_some(), "{st:?}");
    assert_eq!(st.ring_fault_dark_since, Some(800_004));
    // A restarted sync master counts from 0; later another dark spell: the latch's onset stays.
    for c in 0..3 {
        s.on_frame(
            &frame(900_000 + c, c, &[Packet::sync(0, 15, c)]).encode(),
            0,
        );
    }
    s.dark_input(105, P);
    let st = s.status();
    assert_eq!(st.dark_since_cycle, Some(105));
    assert_eq!(st.ring_fault_dark_since, Some(800_004));
    // Healthy again and reset: forgotten.
    for c in 106..112 {
        s.on_frame(
            &frame(900_000 + c, c, &[Packet::sync(0, 15, c)]).encode(),
            0,
        );
        s.run_check();
    }
    assert!(s.reset(), "{:?}", s.status());
    assert_eq!(s.status().ring_fault_dark_since, None);
}
