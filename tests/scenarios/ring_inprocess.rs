//! In-process lockstep ring scenarios (issue 2, item 7): routing, broadcast, two masters,
//! sync lock, error classes, ring check, cut link and recovery. Deterministic: no sockets,
//! no clock.

use mcc_ring::check::{CheckFault, RingCheck};
use mcc_ring::control::MemberKind;
use mcc_ring::core::{CoreConfig, MemberCore, RingApp};
use mcc_ring::fault::{FaultKind, FaultSpec};
use mcc_ring::member::RingMember;
use mcc_ring::settings::{period_ns, RingSettings, DEFAULT_RATE_HZ};
use mcc_ring::sim::{RingSim, TickKind};
use mcc_ring::status::{
    STATUS_BYTE_VIOLATION, STATUS_CHECKSUM, STATUS_OVERRUN, STATUS_SYNC_RECEIVED, STATUS_UNDERRUN,
};

/// Test app: a master writes r0 = 2 × cycle on its nodes; a slave answers r0 = command + 1000.
#[derive(Default)]
struct App {
    master: bool,
    nodes: Vec<u8>,
    ticks: Vec<(u64, bool)>,
}

impl RingApp for App {
    fn tick(&mut self, cycle: u64, _time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        self.ticks.push((cycle, ring_fault));
        for &n in &self.nodes {
            let v = if self.master {
                (cycle * 2) as u32
            } else {
                regs.read_regs(n).r0 + 1000
            };
            regs.write_regs_mut(n).r0 = v & 0xFF_FFFF;
        }
    }
}

/// One member of a test ring.
struct Spec {
    kind: MemberKind,
    i995: u32,
    i996: u32,
    check: RingCheck,
    nodes: Vec<u8>,
}

fn card(i995: u32, i996: u32, check: RingCheck, nodes: &[u8]) -> Spec {
    Spec {
        kind: MemberKind::Card,
        i995,
        i996,
        check,
        nodes: nodes.to_vec(),
    }
}

fn station(i995: u32, i996: u32, check: RingCheck, nodes: &[u8]) -> Spec {
    Spec {
        kind: MemberKind::Station,
        i995,
        i996,
        check,
        nodes: nodes.to_vec(),
    }
}

fn unchecked() -> RingCheck {
    RingCheck::card(0, 0, 0, 0)
}

fn ring(specs: Vec<Spec>) -> RingSim<App> {
    let n = specs.len() as u16;
    let members = specs
        .into_iter()
        .enumerate()
        .map(|(i, s)| {
            let pos = i as u16;
            let settings = RingSettings::new(s.i995, s.i996);
            let mut cfg = CoreConfig::new(
                &format!("m{i}"),
                s.kind,
                pos,
                settings,
                period_ns(DEFAULT_RATE_HZ),
            );
            cfg.upstream = Some((pos + n - 1) % n);
            cfg.check = s.check;
            let app = App {
                master: settings.is_master() || settings.is_sync_master(),
                nodes: s.nodes,
                ticks: Vec::new(),
            };
            (MemberCore::new(cfg), app)
        })
        .collect();
    RingSim::new(members, period_ns(DEFAULT_RATE_HZ))
}

/// Sync master (master 0, sync node 15) commanding nodes 0 and 1; a listener with no node
/// active; slaves on node 0 and node 1.
fn basic_ring() -> RingSim<App> {
    ring(vec![
        card(0x30, 0x0F_0003, unchecked(), &[0, 1]),
        station(0x80, 0x0F_8000, unchecked(), &[]),
        station(0x80, 0x0F_8001, unchecked(), &[0]),
        station(0x80, 0x0F_8002, unchecked(), &[1]),
    ])
}

