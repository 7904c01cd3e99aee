//! Servo-tick benchmark (issue 4 item 10): the whole card servo cycle ([`Servo::tick`]:
//! ECT, actions, 8 closed-loop motors jogging back and forth, registers, reports, aux copy)
//! over a minimal in-memory plant that stands in for the ring and the station, timed per tick.
//! Per-motor cost = tick time / 8; the share of one core = tick time × 2258.7 Hz.

use std::fmt;
use std::time::Instant;

use crate::core::rig::{bench_card, LoopbackPlant, MOTORS, NODES};
use crate::lang::interp::Session;
use crate::servo::Servo;

/// Servo rate the share of a core is computed for, Hz.
pub const RATE_HZ: f64 = 2258.7;

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
