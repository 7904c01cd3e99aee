//! Fault injection on a member's send path (architecture §3.4), steered at run time.
//!
//! Byte-level faults edit the frame's packet bytes so the receiver's own error detection
//! classifies them: `corrupt` flips the check byte of the frame's last packet, `byte-violation`
//! overwrites its header byte, `underrun` cuts 5 bytes off the end (or, in a frame without
//! packets, declares one more packet than it carries), `overrun` appends 5 bytes beyond the
//! declared packets. `drop-sync` removes the sync packet, `drop-packets` removes every packet
//! (the frame envelope still goes, so the ring keeps its cadence: the data is missing, not the
//! cycle), `cut` replaces the frame with a dark frame (loss of light: the receiver reads a byte
//! violation every cycle; frames held by `delay` stay held), `delay` holds frames for N cycles
//! (an empty frame goes in their place), `delay-us` asks the transport to hold each frame N µs
//! before sending: a wall-clock delay that never moves a frame to another ring cycle (the
//! paced and lockstep rings, and the simulator, wait for it; `docs/ring.md`, Faults).

use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::frame::Frame;
use crate::packet::{Packet, PACKET_LEN};

/// Most faults active at once on one member.
pub const MAX_FAULTS: usize = 32;
/// Most frames held by `delay` at once (older ones are dropped beyond it).
pub const MAX_HELD_FRAMES: usize = 1024;

/// What a fault does to the frames a member sends. In JSON (the control plane, `mcc status
/// --json`) it is always one string, the CLI word: `"cut"`, `"delay=3"`, `"delay-us=250"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// Remove the sync packet.
    DropSync,
    /// Drop every packet of the frame (the empty envelope still goes).
    DropPackets,
    /// Wrong check byte (checksum error downstream).
    Corrupt,
    /// Invalid header byte (byte violation downstream).
    ByteViolation,
    /// Bytes beyond the declared packets (overrun downstream).
    Overrun,
    /// Truncated packet (underrun downstream).
    Underrun,
    /// Hold frames for this many ring cycles.
    DelayCycles(u32),
    /// Hold each frame this many µs before it leaves (transport-side sleep).
    DelayMicros(u32),
    /// The link is cut: only dark frames leave (loss of light).
    Cut,
}

impl fmt::Display for FaultKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FaultKind::DropSync => f.write_str("drop-sync"),
            FaultKind::DropPackets => f.write_str("drop-packets"),
            FaultKind::Corrupt => f.write_str("corrupt"),
            FaultKind::ByteViolation => f.write_str("byte-violation"),
            FaultKind::Overrun => f.write_str("overrun"),
            FaultKind::Underrun => f.write_str("underrun"),
            FaultKind::DelayCycles(n) => write!(f, "delay={n}"),
            FaultKind::DelayMicros(n) => write!(f, "delay-us={n}"),
            FaultKind::Cut => f.write_str("cut"),
        }
    }
}

/// Why a fault could not be parsed or injected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaultError {
    /// Not one of [`FAULT_WORDS`].
    #[error("unknown fault kind '{0}' (expected one of: {FAULT_WORDS})")]
    UnknownKind(String),
    /// `delay` / `delay-us` without `=N`.
    #[error("fault kind '{0}' needs an amount ({0}=N)")]
    NeedsAmount(String),
    /// An amount on a kind that takes none.
    #[error("fault kind '{0}' takes no amount")]
    TakesNoAmount(String),
    /// The amount is not a number.
    #[error("fault amount '{0}' is not a number 0-4294967295")]
    BadAmount(String),
    /// Probability outside 0..1.
    #[error("fault probability {0} is not between 0 and 1")]
    BadProbability(f64),
    /// The member already carries [`MAX_FAULTS`] faults.
    #[error("too many faults on this member (at most {MAX_FAULTS})")]
    TooMany,
    /// No member at this ring position (in-process simulations).
    #[error("no member {0}")]
    NoMember(usize),
}

/// The fault words, for error messages and help text.
pub const FAULT_WORDS: &str =
    "drop-sync, drop-packets, corrupt, byte-violation, overrun, underrun, delay=N, delay-us=N, cut";

impl FaultKind {
    /// Parse a fault word plus the amount that `delay` and `delay-us` need.
    pub fn parse_with(word: &str, amount: Option<u32>) -> Result<FaultKind, FaultError> {
        let needs = |k: fn(u32) -> FaultKind| {
            amount
                .map(k)
                .ok_or_else(|| FaultError::NeedsAmount(word.to_string()))
        };
        let kind = match word {
            "drop-sync" => FaultKind::DropSync,
            "drop-packets" => FaultKind::DropPackets,
            "corrupt" => FaultKind::Corrupt,
            "byte-violation" => FaultKind::ByteViolation,
            "overrun" => FaultKind::Overrun,
            "underrun" => FaultKind::Underrun,
            "cut" => FaultKind::Cut,
            "delay" => return needs(FaultKind::DelayCycles),
            "delay-us" => return needs(FaultKind::DelayMicros),
            _ => return Err(FaultError::UnknownKind(word.to_string())),
        };
        match amount {
            None => Ok(kind),
            Some(_) => Err(FaultError::TakesNoAmount(word.to_string())),
        }
    }
}

