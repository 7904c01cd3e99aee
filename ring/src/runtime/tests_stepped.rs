//! The stepped sync master against a hand-driven rest of the ring.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::Stepper;
use crate::control::MemberKind;
use crate::core::{CoreConfig, MemberCore, RingApp};
use crate::frame::Frame;
use crate::member::RingMember;
use crate::runtime::driver::{Driver, DriverConfig, DriverExit};
use crate::settings::RingSettings;
use crate::transport::loopback::LoopbackRing;
use crate::transport::LinkTx;
use mcc_contracts::config::ClockMode;

#[derive(Debug, Default)]
struct Cycles(Vec<u64>);

impl RingApp for Cycles {
    fn tick(&mut self, cycle: u64, _t: u64, _regs: &mut RingMember, _fault: bool) {
        self.0.push(cycle);
    }
}

/// The sync master card0 of a two-member loopback ring (member 1 is the test's hand), on
/// `clock`, with the given upstream-death flag and rejoin count.
fn sync_master(
    tx0: impl LinkTx + 'static,
    rx0: crate::transport::LinkRx,
    clock: ClockMode,
    max_cycles: Option<u64>,
    upstream_dead: Option<Arc<AtomicBool>>,
    rejoins: Option<Arc<std::sync::atomic::AtomicU64>>,
    links_matched: Option<Arc<std::sync::atomic::AtomicU64>>,
) -> Driver<Cycles> {
    let mut cc = CoreConfig::new(
        "card0",
        MemberKind::Card,
        0,
        RingSettings::new(0x30, 0x0F_0001),
        (1e9 / 2258.7) as u64,
    );
    cc.upstream = Some(1);
    let d = DriverConfig {
        name: "card0".into(),
        clock,
        rate_hz: 2258.7,
        rtf: 1.0,
        // Far longer than any test's bound: a master that waits for a lost cycle fails it.
        member_timeout: Duration::from_secs(120),
        upstream_dead,
        rejoins,
        members_present: None,
        links_matched,
        upstream_probe: None,
        in_flight: 1,
        harden: false,
        max_cycles,
        kind: MemberKind::Card,
        position: 0,
        extra: serde_json::Map::new(),
        record: 0,
        phase_delay_ns: 0,
    };
    let (_cmd_tx, cmd_rx) = crossbeam_channel::unbounded();
    Driver::new(
        d,
        MemberCore::new(cc),
        Cycles::default(),
        Box::new(tx0),
        rx0,
        cmd_rx,
        Arc::new(AtomicBool::new(false)),
    )
}

#[test]
fn a_frame_numbered_beyond_the_cycle_in_flight_does_not_let_the_sync_master_run_ahead() {
    // A member that ran on its own clock (it judged its upstream frozen) numbers its dark
    // frames far ahead of the sync master. Main's loaded run: the master took such a number as
    // the return of cycles it had not started and started cycles without waiting, flooding
    // the ring. The number is only the return of the cycle in flight.
    let cycles = 120;
    let ring = LoopbackRing::new(2);
    let (tx0, rx0) = ring.member(0).unwrap();
    let (tx1, rx1) = ring.member(1).unwrap();
    let master = std::thread::spawn(move || {
        let mut drv = sync_master(
            tx0,
            rx0,
            ClockMode::Lockstep,
            Some(cycles),
            None,
            None,
            None,
        );
        let exit = drv.run();
        (exit, drv.into_parts().1)
    });
    // The rest of the ring: every frame comes back dark; cycle 50's numbered 5000 ahead.
    let t0 = Instant::now();
    let mut seq = 0;
    let mut after_future = 0;
    while !master.is_finished() {
        assert!(t0.elapsed() < Duration::from_secs(60), "ring stuck");
        let Ok(Some(bytes)) = rx1.recv_timeout(Duration::from_millis(20)) else {
            continue;
        };
        let f = Frame::decode(&bytes).unwrap();
        if f.cycle > 50 && after_future < 5 {
            // Give a master that would run ahead every chance to: nothing may come before
            // this cycle has gone back.
            after_future += 1;
            std::thread::sleep(Duration::from_millis(100));
            assert_eq!(rx1.pending(), 0, "cycle {} not back yet", f.cycle);
        }
        let c = if f.cycle == 50 { 5050 } else { f.cycle };
        seq += 1;
        tx1.send(Frame::dark(1, seq, 0, c, 0).encode()).unwrap();
    }
    let (exit, app) = master.join().unwrap();
    assert!(matches!(exit, DriverExit::Done), "{exit:?}");
    assert_eq!(after_future, 5);
    // The master's count is its own: consecutive, never from the far-ahead frame.
    assert_eq!(app.0, (0..cycles).collect::<Vec<_>>());
}

