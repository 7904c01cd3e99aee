//! Packet routing of one ring member (architecture §3.2, spec §6.2-§6.4).
//!
//! Rules, for a packet (master m, node n) reaching a member whose master number is M:
//! - **Sync packet** (n = sync node and m = M, or n's master check disabled): latched (node
//!   registers if the address matches, broadcast copy always), reported as a sync, forwarded
//!   unchanged. Nobody but the synchronizing master modifies or removes it; the sync master
//!   removes its own sync packet when it comes back ("cycle complete").
//! - **Own packet back at a master** (m = M, n activated, member is a master): latched into
//!   the read registers and removed.
//! - **Slave node** (m = M, n activated, member is not a master): latched into the read
//!   registers and replaced by this member's write registers, then forwarded.
//! - **Match only because the master check is disabled** (n in 8-15, I995 bit 8+n-8 set,
//!   m ≠ M): latched into the read registers and forwarded unchanged.
//! - **Anything else** (node not activated or another master's packet): forwarded unchanged;
//!   a broadcast copy is kept per address ([`RingMember::latched_copy`]), and if m = M the
//!   read registers of n are updated too.
//!
//! Masters send one packet per activated node with their write registers. On node 15 (the
//! sync node and the Type 1 auxiliary channel, [`crate::aux_channel`]) registers 0-1 always
//! carry the ring cycle number and registers 2-3 the master's auxiliary word: the sync
//! master's node-15 packet is the sync packet; another master sends its own node-15 packet
//! each cycle while its channel is busy (node 15 activated, a non-idle word). With a sync source set ([`RingMember::set_sync_source`])
//! only the sync-node packet of that master number is a sync packet. A slave forwards node-15
//! packets of its master unchanged except for registers 2-3 while it has an auxiliary reply
//! armed ([`RingMember::set_aux_reply`]).

use crate::aux_channel::AUX_NODE;
use crate::packet::{NodeRegs, Packet};
use crate::settings::RingSettings;

/// Most packets the synchronizing master holds for the next cycle.
pub const MAX_HELD_PACKETS: usize = 256;

/// What routing one packet produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Routed {
    /// The packet to forward downstream (None = removed here).
    pub forward: Option<Packet>,
    /// A sync packet of another member was seen: its ring cycle.
    pub sync: Option<u64>,
    /// This member's own sync packet came back (synchronizing master): its ring cycle.
    pub own_sync_return: Option<u64>,
}

/// Node registers and routing state of one member.
#[derive(Clone, Debug)]
pub struct RingMember {
    settings: RingSettings,
    read: [NodeRegs; 16],
    write: [NodeRegs; 16],
    copies: Box<[[Option<NodeRegs>; 16]; 16]>,
    held: Vec<Packet>,
    sync_source: Option<u8>,
    aux_reply: Option<(u16, u16)>,
}

impl RingMember {
    /// A member with these I995/I996 settings; all registers zero.
    pub fn new(settings: RingSettings) -> Self {
        RingMember {
            settings,
            read: [NodeRegs::default(); 16],
            write: [NodeRegs::default(); 16],
            copies: Box::new([[None; 16]; 16]),
            held: Vec::new(),
            sync_source: None,
            aux_reply: None,
        }
    }

    /// Only sync-node packets of master `m` are sync packets (None: any packet whose address
    /// matches, as I995/I996 alone say). Set from the cluster config: other masters' node-15
    /// packets carry their auxiliary channel and must not clock the ring.
    pub fn set_sync_source(&mut self, m: Option<u8>) {
        self.sync_source = m.map(|m| m & 0x0F);
    }

    /// Slave: registers 2 and 3 to put into node-15 packets of this member's master as they
    /// pass (an auxiliary reply word), or None to forward them unchanged.
    pub fn set_aux_reply(&mut self, regs: Option<(u16, u16)>) {
        self.aux_reply = regs;
    }

    /// Current settings.
    pub fn settings(&self) -> RingSettings {
        self.settings
    }

