//! `mcc term`: the terminal attached to a running cluster, a new host connection on its
//! daisy chain.

use anyhow::Result;

use crate::cluster::attach::attach;
use crate::cluster::terminal::{status_line, Terminal};

/// `mcc term`: the interactive terminal on a running cluster's chain; leaving it leaves the
/// cluster running.
pub fn cmd_term(cluster: &str, args: &crate::cli::TermArgs) -> Result<()> {
    let a = attach(cluster)?;
    let link = a.chain_link(args.timeout_ms);
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
    let printer = crate::cluster::events::Printer::default();
    let _watcher = crate::cluster::events::spawn(a.session.clone(), a.cfg.clone(), printer.clone());
    let res = Terminal::new(&link, args.show_framing, status)
        .with_printer(printer)
        .run();
    link.close();
    res
}
