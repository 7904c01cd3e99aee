//! One servo node of a station: amplifier + motor + quadrature encoder + switches, meeting the
//! card only through the node's four registers.
//!
//! Per station tick (ring time `t_k`), in this order:
//! 1. [`ServoNode::advance`]: the plant integrates over `[t_{k−1}, t_k]` with the amplifier
//!    output latched at the previous tick (zero-order hold), in sub-steps of at most
//!    `max_substep` (the motor model is exact per sub-step; sub-steps only matter for the
//!    velocity-mode torque clip and pulse mode).
//! 2. [`ServoNode::apply_command`]: the command registers latched this cycle take effect:
//!    register 3 bit 6 (AENA) enables the amplifier, register 0 (24-bit, DAC << 8) or register
//!    2 (pulse mode) sets the command. On a ring fault the amplifier is shut down instead (zero
//!    command, enable dropped) in this same tick, and it stays off after the ring recovers
//!    until the card has been seen sending AENA = 0 (no motion restarts by itself).
//! 3. [`ServoNode::feedback`]: register 0 = position in 1/32 count (24-bit rollover), register
//!    1 = the encoder count latched at the last capture-flag edge (low 16 bits; register 3 bit
//!    12 says one was latched: the hardware position capture, exact to the count at the switch
//!    edge crossed within the sub-step), register 2 = amplifier output torque as a signed 16-bit fraction of
//!    `torque_full_scale` (a "current" reading), register 3 = status flags
//!    ([`crate::plant::flags`]).
//!
//! Injected axis faults ([`crate::faults`]) are set before step 1 ([`ServoNode::set_faults`]):
//! a jam holds the shaft, a load adds its torque in step 1, an amplifier fault asserts FAULT
//! and latches the amplifier off in steps 1 and 2, an encoder loss freezes register 0 and the
//! A/B levels, a glitch offsets register 0 and the capture, a switch fault forces the flag
//! (and the capture flag it feeds: a forced rise latches a capture at the present count).

use mcc_ring::packet::NodeRegs;

use crate::config::NodePlantConfig;
use crate::faults::NodeFaults;
use crate::plant::amplifier::{AmpOutput, Amplifier};
use crate::plant::encoder::{wrap24, Encoder};
use crate::plant::flags::{CommandFlags, StatusFlags, Switch, SwitchStates, Switches, ST_CAPTURED};
use crate::plant::motor::Motor;

/// Most sub-steps in one tick (a long gap in realtime mode is integrated in coarser steps).
pub const MAX_SUBSTEPS: u32 = 10_000;
/// Longest interval one tick integrates, seconds (a longer gap is cut to this).
pub const MAX_TICK_SECONDS: f64 = 10.0;

/// A snapshot of a servo node for status reports and tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeSnapshot {
    /// Actual position, counts (continuous, not wrapped).
    pub position: f64,
    /// Actual velocity, counts/s.
    pub velocity: f64,
    /// Amplifier output torque, N·m.
    pub torque: f64,
    /// Status flags as reported.
    pub flags: StatusFlags,
    /// Locked out after a ring fault until AENA is seen low.
    pub ring_lockout: bool,
}

/// A simulated servo node.
#[derive(Clone, Debug)]
pub struct ServoNode {
    node: u8,
    cfg: NodePlantConfig,
    amp: Amplifier,
    motor: Motor,
    encoder: Encoder,
    switches: Switches,
    /// The switches' states, carried along the shaft's path (they have hysteresis).
    switch_states: SwitchStates,
    user_flag: bool,
    ring_lockout: bool,
    ring_fault_flag: bool,
    /// Encoder count latched at the last capture-flag edge (hardware capture).
    captured: Option<i64>,
    /// Injected faults of this tick.
    faults: NodeFaults,
    /// Register 0 and the A/B levels at the moment the encoder was lost.
    frozen: Option<(u32, (bool, bool))>,
    /// Where a jam holds the shaft, counts.
    jam_at: Option<f64>,
}