    /// Change I995/I996 (takes effect on the next packet).
    pub fn set_settings(&mut self, settings: RingSettings) {
        self.settings = settings;
    }

    /// This member sends command packets (I995 bit 4 or bit 5).
    pub fn is_master(&self) -> bool {
        self.settings.is_master() || self.settings.is_sync_master()
    }

    /// Latched (read/feedback) registers of `node` (0-15; others read as zero).
    pub fn read_regs(&self, node: u8) -> NodeRegs {
        self.read
            .get(usize::from(node))
            .copied()
            .unwrap_or_default()
    }

    /// Write (command/feedback-out) registers of `node`, masked to 0-15.
    pub fn write_regs_mut(&mut self, node: u8) -> &mut NodeRegs {
        &mut self.write[usize::from(node & 0x0F)]
    }

    /// Write registers of `node` (0-15; others read as zero).
    pub fn write_regs(&self, node: u8) -> NodeRegs {
        self.write
            .get(usize::from(node))
            .copied()
            .unwrap_or_default()
    }

    /// The last packet seen with address (`master`, `node`), as received (broadcast copy).
    pub fn latched_copy(&self, master: u8, node: u8) -> Option<NodeRegs> {
        self.copies
            .get(usize::from(master))?
            .get(usize::from(node))
            .copied()
            .flatten()
    }

    /// Zero every write register (e.g. "MACRO output registers cleared on reset").
    pub fn clear_outputs(&mut self) {
        self.write = [NodeRegs::default(); 16];
    }

    /// Is `p` a sync packet for this member?
    pub fn is_sync(&self, p: &Packet) -> bool {
        let s = &self.settings;
        p.node == s.sync_node()
            && (p.master == s.master_number() || s.master_check_disabled(p.node))
            && self.sync_source.is_none_or(|m| p.master & 0x0F == m)
    }

    /// The sync packet this member emits as synchronizing master for `cycle`.
    /// Registers 2 and 3 carry this master's auxiliary word (write registers of node 15).
    pub fn sync_packet(&self, cycle: u64) -> Packet {
        let mut p = Packet::sync(
            self.settings.master_number(),
            self.settings.sync_node(),
            cycle,
        );
        let aux = self.write_regs(AUX_NODE);
        (p.regs.r2, p.regs.r3) = (aux.r2, aux.r3);
        p
    }

    /// One command packet per activated node (masters only). A sync master sends nothing else
    /// on its sync node (its sync packet carries the auxiliary word); another master's node-15
    /// packet carries `cycle` in registers 0-1 and its auxiliary word in registers 2-3.
    pub fn command_packets(&self, cycle: u64) -> Vec<Packet> {
        if !self.is_master() {
            return Vec::new();
        }
        let s = self.settings;
        s.active_nodes()
            .filter(|n| !(s.is_sync_master() && *n == s.sync_node()))
            // another master's node-15 packet exists while its auxiliary channel is busy
            .filter(|n| {
                *n != AUX_NODE || {
                    let w = self.write_regs(AUX_NODE);
                    (w.r2, w.r3) != (0, 0)
                }
            })
            .map(|n| {
                if n == AUX_NODE {
                    let mut p = Packet::sync(s.master_number(), n, cycle);
                    let aux = self.write_regs(n);
                    (p.regs.r2, p.regs.r3) = (aux.r2, aux.r3);
                    p
                } else {
                    Packet::new(s.master_number(), n, self.write_regs(n))
                }
            })
            .collect()
    }

