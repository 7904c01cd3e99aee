//! A drive's EEPROM image (spec emcl.md §6.6, §7, §8, §10): stored axis parameters, the
//! bank-0 EEPROM parameters, user variables 0..=55, coordinates 1..=20 and the program
//! memory, and its file format. Pure: bytes in, bytes out; the station runtime writes the
//! file atomically.
//!
//! File format (little endian): magic `EMCLEEP\0` (8 bytes), format version u32, payload
//! length u32, payload (bincode 2 standard config, serde), CRC-32 (ISO-HDLC) of the payload.

use serde::{Deserialize, Serialize};

use super::codec::Instr;
use super::params::{self, Access, USER_EEPROM_VARS};
use super::spec::DriveSpec;

/// File magic.
pub const MAGIC: &[u8; 8] = b"EMCLEEP\0";
/// Format version.
pub const VERSION: u32 = 1;
/// Program memory slots (§6.1).
pub const PROGRAM_SLOTS: usize = 2048;
/// Coordinate slots 0..=20 (§10).
pub const COORDS: usize = 21;
/// Largest payload accepted (a full program is ~16 KiB).
pub const MAX_PAYLOAD: usize = 1 << 20;

/// The EEPROM contents.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct EepromImage {
    /// Every writable axis parameter: (number, value).
    pub axis: Vec<(u8, i32)>,
    /// Bank-0 EEPROM parameters 64..=87: (number, value); GP 73 holds 1 = locked.
    pub global: Vec<(u8, i32)>,
    /// Bank-2 user variables 0..=55.
    pub user: Vec<i32>,
    /// Coordinates 0..=20 (slot 0 is never used: RAM only).
    pub coords: Vec<i32>,
    /// Program memory up to the last slot ever written.
    pub program: Vec<Instr>,
}

impl EepromImage {
    /// The factory image of a drive: parameters at their factory values, no program.
    pub fn factory(spec: &DriveSpec) -> Self {
        EepromImage {
            axis: params::AXIS_PARAMS
                .iter()
                .filter(|p| p.access == Access::RW)
                .map(|p| (p.num, spec.axis_default(p.num)))
                .collect(),
            global: params::GLOBAL_PARAMS
                .iter()
                .filter(|p| params::global_is_eeprom(p.num))
                .map(|p| (p.num, spec.global_default(p.num)))
                .collect(),
            user: vec![0; USER_EEPROM_VARS],
            coords: vec![0; COORDS],
            program: Vec::new(),
        }
    }

    /// Stored value of axis parameter `n`.
    pub fn axis(&self, n: u8) -> Option<i32> {
        self.axis.iter().find(|(k, _)| *k == n).map(|(_, v)| *v)
    }

    /// Store axis parameter `n`.
    pub fn set_axis(&mut self, n: u8, v: i32) {
        match self.axis.iter_mut().find(|(k, _)| *k == n) {
            Some(e) => e.1 = v,
            None => {
                self.axis.push((n, v));
                self.axis.sort_unstable_by_key(|e| e.0);
            }
        }
    }

    /// Stored value of bank-0 parameter `n`.
    pub fn global(&self, n: u8) -> Option<i32> {
        self.global.iter().find(|(k, _)| *k == n).map(|(_, v)| *v)
    }

    /// Store bank-0 parameter `n`.
    pub fn set_global(&mut self, n: u8, v: i32) {
        match self.global.iter_mut().find(|(k, _)| *k == n) {
            Some(e) => e.1 = v,
            None => {
                self.global.push((n, v));
                self.global.sort_unstable_by_key(|e| e.0);
            }
        }
    }

    /// Program slot `a` (empty slots read as instruction 0).
    pub fn slot(&self, a: usize) -> Instr {
        self.program.get(a).copied().unwrap_or_default()
    }

    /// Write program slot `a` (< [`PROGRAM_SLOTS`]).
    pub fn set_slot(&mut self, a: usize, i: Instr) {
        if a >= PROGRAM_SLOTS {
            return;
        }
        if self.program.len() <= a {
            self.program.resize(a + 1, Instr::default());
        }
        if let Some(s) = self.program.get_mut(a) {
            *s = i;
        }
    }

    /// Bring a decoded image to the shapes the drive expects (lengths, slot count); an image
    /// from an older drive keeps what it has.
    fn normalise(&mut self) {
        self.user.resize(USER_EEPROM_VARS, 0);
        self.coords.resize(COORDS, 0);
        self.program.truncate(PROGRAM_SLOTS);
    }

