//! `mcc bench sync`: wall-clock skew of synchronized multi-card starts. Starts a realtime
//! cluster of its own (unique name, own supervisor in this process), loads a one-line program
//! on every card through the daisy chain, then runs `&1B1R` as a synchronized start COUNT
//! times and reports the spread of the cards' recorded CLOCK_MONOTONIC program start times
//! (`program_start_ns`) per start: p50/p99/max against the 100 µs target. Also the shared
//! helper [`with_cluster`] the other cluster benchmarks use.

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::{ClockMode, ClusterConfig};

use mcc_ring::control::{card_cmd_key, ctl_key};

use crate::cli::BenchSyncArgs;
use crate::cluster::chain::link::{ChainLink, DEFAULT_TIMEOUT};
use crate::cluster::ctl::query_text;
use crate::cluster::rundir::RunDir;
use crate::cluster::supervisor::Supervisor;
use crate::cluster::sync_start::{start_sync, SyncOptions};
use crate::verbs::bench::stats::{percentile, us};

/// Target p99 wall-clock skew of a synchronized start, ns.
pub const TARGET_SKEW_NS: u64 = 100_000;

/// The program every card starts (the `#1J/` settles before the first start).
pub const SETUP: &str = "@@&1#1->1000X\r#1J/\rOPEN PROG 1 CLEAR\rDWELL 1\rCLOSE\r";

/// Start `cfg` (resolved here) under a supervisor in this process with a run directory of its
/// own, wait until the ring locks, run `f`, and always stop the cluster again.
pub fn with_cluster<T>(
    cfg: ClusterConfig,
    f: impl FnOnce(&mut Supervisor, &ClusterConfig) -> Result<T>,
) -> Result<T> {
    let cfg = cfg.resolve().map_err(|e| anyhow!(e))?;
    let rd = RunDir::for_cluster(&cfg.cluster)?;
    rd.claim(std::process::id())?;
    rd.write_config(&cfg.to_toml_string()?)?;
    let mut sup = match Supervisor::start(rd.clone(), cfg.clone()) {
        Ok(s) => s,
        Err(e) => {
            let _ = rd.cleanup();
            return Err(e);
        }
    };
    // Interrupted (SIGINT, SIGTERM, SIGHUP): the run directory goes, and the members with
    // this process (their parent-death signal).
    let (_signals, stop) = crate::cluster::supervisor::stop_signals()?;
    let dir = rd.clone();
    std::thread::spawn(move || {
        if let Ok(which) = stop.recv() {
            eprintln!("mcc: {which}: the benchmark's cluster stops");
            let _ = dir.cleanup();
            std::process::exit(130);
        }
    });
    let res =
        crate::cluster::ready::wait_locked(sup.session(), &cfg, Duration::from_secs(60), || None)
            .and_then(|_| f(&mut sup, &cfg));
    sup.shutdown(Duration::from_secs(6));
    res
}

