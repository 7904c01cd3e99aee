//! The 12-byte MACRO-shaped packet (architecture §3.1, spec §6.5).
//!
//! Layout (big-endian registers):
//!
//! | byte | content |
//! | --- | --- |
//! | 0 | header: [`HEADER`] (the only valid packet code) |
//! | 1 | address: master number << 4 \| node number |
//! | 2-4 | register 0 (24 bits) |
//! | 5-6, 7-8, 9-10 | registers 1, 2, 3 (16 bits each) |
//! | 11 | check byte: CRC-8/SMBUS (poly 0x07, init 0, no reflection) over bytes 0-10 |
//!
//! The sync packet is an ordinary packet addressed to the sync node; its registers carry the
//! 40-bit ring cycle number: register 0 = low 24 bits, register 1 = high 16 bits.

use serde::{Deserialize, Serialize};

/// Bytes in one packet.
pub const PACKET_LEN: usize = 12;

/// The valid packet code of byte 0. Any other value is a byte violation.
pub const HEADER: u8 = 0xA5;

/// Mask of the 40-bit ring cycle number carried by the sync packet.
pub const CYCLE_MASK: u64 = (1 << 40) - 1;

const CRC8: crc::Crc<u8> = crc::Crc::<u8>::new(&crc::CRC_8_SMBUS);

/// One node's registers: register 0 is 24 bits wide, registers 1-3 are 16 bits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NodeRegs {
    /// Register 0 (24 bits; the upper 8 bits are ignored on encode).
    pub r0: u32,
    /// Register 1 (16 bits).
    pub r1: u16,
    /// Register 2 (16 bits).
    pub r2: u16,
    /// Register 3 (16 bits; Type 1 flags).
    pub r3: u16,
}

/// A decoded packet: address plus registers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Packet {
    /// Master number (0-15; upper bits ignored on encode).
    pub master: u8,
    /// Node number (0-15; upper bits ignored on encode).
    pub node: u8,
    /// The four registers.
    pub regs: NodeRegs,
}

/// Why a packet could not be decoded (the receive error classes of one packet).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    /// Fewer than [`PACKET_LEN`] bytes.
    #[error("packet underrun: {0} of 12 bytes")]
    Truncated(usize),
    /// Header byte is not a valid packet code.
    #[error("byte violation: header byte ${0:02X}")]
    ByteViolation(u8),
    /// Check byte mismatch.
    #[error("packet checksum error: check byte ${got:02X}, computed ${want:02X}")]
    Checksum {
        /// Check byte received.
        got: u8,
        /// Check byte computed over the 11 bytes before it.
        want: u8,
    },
}

/// CRC-8/SMBUS of `bytes` (the check byte algorithm).
pub fn check_byte(bytes: &[u8]) -> u8 {
    CRC8.checksum(bytes)
}

impl Packet {
    /// A packet for (`master`, `node`) carrying `regs`.
    pub fn new(master: u8, node: u8, regs: NodeRegs) -> Self {
        Packet { master, node, regs }
    }

    /// The address byte: master << 4 | node.
    pub fn address(&self) -> u8 {
        (self.master & 0x0F) << 4 | (self.node & 0x0F)
    }

    /// Encode to the 12 wire bytes.
    pub fn encode(&self) -> [u8; PACKET_LEN] {
        let r = &self.regs;
        let mut b = [0u8; PACKET_LEN];
        b[0] = HEADER;
        b[1] = self.address();
        b[2] = (r.r0 >> 16) as u8;
        b[3] = (r.r0 >> 8) as u8;
        b[4] = r.r0 as u8;
        b[5..7].copy_from_slice(&r.r1.to_be_bytes());
        b[7..9].copy_from_slice(&r.r2.to_be_bytes());
        b[9..11].copy_from_slice(&r.r3.to_be_bytes());
        b[11] = check_byte(&b[..11]);
        b
    }

    /// Decode the first [`PACKET_LEN`] bytes of `bytes` (extra bytes are ignored: framing is
    /// the frame's business). Checks, in order: length, header code, check byte.
    pub fn decode(bytes: &[u8]) -> Result<Packet, PacketError> {
        let Some(b) = bytes.get(..PACKET_LEN) else {
            return Err(PacketError::Truncated(bytes.len()));
        };
        if b[0] != HEADER {
            return Err(PacketError::ByteViolation(b[0]));
        }
        let want = check_byte(&b[..11]);
        if b[11] != want {
            return Err(PacketError::Checksum { got: b[11], want });
        }
        Ok(Packet {
            master: b[1] >> 4,
            node: b[1] & 0x0F,
            regs: NodeRegs {
                r0: u32::from(b[2]) << 16 | u32::from(b[3]) << 8 | u32::from(b[4]),
                r1: u16::from_be_bytes([b[5], b[6]]),
                r2: u16::from_be_bytes([b[7], b[8]]),
                r3: u16::from_be_bytes([b[9], b[10]]),
            },
        })
    }

