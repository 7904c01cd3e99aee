//! The EMCL bus between the orchestrator's bus server and the processes hosting drives
//! (stations, stand-alone drive processes), spec emcl.md, architecture §5.
//!
//! - `mcc/<cluster>/emcl/<host>/frame`: query payload = one 9-byte frame; the reply payload
//!   is the answers of the host's drives that the frame addresses, each
//!   `pause_ms u8, length u8, bytes` (length 9, or 0 for an executed frame that sends no
//!   reply, e.g. the factory reset). An empty reply = no drive there answers (RS485 silence).
//! - `mcc/<cluster>/emcl/<host>/status`: query → JSON array of [`DriveStatus`].
//! - `mcc/<cluster>/emcl/<host>/io`: query with an [`IoRequest`] JSON → `mcc_ring::control::CtlReply`
//!   (set a drive's input lines, inject a driver fault: the test bench's hands).

use serde::{Deserialize, Serialize};

/// Bytes in an EMCL frame.
pub const FRAME_LEN: usize = 9;

/// `mcc/<cluster>/emcl/<host>/frame`.
pub fn frame_key(cluster: &str, host: &str) -> String {
    format!("mcc/{cluster}/emcl/{host}/frame")
}

/// `mcc/<cluster>/emcl/*/frame`: every host at once.
pub fn frame_key_all(cluster: &str) -> String {
    format!("mcc/{cluster}/emcl/*/frame")
}

/// `mcc/<cluster>/emcl/<host>/status`.
pub fn status_key(cluster: &str, host: &str) -> String {
    format!("mcc/{cluster}/emcl/{host}/status")
}

/// `mcc/<cluster>/emcl/<host>/io`.
pub fn io_key(cluster: &str, host: &str) -> String {
    format!("mcc/{cluster}/emcl/{host}/io")
}

/// One drive's answer to a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusAnswer {
    /// GP 75 telegram pause before the reply, ms.
    pub pause_ms: u8,
    /// The reply (none: executed without a reply).
    pub bytes: Option<[u8; FRAME_LEN]>,
}

/// Encode a host's answers.
pub fn encode_answers(a: &[BusAnswer]) -> Vec<u8> {
    let mut out = Vec::with_capacity(a.len() * (FRAME_LEN + 2));
    for x in a {
        out.push(x.pause_ms);
        match x.bytes {
            Some(b) => {
                out.push(FRAME_LEN as u8);
                out.extend_from_slice(&b);
            }
            None => out.push(0),
        }
    }
    out
}

/// Decode a host's answers (malformed trailing bytes end the list).
pub fn decode_answers(b: &[u8]) -> Vec<BusAnswer> {
    let mut out = Vec::new();
    let mut rest = b;
    while let [pause, len, tail @ ..] = rest {
        match *len as usize {
            0 => {
                out.push(BusAnswer {
                    pause_ms: *pause,
                    bytes: None,
                });
                rest = tail;
            }
            FRAME_LEN if tail.len() >= FRAME_LEN => {
                let mut f = [0u8; FRAME_LEN];
                f.copy_from_slice(&tail[..FRAME_LEN]);
                out.push(BusAnswer {
                    pause_ms: *pause,
                    bytes: Some(f),
                });
                rest = &tail[FRAME_LEN..];
            }
            _ => break,
        }
    }
    out
}

/// Error flags of a drive.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveErrors {
    /// POS_ERROR latched (position or velocity deviation).
    pub pos_error: bool,
    /// Stopped by stall detection.
    pub stall: bool,
    /// Program timeout flag (ETO).
    pub eto: bool,
    /// AP 208 driver error flags.
    pub driver_flags: u8,
    /// Left limit switch active.
    pub left_limit: bool,
    /// Right limit switch active.
    pub right_limit: bool,
    /// Configuration EEPROM locked (GP 73).
    pub eeprom_locked: bool,
}

/// What `mcc status` shows of a drive.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveStatus {
    /// Config name.
    pub name: String,
    /// Hosting process (station name, or the drive's own name when it stands alone).
    pub host: String,
    /// RS485 address (GP 66).
    pub address: u8,
    /// Secondary address (GP 87, 0 = none).
    pub secondary_address: u8,
    /// MACRO node it is bound to in the config.
    pub node: Option<u8>,
    /// `direct`, `bound` (following its MACRO node) or `download`.
    pub mode: String,
    /// `idle`, `velocity`, `position`, `stopping`, `reference` or `bound`.
    pub motion: String,
    /// AP 1, µsteps.
    pub position: i32,
    /// AP 0.
    pub target: i32,
    /// AP 3, pps.
    pub velocity: i64,
    /// AP 209.
    pub encoder: i32,
    /// AP 8.
    pub target_reached: bool,
    /// Program state: `stop`, `run`, `step`, `reset`.
    pub program: String,
    /// Program counter (GP 130).
    pub pc: u16,
    /// Program memory slots used.
    pub program_size: usize,
    /// Error flags.
    pub errors: DriveErrors,
    /// How the EEPROM image was found at power-up (`loaded`, `factory`, `CORRUPT (...)`).
    pub eeprom: String,
    /// Last EEPROM write failure, if any.
    pub eeprom_error: Option<String>,
    /// The EEPROM state file.
    pub state_file: Option<String>,
    /// Frames addressed to the drive.
    pub frames: u64,
    /// Of them answered with an error status.
    pub frame_errors: u64,
    /// The drive's clock, ms.
    pub now_ms: u64,
}

/// Set an input line of a drive, or inject a driver fault.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct IoRequest {
    /// Drive name.
    pub drive: String,
    /// `in0`..`in2`, `analog`, `enable_in`, `reset_in`, `overtemp`, `short`.
    pub input: String,
    /// The value.
    pub value: i64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn answers_round_trip_and_garbage_is_bounded() {
        let a = [
            BusAnswer {
                pause_ms: 15,
                bytes: Some([1, 2, 3, 4, 5, 6, 7, 8, 9]),
            },
            BusAnswer {
                pause_ms: 0,
                bytes: None,
            },
        ];
        assert_eq!(decode_answers(&encode_answers(&a)), a);
        assert!(decode_answers(&[]).is_empty());
        assert!(decode_answers(&[0, 9, 1, 2]).is_empty());
        assert!(decode_answers(&[0, 7, 1, 2, 3, 4, 5, 6, 7]).is_empty());
        assert_eq!(frame_key("c", "station0"), "mcc/c/emcl/station0/frame");
    }
}
