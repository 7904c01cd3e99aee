//! Synchronized multi-card start (the verb is `mcc start-sync`), orchestrator side of the two-phase
//! protocol the cards serve on `mcc/<cluster>/card/<n>/at` (card/src/runtime/sync_start.rs;
//! the wire types are `mcc_contracts::control::sync_start`):
//!
//! 1. probe: every card's current ring cycle, twice, to measure the ring rate and the query
//!    round trip; T = latest cycle + lead, the lead covering two round trips (arm, commit) at
//!    the measured rate with a safety factor;
//! 2. arm every card for T; if one refuses (late, or no answer) abort them all and retry with
//!    a doubled lead;
//! 3. commit every card. A card executes an armed line only once committed, and its tick of T
//!    waits (bounded) for the commit or abort if it has neither: a slow commit stalls the ring
//!    a little but still executes at T, so the start never splits;
//! 4. collect each card's result (executed cycle and reply).

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use mcc_contracts::control::sync_start::{at_key, AtReply, AtRequest};
use mcc_contracts::control::CardRefusal;
use serde::Serialize;
use zenoh::Wait;

/// Largest reply accepted from a card, bytes.
const MAX_REPLY: usize = 64 * 1024;

/// Tuning of a synchronized start.
#[derive(Debug, Clone)]
pub struct SyncOptions {
    /// Smallest lead, in milliseconds of ring time.
    pub min_lead_ms: f64,
    /// Attempts before giving up.
    pub attempts: u32,
    /// Timeout of each query.
    pub query_timeout: Duration,
}

impl Default for SyncOptions {
    fn default() -> Self {
        SyncOptions {
            min_lead_ms: 10.0,
            attempts: 6,
            query_timeout: Duration::from_secs(2),
        }
    }
}

/// One card's part of a start.
#[derive(Debug, Clone, Serialize)]
pub struct CardStart {
    /// Card number.
    pub card: u32,
    /// Cycle it executed at.
    pub executed_cycle: Option<u64>,
    /// CLOCK_MONOTONIC ns at which it executed (the tick of T).
    pub executed_ns: Option<u64>,
    /// Its reply (control characters made visible).
    pub reply: String,
    /// Its reply as the card framed it.
    #[serde(skip)]
    pub raw_reply: String,
    /// The line's refusal (`ERR003`, `error #20`), whether or not the reply shows it.
    pub refusal: Option<CardRefusal>,
    /// CLOCK_MONOTONIC ns of its program start (when the line started a program).
    pub program_start_ns: Option<u64>,
    /// The card's program start cycle when its result was read.
    pub program_start_cycle: Option<u64>,
}

/// A completed synchronized start.
#[derive(Debug, Clone, Serialize)]
pub struct StartOutcome {
    /// The ring cycle T.
    pub cycle: u64,
    /// Lead used, cycles.
    pub lead_cycles: u64,
    /// Measured ring rate, cycles/s.
    pub rate_hz: f64,
    /// Attempts needed.
    pub attempts: u32,
    /// Per card.
    pub cards: Vec<CardStart>,
}

/// Send the same request to several cards at once; each answer (or an error) in card order,
/// with the round-trip time.
pub fn query_all(
    session: &zenoh::Session,
    cluster: &str,
    reqs: &[(u32, String)],
    timeout: Duration,
) -> Vec<(Result<AtReply>, Duration)> {
    let t0 = Instant::now();
    let gets: Vec<_> = reqs
        .iter()
        .map(|(n, body)| {
            session
                .get(at_key(cluster, *n))
                .payload(body.clone())
                .timeout(timeout)
                .wait()
        })
        .collect();
    gets.into_iter()
        .zip(reqs)
        .map(|(g, (n, _))| {
            let r = (|| {
                let replies = g.map_err(|e| anyhow!("card {n}: {e}"))?;
                let reply = replies.recv().map_err(|_| {
                    anyhow!("card {n}: no answer within {} ms", timeout.as_millis())
                })?;
                let sample = reply
                    .result()
                    .map_err(|_| anyhow!("card {n}: error reply"))?;
                if sample.payload().len() > MAX_REPLY {
                    bail!("card {n}: reply too large");
                }
                serde_json::from_slice::<AtReply>(&sample.payload().to_bytes())
                    .map_err(|e| anyhow!("card {n}: bad reply: {e}"))
            })();
            (r, t0.elapsed())
        })
        .collect()
}

fn same(cards: &[u32], req: &AtRequest) -> Vec<(u32, String)> {
    let s = req.to_json();
    cards.iter().map(|&c| (c, s.clone())).collect()
}

