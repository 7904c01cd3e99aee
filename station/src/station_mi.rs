//! The station's MI-level state, run once per tick by [`crate::station_app::StationApp`]: its
//! setup ([`crate::mi`]), ring-check bookkeeping (MI5 error counter, MI12 errors in the last
//! second, MI6 limit, break localisation), the fault latch, and the Type 1 auxiliary requests
//! that arrive on node 15 ([`crate::macro_aux`]).
//!
//! **Ring fault** (the ring core's latch from MI8/MI9/MI10, or too many errors in one second
//! per MI6): outputs zeroed and amplifier enables dropped in the same tick, FAULT reported on
//! every servo node while latched. If at least half of the period's errors were byte
//! violations (what a station with no light at its input sees), the break is directly
//! upstream (`suspected_break`). Cleared by `MS{node}CLRF`, `MS$$${node}`, `mcc fault reset`,
//! only once a check period has passed again.
//!
//! **`MS SAVE`** is an effect ([`crate::save_effect`]): the tick never writes the state file.
//! The SAVE's reply is held (the station streams `WORKING`, so its master keeps waiting) until
//! the runtime hands back the write's result ([`StationMi::save_done`]), then answers Done or
//! `SAVE_FAILED` as before. While the write is in flight every other request gets
//! `slave_error::BUSY`.

use std::path::PathBuf;

use mcc_ring::aux_channel::{
    slave_error, AuxWord, Reply, Request, StationCmd, ValueFormat, AUX_NODE,
};
use mcc_ring::check::{CheckFault, CheckParams, RingCheck};
use mcc_ring::core::CheckReport;
use mcc_ring::member::RingMember;
use serde_json::{json, Map, Value};
use tracing::{info, warn};

use crate::macro_aux::{AuxSlave, Incoming};
use crate::mi::persist::{self, Loaded};
use crate::mi::{self, status_bits, Changed, Live, Setup};
use crate::save_effect::{SaveDone, SaveEffects, SaveJob};
use crate::servo_node::ServoNode;

const SECOND_NS: u64 = 1_000_000_000;

/// MI-level state of a station.
#[derive(Clone, Debug)]
pub struct StationMi {
    setup: Setup,
    factory: Setup,
    live: Live,
    state_file: Option<PathBuf>,
    config_error: Option<String>,
    aux: AuxSlave,
    check_params: Option<CheckParams>,
    ring_reset: bool,
    core_fault: bool,
    per_second_fault: bool,
    suspected_break: bool,
    healthy: bool,
    window_start: Option<u64>,
    window_errors: u32,
    /// Every servo node needs its parameters (re)applied at the next tick.
    reapply: bool,
    requests: u64,
    save: SaveEffects,
}

impl StationMi {
    /// From the config values (`factory`), replaced by the state file's setup if there is a
    /// good one; a corrupt file is reported (MI4 bit 2) and the config values are used.
    pub fn new(factory: Setup, state_file: Option<PathBuf>) -> Self {
        let mut config_error = None;
        let setup = match state_file.as_deref().map(persist::load) {
            Some(Loaded::Setup(s)) if same_nodes(&s, &factory) => s,
            Some(Loaded::Setup(_)) => {
                config_error = Some("state file: its nodes are not this station's".into());
                factory.clone()
            }
            Some(Loaded::Corrupt(why)) => {
                config_error = Some(format!("state file: {why}"));
                factory.clone()
            }
            Some(Loaded::Absent) | None => factory.clone(),
        };
        if let (Some(e), Some(p)) = (&config_error, &state_file) {
            warn!(path = %p.display(), "{e}: starting from the config values (MI4 bit 2 set)");
        }
        let mut live = Live::default();
        if config_error.is_some() {
            live.status |= status_bits::CONFIG_ERROR;
        }
        StationMi {
            check_params: Some(check_params(&setup)),
            setup,
            factory,
            live,
            state_file,
            config_error,
            aux: AuxSlave::default(),
            ring_reset: false,
            core_fault: false,
            per_second_fault: false,
            suspected_break: false,
            healthy: false,
            window_start: None,
            window_errors: 0,
            reapply: true,
            requests: 0,
            save: SaveEffects::default(),
        }
    }

    /// The write an `MS SAVE` asks for, to perform off the tick (once; answer it with
    /// [`StationMi::save_done`]).
    pub fn take_save_job(&mut self) -> Option<SaveJob> {
        self.save.take_job()
    }

    /// A save is in flight (the station answers other requests `BUSY`).
    pub fn saving(&self) -> bool {
        self.save.busy()
    }

    /// The runtime's result of a [`SaveJob`]: answer the held SAVE (Done or `SAVE_FAILED`),
    /// sent from the next [`StationMi::tick`] on. A result nobody waits for is logged.
    pub fn save_done(&mut self, done: SaveDone) {
        let Some((tag, reply)) = self.save.finish(&done) else {
            warn!(
                token = done.token,
                "a save result for no save in flight: ignored"
            );
            return;
        };
        if !self.aux.answer_held(tag, reply) {
            info!(
                ok = done.result.is_ok(),
                "SAVE finished after its master stopped waiting"
            );
        }
    }

