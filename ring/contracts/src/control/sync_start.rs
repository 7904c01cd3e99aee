//! The synchronized-start contract (architecture §6): the JSON requests and replies of card
//! `n`'s `at` queryable, `mcc/<cluster>/card/<n>/at`. The card serves them
//! (`mcc_card::runtime::sync_start`), the orchestrator drives the two-phase arm/commit start
//! with them (`mcc start-sync`, chain lines that start programs on several cards).

use serde::{Deserialize, Serialize};

use super::refusal::CardRefusal;

/// Key of card `n`'s synchronized-start queryable.
pub fn at_key(cluster: &str, n: u32) -> String {
    format!("mcc/{cluster}/card/{n}/at")
}

/// A request to the `at` queryable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "lowercase")]
pub enum AtRequest {
    /// Current cycle, program start record, ring fault and motor state.
    Info,
    /// Keep `line` for the tick of ring cycle `cycle`, undecided.
    Arm {
        /// Start identifier chosen by the orchestrator.
        id: u64,
        /// Ring cycle T.
        cycle: u64,
        /// One command line (no CR).
        line: String,
    },
    /// Execute armed start `id` at its cycle.
    Commit {
        /// Start identifier.
        id: u64,
    },
    /// Forget armed start `id` (refused once committed).
    Abort {
        /// Start identifier.
        id: u64,
    },
    /// Outcome of start `id`: executed (cycle and reply) or still pending.
    Result {
        /// Start identifier.
        id: u64,
    },
}

impl AtRequest {
    /// The JSON payload of this request.
    pub fn to_json(&self) -> String {
        // A tagged enum of integers and strings always serializes.
        serde_json::to_string(self).unwrap_or_default()
    }
}

/// The answer to every [`AtRequest`] (fields not relevant to the request keep defaults).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AtReply {
    /// The request was accepted.
    pub ok: bool,
    /// Error or information text.
    pub message: String,
    /// Arm refused because the tick of the requested cycle has already started.
    pub late: bool,
    /// Ring cycle of the card's most recent tick.
    pub cycle: Option<u64>,
    /// `result`: ring cycle at which the line executed.
    pub executed_cycle: Option<u64>,
    /// `result`: CLOCK_MONOTONIC ns at which the line executed.
    pub executed_ns: Option<u64>,
    /// `result`: the card's reply to the line (framed bytes as text).
    pub reply: Option<String>,
    /// `result`: the line's refusal (JSON: its text form, `ERR003`, `error #20`), whether or
    /// not the reply shows it (I6); `None`: not refused.
    pub refusal: Option<CardRefusal>,
    /// `result`: the line was abandoned (no commit/abort within the stall limit).
    pub abandoned: bool,
    /// Ring cycle of the most recent program start.
    pub program_start_cycle: Option<u64>,
    /// CLOCK_MONOTONIC ns of the most recent program start.
    pub program_start_ns: Option<u64>,
    /// The card's ring-fault bit (X:$0003 bit 4).
    pub ring_fault: bool,
    /// Ring fault latched and every activated motor killed.
    pub motors_killed: bool,
    /// Activated motors (Ix00=1) that are killed (open loop, amplifier disabled).
    pub killed_motors: Vec<u16>,
    /// Ticks that waited for a commit (a lead that was too short).
    pub stalls: u64,
}

impl AtReply {
    /// A refusal carrying `message` (every other field at its default).
    pub fn err(message: impl Into<String>) -> Self {
        AtReply {
            message: message.into(),
            ..AtReply::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_tagged_json_and_round_trip() {
        assert_eq!(at_key("lab", 3), "mcc/lab/card/3/at");
        assert_eq!(AtRequest::Info.to_json(), r#"{"op":"info"}"#);
        let arm = AtRequest::Arm {
            id: 7,
            cycle: 1200,
            line: "&1B1R".into(),
        };
        assert_eq!(
            arm.to_json(),
            r#"{"op":"arm","id":7,"cycle":1200,"line":"&1B1R"}"#
        );
        assert_eq!(
            serde_json::from_str::<AtRequest>(&arm.to_json()).unwrap(),
            arm
        );
        assert_eq!(
            AtRequest::Commit { id: 9 }.to_json(),
            r#"{"op":"commit","id":9}"#
        );
        assert!(serde_json::from_str::<AtRequest>(r#"{"op":"melt"}"#).is_err());
    }

    #[test]
    fn replies_fill_missing_fields_with_defaults() {
        let r: AtReply = serde_json::from_str(r#"{"ok":true,"cycle":5}"#).unwrap();
        assert!(r.ok && !r.late && r.killed_motors.is_empty());
        assert_eq!(r.cycle, Some(5));
        let e = AtReply::err("busy");
        assert_eq!((e.ok, e.message.as_str()), (false, "busy"));
        assert_eq!(r.refusal, None);
        let j = r#"{"ok":true,"reply":"\u0007","refusal":"ERR003"}"#;
        let r: AtReply = serde_json::from_str(j).unwrap();
        assert_eq!(r.refusal, Some(CardRefusal::Pmac(3)));
        let back: AtReply = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
        assert!(serde_json::from_str::<AtReply>(r#"{"refusal":"ERR"}"#).is_err());
    }
}
