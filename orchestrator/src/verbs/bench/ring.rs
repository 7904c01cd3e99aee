//! `mcc bench ring`:
//! (0) the floor ([`super::floor`]): two processes configured as ring members bouncing a
//!     frame over zenoh, back to back and paced at the ring rate — one-way latency and CPU per
//!     message — measured first in the same run; the cluster figures below are given as ratios
//!     to it;
//! (a) lockstep throughput of real multi-process clusters as users run them (`mcc up --clock
//!     lockstep`, cycles counted from the sync master's status) beside a raw UDP ring of as many
//!     processes, measured one after the other in the same run: cycles/s, hop latency (each
//!     member's status `hop`), CPU and context switches per cycle;
//! (b) what a cluster at real-time factor 1 costs: `mcc up` with the default clock, CPU per
//!     member;
//! (c) realtime sync-arrival lateness per member (in-process ring) beside a bare OS timer probe
//!     run at the same time;
//! (d) across hosts: one ring on one machine, on two hosts peer to peer, and through `zenohd`
//!     (the hop cost of the router vs peer to peer; [`super::hosts`]);
//! (e) the same two hosts in network namespaces of their own, `zenohd` in a third: peer to peer
//!     and through the router in one run (root only, else SKIPPED; [`super::netns`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Result};
use mcc_contracts::config::ClockMode;

use super::cluster::{self, ClusterFigures, ClusterSpec};
use super::floor::{self, FloorFigures};
use super::stats::{complete_cycles, lateness, percentile, us};
use super::{hosts, inproc, netns, udp};
use crate::cli::BenchRingArgs;

/// Lockstep targets (issue 27) on the reference 2-core machine: cycles/s by (cards, stations,
/// `ring.in_flight`).
const TARGETS: [((u8, u8, u64), f64); 4] = [
    ((2, 2, 1), 5000.0),
    ((2, 2, 4), 8000.0),
    ((4, 8, 1), 1700.0),
    ((4, 8, 4), 2500.0),
];
/// Real-time factor 1 target (issue 27): the paced ring of (cards, stations) with this
/// `ring.in_flight` holds at least this real-time factor.
const RTF_TARGETS: [((u8, u8, u64), f64); 1] = [((4, 8, 2), 0.99)];
/// Hop latency target: a cluster's hop p50 at most this many times the floor's one-way p50.
const FLOOR_HOP_RATIO: f64 = 1.2;
/// CPU target at real-time factor 1: a member's CPU at most this many times the floor's CPU per
/// message × the ring rate.
const FLOOR_CPU_RATIO: f64 = 1.3;
/// Back-to-back round trips of the floor.
const FLOOR_MSGS: u64 = 20_000;

fn verdict(ok: bool) -> &'static str {
    if ok {
        "met"
    } else {
        "MISSED"
    }
}

/// Parse `1+1,2+2,4+8` into (cards, stations) pairs.
pub fn parse_sizes(text: &str) -> Result<Vec<(u8, u8)>> {
    let mut v = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((c, s)) = item.split_once('+') else {
            bail!("--sizes {item:?}: expected CARDS+STATIONS, e.g. 2+2");
        };
        let c: u8 = c
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("--sizes {item:?}: cards must be 1-16"))?;
        let s: u8 = s
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("--sizes {item:?}: stations must be 0-48"))?;
        if !(1..=16).contains(&c) || s > 48 {
            bail!("--sizes {item:?}: 1-16 cards and 0-48 stations");
        }
        v.push((c, s));
    }
    if v.is_empty() {
        bail!("--sizes: give at least one CARDS+STATIONS");
    }
    Ok(v)
}

/// Parse `1,4` into `ring.in_flight` settings (1-8).
pub fn parse_in_flight(name: &str, text: &str) -> Result<Vec<u64>> {
    let mut v = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let n: u64 = item
            .parse()
            .map_err(|_| anyhow::anyhow!("{name} {item:?}: expected a number of cycles, 1-8"))?;
        if !(1..=mcc_contracts::config::MAX_IN_FLIGHT).contains(&n) {
            bail!("{name} {item:?}: 1-8 cycles in flight");
        }
        if !v.contains(&n) {
            v.push(n);
        }
    }
    if v.is_empty() {
        bail!("{name}: give at least one setting, e.g. 1");
    }
    Ok(v)
}