#[test]
fn routing_master_slave_master_same_cycle() {
    let mut sim = basic_ring();
    // Cycle k: the command packet carries the master's tick k-1 output 2(k-1); the slave
    // latches it and substitutes its tick k-1 output 2(k-2)+1000, which the master latches
    // when the packet returns at the end of the same cycle k.
    for k in 1..=6u64 {
        let rep = sim.step();
        assert!(rep.completed, "cycle {k} must complete");
        let cmd = 2 * (k as u32 - 1);
        let fb = if k >= 2 { 2 * (k as u32 - 2) + 1000 } else { 0 };
        assert_eq!(
            sim.member(2).member().read_regs(0).r0,
            cmd,
            "station node 0 command, cycle {k}"
        );
        assert_eq!(
            sim.member(3).member().read_regs(1).r0,
            cmd,
            "station node 1 command, cycle {k}"
        );
        assert_eq!(
            sim.member(0).member().read_regs(0).r0,
            fb,
            "card feedback node 0, cycle {k}"
        );
        assert_eq!(
            sim.member(0).member().read_regs(1).r0,
            fb,
            "card feedback node 1, cycle {k}"
        );
    }
    assert_eq!(sim.app(0).ticks.len(), 6);
}

#[test]
fn broadcast_copy_latched_by_non_activated_member() {
    let mut sim = basic_ring();
    sim.run(4);
    let listener = sim.member(1).member();
    // The listener (no node active) sees master 0's commands unchanged: 2 × 3 from tick 3.
    assert_eq!(listener.latched_copy(0, 0).map(|r| r.r0), Some(6));
    assert_eq!(listener.latched_copy(0, 1).map(|r| r.r0), Some(6));
    assert_eq!(listener.read_regs(0).r0, 6);
    // and forwarded them unchanged: the slaves got the same value.
    assert_eq!(sim.member(2).member().read_regs(0).r0, 6);
    // The node 0 slave (position 2) sees node 1's command but not its feedback (downstream).
    assert_eq!(
        sim.member(2).member().latched_copy(0, 1).map(|r| r.r0),
        Some(6)
    );
    // The node 1 slave sees node 0's feedback substituted upstream of it: 2×2 + 1000.
    assert_eq!(
        sim.member(3).member().latched_copy(0, 0).map(|r| r.r0),
        Some(1004)
    );
}

#[test]
fn two_masters_second_downstream_gets_feedback_one_cycle_later() {
    let mut sim = ring(vec![
        card(0x30, 0x0F_0001, unchecked(), &[0]),
        card(0x8090, 0x1F_8002, unchecked(), &[1]),
        station(0x80, 0x0F_8001, unchecked(), &[0]),
        station(0x8080, 0x1F_8002, unchecked(), &[1]),
    ]);
    for k in 1..=8u64 {
        sim.step();
        let k = k as u32;
        // master 0 (sync master): same-cycle feedback.
        let fb0 = if k >= 2 { 2 * (k - 2) + 1000 } else { 0 };
        assert_eq!(
            sim.member(0).member().read_regs(0).r0,
            fb0,
            "card0 cycle {k}"
        );
        // master 1: its packet is held by the sync master and comes back next cycle.
        let fb1 = if k >= 3 { 2 * (k - 3) + 1000 } else { 0 };
        assert_eq!(
            sim.member(1).member().read_regs(1).r0,
            fb1,
            "card1 cycle {k}"
        );
        // station of master 1 got master 1's tick k-1 command this cycle.
        assert_eq!(
            sim.member(3).member().read_regs(1).r0,
            2 * (k - 1),
            "station b cycle {k}"
        );
    }
    // card0 never latched master 1's packet into its registers, only as a broadcast copy.
    assert_eq!(sim.member(0).member().read_regs(1).r0, 0);
    assert!(sim.member(0).member().latched_copy(1, 1).is_some());
    // master 0's station ignored master 1's node 1 (master numbers differ).
    assert_eq!(sim.member(2).member().read_regs(1).r0, 0);
    for i in 0..4 {
        assert_eq!(
            sim.member(i).status().errors,
            Default::default(),
            "member {i}"
        );
    }
}

