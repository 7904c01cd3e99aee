//! One host connection on the daisy chain. Each chunk of input goes to every card's
//! `mcc/<cluster>/card/<n>/chain` queryable at once (wire format: `mcc_contracts::control::chain`);
//! each card answers with position-tagged segments and the segments of all cards are merged
//! by input position, so replies come out in the order the host's characters caused them. A
//! card that does not answer within the timeout contributes nothing — as a silent card on a
//! serial cable — and the link carries on.
//!
//! Synchronized starts: before a `<CR>` whose line may start programs (it contains `R`/`S`),
//! the link asks every card (op `?`) whether its collected line starts a program. When two or
//! more do, it takes those lines (op `T`), sends the `<CR>` (the other cards run theirs as
//! usual) and runs the taken lines through the cards' arm/commit synchronized start
//! (crate::cluster::sync_start), so every program starts in the servo tick of one ring cycle; the
//! answering card's reply is the one its line gave there. If no common cycle can be agreed
//! the lines run nowhere and the answering card's reply is `<BELL>ERR008<CR>` (never a split
//! start).
//!
//! Refusals: each card lists the refusals of the lines it answered in its reply's attachment
//! (`mcc_contracts::control::chain::decode_refusals`), a synchronized start's card in its
//! result; [`ChainReply::refusals`] has them in input order, so a caller matches on them and
//! never reads a refusal back out of the reply bytes (which show what I6 made of it).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::chain::{
    chain_key, decode_refusals, decode_reply, encode_request, FLAG_STARTS, FLAG_TALKS, MAX_CHUNK,
    MAX_REPLY, OP_CLOSE, OP_DATA, OP_QUERY_START, OP_TAKE_START,
};
use mcc_contracts::control::CardRefusal;
use zenoh::Wait;

/// Reply of the answering card when a synchronized start could not be agreed.
pub const SYNC_FAILED_REPLY: &[u8] = b"\x07ERR008\r";
/// The refusal of [`SYNC_FAILED_REPLY`].
pub const SYNC_FAILED_REFUSAL: CardRefusal = CardRefusal::Pmac(8);
/// Default time a card has to answer one chunk.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(2);

/// A connection id unlikely to collide with another process's (pid, time, counter).
pub fn new_conn_id() -> u64 {
    static N: AtomicU64 = AtomicU64::new(0);
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    (u64::from(std::process::id()) << 40)
        ^ (t & 0xFF_FFFF_FFFF)
        ^ (N.fetch_add(1, Ordering::Relaxed) << 20)
}

/// Merge the segments of every card (in card order): by input position, then card order.
pub fn merge(per_card: &[Vec<(u32, Vec<u8>)>]) -> Vec<u8> {
    let mut all: Vec<(u32, usize, &[u8])> = per_card
        .iter()
        .enumerate()
        .flat_map(|(k, segs)| segs.iter().map(move |(p, b)| (*p, k, b.as_slice())))
        .collect();
    all.sort_by_key(|s| (s.0, s.1));
    all.into_iter().flat_map(|s| s.2.iter().copied()).collect()
}

/// Merge the refusals of every card (in card order) as [`merge`] merges their segments.
pub fn merge_refusals(per_card: &[Vec<(u32, CardRefusal)>]) -> Vec<CardRefusal> {
    let mut all: Vec<(u32, usize, CardRefusal)> = per_card
        .iter()
        .enumerate()
        .flat_map(|(k, r)| r.iter().map(move |&(p, r)| (p, k, r)))
        .collect();
    all.sort_by_key(|s| (s.0, s.1));
    all.into_iter().map(|s| s.2).collect()
}

/// What one send brought back.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ChainReply {
    /// The merged reply bytes, as the host would read them from the cable.
    pub bytes: Vec<u8>,
    /// Cards (config numbers) that did not answer in time or answered garbage.
    pub silent: Vec<u32>,
    /// The refusals of the lines answered, in input order (typed: whether or not the card's
    /// I6 printed them in [`ChainReply::bytes`]).
    pub refusals: Vec<CardRefusal>,
}

/// One host connection.
pub struct ChainLink {
    session: zenoh::Session,
    cluster: String,
    cards: Vec<(u32, String)>,
    conn: u64,
    timeout: Duration,
    /// The line since the last `<CR>` has a character that may start a program.
    maybe_start: AtomicBool,
}

impl ChainReply {
    fn add(&mut self, r: ChainReply) {
        self.bytes.extend_from_slice(&r.bytes);
        self.refusals.extend_from_slice(&r.refusals);
        for s in r.silent {
            if !self.silent.contains(&s) {
                self.silent.push(s);
            }
        }
    }
}

impl std::fmt::Debug for ChainLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ChainLink")
            .field("conn", &self.conn)
            .field("cards", &self.cards.len())
            .finish_non_exhaustive()
    }
}

