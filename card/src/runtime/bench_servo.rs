//! Servo-tick benchmark (issue 4 item 10): the whole card servo cycle ([`Servo::tick`]:
//! ECT, actions, 8 closed-loop motors jogging back and forth, registers, reports, aux copy)
//! over a minimal in-memory plant that stands in for the ring and the station, timed per tick.
//! Per-motor cost = tick time / 8; the share of one core = tick time × 2258.7 Hz.

use std::fmt;
use std::time::Instant;

use crate::core::rig::{bench_card, LoopbackPlant, MOTORS, NODES};
use crate::lang::Session;
use crate::servo::Servo;

/// Servo rate the share of a core is computed for, Hz.
pub(crate) const RATE_HZ: f64 = 2258.7;

/// Result of [`run_servo_bench`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoBenchReport {
    /// Ticks timed.
    pub ticks: usize,
    /// Per-motor cost, median, ns.
    pub per_motor_p50_ns: f64,
    /// Per-motor cost, 99th percentile, ns.
    pub per_motor_p99_ns: f64,
    /// Share of one core used by 8 motors at 2258.7 Hz (median tick), percent.
    pub core_share_p50_pct: f64,
    /// Same at the 99th-percentile tick, percent.
    pub core_share_p99_pct: f64,
}

impl fmt::Display for ServoBenchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "servo tick ({MOTORS} motors closed loop, jogging; {} ticks):",
            self.ticks
        )?;
        writeln!(
            f,
            "  per motor: p50 {:.0} ns, p99 {:.0} ns",
            self.per_motor_p50_ns, self.per_motor_p99_ns
        )?;
        write!(
            f,
            "  {MOTORS} motors at {RATE_HZ} Hz: {:.2} % of one core (p50), {:.2} % (p99); target < 5 %",
            self.core_share_p50_pct, self.core_share_p99_pct
        )
    }
}

fn percentile(sorted: &[u64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i.min(sorted.len() - 1)] as f64
}

/// Run the benchmark (about 20,000 servo ticks).
pub fn run_servo_bench() -> ServoBenchReport {
    let mut card = bench_card();
    let mut servo = Servo::new(&card.model);
    let mut plant = LoopbackPlant::default();
    let mut s = Session::default();
    let ticks = 20_000usize;
    let mut times = Vec::with_capacity(ticks);
    for c in 0..(ticks + 200) as u64 {
        if c % 4000 == 2 {
            for m in 1..=MOTORS {
                let target = if (c / 4000) % 2 == 0 { 10_000 } else { 0 };
                let line = format!("#{m}J={target}");
                let _ = card.command_line(&mut s, line.as_bytes());
            }
        }
        plant.step(&mut card.model, &NODES);
        let t0 = Instant::now();
        let (model, mut cmds) = card.split();
        servo.tick(model, &mut cmds, c);
        let dt = t0.elapsed().as_nanos() as u64;
        if c >= 200 {
            times.push(dt);
        }
    }
    times.sort_unstable();
    let p50 = percentile(&times, 0.5);
    let p99 = percentile(&times, 0.99);
    ServoBenchReport {
        ticks,
        per_motor_p50_ns: p50 / MOTORS as f64,
        per_motor_p99_ns: p99 / MOTORS as f64,
        core_share_p50_pct: p50 * RATE_HZ / 1e9 * 100.0,
        core_share_p99_pct: p99 * RATE_HZ / 1e9 * 100.0,
    }
}

/// Servo ticks per phase of [`run_servo_load_bench`].
pub(crate) const LOAD_TICKS: usize = 4_000;

/// Timing of one phase of the load benchmark, ns.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PhaseTiming {
    /// Servo tick alone (ECT, motors, programs): p50.
    pub tick_p50: f64,
    /// Servo tick alone: p99.
    pub tick_p99: f64,
    /// Servo tick plus the host slice served after it (the servo thread's busy time): p99.
    pub busy_p99: f64,
    /// The same: the worst cycle.
    pub busy_max: f64,
    /// Tick start after its scheduled time (sleep to a deadline, spin the last 60 µs): p99.
    pub late_p99: f64,
    /// Host requests answered during the phase.
    pub replies: u64,
}

/// Result of [`run_servo_load_bench`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ServoLoadReport {
    /// No host traffic.
    pub idle: PhaseTiming,
    /// Hosts hammering SAVE and the heaviest legal lines.
    pub loaded: PhaseTiming,
    /// Heavy lines (1 KB of `P0..8191` on a Turbo card) answered during the loaded phase.
    pub heavy_lines: u64,
    /// SAVEs acknowledged during the loaded phase.
    pub saves: u64,
}

impl fmt::Display for ServoLoadReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let us = |ns: f64| ns / 1000.0;
        writeln!(
            f,
            "servo tick under host load (turbo card, 8 motors jogging, {LOAD_TICKS} ticks per phase at {RATE_HZ} Hz):"
        )?;
        for (name, p) in [("idle  ", &self.idle), ("loaded", &self.loaded)] {
            writeln!(
                f,
                "  {name}: tick p50 {:.1} µs p99 {:.1} µs; tick+host slice p99 {:.1} µs max {:.1} µs; start late p99 {:.1} µs; {} replies",
                us(p.tick_p50),
                us(p.tick_p99),
                us(p.busy_p99),
                us(p.busy_max),
                us(p.late_p99),
                p.replies
            )?;
        }
        write!(
            f,
            "  load: {} heavy lines (1 KB of P0..8191) and {} SAVEs served; tick p99 loaded/idle = {:.2}, busy max {:.0} % of the {:.0} µs period",
            self.heavy_lines,
            self.saves,
            self.loaded.tick_p99 / self.idle.tick_p99.max(1.0),
            self.loaded.busy_max / (1e9 / RATE_HZ) * 100.0,
            1e6 / RATE_HZ
        )
    }
}

