//! `mcc send [--card N] LINE…` (for scripts): the lines as a new host connection on the
//! cluster's daisy chain.

use std::time::Duration;

use anyhow::{bail, Result};

use crate::cluster::attach::attach;
use crate::cluster::chain::text::{render, translate};

/// `mcc send`: each LINE is sent (with `<CR>`), its reply printed. With `--card N` the first
/// line is prefixed with `@N`. Exit status 0 even when a card answers an error (the output
/// shows it); a line nobody answered is noted on stderr: an empty reply while the addressed
/// card is not in the cluster or did not answer in time. An empty reply of a card that got
/// the line is its answer (`$$$` and `$$$***` answer nothing on a PMAC). With `--json` one array is printed:
/// per line `{"line", "reply" (plain text), "framed" (framing shown), "error" (the line's
/// refusal as the card reports it beside the bytes: "ERRnnn" whatever I6 printed, a Power
/// card's "error #n", "BELL" for a refusal without a code, or null), "answered",
/// "silent_cards"}`.
pub fn cmd_send(cluster: &str, args: &crate::cli::SendArgs) -> Result<()> {
    if args.lines.iter().any(|l| l.len() > 64 * 1024) {
        bail!("a LINE is longer than 65536 bytes");
    }
    let a = attach(cluster)?;
    if a.cfg.cards.is_empty() {
        bail!("cluster {cluster:?} has no cards");
    }
    let link = a.chain_link(args.timeout_ms);
    // A card not yet routable would look silent: give routing a moment first.
    let _ = link.wait_ready(Duration::from_millis(args.timeout_ms.clamp(100, 3000)));
    let mut doc = Vec::new();
    let mut addressed = Addressed::default();
    for (i, line) in args.lines.iter().enumerate() {
        let mut bytes = Vec::new();
        if let (0, Some(n)) = (i, args.card) {
            bytes.extend_from_slice(format!("@{n:X}").as_bytes());
        }
        bytes.extend_from_slice(&translate(line));
        let r = link.send(&bytes);
        addressed = addressed.after(&bytes);
        let answered = !r.bytes.is_empty()
            || bytes.last() != Some(&b'\r')
            || addressed.reached(&a.cfg, &r.silent);
        if args.json {
            doc.push(serde_json::json!({
                "line": line,
                "reply": render(&r.bytes, false).replace("<BELL>", ""),
                "framed": render(&r.bytes, true),
                "error": r.refusals.first().map(ToString::to_string),
                "answered": answered,
                "silent_cards": r.silent,
            }));
            continue;
        }
        let mut text = render(&r.bytes, args.show_framing);
        if !text.is_empty() && !text.ends_with('\n') {
            text.push('\n');
        }
        print!("{text}");
        if !answered {
            eprintln!("mcc send: no card answered {line:?} (is the addressed card on the chain?)");
        }
        if !r.silent.is_empty() {
            eprintln!("mcc send: card(s) {:?} did not answer in time", r.silent);
        }
    }
    link.close();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
    }
    Ok(())
}

/// The card a chain connection addresses, as the cards see it (chain.rs of the card): card 0
/// on a new connection, `@n` card n, `@@` every card (card 0 answers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Addressed {
    Card(u8),
    All,
}

impl Default for Addressed {
    fn default() -> Self {
        Addressed::Card(0)
    }
}

impl Addressed {
    /// The addressing after the host sent `bytes`.
    fn after(mut self, bytes: &[u8]) -> Self {
        let mut it = bytes.iter().peekable();
        while let Some(&b) = it.next() {
            if b != b'@' {
                continue;
            }
            match it.peek().copied() {
                Some(b'@') => {
                    self = Addressed::All;
                    it.next();
                }
                Some(&h) if h.is_ascii_hexdigit() => {
                    let n = char::from(h).to_digit(16).unwrap_or(0);
                    self = Addressed::Card(n as u8);
                    it.next();
                }
                _ => {}
            }
        }
        self
    }

    /// The card that answers is in the cluster and answered in time (its reply, even
    /// empty, is the reply).
    fn reached(self, cfg: &mcc_contracts::config::ClusterConfig, silent: &[u32]) -> bool {
        let n = match self {
            Addressed::Card(n) => n,
            Addressed::All => 0,
        };
        cfg.cards.iter().any(|c| c.number == n) && !silent.contains(&u32::from(n))
    }
}

#[cfg(test)]
mod tests {
    use super::Addressed;

    #[test]
    fn the_answering_card_follows_the_addressing() {
        let cfg = mcc_contracts::config::ClusterConfig::default_cluster(2, 0);
        let a = Addressed::default();
        assert_eq!(a, Addressed::Card(0));
        assert_eq!(a.after(b"@1$$$\r"), Addressed::Card(1));
        assert_eq!(a.after(b"@1P1 @@\r"), Addressed::All);
        assert_eq!(a.after(b"@A\r"), Addressed::Card(10));
        assert_eq!(a.after(b"@\r"), Addressed::Card(0), "a lone @ is a command");
        // `$$$` to a card of the cluster: reached, its empty reply is the answer.
        assert!(a.after(b"@1$$$\r").reached(&cfg, &[]));
        assert!(Addressed::All.reached(&cfg, &[]));
        // No card 7; card 1 silent (did not answer in time).
        assert!(!a.after(b"@7P4\r").reached(&cfg, &[]));
        assert!(!a.after(b"@1P4\r").reached(&cfg, &[1]));
    }
}