/// Latest cycle over the cards and the slowest round trip; errors name the card.
fn probe(
    session: &zenoh::Session,
    cluster: &str,
    cards: &[u32],
    t: Duration,
) -> Result<(u64, Duration, Instant)> {
    let at = Instant::now();
    let mut max_cycle = 0;
    let mut rtt = Duration::ZERO;
    for (r, dt) in query_all(session, cluster, &same(cards, &AtRequest::Info), t) {
        let r = r?;
        let c = r
            .cycle
            .ok_or_else(|| anyhow!("a card has not ticked yet: is the ring running?"))?;
        max_cycle = max_cycle.max(c);
        rtt = rtt.max(dt);
    }
    Ok((max_cycle, rtt, at))
}

/// Lead in cycles for a lead time at a rate (at least 2 cycles).
pub fn lead_cycles(rate_hz: f64, lead: Duration) -> u64 {
    ((rate_hz * lead.as_secs_f64()).ceil() as u64).max(2)
}

fn new_id() -> u64 {
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    t ^ (u64::from(std::process::id()) << 40)
}

/// Run `line` on every card of `cards` in the tick of one ring cycle.
pub fn start_sync(
    session: &zenoh::Session,
    cluster: &str,
    cards: &[u32],
    line: &str,
    opts: &SyncOptions,
) -> Result<StartOutcome> {
    let lines: Vec<(u32, String)> = cards.iter().map(|&c| (c, line.to_string())).collect();
    start_sync_lines(session, cluster, &lines, opts)
}

/// Run each card's own line (`(card, line)`) in the tick of one ring cycle (the daisy chain's
/// `@0&1B1R@1&1B7R<CR>`).
pub fn start_sync_lines(
    session: &zenoh::Session,
    cluster: &str,
    lines: &[(u32, String)],
    opts: &SyncOptions,
) -> Result<StartOutcome> {
    let cards: Vec<u32> = lines.iter().map(|(c, _)| *c).collect();
    let cards = cards.as_slice();
    if cards.is_empty() {
        bail!("no cards given");
    }
    let qt = opts.query_timeout;
    let (c0, _, t0) = probe(session, cluster, cards, qt)?;
    std::thread::sleep(Duration::from_millis(20));
    let mut last_reason = String::new();
    for attempt in 0..opts.attempts.max(1) {
        let (c1, rtt, t1) = probe(session, cluster, cards, qt)?;
        let dt = t1.duration_since(t0).as_secs_f64().max(1e-3);
        let rate = (c1.saturating_sub(c0) as f64 / dt).max(1.0);
        // Two round trips (arm, commit) plus the minimum, times 2, doubled on every retry.
        let base = (2 * rtt).as_secs_f64() * 1000.0 + opts.min_lead_ms;
        let lead_ms = 2.0 * base * f64::from(1u32 << attempt.min(16));
        let lead = lead_cycles(rate, Duration::from_secs_f64(lead_ms / 1000.0));
        let elapsed = (t1.elapsed().as_secs_f64() * rate) as u64;
        let cycle = c1 + elapsed + lead;
        let id = new_id();
        let arm: Vec<(u32, String)> = lines
            .iter()
            .map(|(n, line)| {
                let arm = AtRequest::Arm {
                    id,
                    cycle,
                    line: line.clone(),
                };
                (*n, arm.to_json())
            })
            .collect();
        let armed = query_all(session, cluster, &arm, qt);
        let refusals: Vec<String> = armed
            .iter()
            .zip(cards)
            .filter_map(|((r, _), n)| match r {
                Ok(a) if a.ok => None,
                Ok(a) if a.late => Some(format!("card {n} late ({})", a.message)),
                Ok(a) => Some(format!("card {n} refused: {}", a.message)),
                Err(e) => Some(format!("{e:#}")),
            })
            .collect();
        if !refusals.is_empty() {
            let hard = armed
                .iter()
                .find_map(|(r, _)| r.as_ref().ok().filter(|a| !a.ok && !a.late).cloned());
            let _ = query_all(session, cluster, &same(cards, &AtRequest::Abort { id }), qt);
            last_reason = refusals.join("; ");
            tracing::info!(attempt, lead, "synchronized start retried: {last_reason}");
            if let Some(h) = hard {
                bail!("synchronized start refused: {}", h.message);
            }
            continue;
        }
        let commit = same(cards, &AtRequest::Commit { id });
        let committed = query_all(session, cluster, &commit, qt);
        for ((r, _), n) in committed.iter().zip(cards) {
            match r {
                Ok(a) if a.ok => {}
                Ok(a) => bail!(
                    "card {n} refused the commit of start {id} at cycle {cycle}: {} (split start!)",
                    a.message
                ),
                Err(e) => tracing::warn!(
                    "commit to card {n}: {e:#} (it waits for the commit at cycle {cycle})"
                ),
            }
        }
        let wait = Duration::from_secs_f64(lead as f64 / rate) + Duration::from_secs(10);
        let outcome = collect(session, cluster, cards, id, cycle, wait)?;
        return Ok(StartOutcome {
            cycle,
            lead_cycles: lead,
            rate_hz: rate,
            attempts: attempt + 1,
            cards: outcome,
        });
    }
    bail!(
        "synchronized start failed after {} attempts: {last_reason}",
        opts.attempts.max(1)
    )
}

