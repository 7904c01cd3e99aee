//! The campaign's plan: which fault, on which member, when, for how long — drawn from one seed
//! (the same seed and ring give the same plan), every kind equally often, and each fault's
//! expectation from the ring-check rules ([`mcc_ring::expect`]). Pure.

use std::fmt;

use mcc_ring::expect::{Disturbance, Expectation, RingModel};
use mcc_ring::fault::{FaultKind, FaultSpec};
use mcc_ring::linkfault::{LinkFaultKind, LinkFaultSpec, LINK_KINDS};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};

/// The kinds of fault a campaign injects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    /// `drop-sync`.
    DropSync,
    /// `drop-packets`.
    DropPackets,
    /// `corrupt`.
    Corrupt,
    /// `byte-violation`.
    ByteViolation,
    /// `overrun`.
    Overrun,
    /// `underrun`.
    Underrun,
    /// `delay=N` (ring cycles).
    Delay,
    /// `delay-us=N` (the transport holds each frame N µs; the ring waits for it).
    DelayUs,
    /// `cut`.
    Cut,
    /// SIGSTOP (past the frozen-member wait, or a stall shorter than it).
    Freeze,
    /// SIGKILL, then `mcc fault MEMBER restart` to recover.
    Kill,
    /// `mcc fault MEMBER restart` on a running member (kill and start again at once).
    Restart,
    /// A card's abort input (`mcc fault CARD input abort`), on cards only.
    Input,
    /// An amplifier fault on the servo node of its card's motor 1 (`mcc fault STATION axis
    /// NODE amp-fault`), on stations only.
    Axis,
    /// A host-link fault on a card's text port (`mcc fault CARD link KIND`, one reply), on
    /// cards only.
    Link,
}

/// Every kind, in report order.
pub const KINDS: [Kind; 15] = [
    Kind::DropSync,
    Kind::DropPackets,
    Kind::Corrupt,
    Kind::ByteViolation,
    Kind::Overrun,
    Kind::Underrun,
    Kind::Delay,
    Kind::DelayUs,
    Kind::Cut,
    Kind::Freeze,
    Kind::Kill,
    Kind::Restart,
    Kind::Input,
    Kind::Axis,
    Kind::Link,
];

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Kind::DropSync => "drop-sync",
            Kind::DropPackets => "drop-packets",
            Kind::Corrupt => "corrupt",
            Kind::ByteViolation => "byte-violation",
            Kind::Overrun => "overrun",
            Kind::Underrun => "underrun",
            Kind::Delay => "delay",
            Kind::DelayUs => "delay-us",
            Kind::Cut => "cut",
            Kind::Freeze => "freeze",
            Kind::Kill => "kill",
            Kind::Restart => "restart",
            Kind::Input => "input",
            Kind::Axis => "axis",
            Kind::Link => "link",
        })
    }
}

impl Kind {
    /// Parse a kind's name (as printed).
    pub fn parse(s: &str) -> Option<Kind> {
        KINDS.iter().copied().find(|k| k.to_string() == s.trim())
    }
}

/// The host-link kinds a card's ports take (all but the EMCL bus's `bad-checksum`).
const LINK_KINDS_ON_CARDS: [LinkFaultKind; 9] = {
    let mut out = [LinkFaultKind::NoReply; 9];
    let mut i = 0;
    let mut j = 0;
    while i < LINK_KINDS.len() {
        if !matches!(LINK_KINDS[i], LinkFaultKind::BadChecksum) {
            out[j] = LINK_KINDS[i];
            j += 1;
        }
        i += 1;
    }
    out
};

/// What is done to the target.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// A send-path fault (`spec.cycles`: a burst; none: until cleared).
    Frames(FaultSpec),
    /// SIGSTOP until the ring has detected it (a stopped process is loss of light, seen
    /// by the member downstream on this machine); then restart.
    Freeze,
    /// SIGKILL; then restart.
    Kill,
    /// Restart at once (the supervisor kills the process and starts a new one).
    Restart,
    /// The card's abort input held active, C.S. 1 selected, until the recovery clears it.
    Input,
    /// The station's amplifier fault on the servo node of its card's motor 1, held until the
    /// recovery clears it.
    Axis,
    /// A host-link fault on the card's text port (ASCII, or a Power card's gpascii) for its
    /// next reply (`spec.replies` = 1).
    Link(LinkFaultSpec),
}

/// One planned fault.
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    /// Its place in the campaign (0-based).
    pub index: usize,
    /// The kind.
    pub kind: Kind,
    /// Ring index of the member it is done to.
    pub target: usize,
    /// Wall time the programs run before it is injected, ms.
    pub wait_ms: u64,
    /// What is done.
    pub action: Action,
    /// What the ring checks must make of it.
    pub expect: Expectation,
}

impl Planned {
    /// It must be detected (and then recovered from).
    pub fn sustained(&self) -> bool {
        !self.expect.must.is_empty()
    }

