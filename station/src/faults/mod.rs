//! Axis faults injected into the station plant at run time (`mcc fault STATION axis NODE
//! KIND [--cycles N] [--value V]`, `mcc fault STATION power-loss`): the request the station
//! accepts ([`StationFaultRequest`], JSON inside `FaultRequest::App`), the kinds
//! ([`AxisFaultKind`]) and the pure state machine ([`FaultTable`]) that the station's tick
//! drives with ring cycle numbers.
//!
//! **Timing.** A request is accepted between ticks and starts at the next tick: its
//! `since_cycle` is that tick's ring cycle C, and its effect is in the feedback registers the
//! station writes in tick C (the card reads them one ring cycle later). With `cycles = N` it
//! acts in the ticks of cycles C ..= C + N − 1 and is gone from cycle C + N on; without, until
//! `mcc fault clear` ([`FaultTable::clear`]). A second fault of the same kind on the same node
//! replaces the first (the new one starts at the next tick).
//!
//! What each kind does to a node ([`NodeFaults`], applied by [`crate::servo_node`]):
//!
//! | kind | `--value` | effect |
//! |---|---|---|
//! | `amp-fault` | none | the amplifier's FAULT line is asserted and its output is off (the motor coasts) |
//! | `encoder-loss` | none | register 0 (position) and the A/B levels freeze at their value when it starts |
//! | `encoder-glitch` | counts | the reported position jumps by V counts and stays offset while active |
//! | `load` | N·m | an extra constant torque V (signed) on the shaft |
//! | `jam` | none | the shaft is held at its position when it starts, whatever the torque |
//! | `plus-limit-on`/`-off`/`-chatter` | none | the +limit flag reads 1 / 0 / alternates every ring cycle (1 first) |
//! | `minus-limit-on`/`-off`/`-chatter` | none | the same for the −limit |
//! | `home-on`/`-off`/`-chatter` | none | the same for the home switch (the capture flag when MI913 selects it) |
//! | `power-loss` (station) | none | every servo node's amplifier faults as with `amp-fault`; the station keeps answering the ring |

use serde::{Deserialize, Serialize};

/// Largest `--value` of an encoder glitch, counts (a quarter of the 24-bit register turn, so
/// the card's sign-extended delta still reads the jump as it is).
pub const MAX_GLITCH_COUNTS: f64 = 131_072.0;
/// Largest `--value` of a load, N·m.
pub const MAX_LOAD_NM: f64 = 1_000.0;

/// A fault request the station refuses; the message names the problem and the choices.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AxisFaultError {
    /// Not one of [`AXIS_KINDS`].
    #[error("unknown axis fault {0:?} (one of: {kinds})", kinds = AXIS_KINDS.join(", "))]
    UnknownKind(String),
    /// A kind of [`VALUE_KINDS`] without its value.
    #[error("axis fault {kind} needs --value ({unit})")]
    NeedsValue {
        /// The kind word.
        kind: String,
        /// The value's unit.
        unit: &'static str,
    },
    /// A value for a kind that takes none.
    #[error("axis fault {kind} takes no --value (got {value}; only {takers} take one)", takers = value_kinds())]
    NoValue {
        /// The kind word.
        kind: String,
        /// The value given.
        value: f64,
    },
    /// A value outside −max ..= max (or not finite).
    #[error("axis fault {kind}: --value {value} out of range (−{max} ..= {max} {unit})")]
    OutOfRange {
        /// The kind word.
        kind: String,
        /// The value given.
        value: f64,
        /// The bound.
        max: f64,
        /// Its unit.
        unit: &'static str,
    },
    /// A node that is not a servo node of the station.
    #[error("node {node} is not a servo node of this station (servo nodes: {nodes})")]
    NotServo {
        /// The node asked for.
        node: u8,
        /// The station's servo nodes, comma-separated.
        nodes: String,
    },
    /// `cycles = 0`.
    #[error("cycles must be at least 1 (omit it to fault until cleared)")]
    ZeroCycles,
}