    /// Route one valid packet.
    pub fn route(&mut self, mut p: Packet) -> Routed {
        let s = self.settings;
        let (m, n) = (p.master & 0x0F, p.node & 0x0F);
        let me = s.master_number();
        let addr_match = m == me || s.master_check_disabled(n);
        if let Some(slot) = self
            .copies
            .get_mut(usize::from(m))
            .and_then(|r| r.get_mut(usize::from(n)))
        {
            *slot = Some(p.regs);
        }
        if s.is_sync_master() && n == s.sync_node() && m == me {
            return Routed {
                forward: None,
                sync: None,
                own_sync_return: Some(p.sync_cycle()),
            };
        }
        if addr_match {
            self.read[usize::from(n)] = p.regs;
        }
        let aux_slave = n == AUX_NODE && m == me && !self.is_master();
        if let Some((r2, r3)) = self.aux_reply.filter(|_| aux_slave) {
            (p.regs.r2, p.regs.r3) = (r2, r3);
        }
        if self.is_sync(&p) {
            return Routed {
                forward: Some(p),
                sync: Some(p.sync_cycle()),
                own_sync_return: None,
            };
        }
        let forward = if aux_slave {
            Some(p)
        } else if s.node_active(n) && m == me {
            if self.is_master() {
                None
            } else {
                Some(Packet {
                    regs: self.write[usize::from(n)],
                    ..p
                })
            }
        } else {
            Some(p)
        };
        Routed {
            forward,
            sync: None,
            own_sync_return: None,
        }
    }

    /// Synchronizing master: keep packets of other masters for the next cycle's frame.
    /// Returns how many were dropped because the hold buffer was full.
    ///
    /// A node address has one slot per cycle, as on a MACRO ring: a later packet for an
    /// address already held replaces it in place (delayed frames released late bring old
    /// copies: passing both on would make the members downstream see more packets than a
    /// cycle holds, an overrun on a link that is whole).
    pub fn hold(&mut self, packets: impl IntoIterator<Item = Packet>) -> usize {
        let mut dropped = 0;
        for p in packets {
            if let Some(slot) = self.held.iter_mut().find(|h| h.address() == p.address()) {
                *slot = p;
            } else if self.held.len() < MAX_HELD_PACKETS {
                self.held.push(p);
            } else {
                dropped += 1;
            }
        }
        dropped
    }