impl FromStr for FaultKind {
    type Err = FaultError;

    /// `word`, or `word=N` / `word:N` for `delay` and `delay-us`.
    fn from_str(s: &str) -> Result<Self, FaultError> {
        let s = s.trim();
        match s.split_once(['=', ':']) {
            None => FaultKind::parse_with(s, None),
            Some((word, n)) => {
                let n: u32 = n
                    .trim()
                    .parse()
                    .map_err(|_| FaultError::BadAmount(n.to_string()))?;
                FaultKind::parse_with(word.trim(), Some(n))
            }
        }
    }
}

impl Serialize for FaultKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for FaultKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let word = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        word.parse().map_err(serde::de::Error::custom)
    }
}

fn one() -> f64 {
    1.0
}

/// One injected fault.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct FaultSpec {
    /// What it does.
    pub kind: FaultKind,
    /// For how many ring cycles (from the first send after injection); `None` = until cleared.
    #[serde(default)]
    pub cycles: Option<u64>,
    /// Probability per frame, 0.0-1.0.
    #[serde(default = "one")]
    pub probability: f64,
    /// Seed of the fault's own random generator (runs are reproducible).
    #[serde(default)]
    pub seed: u64,
}

impl FaultSpec {
    /// A fault that always applies until cleared.
    pub fn always(kind: FaultKind) -> Self {
        FaultSpec {
            kind,
            cycles: None,
            probability: 1.0,
            seed: 0,
        }
    }

    /// Check the spec's values.
    pub fn validate(&self) -> Result<(), FaultError> {
        if !(0.0..=1.0).contains(&self.probability) {
            return Err(FaultError::BadProbability(self.probability));
        }
        Ok(())
    }
}

/// A fault as a member reports it (`faults` in its status): the spec, and the first ring cycle
/// it applied to (`null` until the member's next send after injection). In JSON the spec's
/// fields plus `since_cycle`.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ActiveFault {
    /// The injected fault.
    #[serde(flatten)]
    pub spec: FaultSpec,
    /// First ring cycle whose frame it acted on.
    #[serde(default)]
    pub since_cycle: Option<u64>,
}

/// A frame the fault layer lets through, before the member stamps its link sequence number
/// (frames a `delay` releases late get a fresh one, so the receiver reads them as late data
/// rather than as stale duplicates).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sent {
    /// The frame.
    pub frame: Frame,
    /// Hold it this long before sending (0 = now).
    pub delay_us: u32,
}

/// A frame to put on the link.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outgoing {
    /// The encoded frame.
    pub frame_bytes: Vec<u8>,
    /// Hold it this long before sending (0 = now).
    pub delay_us: u32,
}

#[derive(Debug)]
struct Active {
    spec: FaultSpec,
    rng: StdRng,
    first_cycle: Option<u64>,
}

impl Active {
    fn expired(&self, cycle: u64) -> bool {
        match (self.first_cycle, self.spec.cycles) {
            (Some(first), Some(n)) => cycle >= first.saturating_add(n),
            _ => false,
        }
    }
}

/// The fault layer of one member's send path.
#[derive(Debug)]
pub struct FaultLayer {
    sync_node: u8,
    faults: Vec<Active>,
    held: VecDeque<(u64, Frame)>,
}

impl FaultLayer {
    /// A layer for a ring whose sync packet is on `sync_node`.
    pub fn new(sync_node: u8) -> Self {
        FaultLayer {
            sync_node: sync_node & 0x0F,
            faults: Vec::new(),
            held: VecDeque::new(),
        }
    }

    /// The sync node changed (I996 bits 16-19): `drop-sync` removes packets on this node.
    pub fn set_sync_node(&mut self, sync_node: u8) {
        self.sync_node = sync_node & 0x0F;
    }

    /// Add a fault.
    pub fn inject(&mut self, spec: FaultSpec) -> Result<(), FaultError> {
        spec.validate()?;
        if self.faults.len() >= MAX_FAULTS {
            return Err(FaultError::TooMany);
        }
        let rng = StdRng::seed_from_u64(spec.seed);
        self.faults.push(Active {
            spec,
            rng,
            first_cycle: None,
        });
        Ok(())
    }

    /// Remove every fault; frames held by `delay` are released at the next send or poll.
    pub fn clear(&mut self) {
        self.faults.clear();
    }

