//! `mcc bench soak --minutes N [--clock paced|lockstep|realtime] [--cards C --stations S]
//! [--rtf X] [--load K]`: a cluster of its own (real member processes) runs for N minutes
//! while a bare OS timer probe sleeps to absolute deadlines at the same wall period beside it
//! (and, with `--load`, K CPU-bound threads compete for the cores). Reports ring faults and
//! receive errors (a paced or lockstep ring must have none), the real-time factor achieved, late
//! cycles, the sync master's start lag p50/p99/max, lost time and the longest stall, next to
//! the probe's lateness and longest gap.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use mcc_contracts::config::{ClockMode, ClusterConfig};
use mcc_ring::control::{ClockReport, MemberStatus};
use mcc_ring::runtime::timing::LagHistogram;

use crate::cli::BenchSoakArgs;
use crate::cluster::ctl::query_statuses;
use crate::verbs::bench::syncstart::with_cluster;

/// What the OS timer probe saw.
#[derive(Debug, Default)]
struct Probe {
    lateness: LagHistogram,
    max_late_ns: u64,
    longest_gap_ns: u64,
}

/// Sleep to each absolute deadline `period_ns` apart until `stop`; record wake − deadline and
/// the longest gap between wakes.
fn timer_probe(period_ns: u64, stop: &AtomicBool) -> Probe {
    let mut p = Probe::default();
    let start = Instant::now();
    let mut last = start;
    let mut k: u64 = 1;
    while !stop.load(Ordering::Relaxed) {
        let deadline = start + Duration::from_nanos(period_ns.saturating_mul(k));
        let now = Instant::now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        }
        let woke = Instant::now();
        let late = woke.saturating_duration_since(deadline).as_nanos() as u64;
        p.lateness.add(late / 1000);
        p.max_late_ns = p.max_late_ns.max(late);
        p.longest_gap_ns = p
            .longest_gap_ns
            .max(woke.saturating_duration_since(last).as_nanos() as u64);
        last = woke;
        // A probe far behind (stopped) resumes from the present, as the paced clock re-bases.
        let behind = woke.saturating_duration_since(start).as_nanos() as u64 / period_ns.max(1);
        k = (k + 1).max(behind);
    }
    p
}

/// Receive errors of one member (byte violations, checksum, overruns, underruns).
fn receive_errors(m: &MemberStatus) -> u64 {
    let x = &m.errors;
    x.byte_violation + x.checksum + x.overrun + x.underrun
}

/// Ring-fault counts of the members that answered, and their receive errors since `base`
/// (members counted only where both documents have them: a member slow to answer one poll
/// never makes the sum go back).
fn faults_and_errors_since(
    base: &[Option<MemberStatus>],
    st: &[Option<MemberStatus>],
) -> (u64, u64) {
    let faults = st.iter().flatten().map(|m| m.ring_fault_count).sum();
    let errors = base
        .iter()
        .zip(st)
        .filter_map(|(b, n)| {
            Some(receive_errors(n.as_ref()?).saturating_sub(receive_errors(b.as_ref()?)))
        })
        .sum();
    (faults, errors)
}