#[test]
fn sync_lock_every_member_runs_the_sync_masters_cycle() {
    let mut sim = basic_ring();
    for rep in sim.run(50) {
        for (i, t) in rep.ticks.iter().enumerate() {
            let kind = if i == 0 {
                TickKind::Start
            } else {
                TickKind::Sync
            };
            assert_eq!(
                *t,
                Some((rep.cycle, kind)),
                "member {i}, cycle {}",
                rep.cycle
            );
        }
    }
    for i in 0..4 {
        let st = sim.member(i).status();
        assert_eq!(st.cycle, 50, "member {i}");
        assert!(st.locked, "member {i}");
        assert_eq!(st.sync_count, 50, "member {i}");
        assert_eq!(st.holdover_cycles, 0);
    }
    assert_eq!(
        sim.app(3).ticks.iter().map(|t| t.0).collect::<Vec<_>>(),
        (1..=50).collect::<Vec<_>>()
    );
}

#[test]
fn each_error_class_from_its_fault() {
    let cases = [
        (FaultKind::Corrupt, STATUS_CHECKSUM),
        (FaultKind::ByteViolation, STATUS_BYTE_VIOLATION),
        (FaultKind::Overrun, STATUS_OVERRUN),
        (FaultKind::Underrun, STATUS_UNDERRUN),
    ];
    for (kind, bit) in cases {
        let mut sim = basic_ring();
        sim.run(3);
        for i in 0..4 {
            sim.member_mut(i).ring_status_mut().read_and_clear();
        }
        sim.inject(
            1,
            FaultSpec {
                cycles: Some(2),
                ..FaultSpec::always(kind)
            },
        )
        .unwrap();
        sim.run(5);
        let st = sim.member(2).status();
        let e = st.errors;
        let counts = [e.checksum, e.byte_violation, e.overrun, e.underrun];
        let want = match kind {
            FaultKind::Corrupt => [2, 0, 0, 0],
            FaultKind::ByteViolation => [0, 2, 0, 0],
            FaultKind::Overrun => [0, 0, 2, 0],
            _ => [0, 0, 0, 2],
        };
        assert_eq!(counts, want, "{kind}");
        assert_eq!(e.bad_frames, 0);
        // latched, cleared on read (the sync bit is set by every cycle's sync packet)
        let s = sim.member_mut(2).ring_status_mut();
        assert_eq!(s.read_and_clear(), bit | STATUS_SYNC_RECEIVED, "{kind}");
        assert_eq!(s.read_and_clear(), 0, "{kind}");
        // the bad packet was dropped: nobody downstream saw an error
        for i in [3, 0] {
            assert_eq!(
                sim.member(i).status().errors,
                Default::default(),
                "{kind} member {i}"
            );
        }
        // the fault expired
        assert!(sim.member(1).faults().is_empty());
    }
}

#[test]
fn delayed_frames_arrive_as_overrun() {
    let mut sim = basic_ring();
    sim.run(3);
    sim.inject(
        1,
        FaultSpec {
            cycles: Some(1),
            ..FaultSpec::always(FaultKind::DelayCycles(1))
        },
    )
    .unwrap();
    // cycle 4 is held one cycle (an empty frame keeps the cycle: member 2 runs it unlocked);
    // in cycle 5 the held frame and cycle 5's frame arrive together.
    let rep = sim.step();
    assert_eq!(rep.ticks[2], Some((4, TickKind::Unlocked)));
    sim.step();
    assert_eq!(sim.member(2).status().errors.overrun, 1);
    assert_eq!(sim.member(2).cycle(), 5);
}