    /// The current setup.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// Why the state file could not be used at start-up.
    pub fn config_error(&self) -> Option<&str> {
        self.config_error.as_deref()
    }

    /// The effective fault latch (ring check or MI6).
    pub fn faulted(&self) -> bool {
        self.core_fault || self.per_second_fault
    }

    /// The latest fault was localised to the link directly upstream.
    pub fn suspected_break(&self) -> bool {
        self.suspected_break
    }

    /// Live MI values (counters, status).
    pub fn live(&self) -> &Live {
        &self.live
    }

    /// What the ring check saw this cycle.
    pub fn on_check(&mut self, r: &CheckReport, time_ns: u64) {
        self.healthy = r.healthy;
        if let Some(CheckFault::Errors { errors, .. }) = r.fault {
            self.suspected_break = r.fault_byte_violations.saturating_mul(2) >= errors;
        } else if r.fault.is_some() {
            self.suspected_break = false;
        }
        if r.checked && r.status & 0x0F != 0 {
            self.live.errors = (self.live.errors + 1) & 0xFF_FFFF;
            self.window_errors = self.window_errors.saturating_add(1);
            let max = self.setup.globals.max_errors_per_second;
            if max > 0 && self.window_errors > max && !self.per_second_fault {
                warn!(
                    errors = self.window_errors,
                    max, "ring errors per second over MI6: ring fault"
                );
                self.per_second_fault = true;
            }
        }
        let start = *self.window_start.get_or_insert(time_ns);
        if time_ns.saturating_sub(start) >= SECOND_NS {
            self.live.errors_last_second = self.window_errors;
            self.window_errors = 0;
            self.window_start = Some(time_ns);
        }
    }

    /// New ring-check parameters for the core, if MI8/MI9/MI10 changed.
    pub fn take_check_params(&mut self) -> Option<CheckParams> {
        self.check_params.take()
    }

    /// The station asked the core to clear its ring-fault latch (effective if healthy).
    pub fn take_ring_reset(&mut self) -> bool {
        std::mem::take(&mut self.ring_reset)
    }

    /// One tick, before the plant: track the fault latch, serve the auxiliary channel, apply
    /// changed parameters to the servo nodes. Returns the effective fault latch.
    pub fn tick(
        &mut self,
        regs: &mut RingMember,
        ring_fault: bool,
        nodes: &mut [ServoNode],
    ) -> bool {
        self.core_fault = ring_fault;
        let settings = regs.settings();
        self.live.i995 = settings.i995 & 0xFFFF;
        self.live.i996 = settings.i996 & 0xFF_FFFF;
        let master = settings.master_number();
        let w = regs
            .latched_copy(master, AUX_NODE)
            .map_or(AuxWord::IDLE, |r| AuxWord::decode(r.r2, r.r3));
        let served: Vec<u8> = nodes.iter().map(ServoNode::node).collect();
        if let Some(inc) = self.aux.on_word(w, |n| served.contains(&n)) {
            self.requests += 1;
            // None: a SAVE, held until its write's result is back.
            if let Some(reply) = self.execute(inc, nodes) {
                self.aux.set_reply(reply);
            }
        }
        regs.set_aux_reply(self.aux.reply_regs());
        if self.reapply {
            self.reapply = false;
            for s in nodes.iter_mut() {
                if let Some(cfg) = self.setup.nodes.get(&s.node()) {
                    s.reconfigure(cfg);
                }
            }
        }
        let fault = self.faulted();
        if !fault {
            self.suspected_break = false;
        }
        let mut st = self.live.status & status_bits::CONFIG_ERROR;
        if fault {
            st |= status_bits::RING_FAULT;
        }
        if self.suspected_break {
            st |= status_bits::BREAK_UPSTREAM;
        }
        if self.per_second_fault {
            st |= status_bits::ERRORS_PER_SECOND;
        }
        self.live.status = st;
        for s in nodes.iter_mut() {
            s.set_ring_fault_flag(fault);
        }
        fault
    }

    /// Clear the fault latches if the ring is healthy (CLRF, `$$$`, `mcc fault reset`).
    fn clear_faults(&mut self) {
        self.ring_reset = true;
        if self.healthy {
            self.per_second_fault = false;
        }
    }

    /// The reply to a request, or None for a SAVE (held: [`StationMi::save_done`] answers).
    fn execute(&mut self, inc: Incoming, nodes: &mut [ServoNode]) -> Option<Reply> {
        let node = inc.node;
        info!(node, request = ?inc.request, "auxiliary request");
        if self.save.busy() {
            warn!(node, request = ?inc.request, "busy saving the setup: refused");
            return Some(Reply::Error(slave_error::BUSY));
        }
        let reply = match inc.request {
            Request::ReadMi(n) => self.read(node, n),
            Request::ReadParam(p) => match self.read(node, p) {
                Reply::Value(v, _) => Reply::Value(v, ValueFormat::Decimal),
                r => r,
            },
            Request::WriteMi(n, v) => self.write(node, n, v),
            Request::WriteParam(p, v) => self.write(node, p, f64::from(v)),
            Request::ConfigWrite(v) => self.write(node, 2, v),
            Request::CCommand(2, _) => self.command(StationCmd::Reset, node, nodes),
            Request::CCommand(4, _) | Request::Command(StationCmd::Save) => return self.save(),
            Request::CCommand(..) => Reply::Error(slave_error::UNKNOWN_VARIABLE),
            Request::Command(c) => self.command(c, node, nodes),
        };
        Some(reply)
    }

