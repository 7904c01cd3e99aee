//! The station's ring application: up to 16 nodes, servo nodes with a simulated plant and
//! I/O nodes that echo, run once per ring tick in ring time.
//!
//! Each tick: the time step is `time_ns − previous time_ns` (0 on the first tick or if time
//! did not advance; at most [`crate::servo_node::MAX_TICK_SECONDS`]; time that went back —
//! the ring renumbered by a restarted sync master — is the new origin), so in lockstep mode
//! (time = cycle × period) runs are exactly repeatable. Every servo node integrates, takes the
//! command latched this cycle and writes its feedback registers (sent on the next cycle).
//!
//! **Ring fault** (the member's latched ring-check fault): in the same tick every amplifier is
//! shut down (zero command, enable dropped, so the reported current and the amp-enabled flag
//! read 0) and I/O node outputs are zeroed. Position and flag feedback keep being reported, so
//! the card sees where the coasting motors ended once the ring is back; amplifiers stay off
//! until the card drops AENA ([`crate::servo_node`]).
//!
//! **Axis faults** ([`crate::faults`]): `app_fault` takes a [`StationFaultRequest`]; each tick
//! first advances the [`FaultTable`] to its ring cycle and hands every servo node its faults
//! for that cycle, before the plant integrates. `clear_app_faults` removes them all (the
//! nodes are back to normal in the next tick). Active faults show in the status as
//! `axis_faults` and `power_loss`.
//!
//! **`MS SAVE`** ([`crate::save_effect`]): a station with a state file has an I/O thread
//! ([`SaveWorker`]). Each tick first feeds the core the results of finished writes, then runs
//! it, then hands the write it asked for to the thread; the tick never writes or waits.

use std::path::PathBuf;

use mcc_ring::core::{CheckReport, RingApp, RingControl};
use mcc_ring::member::RingMember;
use mcc_ring::packet::NodeRegs;
use serde::Deserialize;

use crate::config::PlantConfig;
use crate::faults::{FaultTable, StationFaultRequest};
use crate::mi::{Globals, Setup};
use crate::save_effect::{SaveDone, SaveJob};
use crate::save_io::SaveWorker;
use crate::servo_node::{ServoNode, MAX_TICK_SECONDS};
use crate::station_mi::StationMi;

/// A node list [`StationApp::new`] refuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NodeListError {
    /// A node number above 15.
    #[error("node {0}: must be 0-15")]
    OutOfRange(u8),
    /// A node listed twice (as servo or I/O node).
    #[error("node {0}: listed twice")]
    Duplicate(u8),
    /// A plant override for a node that is not a servo node of this station.
    #[error("plant.nodes.{0}: node {0} is not a servo node of this station")]
    NotServo(u8),
}

/// A MACRO station with simulated servo nodes.
#[derive(Debug)]
pub struct StationApp {
    servo: Vec<ServoNode>,
    io: Vec<u8>,
    last_time_ns: Option<u64>,
    ticks: u64,
    ring_fault: bool,
    shutdown_cycle: Option<u64>,
    mi: StationMi,
    faults: FaultTable,
    saver: Option<SaveWorker>,
}

impl StationApp {
    /// A station with these servo and I/O nodes (0-15, no duplicates) and plant parameters.
    /// Fails with a message naming the problem (bad node, duplicate, override for a node that
    /// is not a servo node of this station).
    pub fn new(
        servo_nodes: &[u8],
        io_nodes: &[u8],
        plant: &PlantConfig,
    ) -> Result<Self, NodeListError> {
        let mut seen = [false; 16];
        for &n in servo_nodes.iter().chain(io_nodes) {
            let slot = seen
                .get_mut(usize::from(n))
                .ok_or(NodeListError::OutOfRange(n))?;
            if *slot {
                return Err(NodeListError::Duplicate(n));
            }
            *slot = true;
        }
        if let Some(&n) = plant.nodes.keys().find(|n| !servo_nodes.contains(n)) {
            return Err(NodeListError::NotServo(n));
        }
        let setup = Setup {
            globals: Globals::from_check(8, 4, 4),
            nodes: servo_nodes
                .iter()
                .map(|&n| (n, plant.node(n).clone()))
                .collect(),
        };
        Ok(StationApp {
            servo: servo_nodes
                .iter()
                .map(|&n| ServoNode::new(n, plant.node(n)))
                .collect(),
            io: io_nodes.to_vec(),
            last_time_ns: None,
            ticks: 0,
            ring_fault: false,
            shutdown_cycle: None,
            mi: StationMi::new(setup, None),
            faults: FaultTable::default(),
            saver: None,
        })
    }

    /// Start-up MI values: the config's ring check (MI8 period, MI10 sync packets, MI9
    /// errors) and where `MS SAVE` keeps the setup (a good state file there replaces the
    /// config values; a corrupt one is reported). With a state file the station gets its
    /// save thread (if it cannot be started, every `MS SAVE` fails).
    pub fn with_setup(mut self, globals: Globals, state_file: Option<PathBuf>) -> Self {
        let mut factory = self.mi.setup().clone();
        factory.globals = globals;
        self.saver = match &state_file {
            Some(_) => SaveWorker::start()
                .map_err(|e| tracing::error!("cannot start the station's save thread: {e}"))
                .ok(),
            None => None,
        };
        self.mi = StationMi::new(factory, state_file);
        self
    }

    /// Results of finished writes into the core (before its tick).
    fn collect_saves(&mut self) {
        let Some(w) = &self.saver else { return };
        while let Some(done) = w.poll() {
            self.mi.save_done(done);
        }
    }

