//! `mcc start-sync --cards 0,1 LINE`: one line run on several cards at the same ring cycle
//! (the protocol is in [`crate::cluster::sync_start`]).

use anyhow::{bail, Result};

use crate::cluster::sync_start::{parse_cards, skew_ns, start_sync, SyncOptions};

/// `mcc start-sync --cards 0,1 LINE`.
pub fn cmd_start_sync(cluster: &str, args: &crate::cli::StartSyncArgs) -> Result<()> {
    let cards = parse_cards(&args.cards).map_err(anyhow::Error::msg)?;
    let line = args.line.join(" ");
    if line.trim().is_empty() {
        bail!("no command line given");
    }
    let a = crate::cluster::attach::attach(cluster)?;
    for n in &cards {
        if !a.cfg.cards.iter().any(|c| u32::from(c.number) == *n) {
            let have: Vec<String> = a.cfg.cards.iter().map(|c| c.number.to_string()).collect();
            bail!(
                "cluster {cluster:?} has no card {n} (cards: {})",
                have.join(", ")
            );
        }
    }
    let opts = SyncOptions {
        min_lead_ms: args.lead_ms,
        attempts: args.attempts,
        ..SyncOptions::default()
    };
    if let Some(n) = args.repeat {
        let mut all = Vec::new();
        for _ in 0..n {
            let out = start_sync(&a.session, &a.cfg.cluster, &cards, &line, &opts)?;
            if !args.json {
                let skew = skew_ns(&out)
                    .map(|s| format!(", skew {s} ns"))
                    .unwrap_or_default();
                println!(
                    "cycle {} lead {} attempt {}{skew}",
                    out.cycle, out.lead_cycles, out.attempts
                );
            }
            all.push(out);
        }
        if args.json {
            println!("{}", serde_json::to_string_pretty(&all)?);
        }
        return Ok(());
    }
    let out = start_sync(&a.session, &a.cfg.cluster, &cards, &line, &opts)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{line:?} ran on cards {} at ring cycle {} (lead {} cycles at {:.0} Hz, attempt {})",
            args.cards, out.cycle, out.lead_cycles, out.rate_hz, out.attempts
        );
        for c in &out.cards {
            println!("  card {}: {}", c.card, c.reply);
        }
    }
    if let Some(c) = out.cards.iter().find(|c| c.refusal.is_some()) {
        let why = c.refusal.map(|r| r.to_string()).unwrap_or_default();
        bail!("card {} refused the line: {why} (see its reply)", c.card);
    }
    Ok(())
}