/// Which sections to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Sections {
    floor: bool,
    lockstep: bool,
    rtf1: bool,
    realtime: bool,
    hosts: bool,
    netns: bool,
}

/// Which sections to run: lockstep, rtf1, realtime, hosts, netns (default all).
fn sections(only: Option<&str>) -> Result<Sections> {
    let Some(only) = only else {
        return Ok(Sections {
            floor: true,
            lockstep: true,
            rtf1: true,
            realtime: true,
            hosts: true,
            netns: true,
        });
    };
    let mut s = Sections::default();
    for w in only.split(',').map(str::trim).filter(|w| !w.is_empty()) {
        match w {
            "floor" => s.floor = true,
            "lockstep" => s.lockstep = true,
            "rtf1" => s.rtf1 = true,
            "realtime" => s.realtime = true,
            "hosts" => s.hosts = true,
            "netns" => s.netns = true,
            other => {
                bail!("--only {other:?}: expected floor, lockstep, rtf1, realtime, hosts or netns")
            }
        }
    }
    Ok(s)
}

/// Run the benchmark and print the report.
pub fn run(args: &BenchRingArgs) -> Result<()> {
    if !(args.rate.is_finite() && args.rate > 0.0 && args.rate <= 1e6) {
        bail!(
            "--rate {}: must be a number of Hz in (0, 1000000]",
            args.rate
        );
    }
    for (name, v) in [
        ("--duration", args.duration),
        ("--seconds", args.seconds),
        ("--rtf-seconds", args.rtf_seconds),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= 3600.0) {
            bail!("{name} {v}: must be between 0 and 3600 seconds");
        }
    }
    let sizes = parse_sizes(&args.sizes)?;
    let lockstep_n = parse_in_flight("--in-flight", &args.in_flight)?;
    let rtf_n = parse_in_flight("--rtf-in-flight", &args.rtf_in_flight)?;
    let only = sections(args.only.as_deref())?;
    let cpus = std::thread::available_parallelism()
        .map(|c| c.get())
        .unwrap_or(1);
    let build = if cfg!(debug_assertions) {
        "debug build: the targets are for a release build"
    } else {
        "release build"
    };
    println!("mcc bench ring: {cpus} CPUs, {build}");
    let floor = if only.floor || only.lockstep || only.rtf1 {
        Some(run_floor(Duration::from_secs_f64(args.seconds))?)
    } else {
        None
    };
    if only.lockstep {
        run_lockstep(
            &sizes,
            &lockstep_n,
            Duration::from_secs_f64(args.seconds),
            floor.as_ref(),
        )?;
    }
    if only.rtf1 {
        run_rtf1(
            &sizes,
            &rtf_n,
            Duration::from_secs_f64(args.rtf_seconds),
            floor.as_ref(),
        )?;
    }
    if only.realtime {
        run_realtime(args)?;
    }
    if only.hosts {
        hosts::run(
            Duration::from_secs_f64(args.seconds),
            args.zenohd.as_deref(),
        )?;
    }
    if only.netns {
        netns::run(
            Duration::from_secs_f64(args.seconds),
            args.zenohd.as_deref(),
        )?;
    }
    Ok(())
}

fn run_floor(window: Duration) -> Result<FloorFigures> {
    let rate = mcc_contracts::config::DEFAULT_RATE_HZ;
    let f = floor::run(rate, FLOOR_MSGS, window)?;
    println!(
        "\n(0) the floor: two processes configured as ring members (peer, no scouting, unix \
         socket, express, Drop, real-time priority, one zenoh runtime thread) bounce a message \
         from the receive callback"
    );
    for (name, r) in [
        ("back to back".to_string(), &f.b2b),
        (format!("paced at {rate} Hz"), &f.paced),
    ] {
        println!(
            "    {name:<22} one-way p50/p99 {:.1} / {:.1} µs, CPU {:.1} µs per message, \
             {:.0} messages/s",
            r.p50_us, r.p99_us, r.cpu_us_per_msg, r.msgs_per_s
        );
    }
    println!(
        "    at the ring rate a member receiving and sending one frame a cycle would use {:.1} % \
         of a core",
        f.cpu_pct_at_rate()
    );
    Ok(f)
}

