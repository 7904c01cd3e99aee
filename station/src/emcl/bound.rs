//! A drive bound to a MACRO servo node (issue 12 item 5): the station's node carries a
//! card motor's output as a pulse-frequency command in register 2 (signed 16-bit fraction of
//! `pulse_full_scale`, the amplifier enable in register 3 bit 6), the way a stepper
//! amplifier sits behind a MACRO station in step/direction mode. The drive integrates the
//! pulses in ring time exactly (integer pps·ns with the remainder carried) and answers with
//! its shaft position in register 0 (1/32 µstep, 24-bit, like the station's servo nodes) and
//! the Type 1 flags in register 3 (home, limits, amplifier enabled, fault low-true).
//!
//! Binding needs the config's `node` and AP 254 ≠ 0 (Step/Dir mode, the factory value of a
//! bound drive); SAP 254,0,0 hands the motor back to direct mode. While bound, ROR, ROL, MST,
//! MVP, RFS start/stop and SAP 0/2 are refused with status 6 (instruction not available);
//! parameter reads and everything else work. A ring fault drops the enable in the same tick
//! and keeps it off until the card has sent AENA = 0 once (as the servo nodes do).

use mcc_ring::packet::NodeRegs;

use crate::plant::flags::{StatusFlags, CMD_AMP_ENABLE};

use super::drive::Drive;

/// Bound-mode state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoundState {
    /// Commanded pulse rate, pps (0 while disabled).
    pub velocity: i64,
    /// Carried pps·ns below one µstep.
    acc: i128,
    /// The card's enable is on and the drive follows.
    pub enabled: bool,
    /// Locked out after a ring fault until AENA is seen low.
    pub lockout: bool,
}

impl Drive {
    /// The node this drive is bound to in the config.
    pub fn node(&self) -> Option<u8> {
        self.node
    }

    /// One station tick of `dt_ns` with the command registers latched this cycle; the
    /// feedback registers to send. Call only while [`Drive::is_bound`].
    pub fn bound_tick(&mut self, cmd: NodeRegs, dt_ns: u64, ring_fault: bool) -> NodeRegs {
        let aena = cmd.r3 & CMD_AMP_ENABLE != 0;
        let b = &mut self.bound;
        if ring_fault {
            b.lockout = true;
        } else if b.lockout && !aena {
            b.lockout = false;
        }
        let enabled =
            aena && !self.bound.lockout && !ring_fault && self.driver_on() && !self.pos_error;
        let v = if enabled {
            i64::from(cmd.r2 as i16) * self.spec.pulse_full_scale / 32768
        } else {
            0
        };
        let b = &mut self.bound;
        b.enabled = enabled;
        b.velocity = v;
        if !enabled {
            b.acc = 0;
        }
        b.acc += i128::from(v) * i128::from(dt_ns.min(10_000_000_000));
        let steps = b.acc.div_euclid(1_000_000_000);
        b.acc -= steps * 1_000_000_000;
        let steps = steps as i64;
        if steps != 0 {
            self.motion
                .set_position(self.motion.pos.wrapping_add(steps as i32));
            self.motion.target_pos = self.motion.pos;
        }
        self.move_shaft(steps);
        self.bound_feedback()
    }

    /// Register image the node reports.
    pub fn bound_feedback(&self) -> NodeRegs {
        let s = self.plant.shaft;
        let q = s.rem_euclid(4);
        let flags = StatusFlags {
            cha: q == 1 || q == 2,
            chb: q >= 2,
            amp_enabled: self.bound.enabled,
            amp_fault: self.pos_error || self.driver_faults != 0,
            home: self.home_active(),
            plus_limit: self.right_limit_active(),
            minus_limit: self.left_limit_active(),
            user: false,
        };
        NodeRegs {
            r0: ((s << 5) as u32) & 0xFF_FFFF,
            r1: 0,
            r2: 0,
            r3: flags.to_reg3(false),
        }
    }
}
