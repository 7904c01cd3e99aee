//! `mcc status [--json] [--watch MS]`.

use std::time::Duration;

use anyhow::Result;

use crate::cli::StatusArgs;
use crate::cluster::attach::attach;
use crate::cluster::ctl;
use crate::cluster::status;

/// `mcc status [--json]`.
pub fn cmd_status(cluster: &str, args: &StatusArgs) -> Result<()> {
    if let Some(ms) = args.watch {
        return crate::verbs::watch::watch(cluster, Duration::from_millis(ms));
    }
    let a = attach(cluster)?;
    let (st, slow) = ctl::query_round(
        &a.session,
        &a.cfg,
        Duration::from_millis(700),
        Duration::from_millis(1500),
    );
    let mut doc = status::build(&a.cfg, &a.info, &a.rd.dir.display().to_string(), &st, &slow);
    crate::cluster::drills::enrich_status(&a.session, &a.cfg, &mut doc);
    crate::cluster::emcl::status::enrich(&a.session, &a.cfg, &mut doc);
    crate::cluster::hosts::enrich_status(&a.session, &a.cfg, &mut doc);
    doc.link_faults = crate::cluster::link_ctl::query_status(&a.session, &a.cfg.cluster);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        print!("{}", status::render_table(&doc));
    }
    Ok(())
}