impl ServoNode {
    /// A node at rest at position 0, amplifier disabled. `cfg` should be validated.
    pub fn new(node: u8, cfg: &NodePlantConfig) -> Self {
        ServoNode {
            node,
            amp: Amplifier::new(cfg.amp()),
            motor: Motor::new(cfg.motor()),
            encoder: Encoder::new(cfg.encoder()),
            switches: cfg.switches(),
            switch_states: cfg.switches().at(0.0),
            user_flag: cfg.user_flag,
            ring_lockout: false,
            ring_fault_flag: false,
            captured: None,
            faults: NodeFaults::default(),
            frozen: None,
            jam_at: None,
            cfg: cfg.clone(),
        }
    }

    /// Node number.
    pub fn node(&self) -> u8 {
        self.node
    }

    /// Integrate the plant over `dt` seconds of ring time.
    pub fn advance(&mut self, dt: f64) {
        // (also rejects NaN)
        if dt.is_nan() || dt <= 0.0 {
            return;
        }
        let dt = dt.min(MAX_TICK_SECONDS);
        if let Some(at) = self.jam_at {
            self.put_shaft(at);
            return;
        }
        let load = self.faults.load;
        let n = ((dt / self.cfg.max_substep).ceil() as u32).clamp(1, MAX_SUBSTEPS);
        let h = dt / f64::from(n);
        let mut pos = self.counts();
        let mut level = self.capture_level();
        for _ in 0..n {
            let (stop_torque, stop_damping) = self.stop_contact(pos);
            match self.amp.output(self.motor.velocity()) {
                AmpOutput::Torque { drive, damping } => {
                    self.motor
                        .advance(h, drive + stop_torque + load, damping + stop_damping)
                }
                AmpOutput::Rate(cps) => {
                    self.motor.advance_kinematic(h, self.encoder.omega_for(cps));
                    self.clamp_to_stops();
                }
            }
            let now = self.counts();
            let before = self.switch_states;
            self.switch_states = self.switches.step(before, now);
            let l = self.capture_level();
            if l && !level {
                self.latch_edge(before, pos, now);
            }
            (pos, level) = (now, l);
        }
    }

    fn counts(&self) -> f64 {
        self.encoder.counts(self.motor.position())
    }

    /// Apply this tick's injected faults (before [`ServoNode::advance`]).
    pub fn set_faults(&mut self, f: NodeFaults) {
        let before = self.capture_level();
        if f.encoder_frozen && self.frozen.is_none() {
            let theta = self.motor.position();
            self.frozen = Some((self.register0(), self.encoder.channels(theta)));
        }
        if !f.encoder_frozen {
            self.frozen = None;
        }
        self.jam_at = match (f.jam, self.jam_at) {
            (true, None) => Some(self.counts()),
            (true, at) => at,
            (false, _) => None,
        };
        self.faults = f;
        if f.amp_fault {
            self.amp.inject_fault();
        }
        if self.capture_level() && !before {
            self.captured = Some(self.reported_counts().floor() as i64);
        }
    }

    /// The injected faults in effect.
    pub fn faults(&self) -> NodeFaults {
        self.faults
    }

    /// The position the encoder reports, counts (the glitch offset included).
    fn reported_counts(&self) -> f64 {
        self.counts() + self.faults.count_offset
    }

    /// Register 0 at the present state (frozen by an encoder loss, offset by a glitch).
    fn register0(&self) -> u32 {
        if let Some((r0, _)) = self.frozen {
            return r0;
        }
        let off = (self.faults.count_offset * 32.0).round() as i64;
        wrap24(
            self.encoder
                .position_32nds(self.motor.position())
                .saturating_add(off),
        )
    }

