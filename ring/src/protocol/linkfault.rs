//! Host-link faults (pure): what a faulted host link does to one reply. The card's host ports,
//! the daisy chain and the EMCL bus hold a [`LinkFaultSlot`] and pass every reply through
//! it before writing it; nothing else changes (the command was executed, the card's state is
//! what it would be without the fault).
//!
//! \[DECISION\] A *reply* is the bytes answering one host request (an ASCII line or control
//! character, a PMAC Ethernet packet, a `gpascii` line, a chain chunk, an EMCL frame); an
//! empty reply is nothing to fault and is neither drawn nor counted. `probability` is drawn
//! per reply from the fault's own generator (`seed`); `replies` (`--cycles N` on the CLI)
//! is how many replies the fault looks at before it ends by itself (hit or not; `None`:
//! until cleared). Positions and stray control characters are drawn from the same
//! generator, so a seed gives the same faulted bytes every run.

use std::fmt;
use std::str::FromStr;
use std::sync::{Arc, Mutex};

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// What a link fault does to a reply it hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LinkFaultKind {
    /// The reply is dropped: the host hears nothing.
    NoReply,
    /// The reply is written `delay_ms` late.
    Late,
    /// Only a leading part of the reply is written (at least one byte is missing).
    Short,
    /// A carriage return is inserted at a drawn position.
    StrayCr,
    /// A line feed is inserted at a drawn position.
    StrayLf,
    /// A BEL (0x07) is inserted at a drawn position.
    StrayBel,
    /// A control character (drawn from [`STRAY_CONTROLS`]) is inserted at a drawn position.
    StrayCtrl,
    /// One bit of one byte of the reply is flipped.
    Corrupt,
    /// The connection is reset (TCP RST) instead of the reply.
    Reset,
    /// EMCL only: the reply's checksum byte (its last) is off by one.
    BadChecksum,
}

/// Every kind, in the order `mcc fault --help` lists them.
pub const LINK_KINDS: [LinkFaultKind; 10] = [
    LinkFaultKind::NoReply,
    LinkFaultKind::Late,
    LinkFaultKind::Short,
    LinkFaultKind::StrayCr,
    LinkFaultKind::StrayLf,
    LinkFaultKind::StrayBel,
    LinkFaultKind::StrayCtrl,
    LinkFaultKind::Corrupt,
    LinkFaultKind::Reset,
    LinkFaultKind::BadChecksum,
];

/// Control characters `stray-ctrl` draws from: none of them is a reply terminator of the
/// PMAC protocols (CR, LF, ACK, BEL) or a Telnet/flow-control byte hosts act on.
pub const STRAY_CONTROLS: [u8; 5] = [0x00, 0x0B, 0x0C, 0x1A, 0x1B];

impl LinkFaultKind {
    /// The CLI word.
    pub fn word(self) -> &'static str {
        match self {
            LinkFaultKind::NoReply => "no-reply",
            LinkFaultKind::Late => "late",
            LinkFaultKind::Short => "short",
            LinkFaultKind::StrayCr => "stray-cr",
            LinkFaultKind::StrayLf => "stray-lf",
            LinkFaultKind::StrayBel => "stray-bel",
            LinkFaultKind::StrayCtrl => "stray-ctrl",
            LinkFaultKind::Corrupt => "corrupt",
            LinkFaultKind::Reset => "reset",
            LinkFaultKind::BadChecksum => "bad-checksum",
        }
    }

    /// Every CLI word, comma-separated.
    pub fn words() -> String {
        LINK_KINDS.map(LinkFaultKind::word).join(", ")
    }
}

impl fmt::Display for LinkFaultKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.word())
    }
}

/// Why a link fault request is refused (each names the problem and the valid choices).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinkFaultError {
    /// Not one of the kinds.
    #[error("unknown link fault {0:?} (one of: {all})", all = LinkFaultKind::words())]
    UnknownKind(String),
    /// The kind does not apply to this link.
    #[error("{0}")]
    NotHere(String),
    /// Probability outside 0..1.
    #[error("probability {0} is outside 0.0-1.0")]
    BadProbability(f64),
    /// `--cycles 0`.
    #[error("--cycles must be at least 1 reply (omit it to fault until cleared)")]
    NoReplies,
    /// `late` without a delay, or with one too long.
    #[error("late needs --delay MS (1-{MAX_DELAY_MS}), not {0}")]
    BadDelay(u64),
    /// `--delay` on another kind.
    #[error("--delay only applies to the late link fault, not {0}")]
    DelayNotLate(LinkFaultKind),
}

