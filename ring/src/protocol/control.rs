//! Control plane of the ring: the messages the orchestrator and the ring members exchange over
//! zenoh queries (JSON payloads), and the key expressions they use. Contract between `runtime`
//! (member side) and the orchestrator. The cluster's other control-plane messages (the EMCL
//! bus, the daisy chain, hosts' shares, the synchronized start) are
//! [`mcc_contracts::control`].
//!
//! Key expressions (architecture §3.1, §7):
//! - `mcc/<cluster>/ring/<ring>/link/<k>`: ring link published by member k (frames, bincode).
//! - `mcc/<cluster>/ctl/<member>/status`: query → [`MemberStatus`] JSON.
//! - `mcc/<cluster>/ctl/<member>/fault`: query with a [`FaultRequest`] JSON payload → [`CtlReply`].
//! - `mcc/<cluster>/ctl/<member>/shutdown`: query → [`CtlReply`], then the member exits.
//! - `mcc/<cluster>/ctl/orchestrator/restart`: the supervisor restarts a member (drill).
//! - `mcc/<cluster>/ctl/orchestrator/link`: the supervisor's daisy-chain and EMCL-bus
//!   host-link faults (JSON `{"op": "set"|"clear"|"status", ...}` → [`CtlReply`];
//!   `mcc fault chain|bus link KIND`, [`crate::linkfault`]).
//! - `mcc/<cluster>/card/<n>/cmd`: query with a command line → the card's framed reply bytes.
//! - `mcc/<cluster>/alive/<member>`: liveliness token of each member and of `orchestrator`.
//! - `mcc/<cluster>/card/<n>/{at,chain}`, `mcc/<cluster>/emcl/<host>/…`,
//!   `mcc/<cluster>/hosts/<host>/…`: [`mcc_contracts::control`].

use serde::{Deserialize, Serialize};

use crate::fault::{ActiveFault, FaultSpec};

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
    /// Sync packets are arriving (phase-locked) and the ring check runs (a member that arms
    /// its check after lock: [`crate::core::ARM_AFTER_LOCKED`] cycles locked in a row).
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
    /// Cycles that started late on the wall clock (paced, realtime: the real-time interrupt
    /// warning; counted, never an error).
    pub late_cycles: u64,
    /// The link into this member carries no light (loss of light: a cut or dead sender
    /// upstream; a byte violation every cycle).
    #[serde(default)]
    pub dark: bool,
    /// First ring cycle this member ran with a dark input (while `dark`).
    #[serde(default)]
    pub dark_since_cycle: Option<u64>,
    /// The last dark spell that ended, `[first, last]` cycle without light (a member upstream
    /// that died and came back, a cut that was mended).
    #[serde(default)]
    pub last_dark_spell: Option<(u64, u64)>,
    /// While latched: the first dark cycle of the spell the member was in when its fault
    /// latched (the onset of a loss of light as the member itself saw it, in the numbering of
    /// its latch: a restarted sync master may renumber the ring afterwards).
    #[serde(default)]
    pub ring_fault_dark_since: Option<u64>,
    /// Latest ring cycle in which the link into this member delivered bad data: a packet
    /// error, a dark frame, a frame too many, or no frame at all (not a master's own packets
    /// missing, which means a break further round the ring).
    #[serde(default)]
    pub link_error_cycle: Option<u64>,
    /// Why the latched ring fault was declared (while `ring_fault`).
    #[serde(default)]
    pub fault_reason: Option<String>,
    /// Faults currently injected on this member's send path.
    pub faults: Vec<ActiveFault>,
    /// Synchronizing master: how the ring's clock is keeping time.
    #[serde(default)]
    pub clock: Option<ClockReport>,
    /// What the cycle thread got from the scheduler (realtime: SCHED_FIFO and locked memory
    /// when permitted).
    #[serde(default)]
    pub sched: Option<String>,
    /// The machine it runs on (kernel boot id): a member downstream on the same machine can
    /// tell from `/proc` whether its process is stopped.
    #[serde(default)]
    pub host_id: Option<String>,
    /// Its ring link's publisher has a matching subscriber (zenoh's matching status: the
    /// downstream neighbour's subscriber reached it); null where the transport cannot tell.
    /// The sync master asks for it after a member rejoins (`runtime::links_up`).
    #[serde(default)]
    pub link_matched: Option<bool>,
    /// CPU its process used over the last second, percent of one core (user + system, from
    /// `/proc/self/stat`; null before the first second, or where `/proc` cannot be read).
    #[serde(default)]
    pub cpu_percent: Option<f64>,
    /// Free-form extras by kind (card ports, station nodes, ...).
    #[serde(default)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// How the ring's clock keeps time, as the synchronizing master sees it.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ClockReport {
    /// `paced`, `lockstep` or `realtime`.
    pub mode: String,
    /// The real-time factor asked for (paced; 1 otherwise).
    pub rtf_requested: f64,
    /// Ring time over wall time during the last second.
    pub rtf: f64,
    /// Cycles that started more than one period after their deadline (the real-time interrupt
    /// warning: counted, never an error).
    pub late_cycles: u64,
    /// Worst start lag behind the schedule, µs.
    pub max_lag_us: u64,
    /// Median start lag, µs.
    pub lag_p50_us: u64,
    /// 99th-percentile start lag, µs.
    pub lag_p99_us: u64,
    /// Wall time given up when the ring fell more than the backlog behind (re-based), ms.
    pub lost_ms: u64,
    /// How often the schedule was re-based.
    pub rebases: u64,
    /// Longest wall time between two consecutive cycle starts, µs.
    pub longest_stall_us: u64,
    /// For how long the achieved real-time factor has been below the requested one, ms
    /// (0 = it is not).
    pub below_rtf_ms: u64,
    /// Nothing came back within the frozen-member wait: the sync master runs cycles on its
    /// own clock.
    pub ring_down: bool,
    /// How often the ring went down.
    pub ring_down_count: u64,
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
    /// Remove every injected fault (the send path's and the application's).
    Clear,
    /// A fault for the member's application, not its send path: a station's axis faults, a
    /// card's E-stop input or host-link faults. The payload is the application's own request
    /// (JSON; each application defines and parses its type), handed to
    /// [`crate::core::RingApp::app_fault`] on the thread that holds the application.
    App {
        /// The application's request.
        fault: serde_json::Value,
    },
}

/// Generic control reply.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CtlReply {
    /// Success.
    pub ok: bool,
    /// Human-readable message (error text when `ok` is false).
    pub message: String,
}