/// Frames held 7 cycles by the member upstream of the sync master (the campaign's
/// `delay=7 on station1`) come back late, all at once: the sync master sees the overrun (the
/// link into it), and passes another master's packets on one per node address (the latest),
/// so the card downstream gets no more packets than a cycle holds — its link is whole and it
/// records no link error (found by the fault campaign: `mcc status` named the wrong link).
#[test]
fn delayed_frames_into_the_sync_master_are_no_error_further_round() {
    let mut sim = ring(vec![
        card(0x30, 0x0F_0001, unchecked(), &[0]),
        station(0x80, 0x0F_8001, unchecked(), &[0]),
        card(0x8090, 0x1F_8002, unchecked(), &[1]),
        station(0x8080, 0x1F_8002, unchecked(), &[1]),
    ]);
    // Packets members 1 and 2 receive per cycle: one per node address and cycle.
    let per_cycle = |sim: &mut RingSim<App>, n: u64| {
        let mut most = [0u64; 2];
        for _ in 0..n {
            let before = [1, 2].map(|i| sim.member(i).rx_packets());
            sim.step();
            for (k, i) in [1, 2].into_iter().enumerate() {
                most[k] = most[k].max(sim.member(i).rx_packets() - before[k]);
            }
        }
        most
    };
    let healthy = per_cycle(&mut sim, 5);
    assert!(healthy[0] > 0 && healthy[1] > 0, "{healthy:?}");
    sim.inject(
        3,
        FaultSpec {
            cycles: Some(7),
            ..FaultSpec::always(FaultKind::DelayCycles(7))
        },
    )
    .unwrap();
    let faulted = per_cycle(&mut sim, 30);
    assert!(
        sim.member(0).status().errors.overrun > 0,
        "the sync master sees the late frames"
    );
    // The late copies of card1's packets were not passed on beside the current ones.
    assert!(
        faulted[0] <= healthy[0] && faulted[1] <= healthy[1],
        "packets per cycle: healthy {healthy:?}, after the late frames {faulted:?}"
    );
    for i in [1, 2] {
        let e = sim.member(i).status().errors;
        assert_eq!(
            (e.overrun, e.byte_violation, e.checksum),
            (0, 0, 0),
            "member {i}: {e:?}"
        );
        assert_eq!(sim.member(i).status().link_error_cycle, None, "member {i}");
    }
}

/// The §6.8 pseudo-code, evaluated on per-servo-cycle (error, sync) flags: the servo cycle
/// (1-based) at which the check declares a fault, with errors firing at once.
fn expected_fault_cycle(
    i1001: u32,
    i1004: u32,
    i1005: u32,
    i8: u32,
    flags: impl Fn(u64) -> (bool, bool),
) -> Option<u64> {
    let (mut errors, mut syncs, mut checks, mut elapsed) = (0, 0, 0, 0);
    let (mut err_latch, mut sync_latch) = (false, false);
    for cycle in 1..=10_000u64 {
        let (e, s) = flags(cycle);
        err_latch |= e;
        sync_latch |= s;
        if cycle % u64::from(i8 + 1) != 0 {
            continue;
        }
        errors += u32::from(std::mem::take(&mut err_latch));
        syncs += u32::from(std::mem::take(&mut sync_latch));
        checks += 1;
        elapsed += i8 + 1;
        if errors >= i1004 {
            return Some(cycle);
        }
        if elapsed >= i1001 {
            if syncs < i1005 || errors == checks {
                return Some(cycle);
            }
            (errors, syncs, checks, elapsed) = (0, 0, 0, 0);
        }
    }
    None
}

/// Sync master card0, card1 (master 1, ring check I1001 = 8, I1004 = 2, I1005 = 4, I8 = 0),
/// and card1's slave station.
fn checked_ring() -> RingSim<App> {
    ring(vec![
        card(0x30, 0x0F_0001, unchecked(), &[0]),
        card(0x8090, 0x1F_8002, RingCheck::card(8, 2, 4, 0), &[1]),
        station(0x8080, 0x1F_8002, unchecked(), &[1]),
    ])
}