impl ChainLink {
    /// A new connection to every card of `cfg` over `session`.
    pub fn new(session: zenoh::Session, cfg: &ClusterConfig, timeout: Duration) -> Self {
        let cards = cfg
            .cards
            .iter()
            .map(|c| {
                let n = u32::from(c.number);
                (n, chain_key(&cfg.cluster, n))
            })
            .collect();
        ChainLink {
            session,
            cluster: cfg.cluster.clone(),
            cards,
            conn: new_conn_id(),
            timeout,
            maybe_start: AtomicBool::new(false),
        }
    }

    /// Send host bytes; the merged replies. Never blocks longer than the timeout per
    /// [`MAX_CHUNK`] bytes.
    pub fn send(&self, data: &[u8]) -> ChainReply {
        let mut out = ChainReply::default();
        let mut rest = data;
        while !rest.is_empty() {
            // Up to the first <CR> whose line may start programs: that one goes on its own.
            let mut maybe = self.maybe_start.load(Ordering::Relaxed);
            let mut cut = None;
            for (i, &b) in rest.iter().enumerate() {
                match b {
                    b'\r' if maybe => {
                        cut = Some(i);
                        break;
                    }
                    b'\r' | 0x18 => maybe = false,
                    b'R' | b'r' | b'S' | b's' | b'>' => maybe = true,
                    _ => {}
                }
            }
            self.maybe_start.store(maybe, Ordering::Relaxed);
            let (plain, start_cr) = match cut {
                Some(i) => (&rest[..i], true),
                None => (rest, false),
            };
            for chunk in plain.chunks(MAX_CHUNK) {
                out.add(self.exchange(&encode_request(OP_DATA, self.conn, chunk)));
            }
            rest = &rest[plain.len()..];
            if start_cr {
                out.add(self.start_cr());
                self.maybe_start.store(false, Ordering::Relaxed);
                rest = &rest[1..];
            }
        }
        out
    }

    /// The `<CR>` of a line that may start programs: synchronized when it does on 2+ cards.
    fn start_cr(&self) -> ChainReply {
        let cr = encode_request(OP_DATA, self.conn, b"\r");
        let all: Vec<u32> = self.cards.iter().map(|(n, _)| *n).collect();
        let starters: Vec<u32> = self
            .ask(OP_QUERY_START, &all)
            .into_iter()
            .filter(|(_, r)| r.first().is_some_and(|f| f & FLAG_STARTS != 0))
            .map(|(n, _)| n)
            .collect();
        if starters.len() < 2 {
            return self.exchange(&cr);
        }
        let taken: Vec<(u32, bool, String)> = self
            .ask(OP_TAKE_START, &starters)
            .into_iter()
            .filter_map(|(n, r)| {
                let (&flags, line) = r.split_first()?;
                let talks = flags & FLAG_TALKS != 0;
                Some((n, talks, String::from_utf8_lossy(line).into_owned()))
            })
            .collect();
        let mut out = self.exchange(&cr);
        if taken.is_empty() {
            return out;
        }
        let lines: Vec<(u32, String)> = taken.iter().map(|(n, _, l)| (*n, l.clone())).collect();
        let opts = crate::cluster::sync_start::SyncOptions {
            query_timeout: self.timeout,
            ..crate::cluster::sync_start::SyncOptions::default()
        };
        let res = crate::cluster::sync_start::start_sync_lines(
            &self.session,
            &self.cluster,
            &lines,
            &opts,
        );
        for (n, talks, _) in &taken {
            if !talks {
                continue;
            }
            match &res {
                Ok(o) => {
                    let r = o.cards.iter().find(|c| c.card == *n);
                    out.bytes
                        .extend_from_slice(r.map(|c| c.raw_reply.as_bytes()).unwrap_or_default());
                    out.refusals.extend(r.and_then(|c| c.refusal));
                }
                Err(_) => {
                    out.bytes.extend_from_slice(SYNC_FAILED_REPLY);
                    out.refusals.push(SYNC_FAILED_REFUSAL);
                }
            }
        }
        match res {
            Ok(o) => tracing::info!(
                cycle = o.cycle,
                "chain line started on {} cards",
                taken.len()
            ),
            Err(e) => tracing::warn!("chain synchronized start failed, nothing ran: {e:#}"),
        }
        out
    }

    /// Send `op` (no data) to cards `only`; the raw answers of those that answered.
    fn ask(&self, op: u8, only: &[u32]) -> Vec<(u32, Vec<u8>)> {
        let payload = encode_request(op, self.conn, &[]);
        let gets: Vec<_> = self
            .cards
            .iter()
            .filter(|(n, _)| only.contains(n))
            .map(|(n, key)| {
                let g = self
                    .session
                    .get(key.as_str())
                    .payload(payload.clone())
                    .timeout(self.timeout)
                    .wait();
                (*n, g)
            })
            .collect();
        gets.into_iter()
            .filter_map(|(n, g)| {
                let reply = g.ok()?.recv().ok()?;
                let bytes = reply.result().ok()?.payload().to_bytes().into_owned();
                (bytes.len() <= MAX_REPLY).then_some((n, bytes))
            })
            .collect()
    }