/// A Turbo card with motors 1-8 on their MACRO nodes (the rig's wiring on the Turbo tables).
fn turbo_card() -> crate::lang::Card {
    let mut card = crate::lang::Card::new(crate::domain::Profile::Turbo);
    let mut s = Session::default();
    let _ = card.command_line(&mut s, b"I1000=$3333 I1002=$3333");
    for m in 1..=MOTORS {
        let _ = card.command_line(&mut s, format!("I{m}00=1").as_bytes());
    }
    card
}

fn phase(
    runner: &mut crate::service::handle::Runner,
    plant: &mut LoopbackPlant,
    cycle0: u64,
    replies: &std::sync::atomic::AtomicU64,
) -> PhaseTiming {
    use crate::lang::Budget;
    let period = std::time::Duration::from_secs_f64(1.0 / RATE_HZ);
    let (mut tick, mut busy, mut late) = (Vec::new(), Vec::new(), Vec::new());
    let r0 = replies.load(std::sync::atomic::Ordering::Relaxed);
    let start = Instant::now();
    for k in 0..LOAD_TICKS {
        let due = start + period * k as u32;
        // Sleep to the deadline, spin the last 60 µs (as the ring driver does).
        loop {
            let now = Instant::now();
            if now >= due {
                break;
            }
            let left = due - now;
            if left > std::time::Duration::from_micros(60) {
                std::thread::sleep(left - std::time::Duration::from_micros(60));
            } else {
                std::hint::spin_loop();
            }
        }
        let t0 = Instant::now();
        late.push(t0.duration_since(due).as_nanos() as u64);
        let c = cycle0 + k as u64;
        if c % 2000 == 2 {
            for m in 1..=MOTORS {
                let target = if (c / 2000) % 2 == 0 { 10_000 } else { 0 };
                let line = format!("#{m}J={target}");
                let _ = runner
                    .core
                    .card
                    .command_line(&mut Session::default(), line.as_bytes());
            }
        }
        plant.step(&mut runner.core.card.model, &NODES);
        runner.core.tick(c);
        let t1 = Instant::now();
        runner.pump(&mut Budget::new(crate::core::SLICE_UNITS));
        let t2 = Instant::now();
        tick.push(t1.duration_since(t0).as_nanos() as u64);
        busy.push(t2.duration_since(t0).as_nanos() as u64);
    }
    for v in [&mut tick, &mut busy, &mut late] {
        v.sort_unstable();
    }
    PhaseTiming {
        tick_p50: percentile(&tick, 0.5),
        tick_p99: percentile(&tick, 0.99),
        busy_p99: percentile(&busy, 0.99),
        busy_max: busy.last().copied().unwrap_or(0) as f64,
        late_p99: percentile(&late, 0.99),
        replies: replies.load(std::sync::atomic::Ordering::Relaxed) - r0,
    }
}

/// The servo thread's timing with no host traffic, then while two hosts send SAVE after SAVE
/// (to a real file, written by the I/O thread) and one sends 1 KB lines of `P0..8191` over and
/// over: the tick must not change and the host work after each tick stays within its slice.
pub fn run_servo_load_bench() -> std::io::Result<ServoLoadReport> {
    use crate::core::{CardCore, HostRequest};
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
    use std::sync::Arc;
    let dir = std::env::temp_dir().join(format!("mcc-bench-servo-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let storage = crate::service::storage::FileStorage::new(dir.join("card.sav"));
    let (mut runner, handle) =
        crate::service::handle::channel(CardCore::new(turbo_card()), Some(storage));
    let mut plant = LoopbackPlant::default();
    let replies = Arc::new(AtomicU64::new(0));
    let idle = phase(&mut runner, &mut plant, 0, &replies);
    let stop = Arc::new(AtomicBool::new(false));
    let (heavy, saves) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
    let mut line = Vec::new();
    while line.len() + 9 <= 1024 {
        line.extend_from_slice(b"P0..8191 ");
    }
    let mut hosts = Vec::new();
    for kind in 0..3 {
        let (h, stop, replies) = (handle.clone(), Arc::clone(&stop), Arc::clone(&replies));
        let (heavy, saves, line) = (Arc::clone(&heavy), Arc::clone(&saves), line.clone());
        hosts.push(std::thread::spawn(move || {
            let conn = h.new_conn();
            while !stop.load(Ordering::Relaxed) {
                let req = if kind == 0 {
                    HostRequest::Line(line.clone())
                } else {
                    HostRequest::Line(b"SAVE".to_vec())
                };
                let r = h.host(conn, req);
                if r.bytes.is_empty() {
                    continue;
                }
                replies.fetch_add(1, Ordering::Relaxed);
                if kind == 0 {
                    heavy.fetch_add(1, Ordering::Relaxed);
                } else if r.error.is_none() {
                    saves.fetch_add(1, Ordering::Relaxed);
                }
            }
        }));
    }
    let loaded = phase(&mut runner, &mut plant, LOAD_TICKS as u64, &replies);
    stop.store(true, Ordering::Relaxed);
    // Let the hosts' last requests finish.
    let deadline = Instant::now() + std::time::Duration::from_secs(30);
    while hosts.iter().any(|h| !h.is_finished()) && Instant::now() < deadline {
        runner.pump(&mut crate::lang::Budget::new(crate::core::SLICE_UNITS * 8));
        std::thread::sleep(std::time::Duration::from_micros(200));
    }
    for h in hosts {
        let _ = h.join();
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(ServoLoadReport {
        idle,
        loaded,
        heavy_lines: heavy.load(Ordering::Relaxed),
        saves: saves.load(Ordering::Relaxed),
    })
}