#[test]
fn ring_check_missing_syncs_fault_at_end_of_period() {
    let mut sim = checked_ring();
    sim.run(10);
    assert!(!sim.member(1).ring_fault());
    sim.inject(0, FaultSpec::always(FaultKind::DropSync))
        .unwrap();
    let want = expected_fault_cycle(8, 2, 4, 0, |c| (false, c <= 10)).unwrap();
    assert_eq!(want, 16, "2 syncs (cycles 9, 10) in the period 9-16");
    let mut got = None;
    let reps = sim.run(20);
    for rep in &reps {
        if let Some((_, f)) = rep.faults.iter().find(|f| f.0 == 1) {
            got.get_or_insert((rep.cycle, *f));
        }
    }
    assert_eq!(
        got,
        Some((
            want,
            CheckFault::MissingSyncs {
                syncs: 2,
                required: 4
            }
        ))
    );
    let st = sim.member(1).status();
    assert!(st.ring_fault && !st.locked);
    // cycles 11-30 ran: the next period (17-24) fails too (reported by that check); the latch
    // keeps the cycle it latched at and counts one fault.
    assert_eq!(st.ring_fault_cycle, Some(want));
    let later: Vec<u64> = reps
        .iter()
        .filter(|r| r.faults.iter().any(|f| f.0 == 1))
        .map(|r| r.cycle)
        .collect();
    assert!(later.contains(&24), "still failing every period: {later:?}");
    assert_eq!(st.ring_fault_count, 1);
    assert!(st.holdover_cycles >= 20);
    // the app saw the latch from the faulting cycle on
    assert!(sim.app(1).ticks.iter().all(|(c, f)| *f == (*c >= want)));
}

#[test]
fn ring_check_errors_fault_at_once() {
    let mut sim = checked_ring();
    sim.run(10);
    // card0's frame reaches card1 with a bad check byte on every cycle from 11 on.
    sim.inject(0, FaultSpec::always(FaultKind::Corrupt))
        .unwrap();
    let want = expected_fault_cycle(8, 2, 4, 0, |c| (c > 10, true)).unwrap();
    assert_eq!(want, 12);
    let first = sim
        .run(10)
        .into_iter()
        .find_map(|r| r.faults.iter().find(|f| f.0 == 1).map(|f| (r.cycle, f.1)));
    assert_eq!(
        first,
        Some((
            want,
            CheckFault::Errors {
                errors: 2,
                limit: 2
            }
        ))
    );
    assert!(sim.member(1).status().errors.checksum >= 10);
}

#[test]
fn healthy_ring_never_faults() {
    let mut sim = ring(vec![
        card(0x30, 0x0F_0003, RingCheck::card(8, 2, 4, 0), &[0, 1]),
        station(0x80, 0x0F_8001, RingCheck::station(8, 4, 4), &[0]),
        card(0x8090, 0x1F_8004, RingCheck::card(10, 2, 2, 2), &[2]),
        station(0x8080, 0x1F_8004, RingCheck::station(8, 4, 4), &[2]),
        station(0x80, 0x0F_8002, RingCheck::station(8, 4, 4), &[1]),
    ]);
    for rep in sim.run(1000) {
        assert!(
            rep.completed && rep.faults.is_empty(),
            "cycle {}: {:?}",
            rep.cycle,
            rep.faults
        );
    }
    for i in 0..5 {
        let st = sim.member(i).status();
        assert!(!st.ring_fault && st.locked, "member {i}");
        assert_eq!(st.errors, Default::default(), "member {i}");
        assert_eq!(st.cycle, 1000);
    }
    assert_eq!(sim.locate_break(), None);
}