fn value_kinds() -> String {
    VALUE_KINDS
        .iter()
        .map(|k| k.0)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The station's application-fault request (`FaultRequest::App { fault }`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "kebab-case", deny_unknown_fields)]
pub enum StationFaultRequest {
    /// A fault of one servo node.
    Axis {
        /// Servo node number.
        node: u8,
        /// Kind word ([`AXIS_KINDS`]).
        kind: String,
        /// Amount (`encoder-glitch`: counts, `load`: N·m).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        value: Option<f64>,
        /// Ring cycles it lasts (none: until cleared).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cycles: Option<u64>,
    },
    /// Station-wide power loss.
    PowerLoss {
        /// Ring cycles it lasts (none: until cleared).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cycles: Option<u64>,
    },
}

/// A switch fault: what the flag reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stuck {
    /// Stuck at 1 (active).
    On,
    /// Stuck at 0.
    Off,
    /// Alternates 1, 0, 1, … every ring cycle.
    Chatter,
}

/// One kind of axis fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AxisFaultKind {
    /// The amplifier faults.
    AmpFault,
    /// The encoder count freezes.
    EncoderLoss,
    /// The count jumps by this many counts.
    EncoderGlitch(f64),
    /// An extra torque, N·m.
    Load(f64),
    /// The shaft is held where it is.
    Jam,
    /// The +limit switch.
    PlusLimit(Stuck),
    /// The −limit switch.
    MinusLimit(Stuck),
    /// The home switch.
    Home(Stuck),
}

/// Every axis kind word, in the order help texts list them.
pub const AXIS_KINDS: &[&str] = &[
    "amp-fault",
    "encoder-loss",
    "encoder-glitch",
    "load",
    "jam",
    "plus-limit-on",
    "plus-limit-off",
    "plus-limit-chatter",
    "minus-limit-on",
    "minus-limit-off",
    "minus-limit-chatter",
    "home-on",
    "home-off",
    "home-chatter",
];

/// The kinds that take `--value` (and need it), with its unit.
pub const VALUE_KINDS: &[(&str, &str)] = &[("encoder-glitch", "counts"), ("load", "N·m")];

