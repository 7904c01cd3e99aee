//! `mcc status --json --watch MS`: one compact status document per line every MS
//! milliseconds over one connection, for scripts and test harnesses that poll (a status
//! costs milliseconds here instead of a process start and a zenoh connection). It ends when
//! the cluster stops (no live supervisor) or when nobody reads any more (broken pipe).

use std::io::Write;
use std::time::{Duration, Instant};

use anyhow::Result;

use crate::cluster::attach::attach;
use crate::cluster::ctl;
use crate::cluster::drills;
use crate::cluster::status;

/// Stream status documents of cluster `cluster` every `interval`.
pub fn watch(cluster: &str, interval: Duration) -> Result<()> {
    let a = attach(cluster)?;
    let run_dir = a.rd.dir.display().to_string();
    let mut out = std::io::stdout().lock();
    loop {
        let t0 = Instant::now();
        if a.rd.running().is_none() {
            return Ok(());
        }
        let (st, slow) = ctl::query_round(
            &a.session,
            &a.cfg,
            Duration::from_millis(300),
            Duration::from_millis(600),
        );
        let mut doc = status::build(&a.cfg, &a.info, &run_dir, &st, &slow);
        drills::enrich_status(&a.session, &a.cfg, &mut doc);
        crate::cluster::hosts::enrich_status(&a.session, &a.cfg, &mut doc);
        let line = serde_json::to_string(&doc)?;
        if writeln!(out, "{line}").and_then(|()| out.flush()).is_err() {
            // The reader went away: nothing left to do.
            return Ok(());
        }
        if let Some(rest) = interval.checked_sub(t0.elapsed()) {
            std::thread::sleep(rest);
        }
    }
}