    /// The file bytes.
    pub fn encode(&self) -> Vec<u8> {
        let payload =
            bincode::serde::encode_to_vec(self, bincode::config::standard()).unwrap_or_default();
        let mut out = Vec::with_capacity(payload.len() + 20);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        out.extend_from_slice(&payload);
        out.extend_from_slice(&CRC.checksum(&payload).to_le_bytes());
        out
    }

    /// Decode file bytes; the error says what is wrong.
    pub fn decode(b: &[u8]) -> Result<Self, EepromError> {
        let magic = b.get(..8).ok_or(EepromError::TooShort)?;
        if magic != MAGIC {
            return Err(EepromError::BadMagic);
        }
        let word = |at: usize| -> Result<u32, EepromError> {
            let s = b.get(at..at + 4).ok_or(EepromError::Truncated)?;
            Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
        };
        let version = word(8)?;
        if version != VERSION {
            return Err(EepromError::Version(version));
        }
        let len = word(12)? as usize;
        if len > MAX_PAYLOAD {
            return Err(EepromError::TooLarge(len));
        }
        if b.len() != 16 + len + 4 {
            return Err(EepromError::Length {
                len: b.len(),
                expected: 16 + len + 4,
            });
        }
        let payload = b.get(16..16 + len).ok_or(EepromError::Truncated)?;
        if word(16 + len)? != CRC.checksum(payload) {
            return Err(EepromError::Checksum);
        }
        let cfg = bincode::config::standard().with_limit::<MAX_PAYLOAD>();
        let (mut img, used): (EepromImage, usize) = bincode::serde::decode_from_slice(payload, cfg)
            .map_err(|e| EepromError::Payload(e.to_string()))?;
        if used != payload.len() {
            return Err(EepromError::Trailing);
        }
        img.normalise();
        Ok(img)
    }
}

/// An EEPROM image file that cannot be used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EepromError {
    /// Shorter than the magic.
    #[error("file too short")]
    TooShort,
    /// Not the image magic.
    #[error("not an EMCL EEPROM image (bad magic)")]
    BadMagic,
    /// A header word or the payload is cut off.
    #[error("file truncated")]
    Truncated,
    /// Another format version (the version).
    #[error("unsupported EEPROM image version {0}")]
    Version(u32),
    /// The header's payload length is above the limit (the length).
    #[error("payload length {0} too large")]
    TooLarge(usize),
    /// The file is not as long as its header says.
    #[error("file length {len} does not match its header ({expected} expected)")]
    Length {
        /// Bytes in the file.
        len: usize,
        /// Bytes the header implies.
        expected: usize,
    },
    /// The payload does not match its CRC.
    #[error("checksum mismatch")]
    Checksum,
    /// The payload is not an image (the decoder's message).
    #[error("payload does not decode: {0}")]
    Payload(String),
    /// The payload holds more than one image.
    #[error("trailing bytes after the payload")]
    Trailing,
}

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_corruption_is_detected() {
        let mut img = EepromImage::factory(&DriveSpec::default());
        img.set_axis(4, 1234);
        img.set_slot(5, Instr::new(22, 0, 0, 3));
        img.user[7] = -5;
        let b = img.encode();
        assert_eq!(EepromImage::decode(&b).unwrap(), img);
        for k in [0, 9, 13, 20, b.len() - 1] {
            let mut bad = b.clone();
            bad[k] ^= 0x40;
            assert!(EepromImage::decode(&bad).is_err(), "flip at {k}");
        }
        assert!(EepromImage::decode(&b[..b.len() - 3]).is_err());
        assert_eq!(EepromImage::decode(b""), Err(EepromError::TooShort));
        let mut long = b.clone();
        long.push(0);
        assert_eq!(
            EepromImage::decode(&long).unwrap_err().to_string(),
            format!(
                "file length {} does not match its header ({} expected)",
                b.len() + 1,
                b.len()
            )
        );
    }

    #[test]
    fn factory_image_holds_the_defaults() {
        let spec = DriveSpec {
            address: 7,
            ..DriveSpec::default()
        };
        let img = EepromImage::factory(&spec);
        assert_eq!(img.global(66), Some(7));
        assert_eq!(img.global(76), Some(2));
        assert_eq!(img.global(64), Some(0xE4));
        assert_eq!(img.global(72), Some(7));
        assert_eq!(img.axis(214), Some(200));
        assert_eq!(img.axis(111), Some(256));
        assert_eq!(img.axis(3), None, "read-only parameters are not stored");
        assert!(img.program.is_empty());
    }
}
