//! The station's state file: what `MS SAVE` keeps ([`super::Setup`]) as JSON with a header
//! line and a checksum, written atomically (temporary file, fsync, rename, directory fsync).
//!
//! Format: line 1 `MCCSTATION 1 <fnv1a-64 of the body, 16 hex digits>`, then the JSON body.
//! Anything else (truncation, a flipped byte, another version, values out of range) is a
//! corrupt file: the station starts from its config values with the configuration-error bit
//! (MI4 bit 2) set, and says why in its log.

use std::path::Path;

use super::Setup;
use crate::config::PlantError;

const MAGIC: &str = "MCCSTATION 1";
/// Largest state file accepted (a station's setup is a few KiB).
pub const MAX_FILE: u64 = 1 << 20;

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The file's bytes for `setup`.
pub fn encode(setup: &Setup) -> Vec<u8> {
    let body = serde_json::to_vec_pretty(setup).unwrap_or_default();
    let mut out = format!("{MAGIC} {:016x}\n", fnv1a(&body)).into_bytes();
    out.extend(body);
    out
}

/// A state file that cannot be used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum StateFileError {
    /// No newline: no header line.
    #[error("no header line")]
    NoHeader,
    /// The header line is not UTF-8.
    #[error("header is not text")]
    HeaderNotText,
    /// The header does not start with the magic (the header).
    #[error("not a station state file (header {0:?})")]
    NotStateFile(String),
    /// The checksum field is no hexadecimal number.
    #[error("bad checksum field")]
    BadChecksumField,
    /// The body does not match its checksum.
    #[error("checksum mismatch (truncated or altered)")]
    ChecksumMismatch,
    /// The body is not a setup (the JSON error).
    #[error("body: {0}")]
    Body(String),
    /// A node's saved parameters are out of range.
    #[error("node {node}: {problem}")]
    Node {
        /// Node number.
        node: u8,
        /// What is wrong with its parameters.
        problem: PlantError,
    },
}

/// Parse a state file's bytes; the error says what is wrong.
pub fn decode(bytes: &[u8]) -> Result<Setup, StateFileError> {
    let nl = bytes
        .iter()
        .position(|b| *b == b'\n')
        .ok_or(StateFileError::NoHeader)?;
    let header = std::str::from_utf8(&bytes[..nl]).map_err(|_| StateFileError::HeaderNotText)?;
    let sum = header
        .strip_prefix(MAGIC)
        .and_then(|r| r.strip_prefix(' '))
        .ok_or_else(|| StateFileError::NotStateFile(header.to_string()))?;
    let want = u64::from_str_radix(sum, 16).map_err(|_| StateFileError::BadChecksumField)?;
    let body = &bytes[nl + 1..];
    if fnv1a(body) != want {
        return Err(StateFileError::ChecksumMismatch);
    }
    let setup: Setup =
        serde_json::from_slice(body).map_err(|e| StateFileError::Body(e.to_string()))?;
    for (&node, cfg) in &setup.nodes {
        cfg.validate()
            .map_err(|problem| StateFileError::Node { node, problem })?;
    }
    Ok(setup)
}

/// Write `setup` to `path` atomically: a temporary file beside it, fsync, rename over the old
/// one, fsync the directory. The old file stays intact if anything fails.
pub fn save(path: &Path, setup: &Setup) -> std::io::Result<()> {
    use mcc_contracts::atomic_file::{write_atomic_with, AtomicWrite};
    let how = AtomicWrite {
        durable: true,
        create_dir: true,
        mode: None,
    };
    write_atomic_with(path, &encode(setup), how)
}

/// What start-up found at the state file's path.
#[derive(Debug, PartialEq)]
pub enum Loaded {
    /// No file: use the config values.
    Absent,
    /// A good file.
    Setup(Setup),
    /// A file that cannot be used, and why.
    Corrupt(String),
}

/// Read the state file at `path`.
pub fn load(path: &Path) -> Loaded {
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Loaded::Absent,
        Err(e) => return Loaded::Corrupt(format!("cannot read: {e}")),
    };
    if meta.len() > MAX_FILE {
        return Loaded::Corrupt(format!("{} bytes, at most {MAX_FILE}", meta.len()));
    }
    match std::fs::read(path) {
        Ok(b) => match decode(&b) {
            Ok(s) => Loaded::Setup(s),
            Err(e) => Loaded::Corrupt(e.to_string()),
        },
        Err(e) => Loaded::Corrupt(format!("cannot read: {e}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::NodePlantConfig;
    use crate::mi::Globals;

    fn setup() -> Setup {
        let n = NodePlantConfig {
            inertia: 3e-5,
            ..Default::default()
        };
        Setup {
            globals: Globals {
                config_number: 37,
                ..Globals::from_check(8, 4, 4)
            },
            nodes: [(0u8, n), (1, NodePlantConfig::default())].into(),
        }
    }

    #[test]
    fn save_then_load_round_trips_and_replaces_atomically() {
        let dir = std::env::temp_dir().join(format!("mcc-st-{}", std::process::id()));
        let path = dir.join("sub").join("station0.state");
        assert_eq!(load(&path), Loaded::Absent);
        save(&path, &setup()).unwrap();
        assert_eq!(load(&path), Loaded::Setup(setup()));
        let mut s2 = setup();
        s2.globals.config_number = 38;
        save(&path, &s2).unwrap();
        assert_eq!(load(&path), Loaded::Setup(s2));
        let leftovers: Vec<_> = std::fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(leftovers.len(), 1, "{leftovers:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn corrupt_files_are_reported() {
        let good = encode(&setup());
        assert_eq!(decode(&good), Ok(setup()));
        let mut flipped = good.clone();
        let last = flipped.len() - 3;
        flipped[last] ^= 0x01;
        assert_eq!(decode(&flipped), Err(StateFileError::ChecksumMismatch));
        assert!(decode(&good[..good.len() / 2]).is_err());
        assert_eq!(decode(b""), Err(StateFileError::NoHeader));
        let foreign = decode(b"MCCSAVE\0 1\n{}").unwrap_err();
        assert_eq!(
            foreign.to_string(),
            "not a station state file (header \"MCCSAVE\\0 1\")"
        );
        // a good checksum over bad values
        let mut s = setup();
        s.nodes.get_mut(&0).unwrap().inertia = -1.0;
        let body = serde_json::to_vec(&s).unwrap();
        let mut f = format!("{MAGIC} {:016x}\n", fnv1a(&body)).into_bytes();
        f.extend(body);
        let e = decode(&f).unwrap_err();
        assert!(matches!(e, StateFileError::Node { node: 0, .. }), "{e:?}");
        assert!(
            e.to_string().starts_with("node 0: inertia: must be > 0"),
            "{e}"
        );
    }
}