    /// The write the core asked for to the save thread (after its tick); one it cannot take
    /// fails at once (`SAVE_FAILED`, answered from the next tick).
    fn dispatch_save(&mut self) {
        let Some(job) = self.mi.take_save_job() else {
            return;
        };
        let refused = match &self.saver {
            Some(w) => w.submit(job).err(),
            None => Some(job),
        };
        if let Some(SaveJob { token, path, .. }) = refused {
            tracing::warn!(path = %path.display(), "SAVE failed: the save thread cannot take it");
            self.mi.save_done(SaveDone {
                token,
                result: Err("the save thread cannot take it".into()),
            });
        }
    }

    /// The station's MI-level state.
    pub fn mi(&self) -> &StationMi {
        &self.mi
    }

    /// Ticks run so far.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Whether the last tick ran under a ring fault.
    pub fn ring_fault(&self) -> bool {
        self.ring_fault
    }

    /// The ring cycle whose tick shut the amplifiers down for the present ring fault (none
    /// while the ring is healthy).
    pub fn shutdown_cycle(&self) -> Option<u64> {
        self.shutdown_cycle
    }

    /// The servo node with this number.
    pub fn node(&self, n: u8) -> Option<&ServoNode> {
        self.servo.iter().find(|s| s.node() == n)
    }

    /// The servo node with this number, mutable (fault injection, user flag).
    pub fn node_mut(&mut self, n: u8) -> Option<&mut ServoNode> {
        self.servo.iter_mut().find(|s| s.node() == n)
    }

    /// The injected axis faults.
    pub fn faults(&self) -> &FaultTable {
        &self.faults
    }

    /// Servo nodes in configuration order.
    pub fn servo_nodes(&self) -> impl Iterator<Item = &ServoNode> {
        self.servo.iter()
    }
}

impl RingApp for StationApp {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        self.ticks += 1;
        self.collect_saves();
        let ring_fault = self.mi.tick(regs, ring_fault, &mut self.servo);
        self.dispatch_save();
        self.ring_fault = ring_fault;
        self.shutdown_cycle = match (ring_fault, self.shutdown_cycle) {
            (true, None) => Some(cycle),
            (true, c) => c,
            (false, _) => None,
        };
        let dt = match self.last_time_ns {
            Some(t0) if time_ns > t0 => ((time_ns - t0) as f64 * 1e-9).min(MAX_TICK_SECONDS),
            _ => 0.0,
        };
        // Ring time going back is the ring's count re-established by a restarted sync master
        // (the followers lock to its numbering): the plant steps from the new time on, rather
        // than standing still until the ring's count passes the old one.
        self.last_time_ns = Some(time_ns);
        self.faults.tick(cycle);
        for s in &mut self.servo {
            let n = s.node();
            s.set_faults(self.faults.effects(n, cycle));
            s.advance(dt);
            s.apply_command(regs.read_regs(n), ring_fault);
            *regs.write_regs_mut(n) = s.feedback();
        }
        for &n in &self.io {
            let cmd = regs.read_regs(n);
            *regs.write_regs_mut(n) = if ring_fault {
                NodeRegs::default()
            } else {
                NodeRegs {
                    r0: cmd.r0 & 0xFF_FFFF,
                    r1: cmd.r1,
                    r2: cmd.r2,
                    r3: cmd.r3,
                }
            };
        }
    }

    fn on_check(&mut self, report: &CheckReport) {
        let t = self.last_time_ns.unwrap_or(0);
        self.mi.on_check(report, t);
    }

    fn take_ring_reset(&mut self) -> bool {
        self.mi.take_ring_reset()
    }

    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        if let Some(p) = self.mi.take_check_params() {
            ring.check_mut().set_params(p);
        }
    }

    /// An axis fault or power loss ([`StationFaultRequest`] as JSON).
    fn app_fault(&mut self, fault: &serde_json::Value) -> Result<String, String> {
        let req = StationFaultRequest::deserialize(fault).map_err(|e| {
            format!(
                "not a station fault ({e}): {{\"op\":\"axis\",\"node\":N,\"kind\":K}} with K one of {}, or {{\"op\":\"power-loss\"}}",
                crate::faults::AXIS_KINDS.join(", ")
            )
        })?;
        let nodes: Vec<u8> = self.servo.iter().map(ServoNode::node).collect();
        self.faults.request(&req, &nodes).map_err(|e| e.to_string())
    }

    fn clear_app_faults(&mut self) {
        self.faults.clear();
    }

    /// The MI-variable fields, `ring_shutdown_cycle` (the cycle the ring fault shut the
    /// amplifiers down; null while healthy), `amps_enabled` (the servo nodes whose
    /// amplifier is on), `axis_faults` (the injected faults: node, kind, value, cycles,
    /// since_cycle, until_cycle) and `power_loss`.
    fn status_extra(&self) -> serde_json::Map<String, serde_json::Value> {
        let mut extra = self.mi.status_extra();
        extra.insert(
            "ring_shutdown_cycle".into(),
            serde_json::json!(self.shutdown_cycle),
        );
        let on: Vec<u8> = self
            .servo
            .iter()
            .filter(|s| s.snapshot().flags.amp_enabled)
            .map(ServoNode::node)
            .collect();
        extra.insert("amps_enabled".into(), serde_json::json!(on));
        let faults: Vec<serde_json::Value> =
            self.faults.active().iter().map(|f| f.to_json()).collect();
        extra.insert("axis_faults".into(), serde_json::Value::Array(faults));
        extra.insert(
            "power_loss".into(),
            serde_json::Value::Bool(self.faults.power_loss()),
        );
        extra
    }
}

#[cfg(test)]
#[path = "station_app_tests.rs"]
mod tests;