/// A sync master on the lockstep clock against a hand-driven rest of the ring: when the frame
/// of a cycle arrives, `hand(cycle)` says which cycles come back now, lit, with the master's
/// packets (none: it was lost). Returns the master's ticks.
fn master_against(
    cycles: u64,
    rejoins: Arc<std::sync::atomic::AtomicU64>,
    dead: Arc<AtomicBool>,
    hand: impl FnMut(u64) -> Vec<u64>,
) -> Vec<u64> {
    master_against_facts(cycles, rejoins, dead, None, hand)
}

/// [`master_against`] with the fact "every other member's link publisher matched" given by
/// `links_matched` (the rejoin count it holds for).
fn master_against_facts(
    cycles: u64,
    rejoins: Arc<std::sync::atomic::AtomicU64>,
    dead: Arc<AtomicBool>,
    links_matched: Option<Arc<std::sync::atomic::AtomicU64>>,
    mut hand: impl FnMut(u64) -> Vec<u64>,
) -> Vec<u64> {
    let ring = LoopbackRing::new(2);
    let (tx0, rx0) = ring.member(0).unwrap();
    let (tx1, rx1) = ring.member(1).unwrap();
    let master = std::thread::spawn(move || {
        let mut drv = sync_master(
            tx0,
            rx0,
            ClockMode::Lockstep,
            Some(cycles),
            Some(dead),
            Some(rejoins),
            links_matched,
        );
        let exit = drv.run();
        (exit, drv.into_parts().1)
    });
    let t0 = Instant::now();
    let mut seq = 0;
    let mut sent = std::collections::HashMap::new();
    while !master.is_finished() {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "the sync master waits for a cycle that was lost"
        );
        let Ok(Some(bytes)) = rx1.recv_timeout(Duration::from_millis(20)) else {
            continue;
        };
        let f = Frame::decode(&bytes).unwrap();
        let c0 = f.cycle;
        sent.insert(c0, f);
        for c in hand(c0) {
            seq += 1;
            // Member 1 passes the master's packets on: its sync packet comes back.
            let mut back = sent.get(&c).cloned().unwrap_or_default();
            back.sender = 1;
            back.seq = seq;
            tx1.send(back.encode()).unwrap();
        }
    }
    let (exit, app) = master.join().unwrap();
    assert!(matches!(exit, DriverExit::Done), "{exit:?}");
    app.0
}

