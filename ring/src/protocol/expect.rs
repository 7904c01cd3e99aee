//! What the ring checks must make of a fault (spec §6.8 applied to what each fault does to the
//! frames): which members must latch a ring fault and within how many ring cycles, which link
//! `mcc status` must name, and how short a burst of each fault must be for no check to trip.
//! Pure; the fault campaign (`mcc bench faults --campaign`) holds a cluster to it and the
//! in-process ring is tested against it (`expect_tests.rs`).
//!
//! Bounds count ring cycles from the fault's onset: for a send-path fault the first cycle it
//! acted on (`since_cycle` in the member's status), for a member whose process died or froze
//! the first cycle its downstream neighbour ran without light (`dark_since_cycle`). They hold
//! in the paced and lockstep clocks, where only ring content makes ring errors.
//!
//! How each fault reaches the checks (D = the member downstream of the target, "D..SM" the
//! members from D round to the synchronizing master SM inclusive, U the cards after SM up to
//! the target, whose own packets cross the faulty link):
//! - `corrupt`, `byte-violation`, `overrun`, `underrun`: D finds a bad packet every cycle and
//!   drops it. Nobody else sees anything.
//! - `cut` (and a dead or frozen member): dark frames, a byte violation every cycle at every
//!   member of D..SM; the cards of U miss their own packets (a data underrun from the second
//!   frame without them).
//! - `drop-packets`: no sync packet reaches D..SM; every card misses its own packets.
//! - `drop-sync`: no sync packet reaches D..SM.
//! - `delay=N`: empty frames for N cycles (no sync downstream), then every cycle the frame
//!   held from N cycles ago arrives before the cycle's own: an overrun at every member of
//!   D..SM. The cards of U may or may not see their own packets late enough to count.
//! - `delay-us` and a stall shorter than the frozen-member wait: the ring waits; no error (a
//!   held frame lands in the cycle it was sent in, later on the wall clock; the simulator holds
//!   to this, `expect_tests.rs`, `delay_us_means_the_ring_waits`).
//!
//! The check itself (§6.8, [`crate::check`]): errors are counted per period and fire on the
//! check where the count reaches the limit; sync packets are judged at the end of a period.
//! So an error every cycle is caught within `(rti − 1) + (2·min(L, C) − 2)·rti` cycles (the
//! period in which it starts may end one error short), sync packets lost for good within
//! `2·Pc − (I1005 − 1)·rti − 2` (the period in which they stop may still have enough), where
//! rti = I8 + 1, L = I1004 (station: MI9, the config's max_errors), C = checks per period, Pc = C·rti. The
//! synchronizing master judges its own frame one cycle later (it comes back during the next).

use crate::check::CheckParams;
use crate::control::MemberKind;
use crate::fault::FaultKind;
use mcc_contracts::config::{ClusterConfig, MemberRef};

/// One member as the rules see it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelMember {
    /// Member name.
    pub name: String,
    /// Card or station.
    pub kind: MemberKind,
    /// Its ring check (period 0: not checking).
    pub check: CheckParams,
}

/// A ring as the rules see it: members in ring order and which one is the synchronizing master.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RingModel {
    /// Members in ring order (member i sends to member i + 1 mod N).
    pub members: Vec<ModelMember>,
    /// Index of the synchronizing master.
    pub sync_master: usize,
}

/// What happens to a member.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Disturbance {
    /// A send-path fault, for `cycles` ring cycles (`None`: until cleared).
    Frames {
        /// The fault.
        kind: FaultKind,
        /// How long it lasts.
        cycles: Option<u64>,
    },
    /// No light leaves the member any more: its process was killed (or restarted), or it
    /// stopped answering for longer than the frozen-member wait.
    Dark,
    /// The member stopped for less than the frozen-member wait (paced, lockstep: no error).
    Stall,
}

/// A member that must latch a ring fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Detection {
    /// Ring index of the member.
    pub member: usize,
    /// At most this many ring cycles after the onset (its `ring_fault_cycle − onset`).
    pub within: u64,
}

/// What the ring checks must make of one disturbance.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Expectation {
    /// Members that must latch a ring fault, each within its bound.
    pub must: Vec<Detection>,
    /// Members that may latch one too (a side effect no rule pins down).
    pub may: Vec<usize>,
    /// The link `mcc status` must name: the one leaving this member.
    pub link: Option<usize>,
}

impl Expectation {
    /// Nobody may latch a ring fault.
    pub fn quiet(&self) -> bool {
        self.must.is_empty() && self.may.is_empty()
    }

    /// May member `i` latch a ring fault?
    pub fn allows(&self, i: usize) -> bool {
        self.may.contains(&i) || self.must.iter().any(|d| d.member == i)
    }
}

/// Checks per period (the period ends once a whole number of RTIs covers I1001).
pub fn checks_per_period(p: &CheckParams) -> u64 {
    u64::from(p.period).div_ceil(u64::from(p.rti.max(1)))
}

fn armed(p: &CheckParams) -> bool {
    p.period > 0
}

