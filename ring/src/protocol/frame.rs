//! The frame envelope: what one hop carries in one go (architecture §3.1).
//!
//! bincode 2 (serde, standard configuration: varint integers) around a raw byte string of
//! packets, so faults can be injected and detected at byte level. Decoding is bounded by
//! [`MAX_FRAME_BYTES`] so a hostile length prefix cannot allocate more than that.

use serde::{Deserialize, Serialize};

use crate::packet::{Packet, PACKET_LEN};

/// Frame format version; a frame with another version is rejected.
pub const FORMAT_VERSION: u16 = 2;

/// Upper bound of an encoded frame (and of any length prefix inside it).
pub const MAX_FRAME_BYTES: usize = 64 * 1024;

fn config() -> impl bincode::config::Config {
    bincode::config::standard().with_limit::<MAX_FRAME_BYTES>()
}

/// One hop's frame.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Frame {
    /// [`FORMAT_VERSION`].
    pub version: u16,
    /// Ring position of the member that sent this frame.
    pub sender: u16,
    /// Link sequence number (per sender, strictly increasing).
    pub seq: u64,
    /// Send timestamp in ns (measurement only; the sender's clock).
    pub sent_ns: u64,
    /// Ring cycle the sender was in.
    pub cycle: u64,
    /// When the synchronizing master started this ring cycle (`CLOCK_MONOTONIC` ns in
    /// realtime mode, simulated time in lockstep), carried unchanged around the ring so every
    /// member can tick at the same instant (phase alignment).
    pub origin_ns: u64,
    /// Number of packets the sender put in `packets`.
    pub declared: u16,
    /// The packets' bytes, `declared` × 12 when intact.
    #[serde(with = "serde_bytes")]
    pub packets: Vec<u8>,
}

/// What a dark link carries in place of packets: one packet's worth of zero bytes. A receiver
/// reads it as a byte violation (0x00 is not a packet code), as a MACRO receiver reads a fibre
/// with no light.
pub const DARK_BYTES: [u8; PACKET_LEN] = [0; PACKET_LEN];

/// Why a frame envelope was rejected (counted as `bad_frames`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Format version is not [`FORMAT_VERSION`].
    #[error("frame format version {0}, expected {FORMAT_VERSION}")]
    Version(u16),
    /// Longer than [`MAX_FRAME_BYTES`].
    #[error("frame of {0} bytes exceeds the {MAX_FRAME_BYTES}-byte limit")]
    TooLong(usize),
    /// Not a valid envelope (truncated, bad length prefix, trailing bytes, ...).
    #[error("malformed frame: {0}")]
    Malformed(String),
}

impl Frame {
    /// A frame carrying `packets`, encoded back to back.
    pub fn with_packets(
        sender: u16,
        seq: u64,
        sent_ns: u64,
        cycle: u64,
        packets: &[Packet],
    ) -> Self {
        let mut bytes = Vec::with_capacity(packets.len() * PACKET_LEN);
        for p in packets {
            bytes.extend_from_slice(&p.encode());
        }
        Frame {
            version: FORMAT_VERSION,
            sender,
            seq,
            sent_ns,
            cycle,
            origin_ns: sent_ns,
            declared: u16::try_from(packets.len()).unwrap_or(u16::MAX),
            packets: bytes,
        }
    }

    /// A dark frame for ring cycle `cycle` (loss of light: see [`DARK_BYTES`]). The envelope
    /// still carries the cycle, so the ring keeps cycling and every member downstream of a
    /// break counts the cycles it sees no light.
    pub fn dark(sender: u16, seq: u64, sent_ns: u64, cycle: u64, origin_ns: u64) -> Self {
        Frame {
            version: FORMAT_VERSION,
            sender,
            seq,
            sent_ns,
            cycle,
            origin_ns,
            declared: 1,
            packets: DARK_BYTES.to_vec(),
        }
    }

    /// Is this a dark frame (nothing but [`DARK_BYTES`])?
    pub fn is_dark(&self) -> bool {
        self.declared == 1 && self.packets == DARK_BYTES
    }

    /// Encode with bincode (standard configuration).
    pub fn encode(&self) -> Vec<u8> {
        // Encoding into a Vec cannot fail except on the size limit, which only a frame of
        // more than 64 KiB hits; such a frame is never built by this crate. Fall back to an
        // empty vector (the receiver counts it as a bad frame) rather than panicking.
        bincode::serde::encode_to_vec(self, config()).unwrap_or_default()
    }