    /// `MS SAVE`: hold the reply and hand the setup as it is now to the runtime (None), or
    /// refuse at once when there is nowhere to save.
    fn save(&mut self) -> Option<Reply> {
        let Some(path) = self.state_file.clone() else {
            warn!("SAVE refused: this station has no state file");
            return Some(Reply::Error(slave_error::SAVE_FAILED));
        };
        let tag = self.aux.hold();
        if !self.save.start(path, self.setup.clone(), tag) {
            return Some(Reply::Error(slave_error::BUSY));
        }
        None
    }

    fn read(&self, node: u8, n: u16) -> Reply {
        // A node-specific variable read through node 15 answers for the lowest node.
        let node = if node == AUX_NODE && mi::is_node_var(n) {
            self.setup.nodes.keys().next().copied().unwrap_or(node)
        } else {
            node
        };
        match self.setup.read(&self.live, node, n) {
            Ok((v, f)) => Reply::Value(v, f),
            Err(e) => Reply::Error(e),
        }
    }

    fn write(&mut self, node: u8, n: u16, v: f64) -> Reply {
        // Through node 15 a node-specific variable is written on every node, or on none.
        let targets: Vec<u8> = if node == AUX_NODE && mi::is_node_var(n) {
            self.setup.nodes.keys().copied().collect()
        } else {
            vec![node]
        };
        let mut next = self.setup.clone();
        let mut live = self.live;
        let mut changed = Changed::Nothing;
        for t in targets {
            match next.write(&mut live, t, n, v) {
                Ok(c) => changed = c,
                Err(e) => return Reply::Error(e),
            }
        }
        self.setup = next;
        self.live = live;
        match changed {
            Changed::Globals => self.check_params = Some(check_params(&self.setup)),
            Changed::Node(_) => self.reapply = true,
            Changed::Nothing => {}
        }
        Reply::Done
    }

    fn command(&mut self, c: StationCmd, node: u8, nodes: &mut [ServoNode]) -> Reply {
        match c {
            StationCmd::Reset | StationCmd::Reinit => {
                self.setup = match (c, self.state_file.as_deref().map(persist::load)) {
                    (StationCmd::Reset, Some(Loaded::Setup(s)))
                        if same_nodes(&s, &self.factory) =>
                    {
                        s
                    }
                    _ => self.factory.clone(),
                };
                self.live.errors = 0;
                self.window_errors = 0;
                self.check_params = Some(check_params(&self.setup));
                self.reapply = true;
                self.clear_faults();
                for s in nodes.iter_mut() {
                    s.clear_amp_fault();
                }
                Reply::Done
            }
            StationCmd::ClearFault => {
                self.clear_faults();
                for s in nodes
                    .iter_mut()
                    .filter(|s| node == AUX_NODE || s.node() == node)
                {
                    s.clear_amp_fault();
                }
                Reply::Done
            }
            // Answered by `execute` (a held reply); never reaches here.
            StationCmd::Save => Reply::Error(slave_error::BAD_REQUEST),
            StationCmd::Date => Reply::Value(mi::FIRMWARE_DATE, ValueFormat::Date),
            StationCmd::Version => Reply::Value(mi::FIRMWARE_VERSION, ValueFormat::Version),
            StationCmd::ConfigRead => self.read(node, 2),
        }
    }

    /// Fields for `mcc status --json` (`stations[i]`).
    pub fn status_extra(&self) -> Map<String, Value> {
        let g = &self.setup.globals;
        let mut m = Map::new();
        m.insert("ring_fault".into(), json!(self.faulted()));
        m.insert("suspected_break".into(), json!(self.suspected_break));
        m.insert(
            "mi".into(),
            json!({
                "status": self.live.status,
                "ring_errors": self.live.errors,
                "ring_errors_last_second": self.live.errors_last_second,
                "check_period": g.check_period,
                "error_shutdown_count": g.error_count,
                "sync_packets_required": g.sync_count,
                "max_errors_per_second": g.max_errors_per_second,
                "config_number": g.config_number,
                "firmware_version": format!("{:.3}", mi::FIRMWARE_VERSION),
                "config_error": self.config_error,
                "state_file": self.state_file.as_ref().map(|p| p.display().to_string()),
                "aux_requests": self.requests,
                "saving": self.save.busy(),
            }),
        );
        m
    }
}

fn same_nodes(a: &Setup, b: &Setup) -> bool {
    a.nodes.keys().eq(b.nodes.keys())
}

fn check_params(s: &Setup) -> CheckParams {
    let g = &s.globals;
    RingCheck::station_params(g.check_period, g.sync_count, g.error_count)
}

#[cfg(test)]
#[path = "station_mi_tests.rs"]
mod tests;