/// Wait for every card's result of start `id` (bounded).
fn collect(
    session: &zenoh::Session,
    cluster: &str,
    cards: &[u32],
    id: u64,
    cycle: u64,
    wait: Duration,
) -> Result<Vec<CardStart>> {
    let deadline = Instant::now() + wait;
    let mut out: Vec<Option<CardStart>> = vec![None; cards.len()];
    loop {
        let pending: Vec<(usize, u32)> = cards
            .iter()
            .enumerate()
            .filter(|(i, _)| out.get(*i).is_some_and(Option::is_none))
            .map(|(i, &n)| (i, n))
            .collect();
        if pending.is_empty() {
            break;
        }
        let body = AtRequest::Result { id }.to_json();
        let reqs: Vec<(u32, String)> = pending.iter().map(|&(_, n)| (n, body.clone())).collect();
        for ((r, _), (i, n)) in query_all(session, cluster, &reqs, Duration::from_secs(2))
            .into_iter()
            .zip(&pending)
        {
            let Ok(a) = r else { continue };
            if a.abandoned {
                bail!(
                    "card {n} abandoned start {id} at cycle {cycle}: no commit reached it in time"
                );
            }
            if a.executed_cycle.is_some() {
                if let Some(slot) = out.get_mut(*i) {
                    *slot = Some(CardStart {
                        card: *n,
                        executed_cycle: a.executed_cycle,
                        executed_ns: a.executed_ns,
                        reply: visible(a.reply.as_deref().unwrap_or("")),
                        raw_reply: a.reply.clone().unwrap_or_default(),
                        refusal: a.refusal,
                        program_start_cycle: a.program_start_cycle,
                        program_start_ns: a
                            .program_start_ns
                            .filter(|_| a.program_start_cycle == a.executed_cycle),
                    });
                }
            }
        }
        if Instant::now() >= deadline {
            bail!("cards did not report start {id} (cycle {cycle}) in time: is the ring running?");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(out.into_iter().flatten().collect())
}

/// Wall-clock (CLOCK_MONOTONIC) spread of the cards' execution of the line (the start of
/// their tick of T), ns. Meaningful in realtime mode.
pub fn skew_ns(out: &StartOutcome) -> Option<u64> {
    let ns: Vec<u64> = out.cards.iter().filter_map(|c| c.executed_ns).collect();
    if ns.len() < 2 || ns.len() != out.cards.len() {
        return None;
    }
    Some(ns.iter().max()? - ns.iter().min()?)
}

/// Control characters of a reply made visible (`<ACK>`, `<CR>`, `<BEL>`, `^X`).
pub fn visible(s: &str) -> String {
    let mut o = String::new();
    for c in s.chars() {
        match c {
            '\u{6}' => o.push_str("<ACK>"),
            '\r' => o.push_str("<CR>"),
            '\n' => o.push_str("<LF>"),
            '\u{7}' => o.push_str("<BEL>"),
            c if (c as u32) < 0x20 => o.push_str(&format!("^{}", (b'@' + c as u8) as char)),
            c => o.push(c),
        }
    }
    o
}

/// Parse `--cards 0,1,2`.
pub fn parse_cards(s: &str) -> Result<Vec<u32>, String> {
    let mut v = Vec::new();
    for w in s.split(',').map(str::trim).filter(|w| !w.is_empty()) {
        let n: u32 = w
            .parse()
            .map_err(|_| format!("card number {w:?} is not a number 0-15"))?;
        if n > 15 {
            return Err(format!("card number {n} is out of range 0-15"));
        }
        if v.contains(&n) {
            return Err(format!("card {n} is listed twice"));
        }
        v.push(n);
    }
    if v.is_empty() {
        return Err("no card numbers given (e.g. --cards 0,1)".into());
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn card_lists_parse_and_bad_ones_are_named() {
        assert_eq!(parse_cards("0,1, 2").unwrap(), vec![0, 1, 2]);
        assert!(parse_cards("0,x").unwrap_err().contains("\"x\""));
        assert!(parse_cards("16").unwrap_err().contains("16"));
        assert!(parse_cards("1,1").unwrap_err().contains("twice"));
        assert!(parse_cards(",").is_err());
    }

    #[test]
    fn lead_scales_with_rate_and_has_a_floor() {
        assert_eq!(lead_cycles(2258.7, Duration::from_millis(40)), 91);
        assert_eq!(lead_cycles(10_000.0, Duration::from_millis(1)), 10);
        assert_eq!(lead_cycles(1.0, Duration::from_millis(1)), 2);
    }

    #[test]
    fn replies_show_their_framing() {
        assert_eq!(visible("\u{6}"), "<ACK>");
        assert_eq!(visible("\u{7}ERR015\r"), "<BEL>ERR015<CR>");
        assert_eq!(visible("1\r\u{6}\u{1}"), "1<CR><ACK>^A");
    }
}
