//! `mcc bench sync`: wall-clock skew of synchronized multi-card starts. Starts a realtime
//! cluster of its own (unique name, own supervisor in this process), loads a one-line program
//! on every card through the daisy chain, then runs `&1B1R` as a synchronized start COUNT
//! times and reports the spread of the cards' recorded CLOCK_MONOTONIC program start times
//! (`program_start_ns`) per start: p50/p99/max against the 100 µs target. Also the shared
//! helper [`with_cluster`] the other cluster benchmarks use.

use std::time::Duration;

use anyhow::{anyhow, bail, Context, Result};
use mcc_ring::config::{ClockMode, ClusterConfig};

use crate::bench::stats::{percentile, us};
use crate::chain::link::{ChainLink, DEFAULT_TIMEOUT};
use crate::cli::BenchSyncArgs;
use crate::rundir::RunDir;
use crate::supervisor::Supervisor;
use crate::syncstart::{start_sync, SyncOptions};

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
    let res = crate::up::wait_locked(sup.session(), &cfg, Duration::from_secs(60), || None)
        .and_then(|_| f(&mut sup, &cfg));
    sup.shutdown(Duration::from_secs(6));
    res
}

/// One start's skew, or why it has none.
fn skew(out: &crate::syncstart::StartOutcome) -> Result<u64> {
    let cycles: Vec<Option<u64>> = out.cards.iter().map(|c| c.executed_cycle).collect();
    if cycles.iter().any(|c| *c != Some(out.cycle)) {
        bail!("split start at cycle {}: {cycles:?}", out.cycle);
    }
    let ns: Vec<u64> = out
        .cards
        .iter()
        .map(|c| c.program_start_ns)
        .collect::<Option<_>>()
        .ok_or_else(|| {
            let replies: Vec<&str> = out.cards.iter().map(|c| c.reply.as_str()).collect();
            anyhow!("a card did not start its program: {replies:?}")
        })?;
    Ok(ns.iter().max().copied().unwrap_or(0) - ns.iter().min().copied().unwrap_or(0))
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
    let link = ChainLink::new(session.clone(), cfg, DEFAULT_TIMEOUT);
    let r = link.send(SETUP.as_bytes());
    link.close();
    if r.bytes.contains(&0x07) || !r.silent.is_empty() {
        bail!(
            "loading the program failed: {:?} (silent cards {:?})",
            String::from_utf8_lossy(&r.bytes),
            r.silent
        );
    }
    std::thread::sleep(Duration::from_millis(500));
    let cards: Vec<u32> = cfg.cards.iter().map(|c| u32::from(c.number)).collect();
    let late0: u64 = late_cycles(&session, cfg);
    let opts = SyncOptions::default();
    let (mut skews, mut retries, mut leads) = (Vec::new(), 0u32, Vec::new());
    for k in 0..args.count {
        let out = start_sync(&session, &cfg.cluster, &cards, "&1B1R", &opts)
            .with_context(|| format!("start {k}"))?;
        skews.push(skew(&out).with_context(|| format!("start {k}"))?);
        retries += out.attempts - 1;
        leads.push(out.lead_cycles);
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
        if p99 <= TARGET_SKEW_NS { "met" } else { "MISSED" },
        p99 as f64 / TARGET_SKEW_NS as f64
    );
    println!(
        "  split starts 0 (every start executed in one ring cycle); retries {retries}; lead p50 {} cycles; late ring cycles during the run {late}",
        percentile(&leads, 50.0)
    );
    Ok(())
}

/// Late realtime cycles summed over the members.
fn late_cycles(session: &zenoh::Session, cfg: &ClusterConfig) -> u64 {
    crate::ctl::query_statuses(
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
