//! Runtime tests: whole rings of driver threads over the loopback transport, lockstep.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use super::driver::{DriverConfig, DriverExit};
use super::local::{LocalRing, LocalTransport};
use crate::control::{MemberKind, MemberStatus};
use crate::core::{CoreConfig, RingApp};
use crate::member::RingMember;
use crate::settings::RingSettings;
use mcc_contracts::config::ClockMode;

/// Sync master commanding node 0 with the cycle number; records what comes back.
#[derive(Debug, Default)]
pub(super) struct Master {
    pub(super) seen: Vec<(u64, u32)>,
}

impl RingApp for Master {
    fn tick(&mut self, cycle: u64, _t: u64, regs: &mut RingMember, _fault: bool) {
        self.seen.push((cycle, regs.read_regs(0).r0));
        regs.write_regs_mut(0).r0 = (cycle & 0xFF_FFFF) as u32;
    }
}

/// Slave on node 0: feedback = command + 1.
#[derive(Debug, Default)]
pub(super) struct Plus1 {
    ticks: u64,
}

impl RingApp for Plus1 {
    fn tick(&mut self, _c: u64, _t: u64, regs: &mut RingMember, _fault: bool) {
        self.ticks += 1;
        let cmd = regs.read_regs(0).r0;
        regs.write_regs_mut(0).r0 = (cmd + 1) & 0xFF_FFFF;
    }
}

pub(super) enum App {
    M(Master),
    S(Plus1),
}

impl RingApp for App {
    fn tick(&mut self, c: u64, t: u64, regs: &mut RingMember, f: bool) {
        match self {
            App::M(m) => m.tick(c, t, regs, f),
            App::S(s) => s.tick(c, t, regs, f),
        }
    }
}

fn dcfg(name: &str, kind: MemberKind, position: usize, cycles: u64) -> DriverConfig {
    DriverConfig {
        name: name.into(),
        clock: ClockMode::Lockstep,
        rate_hz: 2258.7,
        rtf: 1.0,
        member_timeout: Duration::from_millis(1000),
        upstream_dead: None,
        rejoins: None,
        members_present: None,
        links_matched: None,
        in_flight: 1,
        upstream_probe: None,
        harden: false,
        max_cycles: Some(cycles),
        kind,
        position,
        extra: serde_json::Map::new(),
        record: 0,
        phase_delay_ns: 0,
    }
}

pub(super) fn ring(cycles: u64) -> Vec<(CoreConfig, App, DriverConfig)> {
    let master = RingSettings::new(0x30, 0x0F_0001);
    let slave = RingSettings::new(0x8080, 0x0F_8001);
    let quiet = RingSettings::new(0x8080, 0x0F_8000);
    let period = 1_000_000_000 / 2258;
    vec![
        (
            CoreConfig::new("card0", MemberKind::Card, 0, master, period),
            App::M(Master::default()),
            dcfg("card0", MemberKind::Card, 0, cycles),
        ),
        (
            CoreConfig::new("station0", MemberKind::Station, 1, slave, period * 100),
            App::S(Plus1::default()),
            dcfg("station0", MemberKind::Station, 1, cycles),
        ),
        (
            CoreConfig::new("station1", MemberKind::Station, 2, quiet, period * 100),
            App::S(Plus1::default()),
            dcfg("station1", MemberKind::Station, 2, cycles),
        ),
    ]
}

#[test]
fn lockstep_loopback_ring_round_trips_commands_every_cycle() {
    let r = LocalRing::start(ring(200), LocalTransport::Loopback).unwrap();
    let out = r.join(Duration::from_secs(20));
    assert_eq!(out.len(), 3);
    for r in &out {
        assert!(
            matches!(r.exit, DriverExit::Done | DriverExit::Stopped),
            "{:?}",
            r.exit
        );
        assert_eq!(
            r.core.status().errors,
            Default::default(),
            "{}",
            r.core.name()
        );
    }
    let App::M(m) = &out[0].app else { panic!() };
    assert_eq!(m.seen.len(), 200);
    // Command of tick c goes out in frame c+1, the station answers cmd+1 in frame c+2, which
    // the master has latched at its tick c+3: feedback at tick c = (c-3)+1.
    for &(c, fb) in m.seen.iter().skip(4) {
        assert_eq!(u64::from(fb), c - 2, "cycle {c}");
    }
    // Every member ran every cycle on the sync packet (no holdover).
    let s = out[1].core.status();
    assert!(s.locked);
    assert_eq!(s.holdover_cycles, 0);
    assert!(s.sync_count >= 199);
}

