//! The station's state file: what `MS SAVE` keeps ([`super::Setup`]) as JSON with a header
//! line and a checksum, written atomically (temporary file, fsync, rename, directory fsync).
//!
//! Format: line 1 `MCCSTATION 1 <fnv1a-64 of the body, 16 hex digits>`, then the JSON body.
//! Anything else (truncation, a flipped byte, another version, values out of range) is a
//! corrupt file: the station starts from its config values with the configuration-error bit
//! (MI4 bit 2) set, and says why in its log.

use std::path::Path;

use super::Setup;

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

/// Parse a state file's bytes; the error says what is wrong.
pub fn decode(bytes: &[u8]) -> Result<Setup, String> {
    let nl = bytes
        .iter()
        .position(|b| *b == b'\n')
        .ok_or("no header line")?;
    let header = std::str::from_utf8(&bytes[..nl]).map_err(|_| "header is not text")?;
    let sum = header
        .strip_prefix(MAGIC)
        .and_then(|r| r.strip_prefix(' '))
        .ok_or_else(|| format!("not a station state file (header {header:?})"))?;
    let want = u64::from_str_radix(sum, 16).map_err(|_| "bad checksum field")?;
    let body = &bytes[nl + 1..];
    if fnv1a(body) != want {
        return Err("checksum mismatch (truncated or altered)".into());
    }
    let setup: Setup = serde_json::from_slice(body).map_err(|e| format!("body: {e}"))?;
    for (n, cfg) in &setup.nodes {
        cfg.validate().map_err(|e| format!("node {n}: {e}"))?;
    }
    Ok(setup)
}

/// Write `setup` to `path` atomically: a temporary file beside it, fsync, rename over the old
/// one, fsync the directory. The old file stays intact if anything fails.
pub fn save(path: &Path, setup: &Setup) -> std::io::Result<()> {
    use mcc_ring::runtime::atomic_file::{write_atomic_with, AtomicWrite};
    let how = AtomicWrite {
        durable: true,
        create_dir: true,
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
            Err(e) => Loaded::Corrupt(e),
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
        assert!(decode(&flipped).unwrap_err().contains("checksum"));
        assert!(decode(&good[..good.len() / 2]).is_err());
        assert!(decode(b"").unwrap_err().contains("header"));
        assert!(decode(b"MCCSAVE\0 1\n{}")
            .unwrap_err()
            .contains("not a station"));
        // a good checksum over bad values
        let mut s = setup();
        s.nodes.get_mut(&0).unwrap().inertia = -1.0;
        let body = serde_json::to_vec(&s).unwrap();
        let mut f = format!("{MAGIC} {:016x}\n", fnv1a(&body)).into_bytes();
        f.extend(body);
        assert!(decode(&f).unwrap_err().contains("node 0: inertia"));
    }
}