    /// The switch states as the node reports them (forced by switch faults).
    fn seen_switches(&self) -> SwitchStates {
        let f = &self.faults;
        let s = self.switch_states;
        SwitchStates {
            home: f.home.unwrap_or(s.home),
            plus_limit: f.plus_limit.unwrap_or(s.plus_limit),
            minus_limit: f.minus_limit.unwrap_or(s.minus_limit),
        }
    }

    /// The position switch the capture flag (MI913) selects (None: the user flag).
    fn capture_switch(&self) -> Option<Switch> {
        match self.cfg.capture_flag {
            1 => Some(Switch::PlusLimit),
            2 => Some(Switch::MinusLimit),
            3 => None,
            _ => Some(Switch::Home),
        }
    }

    /// The capture flag (MI913) with the MI912 edge applied, at the present switch states.
    fn capture_level(&self) -> bool {
        let flag = match self.capture_switch() {
            Some(s) => self.seen_switches().get(s),
            None => self.user_flag,
        };
        flag != (self.cfg.capture_control & 8 != 0)
    }

    /// The capture flag became true on the sub-step from `from` (switch states `before`) to
    /// `to`: latch the encoder count at the switch edge crossed (exact, as the hardware
    /// capture of the count at the flag change).
    fn latch_edge(&mut self, before: SwitchStates, from: f64, to: f64) {
        let dir = if to >= from { 1.0 } else { -1.0 };
        let edge = self.capture_switch().and_then(|s| {
            let on = self.switch_states.get(s);
            (on != before.get(s))
                .then(|| self.switches.edge(s, on, from, to))
                .flatten()
                .map(|e| (e, on))
        });
        let at = match edge {
            // The first position past the edge (in the direction of travel) where the flag
            // is in its new state: the operate point itself (the region is inclusive), just
            // past the release point.
            Some((e, true)) => e,
            Some((e, false)) => e + dir * 1e-6,
            None => to,
        };
        self.captured = Some((at + self.faults.count_offset).floor() as i64);
    }

    /// End-stop contact: (torque N·m, damping N·m·s/rad) at position `counts`.
    fn stop_contact(&self, counts: f64) -> (f64, f64) {
        if !self.cfg.hard_stops {
            return (0.0, 0.0);
        }
        let pen = if counts > self.cfg.plus_stop {
            counts - self.cfg.plus_stop
        } else if counts < self.cfg.minus_stop {
            counts - self.cfg.minus_stop
        } else {
            return (0.0, 0.0);
        };
        let per_rad = self.cfg.counts_per_rev / std::f64::consts::TAU;
        let k = self.cfg.stop_stiffness * per_rad;
        let c = 2.0 * (k * self.cfg.inertia).sqrt();
        (-self.cfg.stop_stiffness * pen, c)
    }

    /// A step drive cannot push through an end stop: it stalls there.
    fn clamp_to_stops(&mut self) {
        if !self.cfg.hard_stops {
            return;
        }
        let c = self.counts();
        let lim = c.clamp(self.cfg.minus_stop, self.cfg.plus_stop);
        if lim != c {
            self.put_shaft(lim);
        }
    }

    /// Take the command registers latched this cycle; `ring_fault` shuts the amplifier down.
    pub fn apply_command(&mut self, cmd: NodeRegs, ring_fault: bool) {
        let enable = CommandFlags::from_reg3(cmd.r3).amp_enable;
        if ring_fault {
            self.ring_lockout = true;
            self.amp.shut_down();
            return;
        }
        if self.ring_lockout {
            if enable {
                self.amp.shut_down();
                return;
            }
            self.ring_lockout = false;
        }
        self.amp.update(enable, cmd.r0, cmd.r2);
        if self.faults.amp_fault {
            self.amp.inject_fault();
        }
    }