fn run_lockstep(
    sizes: &[(u8, u8)],
    in_flight: &[u64],
    window: Duration,
    floor: Option<&FloorFigures>,
) -> Result<()> {
    println!(
        "\n(a) lockstep: `mcc up --clock lockstep` clusters (cycles from the sync master's status), \
         then a raw UDP ring of as many processes; {} s each",
        window.as_secs_f64()
    );
    println!(
        "    {:<34} {:>9} {:>15} {:>9} {:>9}   {:>9} {:>15} {:>9} {:>9}   {:>6} {:>7}",
        "",
        "cycles/s",
        "hop p50/p99 µs",
        "CPU µs/c",
        "switch/c",
        "UDP c/s",
        "hop p50/p99 µs",
        "CPU µs/c",
        "switch/c",
        "÷UDP",
        "÷floor"
    );
    let floor_p50 = floor.map_or(f64::NAN, |f| f.b2b.p50_us);
    let mut verdicts = Vec::new();
    let runs = sizes
        .iter()
        .flat_map(|&cs| in_flight.iter().map(move |&n| (cs, n)));
    for (i, ((c, s), n)) in runs.enumerate() {
        let spec = ClusterSpec {
            cards: c,
            stations: s,
            clock: Some("lockstep".into()),
            rate: None,
            in_flight: Some(n),
        };
        let z = cluster::measure(&spec, &format!("l{i}"), Duration::from_secs(1), window)?;
        let (zh50, zh99) = z.hop_us().unwrap_or((f64::NAN, f64::NAN));
        let (zc, zs) = z.per_cycle();
        let to_floor = zh50 / floor_p50;
        // The raw UDP ring (one cycle in flight) beside the first setting of each size.
        let udp_cells = if n == in_flight[0] {
            let u = udp::run(spec.members(), Duration::from_secs(1), window)?;
            format!(
                "{:>9.0} {:>15} {:>9.1} {:>9.1}   {:>6.2}",
                u.cycles_per_s,
                format!("{:.1} / {:.1}", u.hop_us.0, u.hop_us.1),
                u.per_cycle.0,
                u.per_cycle.1,
                zh50 / u.hop_us.0
            )
        } else {
            format!("{:>9} {:>15} {:>9} {:>9}   {:>6}", "-", "-", "-", "-", "-")
        };
        println!(
            "    {:<34} {:>9.0} {:>15} {:>9.1} {:>9.1}   {udp_cells} {:>7.2}",
            spec.label(),
            z.cycles_per_s,
            format!("{zh50:.1} / {zh99:.1}"),
            zc,
            zs,
            to_floor
        );
        if n == 1 {
            // The hop target is the one-frame-in-flight hop: with more in flight the frames
            // queue behind each other by design.
            verdicts.push(format!(
                "{}: hop p50 {zh50:.1} µs = {to_floor:.2}× the floor's one-way p50 \
                 {floor_p50:.1} µs (target <= {FLOOR_HOP_RATIO}×): {}",
                spec.label(),
                verdict(to_floor <= FLOOR_HOP_RATIO)
            ));
        }
        if let Some((_, t)) = TARGETS.iter().find(|(k, _)| *k == (c, s, n)) {
            verdicts.push(format!(
                "{}: {:.0} cycles/s (target >= {t:.0}: {}, {:.0} %)",
                spec.label(),
                z.cycles_per_s,
                verdict(z.cycles_per_s >= *t),
                z.cycles_per_s / t * 100.0
            ));
        }
    }
    println!("    (CPU µs/c and switch/c: all processes of the ring together, per ring cycle)");
    for v in verdicts {
        println!("    {v}");
    }
    Ok(())
}

fn cpu_cell(f: &ClusterFigures, kind: &str) -> String {
    f.cpu_of(kind)
        .map(|(m, x)| format!("{m:.1} / {x:.1}"))
        .unwrap_or_else(|| "-".into())
}

