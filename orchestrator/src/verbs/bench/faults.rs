//! `mcc bench faults [--clock paced|lockstep|realtime]`: ring-fault detection latency, in ring
//! cycles and milliseconds, per fault kind. Starts a cluster of its own (default clock paced;
//! 2 cards + 2 stations: card0 (sync master) → station0 → card1 → station1), then for each drill
//! injects the fault on station0 (or kills station0, freezes card1, kills or freezes the sync
//! master card0), waits until every card that can still answer has latched a new ring fault,
//! reads each card's `ring_fault_cycle` from its member status, and recovers (clear, restart,
//! `$$$`, latch reset) before the next drill. For a killed or frozen member it also reports the
//! wall time until the member downstream saw loss of light (liveliness notice, or the
//! frozen-member wait).
//!
//! The injection cycle: for drills that stop frames (cut, kill, freeze) it is exact — the
//! first cycle the member downstream of the break never received (its last_rx_cycle + 1). For
//! the others (frames keep flowing) it is bracketed by the faulted member's cycle read just
//! before and just after the fault request, so the latency is reported as a range.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::{ClockMode, ClusterConfig};
use mcc_ring::control::{ctl_key, FaultRequest, MemberStatus};
use mcc_ring::fault::FaultSpec;

use crate::cli::BenchFaultsArgs;
use crate::cluster::ctl::{query_ctl, query_statuses};
use crate::cluster::supervisor::Supervisor;
use crate::verbs::bench::syncstart::{reset_ring_faults, with_cluster};

/// The drills: (label, member, fault word or process drill).
pub const DRILLS: &[(&str, &str, &str)] = &[
    ("drop-sync", "station0", "drop-sync"),
    ("cut", "station0", "cut"),
    ("corrupt", "station0", "corrupt"),
    ("byte-violation", "station0", "byte-violation"),
    ("underrun", "station0", "underrun"),
    ("overrun", "station0", "overrun"),
    ("killed station", "station0", "kill"),
    ("frozen card", "card1", "freeze"),
    ("killed sync master", "card0", "kill"),
    ("frozen sync master", "card0", "freeze"),
];

fn statuses(s: &zenoh::Session, cfg: &ClusterConfig) -> Vec<Option<MemberStatus>> {
    query_statuses(
        s,
        cfg,
        Duration::from_millis(300),
        Duration::from_millis(600),
    )
}

fn index(cfg: &ClusterConfig, name: &str) -> Result<usize> {
    cfg.ring
        .order
        .iter()
        .position(|m| m == name)
        .ok_or_else(|| anyhow!("no member {name} in the ring"))
}