    /// The feedback registers for this cycle.
    pub fn feedback(&self) -> NodeRegs {
        let flags = self.flags();
        let torque = self.amp.torque(self.motor.velocity());
        let current = if self.cfg.torque_full_scale > 0.0 {
            (torque / self.cfg.torque_full_scale * 32768.0)
                .round()
                .clamp(-32768.0, 32767.0) as i16
        } else {
            0
        };
        let (r1, captured) = match self.captured {
            Some(c) => ((c & 0xFFFF) as u16, ST_CAPTURED),
            None => (0, 0),
        };
        NodeRegs {
            r0: self.register0(),
            r1,
            r2: current as u16,
            r3: flags.to_reg3(self.cfg.fault_high_true) | captured,
        }
    }

    /// Status flags at the present state. The HOME bit carries the capture flag chosen by
    /// `capture_flag` (MI913), inverted for a falling-edge `capture_control` (MI912); a
    /// station ring fault reports FAULT on every node while it is latched.
    pub fn flags(&self) -> StatusFlags {
        let theta = self.motor.position();
        let sw = self.seen_switches();
        let (cha, chb) = match self.frozen {
            Some((_, ab)) => ab,
            None => self.encoder.channels(theta),
        };
        StatusFlags {
            cha,
            chb,
            amp_enabled: self.amp.active(),
            amp_fault: self.amp.faulted() || self.ring_fault_flag || self.faults.amp_fault,
            home: self.capture_level(),
            plus_limit: sw.plus_limit,
            minus_limit: sw.minus_limit,
            user: self.user_flag,
        }
    }

    /// The node's parameters.
    pub fn config(&self) -> &NodePlantConfig {
        &self.cfg
    }

    /// Apply new (validated) parameters at run time, keeping the shaft's position and speed
    /// and the amplifier's enable and fault state.
    pub fn reconfigure(&mut self, cfg: &NodePlantConfig) {
        self.amp.set_params(cfg.amp());
        self.motor.set_params(cfg.motor());
        self.encoder = Encoder::new(cfg.encoder());
        self.switches = cfg.switches();
        self.switch_states = self.switches.step(self.switch_states, self.counts());
        if cfg.user_flag != self.cfg.user_flag {
            self.user_flag = cfg.user_flag;
        }
        self.cfg = cfg.clone();
    }

    /// Report the station's latched ring fault in the FAULT flag.
    pub fn set_ring_fault_flag(&mut self, on: bool) {
        self.ring_fault_flag = on;
    }

    /// Inject an amplifier fault (latched; ignored while the amplifier is disabled).
    pub fn inject_amp_fault(&mut self) {
        self.amp.inject_fault();
    }

    /// CLRF-like reset of the amplifier fault latch.
    pub fn clear_amp_fault(&mut self) {
        self.amp.clear_fault();
    }

    /// Set the user flag input (a capture edge when MI913 selects it).
    pub fn set_user_flag(&mut self, on: bool) {
        let c = self.counts();
        let before = self.capture_level();
        self.user_flag = on;
        if self.capture_level() && !before {
            self.captured = Some(c.floor() as i64);
        }
    }

    /// Put the shaft at `counts` (at rest), e.g. to start a test near a switch; the switches
    /// read as if it had come there from outside them.
    pub fn set_position(&mut self, counts: f64) {
        self.put_shaft(counts);
        self.switch_states = self.switches.at(counts);
    }

    /// The shaft at `counts`, at rest (the switches follow on the next sub-step).
    fn put_shaft(&mut self, counts: f64) {
        let theta = counts / self.cfg.counts_per_rev * std::f64::consts::TAU;
        self.motor.set_state(theta, 0.0);
    }

    /// Amplifier (read-only).
    pub fn amplifier(&self) -> &Amplifier {
        &self.amp
    }

    /// Present state.
    pub fn snapshot(&self) -> NodeSnapshot {
        NodeSnapshot {
            position: self.encoder.counts(self.motor.position()),
            velocity: self.encoder.counts_per_s(self.motor.velocity()),
            torque: self.amp.torque(self.motor.velocity()),
            flags: self.flags(),
            ring_lockout: self.ring_lockout,
        }
    }
}

#[cfg(test)]
#[path = "servo_node_tests.rs"]
mod tests;