fn run_rtf1(
    sizes: &[(u8, u8)],
    in_flight: &[u64],
    window: Duration,
    floor: Option<&FloorFigures>,
) -> Result<()> {
    println!(
        "\n(b) real-time factor 1: `mcc up` with the default clock and rate; CPU per member, % of one \
         core, over {} s",
        window.as_secs_f64()
    );
    println!(
        "    {:<34} {:>9} {:>6} {:>22} {:>22} {:>12} {:>13}",
        "",
        "cycles/s",
        "rtf",
        "card % mean / max",
        "station % mean / max",
        "supervisor %",
        "max ÷ floor"
    );
    // The floor's CPU per message at the rate the cluster achieved (a ring below real time
    // handles fewer frames a second).
    let floor_us = floor.map_or(f64::NAN, |f| f.paced.cpu_us_per_msg);
    let mut verdicts = Vec::new();
    let nominal = mcc_contracts::config::DEFAULT_RATE_HZ;
    let runs = sizes
        .iter()
        .flat_map(|&cs| in_flight.iter().map(move |&n| (cs, n)));
    for (i, ((c, s), n)) in runs.enumerate() {
        let spec = ClusterSpec {
            cards: c,
            stations: s,
            clock: None,
            rate: None,
            in_flight: Some(n),
        };
        let f = cluster::measure(&spec, &format!("p{i}"), Duration::from_secs(2), window)?;
        let busiest = ["card", "station"]
            .iter()
            .filter_map(|k| f.cpu_of(k).map(|(_, x)| x))
            .fold(0.0, f64::max);
        let floor_pct = floor_us * f.cycles_per_s / 1e4;
        let to_floor = busiest / floor_pct;
        println!(
            "    {:<34} {:>9.0} {:>6.3} {:>22} {:>22} {:>12.1} {:>13.2}",
            spec.label(),
            f.cycles_per_s,
            f.cycles_per_s / nominal,
            cpu_cell(&f, "card"),
            cpu_cell(&f, "station"),
            f.supervisor_cpu_pct,
            to_floor
        );
        verdicts.push(format!(
            "{}: busiest member {busiest:.1} % = {to_floor:.2}× the floor's {floor_pct:.1} % at \
             {:.0} cycles/s (target <= {FLOOR_CPU_RATIO}×): {}",
            spec.label(),
            f.cycles_per_s,
            verdict(to_floor <= FLOOR_CPU_RATIO)
        ));
        let rtf = f.cycles_per_s / nominal;
        if let Some((_, t)) = RTF_TARGETS.iter().find(|(k, _)| *k == (c, s, n)) {
            verdicts.push(format!(
                "{}: rtf {rtf:.3} (target >= {t}: {})",
                spec.label(),
                verdict(rtf >= *t)
            ));
        }
        if f.cycles_per_s < nominal * 0.99 {
            let help = if n < 2 {
                "fewer members, `ring.in_flight` 2 (one cycle more servo delay), a faster machine"
            } else {
                "fewer members or fewer processes per core: the ring is CPU-bound here (see the \
                 CPU columns)"
            };
            verdicts.push(format!(
                "{}: below real time (rtf {rtf:.3}: {:.0} of {nominal} cycles/s); what would \
                 help: {help}",
                spec.label(),
                f.cycles_per_s
            ));
        }
    }
    for v in verdicts {
        println!("    {v}");
    }
    Ok(())
}