    /// The sync packet of ring cycle `cycle` (only its low 40 bits are carried).
    pub fn sync(master: u8, node: u8, cycle: u64) -> Self {
        let c = cycle & CYCLE_MASK;
        Packet {
            master,
            node,
            regs: NodeRegs {
                r0: (c & 0xFF_FFFF) as u32,
                r1: (c >> 24) as u16,
                r2: 0,
                r3: 0,
            },
        }
    }

    /// The 40-bit ring cycle number carried by a sync packet.
    pub fn sync_cycle(&self) -> u64 {
        u64::from(self.regs.r0 & 0xFF_FFFF) | u64::from(self.regs.r1) << 24
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn crc8_smbus_check_value() {
        // The catalogue check value of CRC-8/SMBUS over "123456789".
        assert_eq!(check_byte(b"123456789"), 0xF4);
    }

    #[test]
    fn known_answer_encode() {
        let p = Packet::new(
            2,
            9,
            NodeRegs {
                r0: 0x12_3456,
                r1: 0x789A,
                r2: 0xBCDE,
                r3: 0xF001,
            },
        );
        let b = p.encode();
        assert_eq!(
            &b[..11],
            &[0xA5, 0x29, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0, 0x01]
        );
        assert_eq!(b[11], check_byte(&b[..11]));
        assert_eq!(Packet::decode(&b), Ok(p));
    }

    #[test]
    fn known_answer_zero_packet_check_byte() {
        // CRC-8/SMBUS of A5 00 00.. (9 zeros after A5 00): computed by hand with poly 0x07.
        let b = Packet::new(0, 0, NodeRegs::default()).encode();
        assert_eq!(b, [0xA5, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, b[11]]);
        let mut crc: u8 = 0;
        for byte in &b[..11] {
            crc ^= byte;
            for _ in 0..8 {
                crc = if crc & 0x80 != 0 {
                    crc << 1 ^ 0x07
                } else {
                    crc << 1
                };
            }
        }
        assert_eq!(b[11], crc);
    }

    #[test]
    fn register0_is_24_bits() {
        let p = Packet::new(
            0x1F,
            0x3E,
            NodeRegs {
                r0: 0xFFAB_CDEF,
                ..Default::default()
            },
        );
        let d = Packet::decode(&p.encode()).unwrap();
        assert_eq!((d.master, d.node, d.regs.r0), (0xF, 0xE, 0xAB_CDEF));
    }

    #[test]
    fn errors_classified() {
        let good = Packet::new(1, 2, NodeRegs::default()).encode();
        assert_eq!(Packet::decode(&good[..11]), Err(PacketError::Truncated(11)));
        let mut bv = good;
        bv[0] = 0x00;
        assert_eq!(Packet::decode(&bv), Err(PacketError::ByteViolation(0)));
        let mut ck = good;
        ck[11] ^= 0xFF;
        assert!(matches!(
            Packet::decode(&ck),
            Err(PacketError::Checksum { .. })
        ));
        let mut data = good;
        data[4] ^= 0x01;
        assert!(matches!(
            Packet::decode(&data),
            Err(PacketError::Checksum { .. })
        ));
    }

    #[test]
    fn sync_cycle_40_bits() {
        let p = Packet::sync(0, 15, 0x12_3456_789A);
        assert_eq!(p.regs.r0, 0x56_789A);
        assert_eq!(p.regs.r1, 0x1234);
        assert_eq!(p.sync_cycle(), 0x12_3456_789A);
        assert_eq!(Packet::sync(0, 15, 1 << 40 | 7).sync_cycle(), 7);
        let b = p.encode();
        assert_eq!(&b[..5], &[0xA5, 0x0F, 0x56, 0x78, 0x9A]);
        assert_eq!(&b[5..7], &[0x12, 0x34]);
    }

    proptest! {
        #[test]
        fn round_trip(m in 0u8..16, n in 0u8..16, r0 in 0u32..(1 << 24), r1: u16, r2: u16, r3: u16) {
            let p = Packet::new(m, n, NodeRegs { r0, r1, r2, r3 });
            prop_assert_eq!(Packet::decode(&p.encode()), Ok(p));
        }

        #[test]
        fn sync_round_trip(c in 0u64..(1 << 40)) {
            let p = Packet::sync(3, 15, c);
            prop_assert_eq!(Packet::decode(&p.encode()).unwrap().sync_cycle(), c);
        }

        #[test]
        fn any_bytes_decode_without_panic(b in proptest::collection::vec(any::<u8>(), 0..30)) {
            let _ = Packet::decode(&b);
        }

        #[test]
        fn single_bit_flip_detected(bit in 0usize..88, m in 0u8..16, n in 0u8..16, r0 in 0u32..(1 << 24)) {
            let mut b = Packet::new(m, n, NodeRegs { r0, ..Default::default() }).encode();
            b[bit / 8] ^= 1 << (bit % 8);
            prop_assert!(Packet::decode(&b).is_err());
        }
    }
}