#[test]
fn lockstep_ring_over_zenoh_sessions_locks_and_round_trips() {
    let cluster = format!("rt-test-{}", std::process::id());
    let r = LocalRing::start(ring(300), LocalTransport::Zenoh { cluster }).unwrap();
    let out = r.join(Duration::from_secs(60));
    let App::M(m) = &out[0].app else { panic!() };
    assert_eq!(m.seen.len(), 300);
    // After the links are up, the relation of the loopback test holds for every later cycle.
    let tail: Vec<_> = m.seen.iter().rev().take(50).collect();
    for &&(c, fb) in &tail {
        assert_eq!(u64::from(fb), c - 2, "cycle {c}");
    }
    assert!(out[0].core.status().locked);
}

#[test]
fn realtime_loopback_ring_runs_locked_without_errors() {
    let mut members = ring(400);
    for (_, _, d) in &mut members {
        d.clock = ClockMode::Realtime;
    }
    // Followers' holdover period: 1.5 nominal periods, as the process runtime sets it.
    let period = 1_000_000_000 / 2258;
    for (c, _, d) in members.iter_mut().skip(1) {
        c.period_ns = period * 3 / 2;
        d.max_cycles = None;
    }
    let r = LocalRing::start(members, LocalTransport::Loopback).unwrap();
    let out = r.join_member(0, Duration::from_secs(20));
    let App::M(m) = &out[0].app else { panic!() };
    assert_eq!(m.seen.len(), 400);
    assert!(m.seen.iter().any(|&(_, fb)| fb > 0), "feedback came back");
    for r in &out {
        let s = r.core.status();
        // (Underruns and loss of light are expected at the end: the sync master stops first.)
        assert_eq!(s.errors.checksum, 0);
        assert!(s.dark_since_cycle.is_none_or(|c| c >= 399), "{s:?}");
    }
}

/// Records the wall-clock (CLOCK_MONOTONIC) time of each tick.
#[derive(Debug, Default)]
struct Clocked {
    ticks: Vec<(u64, u64)>,
}

impl RingApp for Clocked {
    fn tick(&mut self, cycle: u64, _t: u64, _regs: &mut RingMember, _f: bool) {
        self.ticks.push((cycle, super::driver::monotonic_ns()));
    }
}