/// Latest latch, in cycles after the first cycle with an error, of a receive error in every
/// cycle; `None` if the check is off.
pub fn error_latency(p: &CheckParams) -> Option<u64> {
    if !armed(p) {
        return None;
    }
    let rti = u64::from(p.rti.max(1));
    let n = u64::from(p.error_limit.max(1)).min(checks_per_period(p));
    Some((rti - 1) + (2 * n).saturating_sub(2) * rti)
}

/// Latest latch, in cycles after the first cycle without a sync packet, of sync packets lost
/// for good; `None` if the check is off or needs no sync packets.
pub fn sync_latency(p: &CheckParams) -> Option<u64> {
    if !armed(p) || p.sync_min == 0 {
        return None;
    }
    let rti = u64::from(p.rti.max(1));
    let c = checks_per_period(p);
    let pc = c * rti;
    if u64::from(p.sync_min) > c {
        // Never satisfiable: every period fails.
        return Some(pc);
    }
    Some((2 * pc).saturating_sub((u64::from(p.sync_min) - 1) * rti + 2))
}

/// Longest run of consecutive cycles with a receive error the check tolerates.
pub fn safe_error_burst(p: &CheckParams) -> u64 {
    if !armed(p) {
        return u64::MAX;
    }
    // b consecutive cycles touch at most ceil((b − 1)/rti) + 1 checks; a period may see at
    // most min(L, C) − 1 of them.
    let k = u64::from(p.error_limit.max(1)).min(checks_per_period(p)) - 1;
    if k == 0 {
        0
    } else {
        (k - 1) * u64::from(p.rti.max(1)) + 1
    }
}

/// Longest run of consecutive cycles without a sync packet the check tolerates.
pub fn safe_sync_burst(p: &CheckParams) -> u64 {
    if !armed(p) || p.sync_min == 0 {
        return u64::MAX;
    }
    // b cycles empty at most floor(b/rti) checks; a period may lose C − I1005 of them.
    let spare = checks_per_period(p).saturating_sub(u64::from(p.sync_min));
    (spare + 1) * u64::from(p.rti.max(1)) - 1
}

impl RingModel {
    /// The model of a cluster config's ring (cards' checks from their start-up I-variables).
    pub fn from_config(cfg: &ClusterConfig) -> Option<Self> {
        let members = cfg
            .ring
            .order
            .iter()
            .map(|name| {
                let (kind, check) = match cfg.member(name)? {
                    MemberRef::Card(c) => (
                        MemberKind::Card,
                        crate::check::card_config_check(c).params(),
                    ),
                    MemberRef::Station(s) => (
                        MemberKind::Station,
                        crate::check::RingCheck::station(
                            s.check.period,
                            s.check.min_syncs,
                            s.check.max_errors,
                        )
                        .params(),
                    ),
                };
                Some(ModelMember {
                    name: name.clone(),
                    kind,
                    check,
                })
            })
            .collect::<Option<Vec<_>>>()?;
        let sync_master = cfg.position(&cfg.ring.sync_master)?;
        Some(RingModel {
            members,
            sync_master,
        })
    }

    fn n(&self) -> usize {
        self.members.len()
    }

    /// D..SM: the members from the one after `target` round to the sync master, inclusive.
    fn downstream(&self, target: usize) -> Vec<usize> {
        let n = self.n();
        let mut out = Vec::new();
        for k in 1..=n {
            let i = (target + k) % n;
            out.push(i);
            if i == self.sync_master {
                break;
            }
        }
        out
    }

    /// U: the cards after the sync master up to `target` inclusive (their own packets cross
    /// the link leaving `target`); empty when the target is the sync master.
    fn upstream_cards(&self, target: usize) -> Vec<usize> {
        let n = self.n();
        let mut out = Vec::new();
        if target == self.sync_master {
            return out;
        }
        for k in 1..=n {
            let i = (self.sync_master + k) % n;
            if self.members[i].kind == MemberKind::Card {
                out.push(i);
            }
            if i == target {
                break;
            }
        }
        out
    }

    fn is_card(&self, i: usize) -> bool {
        self.members[i].kind == MemberKind::Card
    }

    /// The SM sees its own frame one cycle later.
    fn lag(&self, i: usize) -> u64 {
        u64::from(i == self.sync_master)
    }

    fn err(&self, i: usize, offset: u64) -> Option<u64> {
        error_latency(&self.members[i].check).map(|b| b + offset + self.lag(i))
    }

    fn sync(&self, i: usize, offset: u64) -> Option<u64> {
        sync_latency(&self.members[i].check).map(|b| b + offset + self.lag(i))
    }