impl FromStr for LinkFaultKind {
    type Err = LinkFaultError;

    fn from_str(s: &str) -> Result<Self, LinkFaultError> {
        LINK_KINDS
            .into_iter()
            .find(|k| k.word() == s)
            .ok_or_else(|| LinkFaultError::UnknownKind(s.to_string()))
    }
}

/// Which host link a fault is on (what kinds apply).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkTarget {
    /// A card's host ports (ASCII, PMAC Ethernet, `gpascii`, SSH).
    CardPorts,
    /// The daisy chain (serial, served over TCP and a pty).
    Chain,
    /// The EMCL bus.
    Bus,
}

impl LinkTarget {
    /// Why `kind` does not apply here, if it does not.
    pub fn refuses(self, kind: LinkFaultKind) -> Option<String> {
        match (self, kind) {
            (LinkTarget::Bus, _) => None,
            (_, LinkFaultKind::BadChecksum) => Some(format!(
                "bad-checksum applies to the EMCL bus only: {} replies carry no checksum \
                 (valid here: {})",
                match self {
                    LinkTarget::CardPorts => "a card's host-port",
                    _ => "daisy-chain",
                },
                LINK_KINDS
                    .into_iter()
                    .filter(|k| *k != LinkFaultKind::BadChecksum)
                    .map(LinkFaultKind::word)
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            _ => None,
        }
    }
}

fn one() -> f64 {
    1.0
}

/// One host-link fault as requested.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinkFaultSpec {
    /// What it does to a reply it hits.
    pub kind: LinkFaultKind,
    /// Probability per reply, 0.0-1.0.
    #[serde(default = "one")]
    pub probability: f64,
    /// Seed of the fault's own generator.
    #[serde(default)]
    pub seed: u64,
    /// Replies it looks at before it ends (`None`: until cleared).
    #[serde(default)]
    pub replies: Option<u64>,
    /// `late`: how late, ms.
    #[serde(default)]
    pub delay_ms: u64,
}

/// Longest `late` delay, ms (beyond it every host has long given up).
pub const MAX_DELAY_MS: u64 = 60_000;

impl LinkFaultSpec {
    /// Check the values for `target`: a refusal names the problem and the valid choices.
    pub fn validate(&self, target: LinkTarget) -> Result<(), LinkFaultError> {
        if let Some(why) = target.refuses(self.kind) {
            return Err(LinkFaultError::NotHere(why));
        }
        if !(0.0..=1.0).contains(&self.probability) {
            return Err(LinkFaultError::BadProbability(self.probability));
        }
        if self.replies == Some(0) {
            return Err(LinkFaultError::NoReplies);
        }
        match (self.kind, self.delay_ms) {
            (LinkFaultKind::Late, d) if d == 0 || d > MAX_DELAY_MS => {
                Err(LinkFaultError::BadDelay(d))
            }
            (LinkFaultKind::Late, _) | (_, 0) => Ok(()),
            (k, _) => Err(LinkFaultError::DelayNotLate(k)),
        }
    }
}

/// What to write instead of a reply.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct LinkOutcome {
    /// The bytes to write (empty: nothing).
    pub bytes: Vec<u8>,
    /// Wait this long first, ms.
    pub delay_ms: u64,
    /// Reset the connection after writing `bytes`.
    pub reset: bool,
}

impl LinkOutcome {
    /// The reply as it is.
    pub fn pass(reply: &[u8]) -> Self {
        LinkOutcome {
            bytes: reply.to_vec(),
            ..LinkOutcome::default()
        }
    }
}

/// A fault as reported in `mcc status`: its spec, the replies it has looked at and hit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActiveLinkFault {
    /// The fault.
    #[serde(flatten)]
    pub spec: LinkFaultSpec,
    /// Replies looked at so far.
    pub seen: u64,
    /// Replies faulted so far.
    pub hits: u64,
}

/// An installed fault: the spec, its generator and its counters.
#[derive(Debug, Clone)]
pub struct LinkFaulter {
    spec: LinkFaultSpec,
    rng: StdRng,
    seen: u64,
    hits: u64,
}