#[test]
fn realtime_phase_alignment_ticks_every_member_after_origin_plus_delay() {
    let delay_ns = 200_000;
    let period = 1_000_000_000 / 2258;
    let settings = [
        RingSettings::new(0x30, 0x0F_0001),
        RingSettings::new(0x8080, 0x0F_8001),
        RingSettings::new(0x8080, 0x0F_8000),
    ];
    let members: Vec<_> = settings
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let kind = if k == 0 {
                MemberKind::Card
            } else {
                MemberKind::Station
            };
            let mut d = dcfg(&format!("m{k}"), kind, k, 300);
            d.clock = ClockMode::Realtime;
            d.phase_delay_ns = delay_ns;
            d.record = 400;
            if k > 0 {
                d.max_cycles = None;
            }
            let c = CoreConfig::new(&format!("m{k}"), kind, k as u16, *s, period * 3 / 2);
            (c, Clocked::default(), d)
        })
        .collect();
    let r = LocalRing::start(members, LocalTransport::Loopback).unwrap();
    let out = r.join_member(0, Duration::from_secs(20));
    // The sync master records each cycle's scheduled start; its origin stamp is at or after it.
    let starts: std::collections::HashMap<u64, u64> = out[0].records.iter().copied().collect();
    let mut checked = 0;
    for m in &out {
        for &(cycle, at) in &m.app.ticks {
            if let Some(&start) = starts.get(&cycle) {
                assert!(
                    at >= start + delay_ns,
                    "{} ticked cycle {cycle} {} ns after its scheduled start",
                    m.core.name(),
                    at.saturating_sub(start)
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 600, "checked {checked} ticks");
}

/// A member app for the stepped-clock tests: records what it saw each tick; may stall (sleep)
/// in one tick, as a descheduled process would.
#[derive(Debug, Default)]
struct Probe {
    master: bool,
    seen: Vec<(u64, u64, u32, bool)>,
    stall_at: Option<(u64, Duration)>,
    /// Sleep this long in every tick (a slow link: the ring's round trip exceeds a period).
    slow: Option<Duration>,
}

impl RingApp for Probe {
    fn tick(&mut self, cycle: u64, t: u64, regs: &mut RingMember, fault: bool) {
        if let Some((at, d)) = self.stall_at {
            if at == cycle {
                std::thread::sleep(d);
            }
        }
        if let Some(d) = self.slow {
            std::thread::sleep(d);
        }
        self.seen.push((cycle, t, regs.read_regs(0).r0, fault));
        let v = if self.master {
            (cycle * 3) as u32
        } else {
            regs.read_regs(0).r0 + 7
        };
        regs.write_regs_mut(0).r0 = v & 0xFF_FFFF;
    }
}

const RATE: f64 = 2258.7;

/// card0 (sync master, check armed) → station0 (node 0) → card1 (master 1, no nodes) →
/// station1 (listener): every member checks the ring, as the default cluster does.
fn checked_ring(
    clock: ClockMode,
    cycles: u64,
    timeout: Duration,
) -> Vec<(CoreConfig, Probe, DriverConfig)> {
    let period = (1e9 / RATE) as u64;
    let specs = [
        (
            "card0",
            MemberKind::Card,
            RingSettings::new(0x30, 0x0F_0001),
        ),
        (
            "station0",
            MemberKind::Station,
            RingSettings::new(0x8080, 0x0F_8001),
        ),
        (
            "card1",
            MemberKind::Card,
            RingSettings::new(0x8090, 0x1F_8000),
        ),
        (
            "station1",
            MemberKind::Station,
            RingSettings::new(0x8080, 0x0F_8000),
        ),
    ];
    let n = specs.len();
    specs
        .iter()
        .enumerate()
        .map(|(k, (name, kind, s))| {
            let mut c = CoreConfig::new(name, *kind, k as u16, *s, period);
            c.upstream = Some(((k + n - 1) % n) as u16);
            c.check = match kind {
                MemberKind::Card => crate::check::RingCheck::card(16, 2, 4, 2),
                MemberKind::Station => crate::check::RingCheck::station(8, 4, 4),
            };
            c.holdover_grace_ns = Some(timeout.as_nanos() as u64);
            let mut d = dcfg(name, *kind, k, cycles);
            d.clock = clock;
            d.member_timeout = timeout;
            if k > 0 {
                d.max_cycles = None;
            }
            let app = Probe {
                master: k == 0,
                ..Probe::default()
            };
            (c, app, d)
        })
        .collect()
}

fn run_to_end(
    members: Vec<(CoreConfig, Probe, DriverConfig)>,
    bound: Duration,
) -> Vec<super::local::MemberResult<Probe>> {
    let r = LocalRing::start(members, LocalTransport::Loopback).unwrap();
    r.join_member(0, bound)
}

#[test]
fn paced_and_lockstep_give_the_same_trajectory_cycle_for_cycle() {
    let cycles = 500;
    let lock = run_to_end(
        checked_ring(ClockMode::Lockstep, cycles, Duration::from_secs(1)),
        Duration::from_secs(60),
    );
    let started = std::time::Instant::now();
    let paced = run_to_end(
        checked_ring(ClockMode::Paced, cycles, Duration::from_secs(1)),
        Duration::from_secs(60),
    );
    let elapsed = started.elapsed();
    // The paced clock never runs ahead of the wall clock (a lower bound: load cannot break it).
    let period = 1e9 / RATE;
    assert!(
        elapsed.as_nanos() as f64 >= (cycles - 1) as f64 * period,
        "{cycles} paced cycles took only {elapsed:?}"
    );
    // Same cycles, same ring time, same feedback, at every member.
    for (a, b) in lock.iter().zip(&paced) {
        let n = a.app.seen.len().min(b.app.seen.len());
        assert!(n >= cycles as usize - 2, "{}: {n}", a.core.name());
        assert_eq!(a.app.seen[..n], b.app.seen[..n], "{}", a.core.name());
        for (c, t, _, fault) in &a.app.seen[..n] {
            assert_eq!(*t, c * period as u64, "ring time is cycle x period");
            assert!(!fault);
        }
    }
    let sm = &paced[0].app.seen;
    assert_eq!(sm.len(), cycles as usize);
    // Feedback: the station answers command + 7, latched 3 cycles later.
    assert_eq!(sm[100].2, (97 * 3 + 7) as u32);
}

#[test]
fn a_stall_of_any_length_under_the_member_timeout_is_no_ring_error() {
    // station0 stalls 150 ms in cycle 300 (a descheduled process; three times the old 50 ms
    // lockstep timeout): in paced and lockstep mode the ring waits, then catches up.
    for clock in [ClockMode::Paced, ClockMode::Lockstep] {
        let mut m = checked_ring(clock, 1000, Duration::from_secs(2));
        m[1].1.stall_at = Some((300, Duration::from_millis(150)));
        // Everyone stops after the same cycle (no one sees a closed link at the end).
        for (_, _, d) in &mut m {
            d.max_cycles = Some(1000);
        }
        let out = run_to_end(m, Duration::from_secs(240));
        for r in &out {
            let s = r.core.status();
            assert_eq!(s.errors, Default::default(), "{clock:?} {}", s.name);
            assert!(!s.ring_fault && s.ring_fault_count == 0, "{clock:?} {s:?}");
            // No cycle skipped: consecutive ticks.
            let cycles: Vec<u64> = r.app.seen.iter().map(|t| t.0).collect();
            assert!(cycles.windows(2).all(|w| w[1] == w[0] + 1), "{clock:?}");
        }
        let sm = out[0].core.status();
        assert_eq!(out[0].app.seen.len(), 1000);
        if clock == ClockMode::Paced {
            // The stall made cycles late (counted) and the missed ones ran back to back.
            assert!(sm.late_cycles > 10, "{sm:?}");
        } else {
            assert_eq!(sm.late_cycles, 0);
        }
    }
}

/// Cycle at which member `r` latched its ring fault, and the cycle its input went dark.
fn fault_and_dark(r: &super::local::MemberResult<Probe>) -> (Option<u64>, Option<u64>) {
    let s = r.core.status();
    (s.ring_fault_cycle, s.dark_since_cycle)
}

#[test]
fn a_dead_member_is_loss_of_light_downstream_and_the_ring_keeps_cycling() {
    for clock in [ClockMode::Paced, ClockMode::Lockstep] {
        let mut m = checked_ring(clock, 700, Duration::from_secs(5));
        // station0's process "dies" after 200 cycles; card1 learns it from liveliness.
        m[1].2.max_cycles = Some(200);
        let dead = Arc::new(AtomicBool::new(false));
        m[2].2.upstream_dead = Some(Arc::clone(&dead));
        let r = LocalRing::start(m, LocalTransport::Loopback).unwrap();
        let t0 = std::time::Instant::now();
        while !r.is_finished(1) && t0.elapsed() < Duration::from_secs(30) {
            std::thread::sleep(Duration::from_millis(2));
        }
        dead.store(true, Ordering::Relaxed);
        let dead_at = std::time::Instant::now();
        let out = r.join_member(0, Duration::from_secs(240));
        let own_clock = dead_at.elapsed();
        assert!(matches!(out[0].exit, DriverExit::Done), "{:?}", out[0].exit);
        // The ring kept cycling on card1's own clock: card0 ran all its cycles.
        assert_eq!(out[0].app.seen.len(), 700, "{clock:?}");
        let card1 = out[2].core.status();
        assert!(card1.dark && card1.errors.byte_violation > 100, "{card1:?}");
        let dark_at = card1.dark_since_cycle.expect("dark since");
        assert!((200..=202).contains(&dark_at), "{clock:?} {card1:?}");
        // Every member downstream of the dead one, and the sync master, count the cycles:
        // cards fault on the second RTI with an error (I1004 = 2, RTI = 3 cycles), stations
        // on the fifth cycle with errors.
        for (i, bound) in [(2usize, 6u64), (3, 5), (0, 7)] {
            let (f, d) = fault_and_dark(&out[i]);
            let f = f.unwrap_or_else(|| panic!("{clock:?}: member {i} did not fault"));
            let from = d.unwrap_or(dark_at);
            assert!(
                f >= from && f - from <= bound,
                "{clock:?}: member {i} faulted at {f}, dark from {from}"
            );
        }
        let sm = out[0].clock.clone().unwrap();
        assert!(!sm.ring_down, "{sm:?}");
        // card1's own clock keeps the nominal rate (it goes on a little while the others stop
        // after the sync master's last cycle): no more cycles than the wall time allows. (Not
        // compared with the sync master's count: on a loaded machine the ring may run slower.)
        let c1 = out[2].core.cycle();
        let allowed = 210.0 + own_clock.as_secs_f64() * RATE * 1.1 + 50.0;
        assert!(
            (c1 as f64) < allowed,
            "{clock:?}: card1 at {c1} after {own_clock:?} on its own clock"
        );
    }
}

#[test]
fn a_frozen_member_takes_the_ring_down_after_the_member_timeout_and_back_when_thawed() {
    let timeout = Duration::from_millis(300);
    let mut m = checked_ring(ClockMode::Paced, 4000, timeout);
    m[1].1.stall_at = Some((200, Duration::from_millis(1200)));
    let out = run_to_end(m, Duration::from_secs(240));
    // The ring waited the member timeout once, then kept cycling: on card1's own clock (its
    // dark frames come round) or, if nothing came back first, on the sync master's.
    let sm = out[0].clock.clone().unwrap();
    assert!(!sm.ring_down, "{sm:?}");
    // (card1's wait starts at its last frame, up to a period before the master's last start.)
    // (No upper bound: on a loaded machine the longest stall may be the load's own.)
    let waited = Duration::from_micros(sm.longest_stall_us + 1000);
    assert!(waited >= timeout, "{sm:?}");
    assert!(sm.lost_ms + 10 >= 300, "{sm:?}");
    assert_eq!(out[0].app.seen.len(), 4000);
    // Everyone but the frozen member latched: card0 counted the silence on its own clock,
    // card1 and station1 saw loss of light after the wait.
    for i in [0usize, 2, 3] {
        let s = out[i].core.status();
        assert!(s.ring_fault_count >= 1, "{s:?}");
    }
    let card1 = out[2].core.status();
    assert!(card1.errors.byte_violation > 0, "{card1:?}");
    // Thawed, the frozen member's light is back: everyone received light (sync packets of the
    // sync master's count) up to its last cycles. (After its last cycle the members see loss of
    // light: the sync master has stopped first.)
    for r in &out[1..] {
        let s = r.core.status();
        assert!(s.last_rx_cycle.is_some_and(|c| c >= 3990), "{s:?}");
        assert!(s.dark_since_cycle.is_none_or(|c| c >= 3999), "{s:?}");
    }
}

#[test]
fn a_stopped_upstream_process_is_loss_of_light_at_once_not_after_the_member_timeout() {
    // station0 stalls 1.5 s in cycle 200 while card1's stop probe sees a stopped process (a
    // SIGSTOPped `sleep` stands in for station0's process): card1 goes dark ~20 ms into the
    // silence, the ring keeps cycling on its clock, and nobody waits the 10 s member timeout.
    let mut sleeper = std::process::Command::new("sleep")
        .arg("60")
        .spawn()
        .expect("spawn sleep");
    let pid = sleeper.id();
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(pid as i32),
        nix::sys::signal::Signal::SIGSTOP,
    )
    .unwrap();
    let timeout = Duration::from_secs(10);
    let mut m = checked_ring(ClockMode::Paced, 2500, timeout);
    m[1].1.stall_at = Some((200, Duration::from_millis(1500)));
    m[2].2.upstream_probe = Some(super::light::StopProbe::with_pid(pid));
    let out = run_to_end(m, Duration::from_secs(240));
    let _ = sleeper.kill();
    let _ = sleeper.wait();
    let sm = out[0].clock.clone().unwrap();
    // Nobody waited the member timeout (the longest stall may include the load's own).
    assert!(
        sm.longest_stall_us < timeout.as_micros() as u64,
        "the ring waited for the stalled member: {sm:?}"
    );
    assert_eq!(sm.ring_down_count, 0, "{sm:?}");
    let card1 = out[2].core.status();
    assert!(card1.ring_fault_count >= 1, "{card1:?}");
    assert!(card1.errors.byte_violation > 0, "{card1:?}");
    assert!(out[0].core.status().ring_fault_count >= 1);
}

#[test]
fn a_liveliness_flap_of_an_upstream_whose_process_is_still_there_is_no_loss_of_light() {
    // card1's watch says station0 went away (its zenoh lease expired during a stall, say), but
    // station0's process is still there (this test process stands in for it): no loss of
    // light, no error anywhere. Without a process to look at (another machine) the flag
    // counts, as `a_dead_member_is_loss_of_light...` shows.
    //
    // Robust to scheduling delays: until the first frame comes back, the sync master starts a
    // cycle every 20 ms (`BRINGUP_RETRY_NS`), so followers that a loaded machine leaves
    // unscheduled for some 300 ms at start-up made card0's check (I1001 = 16) miss its syncs.
    // As in a member process, each check starts once its member is locked; a loss of light at
    // card1 still shows (byte violations, `dark`, and card1 never locks).
    let mut m = checked_ring(ClockMode::Lockstep, 600, Duration::from_secs(10));
    for (c, _, d) in &mut m {
        c.check_after_lock = true;
        d.max_cycles = Some(600);
    }
    m[2].2.upstream_dead = Some(Arc::new(AtomicBool::new(true)));
    m[2].2.upstream_probe = Some(super::light::StopProbe::with_pid(std::process::id()));
    let out = run_to_end(m, Duration::from_secs(240));
    assert_eq!(out[0].app.seen.len(), 600);
    for r in &out {
        let s = r.core.status();
        assert_eq!(s.errors, Default::default(), "{}", s.name);
        assert!(s.locked && !s.dark && s.ring_fault_count == 0, "{s:?}");
    }
}

#[test]
fn a_ring_slower_than_its_period_comes_back_after_a_frozen_member() {
    // Across hosts the round trip can exceed a period: station1 takes 3 ms per cycle at
    // 2258.7 Hz (0.44 ms; its receive queue drains within the member timeout). When station1
    // freezes, the sync master runs on its own clock,
    // several of its cycles are then in flight at once, and the first of them that comes
    // back lit must end the ring down (not only a frame of the current cycle, which can
    // never come back first).
    let timeout = Duration::from_millis(1000);
    let mut m = checked_ring(ClockMode::Paced, 3000, timeout);
    // station1 (card0's upstream) freezes: nothing comes back to card0 at all.
    m[3].1.stall_at = Some((200, Duration::from_millis(2000)));
    m[3].1.slow = Some(Duration::from_millis(3));
    // The sync master runs until light has come back (its input lit, a frame of one of its
    // last 10 cycles received) past cycle 3000, not a fixed count: how many cycles it runs
    // on its own clock before station1 thaws depends on the machine's load. 120 s bound.
    m[0].2.max_cycles = None;
    let r = LocalRing::start(m, LocalTransport::Loopback).unwrap();
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    let back = |s: &MemberStatus| {
        s.cycle >= 3000 && !s.dark && s.last_rx_cycle.is_some_and(|c| c + 10 >= s.cycle)
    };
    while std::time::Instant::now() < deadline && !r.status(0).is_some_and(|s| back(&s)) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = r.stop();
    let sm = out[0].clock.clone().unwrap();
    assert!(!sm.ring_down && sm.ring_down_count >= 1, "{sm:?}");
    let seen = &out[0].app.seen;
    assert!(seen.len() >= 3000, "{}", seen.len());
    assert!(seen.iter().enumerate().all(|(k, e)| e.0 == k as u64));
    // Light came back all round: the sync master's input is lit and recent.
    let s = out[0].core.status();
    assert!(back(&s), "{s:?}");
}