impl AxisFaultKind {
    /// Parse a kind word and its `--value`; the error names the problem and the valid
    /// choices.
    pub fn parse(word: &str, value: Option<f64>) -> Result<Self, AxisFaultError> {
        let unit = VALUE_KINDS.iter().find(|(k, _)| *k == word).map(|k| k.1);
        match (unit, value) {
            (Some(unit), None) => {
                return Err(AxisFaultError::NeedsValue {
                    kind: word.into(),
                    unit,
                })
            }
            (None, Some(value)) if AXIS_KINDS.contains(&word) => {
                return Err(AxisFaultError::NoValue {
                    kind: word.into(),
                    value,
                })
            }
            _ => {}
        }
        let v = value.unwrap_or(0.0);
        let bounded = |max: f64, unit: &'static str| {
            if v.is_finite() && v.abs() <= max {
                Ok(v)
            } else {
                Err(AxisFaultError::OutOfRange {
                    kind: word.into(),
                    value: v,
                    max,
                    unit,
                })
            }
        };
        let stuck = |s: &str| match s {
            "on" => Some(Stuck::On),
            "off" => Some(Stuck::Off),
            "chatter" => Some(Stuck::Chatter),
            _ => None,
        };
        let sw = |prefix: &str| word.strip_prefix(prefix).and_then(stuck);
        Ok(match word {
            "amp-fault" => AxisFaultKind::AmpFault,
            "encoder-loss" => AxisFaultKind::EncoderLoss,
            "encoder-glitch" => AxisFaultKind::EncoderGlitch(bounded(MAX_GLITCH_COUNTS, "counts")?),
            "load" => AxisFaultKind::Load(bounded(MAX_LOAD_NM, "N·m")?),
            "jam" => AxisFaultKind::Jam,
            _ => {
                if let Some(s) = sw("plus-limit-") {
                    AxisFaultKind::PlusLimit(s)
                } else if let Some(s) = sw("minus-limit-") {
                    AxisFaultKind::MinusLimit(s)
                } else if let Some(s) = sw("home-") {
                    AxisFaultKind::Home(s)
                } else {
                    return Err(AxisFaultError::UnknownKind(word.into()));
                }
            }
        })
    }

    /// The kind word.
    pub fn word(&self) -> String {
        let st = |p: &str, s: Stuck| {
            let w = match s {
                Stuck::On => "on",
                Stuck::Off => "off",
                Stuck::Chatter => "chatter",
            };
            format!("{p}-{w}")
        };
        match *self {
            AxisFaultKind::AmpFault => "amp-fault".into(),
            AxisFaultKind::EncoderLoss => "encoder-loss".into(),
            AxisFaultKind::EncoderGlitch(_) => "encoder-glitch".into(),
            AxisFaultKind::Load(_) => "load".into(),
            AxisFaultKind::Jam => "jam".into(),
            AxisFaultKind::PlusLimit(s) => st("plus-limit", s),
            AxisFaultKind::MinusLimit(s) => st("minus-limit", s),
            AxisFaultKind::Home(s) => st("home", s),
        }
    }

    /// The `--value` it carries.
    pub fn value(&self) -> Option<f64> {
        match *self {
            AxisFaultKind::EncoderGlitch(v) | AxisFaultKind::Load(v) => Some(v),
            _ => None,
        }
    }

    /// Faults in the same slot replace each other (one state per switch).
    fn slot(&self) -> u8 {
        match self {
            AxisFaultKind::AmpFault => 0,
            AxisFaultKind::EncoderLoss => 1,
            AxisFaultKind::EncoderGlitch(_) => 2,
            AxisFaultKind::Load(_) => 3,
            AxisFaultKind::Jam => 4,
            AxisFaultKind::PlusLimit(_) => 5,
            AxisFaultKind::MinusLimit(_) => 6,
            AxisFaultKind::Home(_) => 7,
        }
    }
}

/// What the active faults do to one node in one tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeFaults {
    /// The amplifier's FAULT line is asserted (amp fault or power loss).
    pub amp_fault: bool,
    /// Encoder feedback frozen.
    pub encoder_frozen: bool,
    /// Offset added to the reported position, counts.
    pub count_offset: f64,
    /// Extra shaft torque, N·m.
    pub load: f64,
    /// Shaft held.
    pub jam: bool,
    /// +limit flag forced to this level.
    pub plus_limit: Option<bool>,
    /// −limit flag forced to this level.
    pub minus_limit: Option<bool>,
    /// Home switch forced to this level.
    pub home: Option<bool>,
}

/// One injected fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActiveFault {
    /// The node (none: station-wide power loss).
    pub node: Option<u8>,
    /// The kind (ignored for power loss).
    pub kind: Option<AxisFaultKind>,
    /// Ring cycles it lasts (none: until cleared).
    pub cycles: Option<u64>,
    /// The ring cycle of the first tick it acted in (none: starts at the next tick).
    pub since: Option<u64>,
}

impl ActiveFault {
    /// The first ring cycle it no longer acts in.
    pub fn until(&self) -> Option<u64> {
        Some(self.since?.saturating_add(self.cycles?))
    }

    /// The JSON shown in the station's status (`axis_faults`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "node": self.node,
            "kind": self.kind.map_or("power-loss".to_string(), |k| k.word()),
            "value": self.kind.and_then(|k| k.value()),
            "cycles": self.cycles,
            "since_cycle": self.since,
            "until_cycle": self.until(),
        })
    }
}

/// The station's injected axis faults.
#[derive(Clone, Debug, Default)]
pub struct FaultTable {
    faults: Vec<ActiveFault>,
}