#[test]
fn a_member_that_comes_back_does_not_stall_the_ring_on_the_frames_its_new_links_lost() {
    // Campaign (paced, loaded): after `restart station1` the new member's links came up one by
    // one; the first frames went nowhere and the sync master waited the whole frozen-member
    // wait for one of them, long enough for a member between it and the restarted one to
    // judge its own upstream frozen and latch a fault nobody asked for. A member that came
    // back means frames may be lost: cycles go on on the own clock until light returns.
    let rejoins = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let r = Arc::clone(&rejoins);
    let ticks = master_against(80, rejoins, Arc::new(AtomicBool::new(false)), move |c| {
        if c == 19 {
            r.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        if (20..=25).contains(&c) {
            vec![]
        } else {
            vec![c]
        }
    });
    assert_eq!(ticks, (0..80).collect::<Vec<_>>());
}

#[test]
fn a_frame_lost_after_the_first_lit_return_does_not_stall_the_ring() {
    // What the first-lit-return rule missed (lockstep campaign under load: 3 stalls of the
    // frozen-member wait in 385 faults): a restarted member's links carried cycle 24 and then
    // lost 25. The links are up only after clean revolutions in a row (here 26, 27, 28).
    let rejoins = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let r = Arc::clone(&rejoins);
    let ticks = master_against(80, rejoins, Arc::new(AtomicBool::new(false)), move |c| {
        if c == 19 {
            r.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        match c {
            20..=23 | 25 => vec![],
            _ => vec![c],
        }
    });
    assert_eq!(ticks, (0..80).collect::<Vec<_>>());
}

#[test]
fn the_links_are_not_up_before_every_publisher_matched() {
    // Clean returns are not enough while a member has not reported its link's publisher
    // matched: a frame lost then (30, 35) costs its cycle only. Once it matched (cycle 40),
    // a loss (42) starts the count again; then the ring steps on returns.
    let rejoins = Arc::new(std::sync::atomic::AtomicU64::new(0));
    // (Matched at start: 1; for the rejoin: 2.)
    let matched = Arc::new(std::sync::atomic::AtomicU64::new(1));
    let (r, m) = (Arc::clone(&rejoins), Arc::clone(&matched));
    let ticks = master_against_facts(
        90,
        rejoins,
        Arc::new(AtomicBool::new(false)),
        Some(matched),
        move |c| {
            use std::sync::atomic::Ordering::Relaxed;
            match c {
                19 => r.store(1, Relaxed),
                40 => m.store(2, Relaxed),
                _ => {}
            }
            match c {
                30 | 35 | 42 => vec![],
                _ => vec![c],
            }
        },
    );
    assert_eq!(ticks, (0..90).collect::<Vec<_>>());
}

#[test]
fn an_upstream_back_from_the_dead_does_not_stall_the_ring_on_lost_frames() {
    // The upstream's death is loss of light (cycles on the own clock, each one dark); once it
    // is back, the frames its new links lose must not hold the ring either.
    let dead = Arc::new(AtomicBool::new(false));
    let d = Arc::clone(&dead);
    let ticks = master_against(
        80,
        Arc::new(std::sync::atomic::AtomicU64::new(0)),
        dead,
        move |c| {
            match c {
                20 => d.store(true, std::sync::atomic::Ordering::Relaxed),
                30 => d.store(false, std::sync::atomic::Ordering::Relaxed),
                _ => {}
            }
            if (20..=33).contains(&c) {
                vec![]
            } else {
                vec![c]
            }
        },
    );
    assert_eq!(ticks, (0..80).collect::<Vec<_>>());
}

#[test]
fn cycles_the_own_clock_lost_are_not_waited_for_once_light_is_back() {
    // On the own clock nothing waits for a cycle to come back, so a loaded machine may drop
    // some from a link's queue. Light is back when cycle 26 returns; 27, started on the own
    // clock before that and lost, must not hold the ring for the frozen-member wait.
    let rejoins = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let r = Arc::clone(&rejoins);
    let ticks = master_against(
        80,
        rejoins,
        Arc::new(AtomicBool::new(false)),
        move |c| match c {
            19 => {
                r.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                vec![19]
            }
            20..=26 => vec![],
            // 26 comes back only now, after 27 (lost) went out.
            27 => vec![26],
            _ => vec![c],
        },
    );
    assert_eq!(ticks, (0..80).collect::<Vec<_>>());
}

#[test]
fn on_the_own_clock_a_backlog_is_not_run_back_to_back() {
    // Paced: after a stall of the master itself the grid is behind. Stepping, the missed
    // cycles may run back to back (each waits for its return); on the own clock nothing waits,
    // and a 200 ms backlog left as ~450 frames at once, overflowed the links' queues, and the
    // lost frames held the ring for the frozen-member wait once it stepped again (paced
    // restart campaign under load). On the own clock a cycle starts once a period at most.
    let ring = LoopbackRing::new(2);
    let (tx0, rx0) = ring.member(0).unwrap();
    let mut drv = sync_master(tx0, rx0, ClockMode::Paced, None, None, None, None);
    let period = drv.wall_period_ns();
    let mut st: Stepper = drv.stepper();
    // Cycle 100 was due at t = 1 s; the master last started a cycle at 1.15 s and looks now.
    let t = 1_000_000_000;
    st.grid = crate::runtime::timing::PaceGrid::new(period, 100, t, 200_000_000);
    st.k = 100;
    st.returned = Some(99);
    st.last_start = t + 150_000_000;
    let now = st.last_start + 1_000;
    // Stepping, the cycle is due at once (its deadline is long past).
    let due = drv.step_due(&mut st, now);
    assert_eq!(due.at, Some(t));
    // On the own clock (waiting for light after a member came back): a period after the last.
    st.await_links = Some(crate::runtime::links_up::LinksUp::new(3));
    let due = drv.step_due(&mut st, now);
    assert_eq!(due.at, Some(st.last_start + period));
    assert!(!due.now(now));
    assert!(due.now(st.last_start + period));
}