#[test]
fn cut_link_seen_downstream_localised_and_recovered() {
    let mut sim = ring(vec![
        card(0x30, 0x0F_0003, RingCheck::card(8, 2, 4, 0), &[0, 1]),
        station(0x80, 0x0F_8001, RingCheck::station(8, 4, 4), &[0]),
        station(0x80, 0x0F_8000, RingCheck::station(8, 4, 4), &[]),
        station(0x80, 0x0F_8002, RingCheck::station(8, 4, 4), &[1]),
        station(0x80, 0x0F_8000, RingCheck::station(8, 4, 4), &[]),
    ]);
    sim.run(10);
    sim.inject(2, FaultSpec::always(FaultKind::Cut)).unwrap();
    let reps = sim.run(10);
    // The ring keeps cycling on dark frames, but no sync packet comes back.
    assert!(reps.iter().all(|r| !r.completed));
    // Loss of light downstream of link 2: a byte violation every cycle. Stations 3 and 4 fault
    // on their MI9 = 4th check with an error (a 16-axis MACRO Station faults on >= MI9 errors)
    // in cycle 14, the sync master (I1004 = 2; a cycle's dark frame
    // comes back after its tick, so it is read one check later) in cycle 13; stations 1 and 2
    // upstream of the cut stay healthy.
    let faulted: Vec<(u64, usize)> = reps
        .iter()
        .flat_map(|r| r.faults.iter().map(move |f| (r.cycle, f.0)))
        .filter(|f| [0, 3, 4].contains(&f.1) && f.0 <= 16)
        .fold(Vec::new(), |mut v, f| {
            if !v.iter().any(|(_, m)| *m == f.1) {
                v.push(f);
            }
            v
        });
    assert_eq!(faulted, vec![(13, 0), (14, 3), (14, 4)]);
    assert!(reps
        .iter()
        .all(|r| r.faults.iter().all(|f| f.0 != 1 && f.0 != 2)));
    for i in [3, 4, 0] {
        let st = sim.member(i).status();
        assert!(
            st.dark && st.dark_since_cycle == Some(11),
            "member {i}: {st:?}"
        );
        assert!(st.errors.byte_violation >= 9, "member {i}: {st:?}");
    }
    for i in [3, 4, 0] {
        let st = sim.member(i).status();
        assert!(st.ring_fault && !st.locked, "member {i}");
        assert_eq!(st.last_rx_cycle, Some(10), "member {i}");
    }
    for i in [1, 2] {
        let st = sim.member(i).status();
        assert!(!st.ring_fault && st.locked, "member {i}");
        assert_eq!(st.last_rx_cycle, Some(20), "member {i}");
    }
    assert_eq!(sim.locate_break(), Some(2));
    // station 3's slave node gets no command: its last one is from cycle 10 (tick 9 output).
    assert_eq!(sim.member(3).member().read_regs(1).r0, 18);
    // $$$ while broken: the latch stays.
    assert!(!sim.member_mut(0).reset());

    sim.clear_faults(2);
    let reps = sim.run(20);
    assert!(reps.iter().all(|r| r.completed));
    assert_eq!(sim.locate_break(), None);
    for i in 0..5 {
        let st = sim.member(i).status();
        assert!(st.locked, "member {i}");
        assert_eq!(st.cycle, 40);
    }
    // latched until reset, then cleared because the ring is healthy again
    assert!(sim.member(3).ring_fault());
    for i in [0, 3, 4] {
        assert!(sim.member_mut(i).reset(), "member {i}");
        assert!(!sim.member(i).ring_fault());
    }
    assert_eq!(sim.member(3).member().read_regs(1).r0, 2 * 39);
}

#[test]
fn same_seed_same_run() {
    let run = |seed| {
        let mut sim = basic_ring();
        sim.inject(
            1,
            FaultSpec {
                probability: 0.3,
                seed,
                ..FaultSpec::always(FaultKind::Corrupt)
            },
        )
        .unwrap();
        sim.inject(
            2,
            FaultSpec {
                probability: 0.2,
                seed: seed + 1,
                ..FaultSpec::always(FaultKind::DropPackets)
            },
        )
        .unwrap();
        sim.run(200);
        (0..4).map(|i| sim.member(i).status()).collect::<Vec<_>>()
    };
    let a = run(11);
    assert_eq!(a, run(11));
    assert_ne!(a, run(12));
    assert!(a[2].errors.checksum > 20, "{:?}", a[2].errors);
}

