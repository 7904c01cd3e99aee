//! The echo station: every activated servo node returns, as feedback, what its master
//! commanded (register 0 → register 0, register 2 → register 2) plus a status word in register
//! 3 and a per-node update counter in register 1, so a master can see its commands make the
//! round trip. On a ring fault the station zeroes every output in the same cycle.

use mcc_ring::core::RingApp;
use mcc_ring::member::RingMember;
use mcc_ring::packet::NodeRegs;

/// Register-3 bit set while the station is healthy (no ring fault): "station OK".
pub const FLAG_STATION_OK: u16 = 1 << 0;

/// A station that echoes its nodes' commands.
#[derive(Debug, Clone)]
pub struct EchoStation {
    nodes: Vec<u8>,
    ticks: u64,
}

impl EchoStation {
    /// An echo station serving `nodes` (node numbers ≥ 16 are ignored).
    pub fn new(nodes: &[u8]) -> Self {
        EchoStation {
            nodes: nodes.iter().copied().filter(|&n| n < 16).collect(),
            ticks: 0,
        }
    }

    /// Servo ticks run so far.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }
}

impl RingApp for EchoStation {
    fn tick(&mut self, _cycle: u64, _time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        self.ticks += 1;
        for &n in &self.nodes {
            let cmd = regs.read_regs(n);
            let out = regs.write_regs_mut(n);
            *out = if ring_fault {
                NodeRegs::default()
            } else {
                NodeRegs {
                    r0: cmd.r0 & 0xFF_FFFF,
                    r1: (self.ticks & 0xFFFF) as u16,
                    r2: cmd.r2,
                    r3: FLAG_STATION_OK,
                }
            };
        }
    }
}
