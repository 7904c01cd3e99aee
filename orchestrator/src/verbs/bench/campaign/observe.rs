//! What the campaign reads from the cluster: every member's status and every card's state (ring
//! fault, killed motors), and waits on them with wall-clock bounds.

use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::AtReply;
use mcc_ring::control::MemberStatus;

use crate::cluster::ctl::query_statuses;
use crate::cluster::drills::{card_infos, card_infos_within};

/// One look at the cluster.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    /// Member statuses in ring order (`None`: no answer).
    pub members: Vec<Option<MemberStatus>>,
    /// Card states in config order (`None`: no answer).
    pub cards: Vec<Option<AtReply>>,
}

impl Snapshot {
    /// Member `i`'s status.
    pub fn member(&self, i: usize) -> Option<&MemberStatus> {
        self.members.get(i).and_then(Option::as_ref)
    }

    /// Ring faults latched so far by each member (0 for one that did not answer).
    pub fn fault_counts(&self) -> Vec<u64> {
        self.members
            .iter()
            .map(|m| m.as_ref().map_or(0, |m| m.ring_fault_count))
            .collect()
    }

    /// The synchronizing master's cycle (or the highest any member reports).
    pub fn cycle(&self, cfg: &ClusterConfig) -> u64 {
        cfg.position(&cfg.ring.sync_master)
            .and_then(|i| self.member(i))
            .map(|m| m.cycle)
            .unwrap_or_else(|| {
                self.members
                    .iter()
                    .flatten()
                    .map(|m| m.cycle)
                    .max()
                    .unwrap_or(0)
            })
    }

    /// Every member answered, is locked and has no ring fault.
    pub fn healthy(&self) -> bool {
        self.members
            .iter()
            .all(|m| m.as_ref().is_some_and(|m| m.locked && !m.ring_fault))
    }
}

/// Member statuses only (fast).
pub fn statuses(s: &zenoh::Session, cfg: &ClusterConfig) -> Snapshot {
    Snapshot {
        members: query_statuses(
            s,
            cfg,
            Duration::from_millis(300),
            Duration::from_millis(600),
        ),
        cards: Vec::new(),
    }
}

/// Member statuses and card states, for a judgement: a member that did not answer is asked
/// again (twice, with longer waits) before it counts as silent — on a loaded machine a status
/// query can take longer than the fast look allows, and that is no fault of the ring.
pub fn snapshot(s: &zenoh::Session, cfg: &ClusterConfig) -> Snapshot {
    let mut snap = statuses(s, cfg);
    for wait in [1500, 3000] {
        if snap.members.iter().all(Option::is_some) {
            break;
        }
        let again = query_statuses(
            s,
            cfg,
            Duration::from_millis(wait),
            Duration::from_millis(2 * wait),
        );
        for (m, a) in snap.members.iter_mut().zip(again) {
            if m.is_none() {
                *m = a;
            }
        }
    }
    snap.cards = card_infos(s, cfg);
    // A card whose member answered but whose card state did not is asked twice more, with
    // longer waits: a card serves its state between servo ticks, and while its sync master is
    // frozen a follower's next tick waits up to the member timeout before its holdover clock
    // takes over (seen: "freeze card0: card1 did not report its motors"), besides a busy
    // machine. What it reports (a ring fault, killed motors) stays latched until the reset,
    // so a later answer is the same evidence. A card that is gone is not waited for.
    for wait in [1500, 3000] {
        let answered = |k: usize| {
            let c = &cfg.cards[k];
            cfg.position(&c.name)
                .is_some_and(|i| snap.member(i).is_some())
        };
        let missing: Vec<usize> = (0..snap.cards.len())
            .filter(|&k| snap.cards[k].is_none() && answered(k))
            .collect();
        if missing.is_empty() {
            break;
        }
        let again = card_infos_within(s, cfg, Duration::from_millis(wait));
        for (k, a) in again.into_iter().enumerate() {
            if missing.contains(&k) {
                snap.cards[k] = a;
            }
        }
    }
    snap
}

/// Poll statuses until `done` holds (returns that snapshot) or `timeout` passes (error naming
/// `what`). `each` sees every snapshot.
pub fn wait_for(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    what: &str,
    timeout: Duration,
    mut each: impl FnMut(&Snapshot),
    mut done: impl FnMut(&Snapshot) -> bool,
) -> Result<Snapshot> {
    let deadline = Instant::now() + timeout;
    loop {
        let snap = statuses(s, cfg);
        each(&snap);
        if done(&snap) {
            return Ok(snap);
        }
        if Instant::now() > deadline {
            bail!("{what}: not within {} s", timeout.as_secs());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Wait until the ring has run `cycles` more cycles (by the sync master's count).
pub fn wait_cycles(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    cycles: u64,
    timeout: Duration,
) -> Result<Snapshot> {
    let from = statuses(s, cfg).cycle(cfg);
    wait_for(
        s,
        cfg,
        &format!("{cycles} ring cycles"),
        timeout,
        |_| {},
        |snap| snap.cycle(cfg) >= from + cycles,
    )
}