/// Cycles at which member `i` latched its ring fault (rising edge) in `reps`.
fn first_fault_cycle(reps: &[mcc_ring::sim::StepReport], i: usize) -> Option<u64> {
    reps.iter()
        .find(|r| r.faults.iter().any(|f| f.0 == i))
        .map(|r| r.cycle)
}

#[test]
fn a_cut_link_is_loss_of_light_downstream_and_faults_within_i1004_checks() {
    // RTI every servo cycle (I8 = 0), I1001 = 16, I1004 = 2, I1005 = 4.
    let check = || RingCheck::card(16, 2, 4, 0);
    let mut sim = ring(vec![
        card(0x30, 0x0F_0003, check(), &[0, 1]),
        station(0x8080, 0x0F_8001, RingCheck::station(16, 4, 2), &[0]),
        station(0x8080, 0x0F_8002, RingCheck::station(16, 4, 2), &[1]),
    ]);
    sim.run(40);
    sim.inject(1, FaultSpec::always(FaultKind::Cut)).unwrap();
    let cut_at = sim.cycle();
    let reps = sim.run(40);
    // Downstream of the cut every cycle brings a dark frame: a byte violation. Station 2
    // faults on its second cycle with an error (MI9 = 2: a station faults on >= MI9 errors) at
    // cut + 2, the sync master on its second check with one (I1004 = 2; the dark frame of a
    // cycle is read at the next tick) at cut + 3, well inside I1001 + 1. No timeout is
    // involved: the ring keeps cycling.
    for (i, after) in [(2, 2), (0, 3)] {
        let at = first_fault_cycle(&reps, i).expect("faulted");
        assert_eq!(at, cut_at + after, "member {i}");
        let st = sim.member(i).status();
        assert!(
            st.errors.byte_violation >= 2 && st.dark,
            "member {i}: {st:?}"
        );
        assert_eq!(st.errors.underrun, 0, "member {i}");
        assert!(at - cut_at <= 16 + 1);
    }
    assert!(reps.iter().all(|r| r.ticks.iter().all(|t| t.is_some())));
    // Upstream of the cut the station keeps receiving: no fault.
    assert!(first_fault_cycle(&reps, 1).is_none());
    assert_eq!(sim.member(1).status().errors, Default::default());
}

#[test]
fn a_master_whose_packets_do_not_come_back_faults_even_upstream_of_the_break() {
    // card0 (sync master, master 0) → card1 (master 1, node 0) → station0 (slave of master 1,
    // node 0) → back to card0. Cutting card1's outgoing link leaves card1 receiving sync
    // packets from card0 but never its own packets: each frame is missing them (underrun).
    let check = || RingCheck::card(16, 2, 4, 0);
    let mut sim = ring(vec![
        card(0x30, 0x0F_0000, check(), &[]),
        card(0x8090, 0x1F_8001, check(), &[0]),
        station(0x8080, 0x1F_8001, RingCheck::station(16, 4, 2), &[0]),
    ]);
    sim.run(40);
    for i in 0..3 {
        let st = sim.member(i).status();
        assert!(st.locked && !st.ring_fault, "member {i}");
        assert_eq!(st.errors.underrun, 0, "member {i}");
    }
    // card1 gets station0's answers: 2 × cycle + 1000 from one cycle back.
    assert!(sim.member(1).member().read_regs(0).r0 > 1000);
    sim.inject(1, FaultSpec::always(FaultKind::Cut)).unwrap();
    let cut_at = sim.cycle();
    let reps = sim.run(40);
    let at = first_fault_cycle(&reps, 1).expect("card1 faulted");
    assert!(at - cut_at <= 4, "card1 faulted at {at}, cut at {cut_at}");
    assert!(
        sim.member(1).status().locked,
        "card1 still gets sync packets"
    );
    assert!(sim.member(1).status().errors.underrun >= 2);
}
