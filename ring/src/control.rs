//! Control plane: the messages the orchestrator and the members exchange over zenoh queries
//! (JSON payloads), and the key expressions they use. Contract between `runtime` (member side)
//! and the orchestrator.
//!
//! Key expressions (architecture §3.1, §7):
//! - `mcc/<cluster>/ring/<ring>/link/<k>`: ring link published by member k (frames, bincode).
//! - `mcc/<cluster>/ctl/<member>/status`: query → [`MemberStatus`] JSON.
//! - `mcc/<cluster>/ctl/<member>/fault`: query with a [`FaultRequest`] JSON payload → [`CtlReply`].
//! - `mcc/<cluster>/ctl/<member>/shutdown`: query → [`CtlReply`], then the member exits.
//! - `mcc/<cluster>/card/<n>/cmd`: query with a command line → the card's framed reply bytes.
//! - `mcc/<cluster>/card/<n>/at`: synchronized start, [`AtRequest`] JSON → [`AtReply`] JSON
//!   ([`sync_start`]).
//! - `mcc/<cluster>/card/<n>/chain`: daisy-chain bytes, binary ([`chain`]).
//! - `mcc/<cluster>/emcl/<host>/{frame,status,io}`: the EMCL bus to drive hosts ([`emcl`]).
//! - `mcc/<cluster>/alive/<member>`: liveliness token of each member and of `orchestrator`.

use serde::{Deserialize, Serialize};

use crate::fault::FaultSpec;

pub mod chain;
pub mod emcl;
pub mod sync_start;

pub use sync_start::{at_key, AtReply, AtRequest};

/// Key of the ring link published by member `k` of ring `ring`.
pub fn link_key(cluster: &str, ring: &str, k: usize) -> String {
    format!("mcc/{cluster}/ring/{ring}/link/{k}")
}

/// Key of a member's control queryable `what` (`status`, `fault`, `shutdown`).
pub fn ctl_key(cluster: &str, member: &str, what: &str) -> String {
    format!("mcc/{cluster}/ctl/{member}/{what}")
}

/// Key of card `n`'s command queryable.
pub fn card_cmd_key(cluster: &str, n: u32) -> String {
    format!("mcc/{cluster}/card/{n}/cmd")
}

/// Liveliness token key of `member` (or `orchestrator`).
pub fn alive_key(cluster: &str, member: &str) -> String {
    format!("mcc/{cluster}/alive/{member}")
}

/// Kind of ring member.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MemberKind {
    /// A controller card (ring master).
    Card,
    /// A MACRO station (ring slave).
    Station,
}

/// Receive-side error counters of one member (since start).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ErrorCounters {
    /// Header byte that is not a valid packet code.
    pub byte_violation: u64,
    /// Check byte mismatch.
    pub checksum: u64,
    /// More bytes than whole packets, or a frame before the previous one was consumed.
    pub overrun: u64,
    /// Truncated packet or frame missing its packets.
    pub underrun: u64,
    /// Frames rejected before packet parsing (bad envelope, wrong format version, stale or
    /// duplicate sequence number, wrong sender).
    pub bad_frames: u64,
}

/// What one member reports about itself (`ctl/<member>/status`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MemberStatus {
    /// Member name from the config (`card0`, `station1`, ...).
    pub name: String,
    /// `card` or `station`.
    pub kind: Option<MemberKind>,
    /// OS process id.
    pub pid: u32,
    /// Position in the ring order (0-based).
    pub ring_position: usize,
    /// This member is the synchronizing master.
    pub sync_master: bool,
    /// Sync packets are arriving (phase-locked).
    pub locked: bool,
    /// Latest ring cycle number known (from the sync packet, or the local holdover clock).
    pub cycle: u64,
    /// Sync packets received since start.
    pub sync_count: u64,
    /// Frames received from upstream since start.
    pub rx_frames: u64,
    /// Ring cycle of the last frame received from upstream, if any.
    pub last_rx_cycle: Option<u64>,
    /// Receive error counters.
    pub errors: ErrorCounters,
    /// Ring fault latched by this member's ring check (card: X:$0003 bit 4; station: outputs off).
    pub ring_fault: bool,
    /// Ring faults detected since start.
    pub ring_fault_count: u64,
    /// Ring cycle at which the ring fault latched (the rising edge; cleared only by a reset).
    pub ring_fault_cycle: Option<u64>,
    /// Cycles run on the local holdover clock (no sync packet arrived in time).
    pub holdover_cycles: u64,
    /// Realtime mode: cycles that started late (the real-time interrupt warning).
    pub late_cycles: u64,
    /// Faults currently injected on this member's send path.
    pub faults: Vec<FaultSpec>,
    /// Free-form extras by kind (card ports, station nodes, ...).
    #[serde(default)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// A fault-injection request for a member's send path.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "lowercase")]
pub enum FaultRequest {
    /// Add a fault.
    Inject {
        /// The fault.
        spec: FaultSpec,
    },
    /// Remove every injected fault.
    Clear,
}

/// Generic control reply.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CtlReply {
    /// Success.
    pub ok: bool,
    /// Human-readable message (error text when `ok` is false).
    pub message: String,
}