    /// Take the held packets (in arrival order).
    pub fn take_held(&mut self) -> Vec<Packet> {
        std::mem::take(&mut self.held)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn regs(r0: u32) -> NodeRegs {
        NodeRegs {
            r0,
            r1: 1,
            r2: 2,
            r3: 3,
        }
    }

    #[test]
    fn master_sends_active_nodes_except_sync_node() {
        // sync master, master number 0, sync node 15, nodes 0, 1, 15 active
        let mut m = RingMember::new(RingSettings::new(0x30, 0x0F_8003));
        *m.write_regs_mut(1) = regs(11);
        let p = m.command_packets(5);
        assert_eq!(
            p,
            vec![
                Packet::new(0, 0, NodeRegs::default()),
                Packet::new(0, 1, regs(11))
            ]
        );
        assert_eq!(m.sync_packet(5), Packet::sync(0, 15, 5));
        // a slave sends nothing of its own
        assert!(RingMember::new(RingSettings::new(0x80, 0x0F_0003))
            .command_packets(5)
            .is_empty());
    }

    #[test]
    fn slave_latches_and_substitutes() {
        let mut s = RingMember::new(RingSettings::new(0x80, 0x0F_0002)); // node 1 of master 0
        *s.write_regs_mut(1) = regs(77);
        let r = s.route(Packet::new(0, 1, regs(5)));
        assert_eq!(r.forward, Some(Packet::new(0, 1, regs(77))));
        assert_eq!(s.read_regs(1), regs(5));
        // master 1's node 1 is not ours: unchanged, copy kept, read registers untouched
        let r = s.route(Packet::new(1, 1, regs(9)));
        assert_eq!(r.forward, Some(Packet::new(1, 1, regs(9))));
        assert_eq!(s.read_regs(1), regs(5));
        assert_eq!(s.latched_copy(1, 1), Some(regs(9)));
        // not activated node 4 of our master: unchanged, latched
        let r = s.route(Packet::new(0, 4, regs(4)));
        assert_eq!(r.forward, Some(Packet::new(0, 4, regs(4))));
        assert_eq!(s.read_regs(4), regs(4));
    }

    #[test]
    fn master_latches_and_removes_own() {
        let mut m = RingMember::new(RingSettings::new(0x90, 0x2F_0001)); // master 2, node 0
        let r = m.route(Packet::new(2, 0, regs(8)));
        assert_eq!(r, Routed::default());
        assert_eq!(m.read_regs(0), regs(8));
        // another master's packet for node 0 passes
        assert_eq!(
            m.route(Packet::new(0, 0, regs(1))).forward,
            Some(Packet::new(0, 0, regs(1)))
        );
        assert_eq!(m.read_regs(0), regs(8));
    }

    #[test]
    fn master_check_disabled_latches_and_forwards_unchanged() {
        // master 1 with check disabled on node 9 (bit 9) and node 9 active
        let mut m = RingMember::new(RingSettings::new(0x0290, 0x1F_0200));
        let r = m.route(Packet::new(3, 9, regs(6)));
        assert_eq!(r.forward, Some(Packet::new(3, 9, regs(6))));
        assert_eq!(m.read_regs(9), regs(6));
        // node 10 has the check enabled: no latch into the registers
        let mut m = RingMember::new(RingSettings::new(0x0290, 0x1F_0400));
        m.route(Packet::new(3, 10, regs(6)));
        assert_eq!(m.read_regs(10), NodeRegs::default());
    }

    #[test]
    fn sync_packet_is_never_modified_by_others() {
        // a slave with node 15 active and master 0: sync packet is latched, not substituted
        let mut s = RingMember::new(RingSettings::new(0x80, 0x0F_8000));
        *s.write_regs_mut(15) = regs(99);
        let sp = Packet::sync(0, 15, 1234);
        let r = s.route(sp);
        assert_eq!(
            r,
            Routed {
                forward: Some(sp),
                sync: Some(1234),
                own_sync_return: None
            }
        );
        assert_eq!(s.read_regs(15), sp.regs);
        // another master (number 1) needs the check disabled on node 15 to see master 0's sync
        let mut m1 = RingMember::new(RingSettings::new(0x90, 0x1F_0000));
        assert_eq!(m1.route(sp).sync, None);
        let mut m1 = RingMember::new(RingSettings::new(0x8090, 0x1F_0000));
        assert_eq!(m1.route(sp).sync, Some(1234));
        // the sync master removes its own sync packet: cycle complete
        let mut sm = RingMember::new(RingSettings::new(0x30, 0x0F_0000));
        assert_eq!(
            sm.route(sp),
            Routed {
                forward: None,
                sync: None,
                own_sync_return: Some(1234)
            }
        );
    }

    #[test]
    fn hold_is_bounded() {
        let mut sm = RingMember::new(RingSettings::new(0x30, 0x0F_0000));
        // More packets than there are addresses: one slot per address, never more.
        let many: Vec<Packet> = (0..MAX_HELD_PACKETS + 3)
            .map(|i| Packet::new((i / 16) as u8, (i % 16) as u8, regs(i as u32)))
            .collect();
        assert_eq!(sm.hold(many), 0);
        let held = sm.take_held();
        assert_eq!(held.len(), MAX_HELD_PACKETS);
        assert_eq!(held[0].regs.r0, 256, "address $00 holds its latest copy");
        assert!(sm.take_held().is_empty());
    }

    /// One slot per node address and cycle: a late copy (a delayed frame released) replaces
    /// the held packet of its address in place, it is not passed on beside it.
    #[test]
    fn hold_keeps_one_packet_per_address_the_latest() {
        let mut sm = RingMember::new(RingSettings::new(0x30, 0x0F_0000));
        let a = |node, r0| Packet::new(1, node, regs(r0));
        assert_eq!(sm.hold([a(0, 10), a(1, 11)]), 0);
        assert_eq!(sm.hold([a(0, 20), a(2, 22)]), 0);
        assert_eq!(sm.take_held(), vec![a(0, 20), a(1, 11), a(2, 22)]);
    }
}