    /// Wait (up to `budget`) until every card's chain queryable answers: a session that has
    /// just connected may not yet route queries to every card, and a query nobody serves
    /// comes back empty at once (a card that seems silent). Returns the cards still not
    /// reachable.
    pub fn wait_ready(&self, budget: Duration) -> Vec<u32> {
        let deadline = std::time::Instant::now() + budget;
        let mut pending: Vec<u32> = self.cards.iter().map(|(n, _)| *n).collect();
        loop {
            let answered: Vec<u32> = self
                .ask(OP_QUERY_START, &pending)
                .into_iter()
                .map(|(n, _)| n)
                .collect();
            pending.retain(|n| !answered.contains(n));
            if pending.is_empty() || std::time::Instant::now() >= deadline {
                return pending;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Tell every card this connection is gone.
    pub fn close(&self) {
        let _ = self.exchange(&encode_request(OP_CLOSE, self.conn, &[]));
    }

    fn exchange(&self, payload: &[u8]) -> ChainReply {
        let gets: Vec<_> = self
            .cards
            .iter()
            .map(|(n, key)| {
                let g = self
                    .session
                    .get(key.as_str())
                    .payload(payload.to_vec())
                    .timeout(self.timeout)
                    .wait();
                (*n, g)
            })
            .collect();
        let mut per_card = Vec::with_capacity(gets.len());
        let mut refusals = Vec::with_capacity(gets.len());
        let mut silent = Vec::new();
        for (n, g) in gets {
            let answer = g
                .ok()
                .and_then(|replies| replies.recv().ok())
                .and_then(|reply| {
                    let s = reply.result().ok()?;
                    let attached = s.attachment().map(|a| a.to_bytes().into_owned());
                    Some((s.payload().to_bytes().into_owned(), attached))
                })
                .and_then(|(bytes, attached)| decode_answer(n, &bytes, attached.as_deref()));
            match answer {
                Some((s, r)) => {
                    per_card.push(s);
                    refusals.push(r);
                }
                None => silent.push(n),
            }
        }
        ChainReply {
            bytes: merge(&per_card),
            silent,
            refusals: merge_refusals(&refusals),
        }
    }
}

/// One card's segments and refusals (`None`: garbage, logged; the card counts as silent).
#[allow(clippy::type_complexity)]
fn decode_answer(
    n: u32,
    payload: &[u8],
    attachment: Option<&[u8]>,
) -> Option<(Vec<(u32, Vec<u8>)>, Vec<(u32, CardRefusal)>)> {
    let decoded = decode_reply(payload)
        .and_then(|s| Ok((s, decode_refusals(attachment.unwrap_or_default())?)));
    match decoded {
        Ok(d) => Some(d),
        Err(e) => {
            tracing::warn!("card {n}: bad chain reply: {e}");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_merge_in_input_order_and_garbage_is_silence() {
        let c0 = vec![(9, CardRefusal::Power(20))];
        let c1 = vec![(3, CardRefusal::Pmac(3)), (12, CardRefusal::Pmac(15))];
        assert_eq!(
            merge_refusals(&[c0, c1]),
            vec![
                CardRefusal::Pmac(3),
                CardRefusal::Power(20),
                CardRefusal::Pmac(15)
            ]
        );
        let seg = mcc_contracts::control::chain::encode_reply(&[(3, b"\x07".to_vec())]);
        let att = mcc_contracts::control::chain::encode_refusals(&[(3, CardRefusal::Pmac(3))]);
        assert_eq!(
            decode_answer(0, &seg, Some(&att)),
            Some((vec![(3, b"\x07".to_vec())], vec![(3, CardRefusal::Pmac(3))]))
        );
        assert_eq!(
            decode_answer(0, &seg, None),
            Some((vec![(3, b"\x07".to_vec())], vec![]))
        );
        assert_eq!(decode_answer(0, &seg, Some(b"\x03\0\0\0\x03ERR")), None);
        assert_eq!(decode_answer(0, b"\x03\0", None), None);
    }

    #[test]
    fn replies_merge_in_input_order() {
        // Card 1 answered the first line (position 3), card 0 the second (position 9).
        let c0 = vec![(9, b"B\r".to_vec())];
        let c1 = vec![(3, b"A\r".to_vec()), (12, b"C".to_vec())];
        assert_eq!(merge(&[c0, c1]), b"A\rB\rC");
        assert_eq!(
            merge(&[vec![(1, b"x".to_vec())], vec![(1, b"y".to_vec())]]),
            b"xy"
        );
    }

    #[test]
    fn connection_ids_differ() {
        assert_ne!(new_conn_id(), new_conn_id());
    }
}