    /// The longest burst (cycles) of `kind` on `target`'s sends that no check trips on (0:
    /// even one cycle may trip one; `u64::MAX`: no length does).
    pub fn safe_burst(&self, target: usize, kind: FaultKind) -> u64 {
        if target >= self.n() {
            return 0;
        }
        let down = self.downstream(target);
        let d = down[0];
        let err = |i: usize| safe_error_burst(&self.members[i].check);
        let sync = |i: usize| safe_sync_burst(&self.members[i].check);
        // A card missing its own packets for b frames counts b − 1 errors.
        let own = |i: usize| err(i).saturating_add(1);
        let cards_own = || {
            self.upstream_cards(target)
                .into_iter()
                .chain(down.iter().copied().filter(|&i| i != self.sync_master))
                .filter(|&i| self.is_card(i))
                .map(own)
                .min()
                .unwrap_or(u64::MAX)
        };
        let all = |f: &dyn Fn(usize) -> u64| down.iter().map(|&i| f(i)).min().unwrap_or(u64::MAX);
        match kind {
            FaultKind::Corrupt
            | FaultKind::ByteViolation
            | FaultKind::Overrun
            | FaultKind::Underrun => err(d),
            FaultKind::DropSync => all(&sync),
            FaultKind::Cut => all(&err).min(all(&sync)).min(
                self.upstream_cards(target)
                    .into_iter()
                    .map(own)
                    .min()
                    .unwrap_or(u64::MAX),
            ),
            FaultKind::DropPackets => all(&sync).min(cards_own()),
            // Each held frame means one cycle without a sync packet and, when it is released,
            // an overrun; held frames of consecutive cycles make those errors pile up (and
            // shift the cards' own packets): only a single held frame is surely tolerated.
            FaultKind::DelayCycles(_) => u64::from(all(&err).min(all(&sync)) >= 1),
            FaultKind::DelayMicros(_) => u64::MAX,
        }
    }

    /// What the checks must make of `what` happening to member `target`.
    pub fn expect(&self, target: usize, what: Disturbance) -> Expectation {
        let mut e = Expectation::default();
        if target >= self.n() {
            return e;
        }
        let down = self.downstream(target);
        let d = down[0];
        let ucards = self.upstream_cards(target);
        let kind = match what {
            Disturbance::Stall => return e,
            Disturbance::Frames { kind, cycles } => {
                if let Some(b) = cycles {
                    if b <= self.safe_burst(target, kind) {
                        return e;
                    }
                    // Longer than tolerated but not for good: whoever it reaches may latch.
                    let reach = self.expect(target, Disturbance::Frames { kind, cycles: None });
                    let mut may: Vec<usize> = reach.must.iter().map(|m| m.member).collect();
                    may.extend(reach.may);
                    return Expectation {
                        must: Vec::new(),
                        may,
                        link: None,
                    };
                }
                Some(kind)
            }
            Disturbance::Dark => None,
        };
        if matches!(kind, Some(FaultKind::DelayMicros(_))) {
            return e;
        }
        let min = |a: Option<u64>, b: Option<u64>| match (a, b) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, None) => x,
            (None, y) => y,
        };
        // (member, bound) pairs; a member listed twice keeps its first bound.
        let mut must: Vec<(usize, Option<u64>)> = Vec::new();
        match kind {
            Some(FaultKind::Corrupt)
            | Some(FaultKind::ByteViolation)
            | Some(FaultKind::Overrun)
            | Some(FaultKind::Underrun) => must.push((d, self.err(d, 0))),
            Some(FaultKind::DropSync) => {
                must.extend(down.iter().map(|&i| (i, self.sync(i, 0))));
            }
            Some(FaultKind::DropPackets) => {
                for &i in &down {
                    let own = (self.is_card(i) && i != self.sync_master)
                        .then(|| self.err(i, 1))
                        .flatten();
                    must.push((i, min(self.sync(i, 0), own)));
                }
                must.extend(ucards.iter().map(|&i| (i, self.err(i, 2))));
            }
            Some(FaultKind::DelayCycles(n)) => {
                let n = u64::from(n);
                for &i in &down {
                    let sync = self
                        .sync(i, 0)
                        .filter(|&b| b < n + u64::from(i == self.sync_master));
                    must.push((i, min(self.err(i, n), sync)));
                }
                e.may.extend(ucards.iter().copied());
            }
            Some(FaultKind::DelayMicros(_)) => {}
            Some(FaultKind::Cut) | None => {
                // Loss of light from the target on: dark frames round to the sync master; a
                // dead or frozen target itself checks nothing.
                let alive = |i: &usize| *i != target || kind.is_some();
                must.extend(
                    down.iter()
                        .filter(|i| alive(i))
                        .map(|&i| (i, self.err(i, 0))),
                );
                must.extend(
                    ucards
                        .iter()
                        .filter(|i| alive(i))
                        .map(|&i| (i, self.err(i, 2))),
                );
            }
        }
        for (i, bound) in must {
            if let Some(within) = bound {
                if !e.must.iter().any(|m| m.member == i) {
                    e.must.push(Detection { member: i, within });
                }
            }
        }
        let taken: Vec<usize> = e.must.iter().map(|m| m.member).collect();
        e.may.retain(|i| !taken.contains(i));
        e.link = (!e.must.is_empty()).then_some(target);
        e
    }
}

#[cfg(test)]
#[path = "expect_tests.rs"]
mod tests;