    /// A one-line description: `cut on station0`, `corrupt on card1 for 1 cycle`.
    pub fn describe(&self, names: &[String]) -> String {
        let who = names.get(self.target).map(String::as_str).unwrap_or("?");
        match &self.action {
            Action::Frames(s) => match s.cycles {
                Some(n) => format!("{} on {who} for {n} cycle(s)", s.kind),
                None => format!("{} on {who}", s.kind),
            },
            Action::Freeze => format!("freeze {who}"),
            Action::Kill => format!("kill {who}"),
            Action::Restart => format!("restart {who}"),
            Action::Input => format!("abort input on {who}"),
            Action::Axis => format!("amplifier fault on {who}"),
            Action::Link(l) => match l.kind {
                LinkFaultKind::Late => format!("link {} ({} ms) on {who}", l.kind, l.delay_ms),
                k => format!("link {k} on {who}"),
            },
        }
    }
}

/// Tuning of the plan.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Share of faults that have a tolerated form (bursts, stalls) planned in that form.
    pub below_share: f64,
    /// Only these kinds (empty: all).
    pub kinds: Vec<Kind>,
}

/// Draw `n` faults for `model` from `seed`: every kind in turn (in shuffled order), random
/// members, waits, durations and amounts.
pub fn plan(model: &RingModel, n: usize, seed: u64, opts: &PlanOptions) -> Vec<Planned> {
    let mut rng = StdRng::seed_from_u64(seed);
    let of_kind = |k: mcc_ring::control::MemberKind| -> Vec<usize> {
        (0..model.members.len())
            .filter(|&i| model.members[i].kind == k)
            .collect()
    };
    let cards = of_kind(mcc_ring::control::MemberKind::Card);
    let stations = of_kind(mcc_ring::control::MemberKind::Station);
    let kinds: Vec<Kind> = if opts.kinds.is_empty() {
        KINDS.to_vec()
    } else {
        opts.kinds.clone()
    };
    // A ring without stations has no amplifier to fault.
    let kinds: Vec<Kind> = kinds
        .into_iter()
        .filter(|&k| k != Kind::Axis || !stations.is_empty())
        .collect();
    if kinds.is_empty() {
        return Vec::new();
    }
    let mut order: Vec<Kind> = (0..n).map(|i| kinds[i % kinds.len()]).collect();
    order.shuffle(&mut rng);
    let members = model.members.len().max(1);
    // Each kind visits the members in a shuffled round: every member (the sync master
    // included) gets every kind once the kind has been drawn as often as there are members.
    let mut rounds: std::collections::HashMap<Kind, (Vec<usize>, usize)> = Default::default();
    order
        .into_iter()
        .enumerate()
        .map(|(index, kind)| {
            let (round, next) = rounds.entry(kind).or_insert_with(|| (Vec::new(), 0));
            if *next % members == 0 {
                *round = (0..members).collect();
                round.shuffle(&mut rng);
            }
            let mut target = round[*next % members];
            *next += 1;
            if matches!(kind, Kind::Input | Kind::Link) && !cards.contains(&target) {
                // Inputs are a card's: the card upstream of the drawn station.
                target = cards
                    .iter()
                    .copied()
                    .filter(|&c| c <= target)
                    .max()
                    .or_else(|| cards.first().copied())
                    .unwrap_or(0);
            }
            if kind == Kind::Axis && !stations.contains(&target) {
                // Axis faults are a station's: the station after the drawn card.
                target = stations
                    .iter()
                    .copied()
                    .find(|&st| st > target)
                    .or_else(|| stations.first().copied())
                    .unwrap_or(target);
            }
            let wait_ms = rng.random_range(0..=300);
            let below = rng.random_bool(opts.below_share.clamp(0.0, 1.0));
            let seed = rng.random::<u64>();
            let frames = |k: FaultKind, rng: &mut StdRng| {
                let safe = model.safe_burst(target, k);
                let cycles = (below && safe > 0).then(|| rng.random_range(1..=safe.min(16)));
                Action::Frames(FaultSpec {
                    kind: k,
                    cycles,
                    probability: 1.0,
                    seed,
                })
            };
            let action = match kind {
                Kind::DropSync => frames(FaultKind::DropSync, &mut rng),
                Kind::DropPackets => frames(FaultKind::DropPackets, &mut rng),
                Kind::Corrupt => frames(FaultKind::Corrupt, &mut rng),
                Kind::ByteViolation => frames(FaultKind::ByteViolation, &mut rng),
                Kind::Overrun => frames(FaultKind::Overrun, &mut rng),
                Kind::Underrun => frames(FaultKind::Underrun, &mut rng),
                Kind::Delay => {
                    let k = FaultKind::DelayCycles(rng.random_range(1..=8));
                    frames(k, &mut rng)
                }
                Kind::DelayUs => Action::Frames(FaultSpec {
                    kind: FaultKind::DelayMicros(rng.random_range(50..=3000)),
                    cycles: Some(rng.random_range(20..=400)),
                    probability: 1.0,
                    seed,
                }),
                Kind::Cut => frames(FaultKind::Cut, &mut rng),
                Kind::Freeze => Action::Freeze,
                Kind::Kill => Action::Kill,
                Kind::Restart => Action::Restart,
                Kind::Input => Action::Input,
                Kind::Axis => Action::Axis,
                Kind::Link => {
                    let k = LINK_KINDS_ON_CARDS[rng.random_range(0..LINK_KINDS_ON_CARDS.len())];
                    Action::Link(LinkFaultSpec {
                        kind: k,
                        probability: 1.0,
                        seed,
                        replies: Some(1),
                        delay_ms: if k == LinkFaultKind::Late {
                            rng.random_range(20..=400)
                        } else {
                            0
                        },
                    })
                }
            };
            let what = match &action {
                Action::Frames(s) => Some(Disturbance::Frames {
                    kind: s.kind,
                    cycles: s.cycles,
                }),
                Action::Freeze | Action::Kill | Action::Restart => Some(Disturbance::Dark),
                // The ring sees neither a card's input, an amplifier's fault line nor a host
                // link: nobody may latch.
                Action::Input | Action::Axis | Action::Link(_) => None,
            };
            Planned {
                index,
                kind,
                target,
                wait_ms,
                expect: what.map_or_else(Expectation::default, |w| model.expect(target, w)),
                action,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcc_contracts::config::ClusterConfig;

    fn opts() -> PlanOptions {
        PlanOptions {
            below_share: 0.4,
            kinds: Vec::new(),
        }
    }

    #[test]
    fn a_plan_covers_every_kind_and_member_reproducibly() {
        let model = RingModel::from_config(&ClusterConfig::default_cluster(2, 2)).unwrap();
        let p = plan(&model, 300, 7, &opts());
        assert_eq!(p, plan(&model, 300, 7, &opts()), "same seed, same plan");
        assert_ne!(p, plan(&model, 300, 8, &opts()));
        for k in KINDS {
            assert_eq!(p.iter().filter(|f| f.kind == k).count(), 20, "{k}");
            // Axis faults are the stations': the sync master is a card.
            assert_eq!(
                p.iter().any(|f| f.kind == k && f.target == 0),
                k != Kind::Axis,
                "{k} on the sync master"
            );
        }
        for t in 0..4 {
            assert!(p.iter().any(|f| f.target == t));
        }
        // Kill and restart must always be detected; below-threshold forms are quiet.
        for f in &p {
            match (&f.action, f.kind) {
                (Action::Kill | Action::Restart | Action::Freeze, _) => assert!(f.sustained()),
                (Action::Input, _) => {
                    assert!(f.expect.quiet() && [0, 2].contains(&f.target), "{f:?}")
                }
                (Action::Link(l), _) => {
                    assert!(f.expect.quiet() && [0, 2].contains(&f.target), "{f:?}");
                    assert_eq!(
                        l.validate(mcc_ring::linkfault::LinkTarget::CardPorts),
                        Ok(()),
                        "{f:?}"
                    );
                    assert_eq!(l.replies, Some(1));
                }
                (Action::Axis, _) => {
                    assert!(f.expect.quiet() && [1, 3].contains(&f.target), "{f:?}")
                }
                (Action::Frames(s), Kind::DelayUs) => {
                    assert!(f.expect.quiet() && s.cycles.is_some())
                }
                (Action::Frames(s), _) => assert_eq!(s.cycles.is_none(), f.sustained(), "{f:?}"),
            }
        }
        assert!(p.iter().filter(|f| !f.sustained()).count() > 40);
        // Every card-port link kind is drawn.
        for k in LINK_KINDS_ON_CARDS {
            assert!(
                p.iter()
                    .any(|f| matches!(&f.action, Action::Link(l) if l.kind == k)),
                "link {k}"
            );
        }
    }

    /// The plan of the test command's campaign (120 faults, seed 11): every kind reaches
    /// every member, the sync master included.
    #[test]
    fn the_test_commands_campaign_reaches_every_member_with_every_kind() {
        let model = RingModel::from_config(&ClusterConfig::default_cluster(2, 2)).unwrap();
        let p = plan(&model, 120, 11, &opts());
        for k in KINDS {
            // Inputs and host links are the cards' (members 0 and 2), axis faults the
            // stations' (1 and 3).
            let targets: &[usize] = match k {
                Kind::Input | Kind::Link => &[0, 2],
                Kind::Axis => &[1, 3],
                _ => &[0, 1, 2, 3],
            };
            for &t in targets {
                assert!(p.iter().any(|f| f.kind == k && f.target == t), "{k} on {t}");
            }
        }
    }

    #[test]
    fn kind_names_round_trip() {
        for k in KINDS {
            assert_eq!(Kind::parse(&k.to_string()), Some(k));
        }
        assert_eq!(Kind::parse("melt"), None);
    }
}
