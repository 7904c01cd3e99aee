//! The one atomic file write of every SAVE-like writer (card state, station setup, drive
//! EEPROM, run-directory files): a temporary beside the target (`<name>.tmp<pid>`), write,
//! fsync, rename over the target, fsync the directory — so a crash leaves either the old or
//! the new file, never a mix.

use std::io::Write;
use std::path::{Path, PathBuf};

/// How [`write_atomic_with`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AtomicWrite {
    /// fsync the file before the rename and the directory after it (off: the page cache
    /// survives a killed process, not a power cut — for a download in progress).
    pub durable: bool,
    /// Create the target's directory first.
    pub create_dir: bool,
    /// Permission bits of the new file (`None`: 0666 less the umask, as `File::create`);
    /// the file has them from its creation on, so no other user can open it meanwhile.
    pub mode: Option<u32>,
}

impl Default for AtomicWrite {
    fn default() -> Self {
        AtomicWrite {
            durable: true,
            create_dir: false,
            mode: None,
        }
    }
}

/// The mode of a file that may hold secrets (a password): the owner's only.
pub const PRIVATE_MODE: u32 = 0o600;

/// The temporary file used while writing `path` (`<name>.tmp<pid>` beside it).
pub fn temp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(format!(".tmp{}", std::process::id()));
    path.with_file_name(name)
}

fn dir_of(path: &Path) -> &Path {
    path.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Write `bytes` to `path` atomically and durably (see the module).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, bytes, AtomicWrite::default())
}

/// [`write_atomic`] with options; the temporary is removed when anything fails.
pub fn write_atomic_with(path: &Path, bytes: &[u8], how: AtomicWrite) -> std::io::Result<()> {
    let dir = dir_of(path);
    if how.create_dir {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = temp_path(path);
    let result = (|| {
        let mut f = create(&tmp, how.mode)?;
        f.write_all(bytes)?;
        if how.durable {
            f.sync_all()?;
        }
        drop(f);
        std::fs::rename(&tmp, path)?;
        if how.durable {
            std::fs::File::open(dir)?.sync_all()?;
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// [`write_atomic`] of a file only its owner may read or write ([`PRIVATE_MODE`]).
pub fn write_private(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let how = AtomicWrite {
        mode: Some(PRIVATE_MODE),
        ..AtomicWrite::default()
    };
    write_atomic_with(path, bytes, how)
}

/// Create (truncate) `path` for writing, with `mode` when given — also when the file was
/// there already (a temporary left by a killed writer keeps its old mode otherwise).
fn create(path: &Path, mode: Option<u32>) -> std::io::Result<std::fs::File> {
    let Some(mode) = mode else {
        return std::fs::File::create(path);
    };
    use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
    let f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(mode)
        .open(path)?;
    f.set_permissions(std::fs::Permissions::from_mode(mode))?;
    Ok(f)
}

/// Remove the temporaries of writes to `path` cut short (`<name>.tmp<pid>`: the process was
/// killed between writing and renaming). Returns the files removed.
pub fn remove_temporaries(path: &Path) -> Vec<PathBuf> {
    let Some(name) = path.file_name() else {
        return Vec::new();
    };
    let prefix = format!("{}.tmp", name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(dir_of(path)) else {
        return Vec::new();
    };
    let mut removed = Vec::new();
    for e in entries.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        let pid_part = n.strip_prefix(&prefix);
        if pid_part.is_some_and(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
            && std::fs::remove_file(e.path()).is_ok()
        {
            removed.push(e.path());
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_replace_and_leave_no_temporary() {
        let dir = std::env::temp_dir().join(format!("mcc-atomic-{}", std::process::id()));
        let path = dir.join("sub").join("f.bin");
        assert!(
            write_atomic(&path, b"x").is_err(),
            "no directory, no create_dir"
        );
        assert!(!temp_path(&path).exists());
        let how = AtomicWrite {
            create_dir: true,
            ..AtomicWrite::default()
        };
        write_atomic_with(&path, b"old", how).unwrap();
        write_atomic(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert!(!temp_path(&path).exists());
        std::fs::write(temp_path(&path), b"half").unwrap();
        std::fs::write(dir.join("sub").join("f.bin.tmpx"), b"not ours").unwrap();
        assert_eq!(remove_temporaries(&path), vec![temp_path(&path)]);
        assert!(dir.join("sub").join("f.bin.tmpx").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn private_files_are_the_owners_only_whatever_was_there() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("mcc-atomic-mode-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        let path = dir.join("cluster.toml");
        // A world-readable file and a world-readable temporary left by a killed writer.
        std::fs::write(&path, b"old").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        std::fs::write(temp_path(&path), b"half").unwrap();
        std::fs::set_permissions(temp_path(&path), std::fs::Permissions::from_mode(0o666)).unwrap();
        write_private(&path, b"ssh_password = \"x\"").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"ssh_password = \"x\"");
        assert_eq!(mode(&path), 0o600);
        // Without a mode, the default (0666 less the umask: at least the owner's rw).
        let plain = dir.join("plain");
        write_atomic(&plain, b"x").unwrap();
        assert_eq!(mode(&plain) & 0o600, 0o600);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