/// Run the soak and print the report.
pub fn run(args: &BenchSoakArgs) -> Result<()> {
    let mut cfg = match &args.config {
        Some(path) => ClusterConfig::from_file(path)?,
        None => ClusterConfig::default_cluster(
            usize::from(args.cards.unwrap_or(2)),
            usize::from(args.stations.unwrap_or(2)),
        ),
    };
    cfg.cluster = format!("bench-soak-{}", std::process::id());
    if let Some(c) = args.clock {
        cfg.clock = c;
    }
    let clock = cfg.clock;
    if let Some(rtf) = args.rtf {
        cfg.rtf = rtf;
    }
    let cfg = cfg
        .resolve()
        .map_err(|e| anyhow::anyhow!("{e}").context("bench soak"))?;
    let seconds = args.seconds.unwrap_or(args.minutes * 60.0);
    if !seconds.is_finite() || seconds <= 0.0 || seconds > 7.0 * 86_400.0 {
        bail!("--minutes/--seconds: {seconds} s is not a duration between 0 and 7 days");
    }
    let run_for = Duration::from_secs_f64(seconds);
    let period = cfg.wall_period_ns().max(1);
    println!(
        "bench soak: {} clock{}, {} Hz, {} cards + {} stations, {:.0} s, {} CPU-bound threads beside it",
        clock.as_str(),
        if clock == ClockMode::Paced {
            format!(" at rtf {}", cfg.rtf)
        } else {
            String::new()
        },
        cfg.rate_hz,
        cfg.cards.len(),
        cfg.stations.len(),
        seconds,
        args.load
    );
    with_cluster(cfg, |sup, cfg| {
        let s = sup.session().clone();
        let stop = Arc::new(AtomicBool::new(false));
        let load: Vec<_> = (0..args.load)
            .map(|_| {
                let stop = Arc::clone(&stop);
                std::thread::spawn(move || {
                    let mut x: u64 = 1;
                    while !stop.load(Ordering::Relaxed) {
                        x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                        std::hint::black_box(x);
                    }
                })
            })
            .collect();
        let probe = {
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || timer_probe(period, &stop))
        };
        let poll = |d: Duration| query_statuses(&s, cfg, d, d * 2);
        // The baseline: a poll every member answered (a few tries on a loaded machine).
        let mut first = poll(Duration::from_millis(700));
        for _ in 0..10 {
            if first.iter().all(Option::is_some) {
                break;
            }
            first = poll(Duration::from_millis(700));
        }
        let sm_index = cfg.position(&cfg.ring.sync_master).unwrap_or(0);
        let sm = |st: &[Option<MemberStatus>]| -> Option<(u64, ClockReport)> {
            let m = st.get(sm_index)?.as_ref()?;
            Some((m.cycle, m.clock.clone()?))
        };
        let c0 = sm(&first).map(|(c, _)| c).unwrap_or(0);
        let t0 = Instant::now();
        let mut min_rtf = f64::INFINITY;
        let mut last = first.clone();
        let mut next_print = Duration::from_secs(60);
        while t0.elapsed() < run_for {
            std::thread::sleep(Duration::from_secs(1).min(run_for.saturating_sub(t0.elapsed())));
            let st = poll(Duration::from_millis(700));
            if let Some((_, t)) = sm(&st) {
                if t0.elapsed() > Duration::from_secs(2) {
                    min_rtf = min_rtf.min(t.rtf);
                }
            }
            if t0.elapsed() >= next_print {
                next_print += Duration::from_secs(60);
                let (f, e) = faults_and_errors_since(&first, &st);
                let answered = st.iter().flatten().count();
                println!(
                    "  {:>5.0} s: {} ring faults, {} receive errors, rtf {}{}",
                    t0.elapsed().as_secs_f64(),
                    f,
                    e,
                    sm(&st)
                        .map(|(_, t)| format!("{:.3}", t.rtf))
                        .unwrap_or("? (the sync master was slow to answer)".into()),
                    if answered < st.len() {
                        format!(" ({answered} of {} members answered this poll)", st.len())
                    } else {
                        String::new()
                    }
                );
            }
            if st.iter().all(Option::is_some) {
                last = st;
            }
        }
        let wall = t0.elapsed();
        stop.store(true, Ordering::Relaxed);
        for t in load {
            let _ = t.join();
        }
        let probe = probe.join().unwrap_or_default();
        // Ring faults since the members started (bring-up included); errors during the soak.
        let (f1, e1) = faults_and_errors_since(&first, &last);
        let Some((c1, clock_report)) = sm(&last) else {
            bail!("the sync master did not report its clock at the end");
        };
        let faulted: Vec<&str> = last
            .iter()
            .flatten()
            .filter(|m| m.ring_fault_count > 0)
            .map(|m| m.name.as_str())
            .collect();
        let nominal = cfg.period_ns() as f64;
        let cycles = c1.saturating_sub(c0);
        let rtf = cycles as f64 * nominal / wall.as_nanos() as f64;
        let ms = |us: u64| us as f64 / 1000.0;
        println!(
            "  ring faults: {} ({}), receive errors during the soak: {}",
            f1,
            if faulted.is_empty() {
                "no member latched one".to_string()
            } else {
                format!("latched by {}", faulted.join(", "))
            },
            e1
        );
        println!(
            "  ring cycles: {cycles} in {:.1} s: achieved rtf {rtf:.3} over the run, lowest rtf over a second {:.3}",
            wall.as_secs_f64(),
            if min_rtf.is_finite() { min_rtf } else { rtf }
        );
        let t = &clock_report;
        println!(
            "  late cycles: {} ({:.2} %); start lag p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms; lost {} ms in {} re-bases; ring down {} times",
            t.late_cycles,
            100.0 * t.late_cycles as f64 / (c1.max(1)) as f64,
            ms(t.lag_p50_us),
            ms(t.lag_p99_us),
            ms(t.max_lag_us),
            t.lost_ms,
            t.rebases,
            t.ring_down_count
        );
        println!(
            "  longest stall: ring {:.1} ms between two cycle starts; OS timer probe at the same period: lateness p50 {:.3} ms, p99 {:.3} ms, max {:.1} ms, longest gap {:.1} ms",
            ms(t.longest_stall_us),
            ms(probe.lateness.quantile(0.5)),
            ms(probe.lateness.quantile(0.99)),
            probe.max_late_ns as f64 / 1e6,
            probe.longest_gap_ns as f64 / 1e6
        );
        if let Some(m) = last.iter().flatten().find_map(|m| m.sched.clone()) {
            println!("  scheduling: {m}");
        }
        println!(
            "  frozen-member wait {} ms: margin {:.1}× over the longest stall",
            cfg.member_timeout_ms,
            cfg.member_timeout_ms as f64 * 1000.0 / t.longest_stall_us.max(1) as f64
        );
        if clock.is_stepped() && f1 > 0 {
            bail!(
                "{} ring fault(s) on a {} ring: scheduling must never make ring errors",
                f1,
                clock.as_str()
            );
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn member(faults: u64, underruns: u64) -> Option<MemberStatus> {
        let mut m = MemberStatus {
            ring_fault_count: faults,
            ..MemberStatus::default()
        };
        m.errors.underrun = underruns;
        Some(m)
    }

    #[test]
    fn a_member_missing_from_a_poll_never_makes_the_error_count_go_back() {
        let base = vec![member(0, 24), member(0, 0)];
        // The first member did not answer this poll: its 24 baseline errors are not
        // subtracted from the second's (the report once printed 2^64 - 24).
        let (f, e) = faults_and_errors_since(&base, &[None, member(1, 3)]);
        assert_eq!((f, e), (1, 3));
        let (f, e) = faults_and_errors_since(&base, &[member(0, 30), member(0, 3)]);
        assert_eq!((f, e), (0, 9));
        // A member missing from the baseline is not counted at all.
        let (_, e) = faults_and_errors_since(&[None, member(0, 0)], &[member(0, 5), member(0, 1)]);
        assert_eq!(e, 1);
    }
}