    /// Decode and validate the envelope (version, bounds, no trailing bytes).
    pub fn decode(bytes: &[u8]) -> Result<Frame, FrameError> {
        if bytes.len() > MAX_FRAME_BYTES {
            return Err(FrameError::TooLong(bytes.len()));
        }
        // The version is the first field: read it alone so a future layout is reported as a
        // version mismatch rather than as garbage.
        let (version, _): (u16, usize) = bincode::serde::decode_from_slice(bytes, config())
            .map_err(|e| FrameError::Malformed(e.to_string()))?;
        if version != FORMAT_VERSION {
            return Err(FrameError::Version(version));
        }
        let (frame, used): (Frame, usize) = bincode::serde::decode_from_slice(bytes, config())
            .map_err(|e| FrameError::Malformed(e.to_string()))?;
        if used != bytes.len() {
            return Err(FrameError::Malformed(format!(
                "{} trailing bytes after the envelope",
                bytes.len() - used
            )));
        }
        Ok(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packet::NodeRegs;
    use proptest::prelude::*;

    #[test]
    fn known_answer_bytes() {
        let f = Frame {
            version: 2,
            sender: 2,
            seq: 300,
            sent_ns: 5,
            cycle: 251,
            origin_ns: 3,
            declared: 1,
            packets: vec![0xA5, 0xFF],
        };
        // varint: values < 251 are one byte; 251..=65535 are 0xFB + u16 LE.
        let want = vec![
            2, 2, 0xFB, 0x2C, 0x01, 5, 0xFB, 0xFB, 0x00, 3, 1, 2, 0xA5, 0xFF,
        ];
        assert_eq!(f.encode(), want);
        assert_eq!(Frame::decode(&want), Ok(f));
    }

    #[test]
    fn dark_frames_are_recognised_and_read_as_byte_violations() {
        let d = Frame::dark(3, 9, 1, 77, 2);
        assert!(d.is_dark());
        let back = Frame::decode(&d.encode()).unwrap();
        assert_eq!(back, d);
        assert_eq!((back.cycle, back.origin_ns), (77, 2));
        assert!(matches!(
            Packet::decode(&back.packets),
            Err(crate::packet::PacketError::ByteViolation(_))
        ));
        // A frame whose only packet was hit by a byte violation is not dark.
        let sync = Packet::new(0, 15, NodeRegs::default());
        let mut f = Frame::with_packets(1, 1, 0, 5, &[sync]);
        assert!(!f.is_dark());
        f.packets[0] = 0;
        assert!(!f.is_dark());
        assert!(!Frame::with_packets(1, 1, 0, 5, &[]).is_dark());
    }

    #[test]
    fn wrong_version_rejected() {
        let f = Frame {
            version: 1,
            ..Default::default()
        };
        assert_eq!(Frame::decode(&f.encode()), Err(FrameError::Version(1)));
        // A garbage tail after a version-3 prefix is still reported as a version error.
        assert_eq!(Frame::decode(&[3, 0xFF, 0xFF]), Err(FrameError::Version(3)));
    }

    #[test]
    fn malformed_rejected() {
        assert!(matches!(Frame::decode(&[]), Err(FrameError::Malformed(_))));
        let mut b = Frame::with_packets(0, 1, 0, 0, &[Packet::default()]).encode();
        b.push(0);
        assert!(matches!(Frame::decode(&b), Err(FrameError::Malformed(_))));
        b.truncate(b.len() - 3);
        assert!(matches!(Frame::decode(&b), Err(FrameError::Malformed(_))));
    }

    #[test]
    fn hostile_length_prefix_is_bounded() {
        // version 2, six small fields, then a packets length prefix of u64::MAX (0xFD + 8 bytes).
        let mut b = vec![2, 0, 0, 0, 0, 0, 0, 0xFD];
        b.extend_from_slice(&u64::MAX.to_le_bytes());
        assert!(matches!(Frame::decode(&b), Err(FrameError::Malformed(_))));
        assert_eq!(
            Frame::decode(&vec![2; MAX_FRAME_BYTES + 1]),
            Err(FrameError::TooLong(MAX_FRAME_BYTES + 1))
        );
    }

    #[test]
    fn with_packets_declares_count() {
        let p = Packet::new(
            1,
            4,
            NodeRegs {
                r0: 7,
                ..Default::default()
            },
        );
        let f = Frame::with_packets(3, 9, 10, 11, &[p, p]);
        assert_eq!(f.declared, 2);
        assert_eq!(f.packets.len(), 24);
        assert_eq!(&f.packets[..12], &p.encode());
        assert_eq!(f.version, FORMAT_VERSION);
    }

    proptest! {
        #[test]
        fn round_trip(sender: u16, seq: u64, sent_ns: u64, cycle: u64, declared: u16,
                      packets in proptest::collection::vec(any::<u8>(), 0..400)) {
            let f = Frame { version: FORMAT_VERSION, sender, seq, sent_ns, cycle, origin_ns: sent_ns, declared, packets };
            prop_assert_eq!(Frame::decode(&f.encode()), Ok(f));
        }

        #[test]
        fn any_bytes_decode_without_panic(b in proptest::collection::vec(any::<u8>(), 0..200)) {
            let _ = Frame::decode(&b);
        }
    }
}
