//! The persistent image written by `SAVE` and loaded at start-up / `$$$`, its file format, and
//! the atomic file write.
//!
//! SAVE keeps (flash-backed PMAC2, pmac-variables §1.4): I-variables, M-definitions (and
//! self-referenced values), P and Q values, the encoder conversion table Y:$0720-$073F, the
//! analog table X:$0708-$070F, the VME/DPRAM setup X:$0783-$078C, the UBUFFER words, the
//! password, and the program/PLC/buffer data INTERP hands in as opaque bytes.
//!
//! File format (little endian): magic `MCCSAVE\0` (8 bytes), format version u32, payload
//! length u64, payload, FNV-1a 64 of the payload (u64).
//!
//! Format versions: 3 (written now): the payload is the JSON schema of `persist_v3`, the
//! product's own (M-definitions as text, regions naming their space, the interpreter's part
//! embedded as JSON with programs and PLCs as their canonical listing text), so neither a new
//! statement kind nor a renamed internal type breaks an old file. 2 (read only, a converter):
//! the internal [`PersistImage`] as JSON, the interpreter's part as a byte array. 1 (read
//! only, a converter): bincode. A version above [`VERSION`] is refused naming both versions.
//! `tests/golden/` holds a file of every version and profile that later versions must load
//! (tests in `service::storage`).
//! Pure: the file itself is written by the runtime (`service::storage`: temporary file, fsync,
//! rename, fsync the directory, so a crash leaves either the old or the new file).

use super::memory::Space;
use crate::domain::ast::MDef;
use serde::{Deserialize, Serialize};

/// File magic.
pub(crate) const MAGIC: &[u8; 8] = b"MCCSAVE\0";
/// Format version written.
pub(crate) const VERSION: u32 = 3;
/// Oldest format version read.
pub(crate) const OLDEST: u32 = 1;
/// Largest payload accepted when loading (bytes).
pub(crate) const MAX_PAYLOAD: u64 = 64 << 20;
const HEADER: usize = 8 + 4 + 8;

/// Everything SAVE keeps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PersistImage {
    /// Profile name (`pmac2` / `turbo`); a mismatching image is refused at load.
    pub profile: String,
    /// I-variable values, by number.
    pub ivars: Vec<f64>,
    /// P-variable values.
    pub pvars: Vec<f64>,
    /// Q-variable values per coordinate system.
    pub qvars: Vec<Vec<f64>>,
    /// M-variable definitions.
    pub mdefs: Vec<MDef>,
    /// Self-referenced M-variable values.
    pub mself: Vec<i32>,
    /// Saved memory regions: (space, first address, words).
    pub regions: Vec<(Space, u16, Vec<u32>)>,
    /// Words reserved by DEFINE UBUFFER.
    pub ubuffer_words: u32,
    /// Password (empty = none).
    pub password: String,
    /// Program buffers, PLCs, DEFINE'd buffers, ...: INTERP's own serialization.
    pub programs: Vec<u8>,
    /// The format version the image was read from ([`VERSION`] for a new one): how to read
    /// `programs`.
    #[serde(skip)]
    pub format: u32,
}

/// Why a saved image could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum PersistError {
    /// The file could not be read or written.
    #[error("i/o error: {0}")]
    Io(String),
    /// Not a save file of this product.
    #[error("not an mcc save file (bad magic)")]
    BadMagic,
    /// Written by a newer (or unknown) format version.
    #[error("save file format version {0} is not readable by this mcc (it reads versions {OLDEST} to {VERSION}): written by a newer mcc?")]
    Version(u32),
    /// Shorter than its header says (partial write).
    #[error("save file truncated ({got} of {want} bytes)")]
    Truncated {
        /// Bytes present.
        got: usize,
        /// Bytes expected.
        want: usize,
    },
    /// Payload length over the limit or trailing garbage.
    #[error("save file has a bad length")]
    BadLength,
    /// Checksum mismatch (corruption).
    #[error("save file checksum mismatch")]
    Checksum,
    /// Payload does not decode.
    #[error("save file payload does not decode: {0}")]
    Decode(String),
    /// Saved for another profile.
    #[error("save file is for profile {0}")]
    Profile(String),
}

/// FNV-1a 64-bit hash.
pub(crate) fn fnv1a64(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ *b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Serialize an image into the file format.
pub(crate) fn encode(image: &PersistImage) -> Vec<u8> {
    // Encoding plain data into a Vec cannot fail (every stored number is finite); an empty
    // payload is still a valid frame.
    let payload =
        serde_json::to_vec(&super::persist_v3::ImageV3::from_image(image)).unwrap_or_default();
    let mut out = Vec::with_capacity(HEADER + payload.len() + 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    out.extend_from_slice(&fnv1a64(&payload).to_le_bytes());
    out
}

/// Parse the file format. Never panics on any input.
pub(crate) fn decode(bytes: &[u8]) -> Result<PersistImage, PersistError> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(PersistError::BadMagic);
    }
    if bytes.len() < HEADER {
        return Err(PersistError::Truncated {
            got: bytes.len(),
            want: HEADER,
        });
    }
    let version = u32::from_le_bytes(
        bytes[8..12]
            .try_into()
            .map_err(|_| PersistError::BadMagic)?,
    );
    if !(OLDEST..=VERSION).contains(&version) {
        return Err(PersistError::Version(version));
    }
    let len = u64::from_le_bytes(
        bytes[12..20]
            .try_into()
            .map_err(|_| PersistError::BadMagic)?,
    );
    if len > MAX_PAYLOAD {
        return Err(PersistError::BadLength);
    }
    let want = HEADER + len as usize + 8;
    if bytes.len() < want {
        return Err(PersistError::Truncated {
            got: bytes.len(),
            want,
        });
    }
    if bytes.len() > want {
        return Err(PersistError::BadLength);
    }
    let payload = &bytes[HEADER..HEADER + len as usize];
    let sum = u64::from_le_bytes(
        bytes[want - 8..want]
            .try_into()
            .map_err(|_| PersistError::BadLength)?,
    );
    if sum != fnv1a64(payload) {
        return Err(PersistError::Checksum);
    }
    let mut image: PersistImage = if version == 1 {
        let cfg = bincode::config::standard().with_limit::<{ MAX_PAYLOAD as usize }>();
        let (image, used): (PersistImage, usize) = bincode::serde::decode_from_slice(payload, cfg)
            .map_err(|e| PersistError::Decode(e.to_string()))?;
        if used != payload.len() {
            return Err(PersistError::Decode("trailing bytes in payload".into()));
        }
        image
    } else if version == 2 {
        serde_json::from_slice(payload).map_err(|e| PersistError::Decode(e.to_string()))?
    } else {
        serde_json::from_slice::<super::persist_v3::ImageV3>(payload)
            .map_err(|e| PersistError::Decode(e.to_string()))?
            .into_image()?
    };
    image.format = version;
    Ok(image)
}

#[cfg(test)]
#[path = "tests_persist.rs"]
mod tests;