impl LinkFaulter {
    /// Install `spec` (validated by the caller for its target).
    pub fn new(spec: LinkFaultSpec) -> Self {
        let rng = StdRng::seed_from_u64(spec.seed);
        LinkFaulter {
            spec,
            rng,
            seen: 0,
            hits: 0,
        }
    }

    /// It has looked at all the replies it was given.
    pub fn expired(&self) -> bool {
        self.spec.replies.is_some_and(|n| self.seen >= n)
    }

    /// The status view.
    pub fn active(&self) -> ActiveLinkFault {
        ActiveLinkFault {
            spec: self.spec.clone(),
            seen: self.seen,
            hits: self.hits,
        }
    }

    /// What to write for `reply`.
    pub fn on_reply(&mut self, reply: &[u8]) -> LinkOutcome {
        if reply.is_empty() || self.expired() {
            return LinkOutcome::pass(reply);
        }
        self.seen += 1;
        let p = self.spec.probability;
        if !(p >= 1.0 || self.rng.random::<f64>() < p) {
            return LinkOutcome::pass(reply);
        }
        self.hits += 1;
        let mut out = LinkOutcome::pass(reply);
        let n = reply.len();
        match self.spec.kind {
            LinkFaultKind::NoReply => out.bytes.clear(),
            LinkFaultKind::Late => out.delay_ms = self.spec.delay_ms,
            LinkFaultKind::Short => out.bytes.truncate(self.rng.random_range(0..n)),
            LinkFaultKind::StrayCr => self.insert(&mut out.bytes, b'\r'),
            LinkFaultKind::StrayLf => self.insert(&mut out.bytes, b'\n'),
            LinkFaultKind::StrayBel => self.insert(&mut out.bytes, 0x07),
            LinkFaultKind::StrayCtrl => {
                let c = STRAY_CONTROLS[self.rng.random_range(0..STRAY_CONTROLS.len())];
                self.insert(&mut out.bytes, c);
            }
            LinkFaultKind::Corrupt => {
                let at = self.rng.random_range(0..n);
                let bit = self.rng.random_range(0..8u32);
                if let Some(b) = out.bytes.get_mut(at) {
                    *b ^= 1 << bit;
                }
            }
            LinkFaultKind::Reset => {
                out.bytes.clear();
                out.reset = true;
            }
            LinkFaultKind::BadChecksum => {
                if let Some(b) = out.bytes.last_mut() {
                    *b = b.wrapping_add(1);
                }
            }
        }
        out
    }

    fn insert(&mut self, bytes: &mut Vec<u8>, c: u8) {
        let at = self.rng.random_range(0..=bytes.len());
        bytes.insert(at, c);
    }
}

/// The one fault of a host link, shared by everything that writes its replies and by what
/// installs it (the card's ring application, the supervisor's control queryable). Cheap to
/// clone (one fault, behind a lock held only to draw).
#[derive(Debug, Clone, Default)]
pub struct LinkFaultSlot(Arc<Mutex<Option<LinkFaulter>>>);

impl LinkFaultSlot {
    fn lock(&self) -> std::sync::MutexGuard<'_, Option<LinkFaulter>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Install `spec` (replacing any fault).
    pub fn set(&self, spec: LinkFaultSpec) {
        *self.lock() = Some(LinkFaulter::new(spec));
    }

    /// Remove the fault.
    pub fn clear(&self) {
        *self.lock() = None;
    }

    /// The fault, if one is installed and not yet expired.
    pub fn active(&self) -> Option<ActiveLinkFault> {
        let mut g = self.lock();
        if g.as_ref().is_some_and(LinkFaulter::expired) {
            *g = None;
        }
        g.as_ref().map(LinkFaulter::active)
    }

    /// What to write for `reply` (the reply itself when no fault is installed).
    pub fn on_reply(&self, reply: &[u8]) -> LinkOutcome {
        let mut g = self.lock();
        let out = match g.as_mut() {
            Some(f) => f.on_reply(reply),
            None => return LinkOutcome::pass(reply),
        };
        if g.as_ref().is_some_and(LinkFaulter::expired) {
            *g = None;
        }
        out
    }

    /// A fault is installed (a port that streams long replies gathers them whole then).
    pub fn armed(&self) -> bool {
        self.lock().is_some()
    }
}

#[cfg(test)]
#[path = "linkfault_tests.rs"]
mod tests;
