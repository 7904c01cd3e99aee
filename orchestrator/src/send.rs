//! `mcc send [--card N] LINE…` (for scripts) and `mcc term` (the terminal attached to a
//! running cluster), both as a new host connection on the cluster's daisy chain.

use std::time::Duration;

use anyhow::{bail, Result};

use crate::chain::link::ChainLink;
use crate::chain::text::{render, translate};
use crate::client::{attach, Attached};
use crate::term::{one_line, Terminal};
use crate::{ctl, status};

/// A closure producing the one-line status of an attached cluster.
pub fn status_line(
    session: zenoh::Session,
    cfg: mcc_ring::config::ClusterConfig,
    info: crate::rundir::SupervisorInfo,
    run_dir: String,
) -> impl Fn() -> String {
    move || {
        let st = ctl::query_statuses(
            &session,
            &cfg,
            Duration::from_millis(500),
            Duration::from_millis(1000),
        );
        one_line(&status::build(&cfg, &info, &run_dir, &st))
    }
}

fn link_for(a: &Attached, timeout_ms: u64) -> ChainLink {
    ChainLink::new(
        a.session.clone(),
        &a.cfg,
        Duration::from_millis(timeout_ms.max(1)),
    )
}

/// `mcc send`: each LINE is sent (with `<CR>`), its reply printed. With `--card N` the first
/// line is prefixed with `@N`. Exit status 0 even when a card answers an error (the output
/// shows it); a line nobody answered is noted on stderr.
pub fn cmd_send(cluster: &str, args: &crate::cli::SendArgs) -> Result<()> {
    if args.lines.iter().any(|l| l.len() > 64 * 1024) {
        bail!("a LINE is longer than 65536 bytes");
    }
    let a = attach(cluster)?;
    if a.cfg.cards.is_empty() {
        bail!("cluster {cluster:?} has no cards");
    }
    let link = link_for(&a, args.timeout_ms);
    for (i, line) in args.lines.iter().enumerate() {
        let mut bytes = Vec::new();
        if let (0, Some(n)) = (i, args.card) {
            bytes.extend_from_slice(format!("@{n:X}").as_bytes());
        }
        bytes.extend_from_slice(&translate(line));
        let r = link.send(&bytes);
        let mut text = render(&r.bytes, args.show_framing);
        if !text.is_empty() && !text.ends_with('\n') {
            text.push('\n');
        }
        print!("{text}");
        if r.bytes.is_empty() && bytes.last() == Some(&b'\r') {
            eprintln!("mcc send: no card answered {line:?} (is the addressed card on the chain?)");
        }
        if !r.silent.is_empty() {
            eprintln!("mcc send: card(s) {:?} did not answer in time", r.silent);
        }
    }
    link.close();
    Ok(())
}

/// `mcc term`: the interactive terminal on a running cluster's chain; leaving it leaves the
/// cluster running.
pub fn cmd_term(cluster: &str, args: &crate::cli::TermArgs) -> Result<()> {
    let a = attach(cluster)?;
    let link = link_for(&a, args.timeout_ms);
    let status = status_line(
        a.session.clone(),
        a.cfg.clone(),
        a.info.clone(),
        a.rd.dir.display().to_string(),
    );
    eprintln!(
        "mcc term: cluster {cluster}, {} cards on the daisy chain; .help for help, Ctrl-D or .quit to leave",
        a.cfg.cards.len()
    );
    let printer = crate::events::Printer::default();
    let _watcher = crate::events::spawn(a.session.clone(), a.cfg.clone(), printer.clone());
    let res = Terminal::new(&link, args.show_framing, status)
        .with_printer(printer)
        .run();
    link.close();
    res
}
