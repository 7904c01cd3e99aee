//! I995/I996-style ring settings of one member (spec §6.2, §6.3).

use serde::{Deserialize, Serialize};

/// Default servo/ring rate of a PMAC2 Ultralite (I992=6527, I997=0, I998=3): 2.2587 kHz.
pub const DEFAULT_RATE_HZ: f64 = 2258.7;

/// Nominal cycle period in ns for `rate_hz` (rounded; at least 1 ns).
pub fn period_ns(rate_hz: f64) -> u64 {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return period_ns(DEFAULT_RATE_HZ);
    }
    ((1e9 / rate_hz).round() as u64).max(1)
}

/// I995 bit 4: master station enable.
pub const I995_MASTER: u32 = 0x10;
/// I995 bit 5: synchronizing master station enable.
pub const I995_SYNC_MASTER: u32 = 0x20;
/// I995 bit 7: sync node phase-lock enable.
pub const I995_PHASE_LOCK: u32 = 0x80;

/// The configuration part of I995 and I996 of one member.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RingSettings {
    /// I995: ring configuration (status bits 0-3 and 6 are ignored here; they live in
    /// [`crate::status::RingStatus`]).
    pub i995: u32,
    /// I996: node activation (bits 0-15), sync node (16-19), master number (20-23).
    pub i996: u32,
}

impl RingSettings {
    /// Settings from raw I995 and I996 values.
    pub fn new(i995: u32, i996: u32) -> Self {
        RingSettings { i995, i996 }
    }

    /// Bit 4: master station.
    pub fn is_master(&self) -> bool {
        self.i995 & I995_MASTER != 0
    }

    /// Bit 5: synchronizing master (it is also a master whatever bit 4 says).
    pub fn is_sync_master(&self) -> bool {
        self.i995 & I995_SYNC_MASTER != 0
    }

    /// Bit 7: phase-lock to the sync packet.
    pub fn phase_lock(&self) -> bool {
        self.i995 & I995_PHASE_LOCK != 0
    }

    /// Bits 8-15: master-address check disabled for `node` (only nodes 8-15 can have it).
    pub fn master_check_disabled(&self, node: u8) -> bool {
        (8..16).contains(&node) && self.i995 & (1 << (u32::from(node))) != 0
    }

    /// I996 bit `node`: node activated.
    pub fn node_active(&self, node: u8) -> bool {
        node < 16 && self.i996 & (1 << u32::from(node)) != 0
    }

    /// I996 bits 16-19: the sync node.
    pub fn sync_node(&self) -> u8 {
        ((self.i996 >> 16) & 0xF) as u8
    }

    /// I996 bits 20-23: this member's master number.
    pub fn master_number(&self) -> u8 {
        ((self.i996 >> 20) & 0xF) as u8
    }

    /// Activated nodes in ascending order.
    pub fn active_nodes(&self) -> impl Iterator<Item = u8> + '_ {
        (0u8..16).filter(move |n| self.node_active(*n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sync_master_defaults() {
        // Ring master $30 with check disabled on node 15; I996 = master 1, sync node 15,
        // nodes 0, 1, 4 and 15 active.
        let s = RingSettings::new(0x8030, 0x1F_8013);
        assert!(s.is_master() && s.is_sync_master() && !s.phase_lock());
        assert!(s.master_check_disabled(15));
        assert!(!s.master_check_disabled(14) && !s.master_check_disabled(7));
        assert_eq!(s.active_nodes().collect::<Vec<_>>(), vec![0, 1, 4, 15]);
        assert_eq!(s.sync_node(), 15);
        assert_eq!(s.master_number(), 1);
        assert!(!s.node_active(16));
    }

    #[test]
    fn other_master_and_slave() {
        let m = RingSettings::new(0x90, 0x2F_0000);
        assert!(m.is_master() && !m.is_sync_master() && m.phase_lock());
        assert_eq!(m.master_number(), 2);
        let slave = RingSettings::new(0x80, 0);
        assert!(!slave.is_master() && slave.phase_lock());
        // bits 0-7 never disable a master check
        assert!(!RingSettings::new(0xFF, 0).master_check_disabled(3));
    }

    #[test]
    fn period() {
        assert_eq!(period_ns(DEFAULT_RATE_HZ), 442_733);
        assert_eq!(period_ns(1000.0), 1_000_000);
        assert_eq!(period_ns(-1.0), 442_733);
        assert_eq!(period_ns(f64::NAN), 442_733);
    }
}
