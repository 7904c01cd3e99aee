//! Auxiliary register copying (pmac-variables §6.7), once per background cycle: for every node
//! n with I1000 bit n set, the node's auxiliary read register is copied into X:$0F7n (status
//! flags the motors read through Ix25) and Y:$0F7n is copied into the node's auxiliary write
//! register (command flags such as amplifier enable). I1002 bit n selects the register: 1 =
//! Type 1, register 3 (16 bits in bits 8-23); 0 = Type 0, register 0 (24 bits).
//!
//! Because the copy runs after the motors in the cycle, flags reach the motors one cycle after
//! they were latched from the ring and an enable written by a motor goes out in the same
//! cycle's packet: flags are at least one cycle late, as on the real card.

use crate::model::CardState;
use crate::model::Space;

/// Copy the auxiliary registers of every enabled node. Returns the number of nodes copied.
pub(super) fn aux_copy(st: &mut CardState) -> usize {
    let rv = st.ring_ivars();
    let enabled = st.peek_ivar(rv.aux_enable).unwrap_or(0.0).max(0.0) as u32 & 0xFFFF;
    if enabled == 0 {
        return 0;
    }
    let type1 = st.peek_ivar(rv.protocol).unwrap_or(0.0).max(0.0) as u32 & 0xFFFF;
    let map = *st.map();
    let mut n = 0;
    for node in 0..16usize {
        if enabled & (1 << node) == 0 {
            continue;
        }
        let reg = if type1 & (1 << node) != 0 { 3 } else { 0 };
        let (space, addr) = map.node_addr(node, reg);
        let image = map.aux_image(node);
        let status = st.memory.read(space, addr);
        st.memory.write(Space::X, image, status);
        let command = st.memory.read(Space::Y, image);
        st.memory.write(space, addr, command);
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;

    #[test]
    fn type1_and_type0_copies() {
        let mut st = CardState::new(Profile::Pmac2);
        st.set_ivar(1000, 0x0011 as f64).unwrap();
        st.set_ivar(1002, 0x0001 as f64).unwrap();
        st.set_node_feedback(0, [0x11_1111, 0, 0, 0x00_8000 | 0x01_0000]);
        st.set_node_feedback(4, [0x12_3456, 0, 0, 0xFF_FF00]);
        st.set_node_feedback(1, [0, 0, 0, 0xAB_CD00]);
        st.memory.write(Space::Y, 0x0F70, 0x00_4000);
        st.memory.write(Space::Y, 0x0F74, 0x65_4321);
        st.memory.write(Space::Y, 0x0F71, 0x00_4000);
        assert_eq!(aux_copy(&mut st), 2);
        assert_eq!(st.aux_images(0), (0x01_8000, 0x00_4000));
        assert_eq!(st.node_command(0)[3], 0x00_4000);
        // Type 0: register 0, 24 bits.
        assert_eq!(st.aux_images(4).0, 0x12_3456);
        assert_eq!(st.node_command(4)[0], 0x65_4321);
        // Node 1 not enabled: untouched.
        assert_eq!(st.aux_images(1).0, 0);
        assert_eq!(st.node_command(1)[3], 0);
    }
}