impl FaultTable {
    /// Accept a request for a station whose servo nodes are `nodes`; the reply text, or a
    /// refusal naming the problem and the valid choices.
    pub fn request(
        &mut self,
        req: &StationFaultRequest,
        nodes: &[u8],
    ) -> Result<String, AxisFaultError> {
        let f = match req {
            StationFaultRequest::Axis {
                node,
                kind,
                value,
                cycles,
            } => {
                if !nodes.contains(node) {
                    let list: Vec<String> = nodes.iter().map(u8::to_string).collect();
                    return Err(AxisFaultError::NotServo {
                        node: *node,
                        nodes: list.join(", "),
                    });
                }
                ActiveFault {
                    node: Some(*node),
                    kind: Some(AxisFaultKind::parse(kind, *value)?),
                    cycles: *cycles,
                    since: None,
                }
            }
            StationFaultRequest::PowerLoss { cycles } => ActiveFault {
                node: None,
                kind: None,
                cycles: *cycles,
                since: None,
            },
        };
        if f.cycles == Some(0) {
            return Err(AxisFaultError::ZeroCycles);
        }
        let slot = |a: &ActiveFault| (a.node, a.kind.map(|k| k.slot()));
        self.faults.retain(|a| slot(a) != slot(&f));
        self.faults.push(f);
        let what = match (f.node, f.kind) {
            (Some(n), Some(k)) => format!("node {n} {}", k.word()),
            _ => "power-loss".into(),
        };
        let how_long = f
            .cycles
            .map_or("until cleared".into(), |n| format!("for {n} ring cycles"));
        Ok(format!("{what} from the next cycle, {how_long}"))
    }

    /// Start the faults accepted since the last tick and drop the expired ones: call at the
    /// start of the tick of ring cycle `cycle`.
    pub fn tick(&mut self, cycle: u64) {
        for f in &mut self.faults {
            if f.since.is_none() {
                f.since = Some(cycle);
            }
        }
        self.faults.retain(|f| f.until().is_none_or(|u| cycle < u));
    }

    /// Remove every fault.
    pub fn clear(&mut self) {
        self.faults.clear();
    }

    /// The active faults.
    pub fn active(&self) -> &[ActiveFault] {
        &self.faults
    }

    /// Station-wide power loss is active.
    pub fn power_loss(&self) -> bool {
        self.faults.iter().any(|f| f.node.is_none())
    }

    /// What the faults do to node `node` in the tick of ring cycle `cycle` (after
    /// [`FaultTable::tick`] for that cycle).
    pub fn effects(&self, node: u8, cycle: u64) -> NodeFaults {
        let started = self.faults.iter().filter(|f| f.since.is_some());
        let mut e = NodeFaults {
            amp_fault: started.clone().any(|f| f.node.is_none()),
            ..NodeFaults::default()
        };
        for f in started.filter(|f| f.node == Some(node)) {
            let Some(kind) = f.kind else { continue };
            let level = |s: Stuck| match s {
                Stuck::On => true,
                Stuck::Off => false,
                Stuck::Chatter => cycle.wrapping_sub(f.since.unwrap_or(cycle)) % 2 == 0,
            };
            match kind {
                AxisFaultKind::AmpFault => e.amp_fault = true,
                AxisFaultKind::EncoderLoss => e.encoder_frozen = true,
                AxisFaultKind::EncoderGlitch(v) => e.count_offset = v,
                AxisFaultKind::Load(v) => e.load = v,
                AxisFaultKind::Jam => e.jam = true,
                AxisFaultKind::PlusLimit(s) => e.plus_limit = Some(level(s)),
                AxisFaultKind::MinusLimit(s) => e.minus_limit = Some(level(s)),
                AxisFaultKind::Home(s) => e.home = Some(level(s)),
            }
        }
        e
    }
}

#[cfg(test)]
mod tests;
