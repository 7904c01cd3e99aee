//! `mcc bench chain`: daisy-chain command round trip. Starts a cluster of its own (default
//! cluster with N cards and one station, own run directory), opens a chain connection as a
//! host would and times `@nP1<CR>` round trips alternating over the cards (the addressed card
//! changes every time, so every round trip crosses every card's receiver), then stops it.

use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use mcc_contracts::config::ClusterConfig;

use crate::cli::BenchChainArgs;
use crate::cluster::chain::link::{ChainLink, DEFAULT_TIMEOUT};
use crate::cluster::rundir::RunDir;
use crate::cluster::supervisor::Supervisor;
use crate::verbs::bench::stats::{percentile, us};

/// Run the benchmark and print p50/p99/max.
pub fn run(args: &BenchChainArgs) -> Result<()> {
    let mut cfg = ClusterConfig::default_cluster(usize::from(args.cards), 1);
    cfg.cluster = format!("bench-chain-{}", std::process::id());
    if let Some(c) = args.clock {
        cfg.clock = c;
    }
    let cfg = cfg.resolve().map_err(|e| anyhow::anyhow!(e))?;
    let rd = RunDir::for_cluster(&cfg.cluster)?;
    rd.claim(std::process::id())?;
    rd.write_config(&cfg.to_toml_string()?)?;
    let sup = match Supervisor::start(rd.clone(), cfg.clone()) {
        Ok(s) => s,
        Err(e) => {
            let _ = rd.cleanup();
            return Err(e);
        }
    };
    let res = measure(&sup, &cfg, args);
    sup.shutdown(Duration::from_secs(6));
    res
}

fn measure(sup: &Supervisor, cfg: &ClusterConfig, args: &BenchChainArgs) -> Result<()> {
    crate::cluster::ready::wait_locked(sup.session(), cfg, Duration::from_secs(60), || None)?;
    let link = ChainLink::new(sup.session().clone(), cfg, DEFAULT_TIMEOUT);
    let n = u32::from(args.cards);
    // Warm-up: every card answers once.
    for k in 0..n.max(1) * 4 {
        let r = link.send(format!("@{:X}P1\r", k % n).as_bytes());
        if r.bytes.is_empty() {
            bail!("card {} did not answer on the daisy chain", k % n);
        }
    }
    let mut rtt = Vec::with_capacity(args.count as usize);
    let mut silent = 0u32;
    for k in 0..args.count {
        let line = format!("@{:X}P1\r", k % n);
        let t = Instant::now();
        let r = link.send(line.as_bytes());
        rtt.push(u64::try_from(t.elapsed().as_nanos()).unwrap_or(u64::MAX));
        if r.bytes.is_empty() {
            silent += 1;
        }
    }
    link.close();
    rtt.sort_unstable();
    println!(
        "daisy chain round trip ({} cards, {}, {} commands): p50 {} µs  p99 {} µs  max {} µs{}",
        n,
        cfg.clock.as_str(),
        rtt.len(),
        us(percentile(&rtt, 50.0)),
        us(percentile(&rtt, 99.0)),
        us(rtt.last().copied().unwrap_or(0)),
        if silent > 0 {
            format!("  ({silent} unanswered)")
        } else {
            String::new()
        }
    );
    Ok(())
}