    /// The faults still active, with the cycle each started acting.
    pub fn active(&self) -> Vec<ActiveFault> {
        self.faults
            .iter()
            .map(|a| ActiveFault {
                spec: a.spec.clone(),
                since_cycle: a.first_cycle,
            })
            .collect()
    }

    /// Drop faults whose cycles are over (counted from the first frame each acted on).
    fn expire(&mut self, cycle: u64) {
        self.faults.retain(|a| !a.expired(cycle));
    }

    fn cut_for_sure(&self) -> bool {
        self.faults
            .iter()
            .any(|a| a.spec.kind == FaultKind::Cut && a.spec.probability >= 1.0)
    }

    /// Expire faults and release frames held by `delay` whose time has come.
    pub fn poll(&mut self, cycle: u64) -> Vec<Sent> {
        self.expire(cycle);
        let mut out = Vec::new();
        if self.cut_for_sure() {
            return out;
        }
        while let Some((release, _)) = self.held.front() {
            if *release > cycle {
                break;
            }
            if let Some((_, frame)) = self.held.pop_front() {
                out.push(Sent { frame, delay_us: 0 });
            }
        }
        out
    }

    /// Pass one frame of ring cycle `cycle` through the active faults: 0, 1 or more frames
    /// to put on the link now (held frames released first, in order).
    pub fn on_send(&mut self, cycle: u64, mut frame: Frame) -> Vec<Sent> {
        // A fault's cycles count from the first frame it acts on.
        for a in &mut self.faults {
            a.first_cycle.get_or_insert(cycle);
        }
        let mut out = self.poll(cycle);
        let (mut drop, mut cut) = (false, false);
        let (mut delay_cycles, mut delay_us) = (0u32, 0u32);
        for a in &mut self.faults {
            let hit = a.rng.random::<f64>() < a.spec.probability;
            if !hit {
                continue;
            }
            match a.spec.kind {
                FaultKind::Cut => cut = true,
                FaultKind::DropPackets => drop = true,
                FaultKind::DropSync => drop_sync(&mut frame, self.sync_node),
                FaultKind::Corrupt => edit_last(&mut frame, 11, |b| *b ^= 0xFF),
                FaultKind::ByteViolation => edit_last(&mut frame, 0, |b| *b = 0x00),
                FaultKind::Overrun => frame.packets.extend_from_slice(&[0xEE; 5]),
                FaultKind::Underrun => {
                    if frame.packets.len() >= 5 {
                        frame.packets.truncate(frame.packets.len() - 5);
                    } else {
                        frame.declared = frame.declared.saturating_add(1);
                    }
                }
                FaultKind::DelayCycles(n) => delay_cycles = delay_cycles.max(n),
                FaultKind::DelayMicros(n) => delay_us = delay_us.max(n),
            }
        }
        if cut {
            // No light leaves, not even frames released by the poll above: put them back.
            for o in out.into_iter().rev() {
                self.held.push_front((cycle, o.frame));
            }
            let dark = Frame::dark(
                frame.sender,
                frame.seq,
                frame.sent_ns,
                frame.cycle,
                frame.origin_ns,
            );
            return vec![Sent {
                frame: dark,
                delay_us,
            }];
        }
        if drop {
            emptied(&mut frame);
        }
        if delay_cycles > 0 {
            if self.held.len() >= MAX_HELD_FRAMES {
                self.held.pop_front();
            }
            let release = cycle.saturating_add(u64::from(delay_cycles));
            self.held.push_back((release, frame.clone()));
            // The cycle still happens: an empty frame takes the held one's place.
            emptied(&mut frame);
        }
        out.push(Sent { frame, delay_us });
        out
    }
}

/// The frame without its packets (the envelope, with its cycle, still travels).
fn emptied(frame: &mut Frame) {
    frame.packets.clear();
    frame.declared = 0;
}

fn drop_sync(frame: &mut Frame, sync_node: u8) {
    let mut kept = Vec::with_capacity(frame.packets.len());
    let mut removed: u16 = 0;
    let mut chunks = frame.packets.chunks(PACKET_LEN);
    for chunk in &mut chunks {
        match Packet::decode(chunk) {
            Ok(p) if p.node == sync_node => removed += 1,
            _ => kept.extend_from_slice(chunk),
        }
    }
    frame.packets = kept;
    frame.declared = frame.declared.saturating_sub(removed);
}

fn edit_last(frame: &mut Frame, offset: usize, f: impl FnOnce(&mut u8)) {
    let whole = frame.packets.len() / PACKET_LEN;
    if whole == 0 {
        return;
    }
    if let Some(b) = frame.packets.get_mut((whole - 1) * PACKET_LEN + offset) {
        f(b);
    }
}

#[cfg(test)]
#[path = "fault_tests.rs"]
mod tests;
