//! Fuzzing the decoders: any byte stream on the bus, in any segmentation, and any EEPROM
//! file: no panic, every reply is a well-formed frame, the drive keeps answering.

use proptest::prelude::*;

use super::codec::{FrameAssembler, Instr, Reply, Request};
use super::drive::Drive;
use super::eeprom::EepromImage;
use super::host::{DriveHost, HostedDrive};
use super::spec::DriveSpec;

fn host() -> DriveHost {
    DriveHost::new(vec![HostedDrive {
        name: "d".into(),
        drive: Drive::new(DriveSpec::default()),
    }])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn any_byte_stream_is_safe(
        bytes in proptest::collection::vec(any::<u8>(), 0..600),
        cuts in proptest::collection::vec(1usize..40, 1..30),
        gaps in proptest::collection::vec(0u64..900, 1..30),
    ) {
        let mut h = host();
        let mut asm = FrameAssembler::new(500);
        let mut now = 0u64;
        let mut rest = &bytes[..];
        let mut k = 0;
        while !rest.is_empty() {
            let n = cuts[k % cuts.len()].min(rest.len());
            now += gaps[k % gaps.len()];
            for f in asm.push(&rest[..n], now) {
                for (_, a) in h.frame(&f) {
                    if let Some(b) = a.bytes {
                        // A normal reply parses; the version string has no checksum.
                        let ok = Reply::parse(&b).is_some() || &b[1..] == b"1360V131";
                        prop_assert!(ok, "bad reply {:02X?}", b);
                    }
                }
                h.advance(now * 1_000_000, None);
            }
            rest = &rest[n..];
            k += 1;
        }
        // Still a working drive at its (possibly changed) address.
        let addr = h.drives[0].drive.address();
        let f = Request { addr, instr: Instr::new(136, 1, 0, 0) }.to_bytes();
        let a = h.frame(&f);
        prop_assert_eq!(a.len(), 1);
    }

    #[test]
    fn any_eeprom_file_is_safe(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = EepromImage::decode(&bytes);
        let mut d = Drive::power_up(DriveSpec::default(), Some(&bytes), None);
        d.run_ms(5);
    }

    #[test]
    fn a_valid_header_with_a_random_payload_is_safe(payload in proptest::collection::vec(any::<u8>(), 0..300)) {
        let mut b = b"EMCLEEP\0".to_vec();
        b.extend_from_slice(&1u32.to_le_bytes());
        b.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        b.extend_from_slice(&payload);
        let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&payload);
        b.extend_from_slice(&crc.to_le_bytes());
        // Decodes or is refused, never panics; a decoded image powers a drive up.
        if let Ok(img) = EepromImage::decode(&b) {
            let mut d = Drive::power_up(DriveSpec::default(), Some(&img.encode()), None);
            d.run_ms(5);
        }
    }
}
