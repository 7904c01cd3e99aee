//! EEPROM state files: read at power-up, written atomically (temporary sibling, write,
//! fsync, rename, fsync of the folder) so a crash leaves the old image or the new one.

use std::fs;
use std::path::{Path, PathBuf};

/// Largest state file read (a full image is ~20 KiB).
pub const MAX_FILE: u64 = 1 << 20;

/// The file's bytes; `Ok(None)` if there is none yet.
pub fn load(path: &Path) -> std::io::Result<Option<Vec<u8>>> {
    match fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
        Ok(m) if m.len() > MAX_FILE => {
            // Too large to be an image: read a prefix, the decoder rejects it.
            let mut b = Vec::new();
            std::io::Read::read_to_end(
                &mut std::io::Read::take(fs::File::open(path)?, MAX_FILE),
                &mut b,
            )?;
            return Ok(Some(b));
        }
        Ok(_) => {}
    }
    fs::read(path).map(Some)
}

/// Write `bytes` to `path` atomically; `durable` adds the fsyncs (a download in progress
/// writes without them: the page cache survives a killed process).
pub fn write_atomic(path: &Path, bytes: &[u8], durable: bool) -> std::io::Result<()> {
    use mcc_contracts::atomic_file::{write_atomic_with, AtomicWrite};
    let how = AtomicWrite {
        durable,
        create_dir: true,
        mode: None,
    };
    write_atomic_with(path, bytes, how)
}

/// Keep a corrupt image for inspection: rename it to `<file>.corrupt` (the drive starts
/// from factory defaults and will write a fresh image). The new name, if it worked.
pub fn keep_corrupt(path: &Path) -> Option<PathBuf> {
    let mut to = path.as_os_str().to_owned();
    to.push(".corrupt");
    let to = PathBuf::from(to);
    fs::rename(path, &to).ok().map(|_| to)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_load_and_corrupt_copy() {
        let dir = std::env::temp_dir().join(format!("emcl-persist-{}", std::process::id()));
        let p = dir.join("sub").join("d.eeprom");
        assert_eq!(load(&p).unwrap(), None);
        write_atomic(&p, b"one", true).unwrap();
        write_atomic(&p, b"two", false).unwrap();
        assert_eq!(load(&p).unwrap().as_deref(), Some(&b"two"[..]));
        assert!(!mcc_contracts::atomic_file::temp_path(&p).exists());
        let kept = keep_corrupt(&p).unwrap();
        assert_eq!(fs::read(&kept).unwrap(), b"two");
        assert_eq!(load(&p).unwrap(), None);
        fs::remove_dir_all(&dir).unwrap();
    }
}