fn run_realtime(args: &BenchRingArgs) -> Result<()> {
    let n = args.members as usize;
    let cfg = inproc::bench_config(n, ClockMode::Realtime, args.rate);
    let period = 1e9 / args.rate;
    // Lateness is measured against the sync master's schedule, so its own row is omitted.
    let rt_cycles = ((args.duration * args.rate).ceil() as u64).max(100);
    let stop = Arc::new(AtomicBool::new(false));
    let probe = {
        let stop = Arc::clone(&stop);
        let p = period.round() as u64;
        std::thread::spawn(move || inproc::timer_probe(p, stop))
    };
    let r = inproc::run(&cfg, rt_cycles);
    stop.store(true, Ordering::Relaxed);
    let probe = probe.join().unwrap_or_default();
    let r = r?;
    // Sync master: scheduled starts; others: sync arrivals (same monotonic clock).
    let rc = complete_cycles(&r.records);
    let skip = (rc.len() / 10).min(1000);
    println!(
        "\n(c) realtime at {} Hz for {} s, {n} members in one process ({} cycles complete on every \
         member)",
        args.rate,
        args.duration,
        rc.len()
    );
    println!(
        "    offset = sync arrival - sync master's scheduled start (the ring's propagation delay);"
    );
    println!(
        "    lateness = arrival - (scheduled start + the member's locked phase = its p1 offset)"
    );
    println!(
        "    {:<18} {:>12} {:>12} {:>12} {:>12}",
        "µs", "offset p50", "late p50", "late p99", "late p99.9"
    );
    let mut worst50 = 0;
    let mut worst99 = 0;
    for (k, name) in cfg.ring.order.iter().enumerate().skip(1) {
        let offsets = lateness(&rc, k, skip);
        let phase = percentile(&offsets, 1.0);
        let l: Vec<u64> = offsets.iter().map(|o| o.saturating_sub(phase)).collect();
        let (a, b, c) = (
            percentile(&l, 50.0),
            percentile(&l, 99.0),
            percentile(&l, 99.9),
        );
        worst50 = worst50.max(a);
        worst99 = worst99.max(b);
        println!(
            "    {:<18} {:>12} {:>12} {:>12} {:>12}",
            name,
            us(percentile(&offsets, 50.0)),
            us(a),
            us(b),
            us(c)
        );
    }
    let (p50, p99, p999) = (
        percentile(&probe, 50.0),
        percentile(&probe, 99.0),
        percentile(&probe, 99.9),
    );
    println!(
        "    {:<18} {:>12} {:>12} {:>12} {:>12}",
        "OS timer probe",
        "-",
        us(p50),
        us(p99),
        us(p999)
    );
    println!(
        "    targets: p50 <= 100 µs (worst member {}): {}; p99 <= probe p99 + 200 µs (worst {} vs {}): {}",
        us(worst50),
        verdict(worst50 <= 100_000),
        us(worst99),
        us(p99 + 200_000),
        verdict(worst99 <= p99 + 200_000)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_flight_lists_parse_and_bad_ones_are_named() {
        assert_eq!(parse_in_flight("--in-flight", "1, 4,1").unwrap(), [1, 4]);
        assert_eq!(parse_in_flight("--rtf-in-flight", "8").unwrap(), [8]);
        for bad in ["", "0", "9", "x", "1,,y"] {
            let e = parse_in_flight("--rtf-in-flight", bad)
                .unwrap_err()
                .to_string();
            assert!(e.contains("--rtf-in-flight"), "{bad}: {e}");
        }
    }

    #[test]
    fn sizes_and_sections_parse_and_bad_ones_are_named() {
        assert_eq!(
            parse_sizes("1+1, 2+2,4+8").unwrap(),
            [(1, 1), (2, 2), (4, 8)]
        );
        for bad in ["", "2", "0+2", "2+x", "17+1", "2+49"] {
            let e = parse_sizes(bad).unwrap_err().to_string();
            assert!(e.contains("--sizes"), "{bad}: {e}");
        }
        let all = sections(None).unwrap();
        assert!(all.lockstep && all.rtf1 && all.realtime && all.hosts && all.netns);
        let rtf1 = Sections {
            rtf1: true,
            ..Sections::default()
        };
        assert_eq!(sections(Some("rtf1")).unwrap(), rtf1);
        let two = Sections {
            lockstep: true,
            hosts: true,
            ..Sections::default()
        };
        assert_eq!(sections(Some("hosts,lockstep")).unwrap(), two);
        let netns = Sections {
            netns: true,
            ..Sections::default()
        };
        assert_eq!(sections(Some(" netns ")).unwrap(), netns);
        assert!(sections(Some("fast"))
            .unwrap_err()
            .to_string()
            .contains("fast"));
    }
}
