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
//!    1 = 0, register 2 = amplifier output torque as a signed 16-bit fraction of
//!    `torque_full_scale` (a "current" reading), register 3 = status flags
//!    ([`crate::plant::flags`]).

use mcc_ring::packet::NodeRegs;

use crate::config::NodePlantConfig;
use crate::plant::amplifier::{AmpOutput, Amplifier};
use crate::plant::encoder::Encoder;
use crate::plant::flags::{CommandFlags, StatusFlags, Switches};
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
    user_flag: bool,
    ring_lockout: bool,
    ring_fault_flag: bool,
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
            user_flag: cfg.user_flag,
            ring_lockout: false,
            ring_fault_flag: false,
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
        let n = ((dt / self.cfg.max_substep).ceil() as u32).clamp(1, MAX_SUBSTEPS);
        let h = dt / f64::from(n);
        for _ in 0..n {
            match self.amp.output(self.motor.velocity()) {
                AmpOutput::Torque { drive, damping } => self.motor.advance(h, drive, damping),
                AmpOutput::Rate(cps) => {
                    self.motor.advance_kinematic(h, self.encoder.omega_for(cps))
                }
            }
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
        NodeRegs {
            r0: self.encoder.register0(self.motor.position()),
            r1: 0,
            r2: current as u16,
            r3: flags.to_reg3(self.cfg.fault_high_true),
        }
    }

    /// Status flags at the present state. The HOME bit carries the capture flag chosen by
    /// `capture_flag` (MI913), inverted for a falling-edge `capture_control` (MI912); a
    /// station ring fault reports FAULT on every node while it is latched.
    pub fn flags(&self) -> StatusFlags {
        let theta = self.motor.position();
        let sw = self.switches.at(self.encoder.counts(theta));
        let (cha, chb) = self.encoder.channels(theta);
        let capture = match self.cfg.capture_flag {
            1 => sw.plus_limit,
            2 => sw.minus_limit,
            3 => self.user_flag,
            _ => sw.home,
        };
        StatusFlags {
            cha,
            chb,
            amp_enabled: self.amp.active(),
            amp_fault: self.amp.faulted() || self.ring_fault_flag,
            home: capture != (self.cfg.capture_control & 8 != 0),
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

    /// Set the user flag input.
    pub fn set_user_flag(&mut self, on: bool) {
        self.user_flag = on;
    }

    /// Put the shaft at `counts` (at rest), e.g. to start a test near a switch.
    pub fn set_position(&mut self, counts: f64) {
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
