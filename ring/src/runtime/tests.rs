//! Runtime tests: whole rings of driver threads over the loopback transport, lockstep.

use std::time::Duration;

use super::driver::{DriverConfig, DriverExit};
use super::local::{LocalRing, LocalTransport};
use crate::config::ClockMode;
use crate::control::MemberKind;
use crate::core::{CoreConfig, RingApp};
use crate::member::RingMember;
use crate::settings::RingSettings;

/// Sync master commanding node 0 with the cycle number; records what comes back.
#[derive(Debug, Default)]
struct Master {
    seen: Vec<(u64, u32)>,
}

impl RingApp for Master {
    fn tick(&mut self, cycle: u64, _t: u64, regs: &mut RingMember, _fault: bool) {
        self.seen.push((cycle, regs.read_regs(0).r0));
        regs.write_regs_mut(0).r0 = (cycle & 0xFF_FFFF) as u32;
    }
}

/// Slave on node 0: feedback = command + 1.
#[derive(Debug, Default)]
struct Plus1 {
    ticks: u64,
}

impl RingApp for Plus1 {
    fn tick(&mut self, _c: u64, _t: u64, regs: &mut RingMember, _fault: bool) {
        self.ticks += 1;
        let cmd = regs.read_regs(0).r0;
        regs.write_regs_mut(0).r0 = (cmd + 1) & 0xFF_FFFF;
    }
}

enum App {
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
        lockstep_timeout: Duration::from_millis(200),
        max_cycles: Some(cycles),
        kind,
        position,
        extra: serde_json::Map::new(),
        record: 0,
        phase_delay_ns: 0,
    }
}

fn ring(cycles: u64) -> Vec<(CoreConfig, App, DriverConfig)> {
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
        // (Silence is expected at the end: the sync master stops first; cards count it as
        // underruns, stations as byte violations, loss of light.)
        assert_eq!(s.errors.checksum, 0);
        if s.kind == Some(MemberKind::Card) {
            assert_eq!(s.errors.byte_violation, 0);
        }
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