/// Run the benchmark and print one line per drill.
pub fn run(args: &BenchFaultsArgs) -> Result<()> {
    if let Some(n) = args.campaign {
        return crate::verbs::bench::campaign::run(args, n);
    }
    let mut cfg = ClusterConfig::default_cluster(2, 2);
    cfg.cluster = format!("bench-faults-{}", std::process::id());
    cfg.clock = args.clock.unwrap_or(ClockMode::Paced);
    with_cluster(cfg, |sup, cfg| {
        // The checks arm after ARM_AFTER_LOCKED locked cycles: let every member get there.
        let armed = u64::from(mcc_ring::core::ARM_AFTER_LOCKED) * 2;
        let deadline = Instant::now() + Duration::from_secs(60);
        while statuses(sup.session(), cfg)
            .iter()
            .any(|m| m.as_ref().is_none_or(|m| m.cycle < armed))
        {
            if Instant::now() > deadline {
                bail!("the ring did not run {armed} cycles within 60 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let i1001 = cfg
            .cards
            .first()
            .and_then(|c| c.ivars.get("I1001"))
            .map(|v| v.as_f64() as u64)
            .unwrap_or(16);
        println!(
            "bench faults: {} ring {} ({}) at {} Hz, card check period I1001 = {i1001} cycles (detection bound 2 x I1001 + 1 = {}), frozen-member wait {} ms",
            cfg.clock.as_str(),
            cfg.ring.name,
            cfg.ring.order.join(" → "),
            cfg.rate_hz,
            2 * i1001 + 1,
            cfg.member_timeout_ms
        );
        println!(
            "  {:<18} {:<9} {:<17} latency per card: cycles from injection to ring_fault_cycle (ms at the nominal rate)",
            "fault", "member", "injected at cycle"
        );
        let mut failures = 0;
        for &(label, member, word) in DRILLS {
            if let Some(only) = &args.only {
                if !only
                    .split(',')
                    .any(|o| o.trim() == label || o.trim() == word)
                {
                    continue;
                }
            }
            match drill(sup, cfg, member, word, Duration::from_secs(args.timeout)) {
                Ok(line) => println!("  {label:<18} {member:<9} {line}"),
                Err(e) => {
                    failures += 1;
                    println!("  {label:<18} {member:<9} {e:#}");
                }
            }
            recover(sup, cfg, member, word)?;
        }
        if failures > 0 {
            println!("  {failures} of the drills run were not detected by any card");
        }
        Ok(())
    })
}

/// One drill: inject, wait for detection, format the result line.
fn drill(
    sup: &mut Supervisor,
    cfg: &ClusterConfig,
    member: &str,
    word: &str,
    timeout: Duration,
) -> Result<String> {
    let s = sup.session().clone();
    let target = index(cfg, member)?;
    let downstream = (target + 1) % cfg.ring.order.len();
    let before = statuses(&s, cfg);
    if before
        .iter()
        .any(|m| m.as_ref().is_none_or(|m| !m.locked || m.ring_fault))
    {
        bail!("the ring is not healthy before the drill");
    }
    let counts: Vec<u64> = before
        .iter()
        .flatten()
        .map(|m| m.ring_fault_count)
        .collect();
    let c0 = before.get(target).and_then(Option::as_ref).map(|m| m.cycle);
    match word {
        "kill" | "freeze" => {
            let pid = sup
                .info()
                .members
                .iter()
                .find(|m| m.name == member)
                .map(|m| m.pid)
                .ok_or_else(|| anyhow!("{member} has no process"))?;
            let sig = if word == "kill" {
                libc::SIGKILL
            } else {
                libc::SIGSTOP
            };
            crate::cluster::sys::signal(pid, sig)?;
        }
        _ => {
            let spec: FaultSpec = FaultSpec {
                kind: word.parse().map_err(anyhow::Error::msg)?,
                cycles: None,
                probability: 1.0,
                seed: 0,
            };
            let req = serde_json::to_string(&FaultRequest::Inject { spec })?;
            let r = query_ctl(
                &s,
                &ctl_key(&cfg.cluster, member, "fault"),
                Some(req),
                Duration::from_secs(2),
            )?;
            if !r.ok {
                bail!("fault refused: {}", r.message);
            }
        }
    }
    let injected = Instant::now();
    // A killed or frozen member: how long until the member downstream sees loss of light.
    let noticed = if matches!(word, "kill" | "freeze") {
        let key = ctl_key(&cfg.cluster, &cfg.ring.order[downstream], "status");
        let deadline = Instant::now() + timeout;
        loop {
            let dark = crate::cluster::ctl::query_text(&s, &key, None, Duration::from_millis(300))
                .ok()
                .and_then(|t| serde_json::from_str::<MemberStatus>(&t).ok())
                .is_some_and(|m| m.dark);
            if dark || Instant::now() > deadline {
                break dark.then(|| injected.elapsed());
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    } else {
        None
    };
    let c1 = statuses(&s, cfg)
        .get(target)
        .and_then(Option::as_ref)
        .map(|m| m.cycle);
    // Wait until every card that answers has a new ring fault.
    let cards: Vec<usize> = cfg
        .cards
        .iter()
        .filter_map(|c| index(cfg, &c.name).ok())
        .filter(|&i| !(matches!(word, "freeze" | "kill") && i == target))
        .collect();
    let deadline = Instant::now() + timeout;
    let detected = |now: &[Option<MemberStatus>], i: usize| {
        now.get(i)
            .and_then(Option::as_ref)
            .zip(counts.get(i))
            .is_some_and(|(m, &n0)| m.ring_fault_count > n0 && m.ring_fault_cycle.is_some())
    };
    // Every card, or (frame faults are only seen by the cards that check those packets) the
    // cards that detected within a second of the first one.
    let mut first: Option<Instant> = None;
    let now = loop {
        let now = statuses(&s, cfg);
        let n = cards.iter().filter(|&&i| detected(&now, i)).count();
        if n == cards.len() || first.is_some_and(|t| t.elapsed() > Duration::from_secs(1)) {
            break now;
        }
        if n > 0 {
            first.get_or_insert_with(Instant::now);
        }
        if Instant::now() > deadline {
            bail!(
                "NOT DETECTED: no card latched a ring fault within {} s",
                timeout.as_secs()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let exact = matches!(word, "cut" | "kill" | "freeze");
    let period_ms = cfg.period_ns() as f64 / 1e6;
    let lost = now
        .get(downstream)
        .and_then(Option::as_ref)
        .and_then(|m| m.last_rx_cycle)
        .map(|c| c + 1);
    let (lo, hi) = match (exact, lost, c0, c1) {
        (true, Some(l), _, _) => (l, l),
        (_, _, Some(a), Some(b)) => (a, b),
        (_, _, Some(a), None) => (a, a),
        _ => bail!("the injection cycle is unknown"),
    };
    let mut parts = Vec::new();
    for &i in &cards {
        let name = cfg.ring.order.get(i).map(String::as_str).unwrap_or("?");
        if !detected(&now, i) {
            parts.push(format!("{name} not detected"));
            continue;
        }
        let at = now
            .get(i)
            .and_then(Option::as_ref)
            .and_then(|m| m.ring_fault_cycle)
            .unwrap_or(0);
        let (a, b) = (at.saturating_sub(hi), at.saturating_sub(lo));
        let ms = |c: u64| c as f64 * period_ms;
        parts.push(if a == b {
            format!("{name} {a} ({:.1} ms)", ms(a))
        } else {
            format!("{name} {a}..{b} ({:.1}..{:.1} ms)", ms(a), ms(b))
        });
    }
    let when = if lo == hi {
        format!("{lo} (exact)")
    } else {
        format!("{lo}..{hi}")
    };
    let notice = noticed
        .map(|d| {
            format!(
                "; loss of light downstream after {:.0} ms",
                d.as_secs_f64() * 1000.0
            )
        })
        .unwrap_or_default();
    Ok(format!("{when:<17} {}{notice}", parts.join(", ")))
}

/// Undo a drill and wait until the ring is healthy again.
fn recover(sup: &mut Supervisor, cfg: &ClusterConfig, member: &str, word: &str) -> Result<()> {
    let s = sup.session().clone();
    if matches!(word, "kill" | "freeze") {
        sup.restart(member)?;
    }
    let clear = serde_json::to_string(&FaultRequest::Clear)?;
    for m in &cfg.ring.order {
        let _ = query_ctl(
            &s,
            &ctl_key(&cfg.cluster, m, "fault"),
            Some(clear.clone()),
            Duration::from_secs(2),
        );
    }
    crate::cluster::ready::wait_locked(&s, cfg, Duration::from_secs(30), || None)?;
    reset_ring_faults(&s, cfg, Duration::from_secs(30))
        .map_err(|e| anyhow!("after {word} on {member}: {e:#}"))
}