/// `$$$` on every card and a latch reset on every member until no member has a ring fault
/// and all are locked (a realtime ring may latch faults while its members join).
pub fn reset_ring_faults(s: &zenoh::Session, cfg: &ClusterConfig, timeout: Duration) -> Result<()> {
    let deadline = std::time::Instant::now() + timeout;
    loop {
        let st = crate::cluster::ctl::query_statuses(
            s,
            cfg,
            Duration::from_millis(300),
            Duration::from_millis(600),
        );
        if st
            .iter()
            .all(|m| m.as_ref().is_some_and(|m| m.locked && !m.ring_fault))
        {
            return Ok(());
        }
        if std::time::Instant::now() > deadline {
            bail!(
                "the ring did not come back healthy within {} s",
                timeout.as_secs()
            );
        }
        for c in &cfg.cards {
            let key = card_cmd_key(&cfg.cluster, u32::from(c.number));
            let _ = query_text(s, &key, Some("$$$".into()), Duration::from_secs(2));
        }
        for m in &cfg.ring.order {
            let key = ctl_key(&cfg.cluster, m, "reset");
            let _ = crate::cluster::ctl::query_ctl(s, &key, None, Duration::from_secs(2));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// One start's skew and whether it executed at the chosen cycle T, or why it has none.
fn skew(out: &crate::cluster::sync_start::StartOutcome) -> Result<(u64, bool)> {
    let cycles: Vec<Option<u64>> = out.cards.iter().map(|c| c.executed_cycle).collect();
    if cycles
        .iter()
        .any(|c| *c != cycles.first().copied().flatten())
    {
        bail!("split start (T = {}): {cycles:?}", out.cycle);
    }
    let at_t = cycles.first().copied().flatten() == Some(out.cycle);
    let ns: Vec<u64> = out
        .cards
        .iter()
        .map(|c| c.program_start_ns)
        .collect::<Option<_>>()
        .ok_or_else(|| {
            let replies: Vec<&str> = out.cards.iter().map(|c| c.reply.as_str()).collect();
            anyhow!("a card did not start its program: {replies:?}")
        })?;
    let spread = ns.iter().max().copied().unwrap_or(0) - ns.iter().min().copied().unwrap_or(0);
    Ok((spread, at_t))
}

/// Run the benchmark and print the report.
pub fn run(args: &BenchSyncArgs) -> Result<()> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number of Hz");
    }
    let n = usize::from(args.cards);
    let mut cfg = ClusterConfig::default_cluster(n, n);
    cfg.cluster = format!("bench-sync-{}", std::process::id());
    cfg.clock = ClockMode::Realtime;
    cfg.rate_hz = args.rate;
    with_cluster(cfg, |sup, cfg| measure(sup, cfg, args))
}

fn measure(sup: &mut Supervisor, cfg: &ClusterConfig, args: &BenchSyncArgs) -> Result<()> {
    let session = sup.session().clone();
    // A realtime ring may latch faults (and kill motors) while its members join.
    prepare(&session, cfg)?;
    let cards: Vec<u32> = cfg.cards.iter().map(|c| u32::from(c.number)).collect();
    let late0: u64 = late_cycles(&session, cfg);
    let opts = SyncOptions::default();
    let (mut skews, mut retries, mut leads, mut not_at_t) = (Vec::new(), 0u32, Vec::new(), 0);
    let mut faults = 0u32;
    let mut k = 0u32;
    while skews.len() < args.count as usize {
        k += 1;
        let res = start_sync(&session, &cfg.cluster, &cards, "&1B1R", &opts)
            .and_then(|out| skew(&out).map(|s| (out, s)));
        match res {
            Ok((out, (spread, at_t))) => {
                skews.push(spread);
                not_at_t += u32::from(!at_t);
                retries += out.attempts - 1;
                leads.push(out.lead_cycles);
            }
            Err(e) if faulted(&session, cfg) && faults < args.count / 4 + 2 => {
                // The ring could not keep up (a late cycle latched a ring fault and killed
                // the motors): recover, reload, and count it.
                faults += 1;
                tracing::warn!("start {k}: {e:#}: ring fault, recovering");
                prepare(&session, cfg)?;
            }
            Err(e) => return Err(e.context(format!("start {k}"))),
        }
        // Let the 1 ms program finish; vary the phase of the next start.
        std::thread::sleep(Duration::from_millis(15 + u64::from(k % 7) * 3));
    }
    let late = late_cycles(&session, cfg).saturating_sub(late0);
    skews.sort_unstable();
    leads.sort_unstable();
    let p99 = percentile(&skews, 99.0);
    println!(
        "bench sync: {} cards + {} stations, realtime ring at {:.0} Hz (cycle {} µs), {} synchronized starts of \"&1B1R\"",
        cards.len(),
        cfg.stations.len(),
        cfg.rate_hz,
        us((1e9 / cfg.rate_hz) as u64),
        skews.len()
    );
    println!(
        "  start skew (spread of the cards' CLOCK_MONOTONIC program start): p50 {} µs  p99 {} µs  max {} µs",
        us(percentile(&skews, 50.0)),
        us(p99),
        us(skews.last().copied().unwrap_or(0))
    );
    println!(
        "  target p99 <= {} µs: {} (p99/target = {:.2})",
        us(TARGET_SKEW_NS),
        if p99 <= TARGET_SKEW_NS {
            "met"
        } else {
            "MISSED"
        },
        p99 as f64 / TARGET_SKEW_NS as f64
    );
    println!(
        "  split starts 0 (every start ran in one ring cycle on all cards); {not_at_t} ran later than the chosen cycle T; retries {retries}; lead p50 {} cycles",
        percentile(&leads, 50.0)
    );
    println!(
        "  late ring cycles during the run {late}; ring faults recovered {faults} (starts lost to them are not counted)"
    );
    Ok(())
}

/// Clear ring faults and load the program on every card.
fn prepare(session: &zenoh::Session, cfg: &ClusterConfig) -> Result<()> {
    reset_ring_faults(session, cfg, Duration::from_secs(30))?;
    let link = ChainLink::new(session.clone(), cfg, DEFAULT_TIMEOUT);
    let r = link.send(SETUP.as_bytes());
    link.close();
    if !r.refusals.is_empty() || !r.silent.is_empty() {
        let refused: Vec<String> = r.refusals.iter().map(ToString::to_string).collect();
        bail!(
            "loading the program failed: {:?} (refusals {refused:?}, silent cards {:?})",
            String::from_utf8_lossy(&r.bytes),
            r.silent
        );
    }
    std::thread::sleep(Duration::from_millis(500));
    Ok(())
}

/// Some member has latched a ring fault.
fn faulted(session: &zenoh::Session, cfg: &ClusterConfig) -> bool {
    crate::cluster::ctl::query_statuses(
        session,
        cfg,
        Duration::from_millis(300),
        Duration::from_millis(600),
    )
    .iter()
    .flatten()
    .any(|m| m.ring_fault)
}

/// Late realtime cycles summed over the members.
fn late_cycles(session: &zenoh::Session, cfg: &ClusterConfig) -> u64 {
    crate::cluster::ctl::query_statuses(
        session,
        cfg,
        Duration::from_millis(500),
        Duration::from_millis(1000),
    )
    .iter()
    .flatten()
    .map(|s| s.late_cycles)
    .sum()
}
