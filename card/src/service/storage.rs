//! The card's saved state on disk: [`FileStorage`] (the [`Storage`] a card process uses) writes
//! atomically — a temporary file in the same directory, fsync, rename over the target, fsync
//! the directory — so a crash leaves either the old or the new file.

use std::path::{Path, PathBuf};

use crate::lang::Storage;
#[cfg(test)]
use crate::model::persist::{decode, encode, PersistError, PersistImage};

/// Temporary file name used while writing `path` (the one atomic write of every SAVE-like
/// writer: `mcc_contracts::atomic_file`).
#[cfg(test)]
use mcc_contracts::atomic_file::temp_path;

/// Write `bytes` to `path` atomically: temp file in the same directory (created when
/// missing: the run directory's `state/` of a cluster card), write, fsync, rename, fsync the
/// directory.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use mcc_contracts::atomic_file::{write_atomic_with, AtomicWrite};
    let how = AtomicWrite {
        create_dir: true,
        ..AtomicWrite::default()
    };
    write_atomic_with(path, bytes, how)
}

/// Save an image to `path` atomically.
#[cfg(test)]
pub(crate) fn save(path: &Path, image: &PersistImage) -> std::io::Result<()> {
    write_atomic(path, &encode(image))
}

/// Load the image at `path`; `Ok(None)` when there is no file (fresh card).
#[cfg(test)]
pub(crate) fn load(path: &Path) -> Result<Option<PersistImage>, PersistError> {
    match read(path).map_err(PersistError::Io)? {
        Some(bytes) => decode(&bytes).map(Some),
        None => Ok(None),
    }
}

/// The bytes at `path`; `Ok(None)` when there is no file.
pub(crate) fn read(path: &Path) -> Result<Option<Vec<u8>>, String> {
    match std::fs::read(path) {
        Ok(bytes) => Ok(Some(bytes)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// Remove temporaries a SAVE cut short left beside `path` (`<name>.tmp<pid>`: the process was
/// killed between writing and renaming). Returns how many were removed.
pub(crate) fn remove_stale_temporaries(path: &Path) -> usize {
    let removed = mcc_contracts::atomic_file::remove_temporaries(path);
    for f in &removed {
        tracing::warn!(file = %f.display(), "removed a SAVE temporary left by a killed process");
    }
    removed.len()
}

/// Move a refused state file aside (`<name>.bad-<n>`, the first free n) so nothing overwrites
/// it; the new name, or `None` when it could not be moved.
pub(crate) fn keep_aside(path: &Path) -> Option<PathBuf> {
    if !path.is_file() {
        return None;
    }
    let name = path.file_name()?.to_string_lossy().into_owned();
    for n in 1..1000 {
        let aside = path.with_file_name(format!("{name}.bad-{n}"));
        if !aside.exists() {
            return std::fs::rename(path, &aside).ok().map(|_| aside);
        }
    }
    None
}

/// A card's saved state in one file.
#[derive(Debug, Clone)]
pub struct FileStorage {
    path: PathBuf,
}

impl FileStorage {
    /// The state file `path`.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        FileStorage { path: path.into() }
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Storage for FileStorage {
    fn save(&mut self, bytes: &[u8]) -> Result<(), String> {
        write_atomic(&self.path, bytes).map_err(|e| format!("{}: {e}", self.path.display()))
    }

    fn load(&mut self) -> Result<Option<Vec<u8>>, String> {
        read(&self.path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;
    use crate::lang::{Card, Session};
    use crate::model::CardState;

    fn tmpdir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("mcc-state-{}-{}", name, std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn sample() -> PersistImage {
        let mut s = CardState::new(Profile::Pmac2);
        s.set_ivar(130, 5000.0).unwrap();
        s.vars.set_p(7, 2.5).unwrap();
        s.password = "Secret".into();
        s.to_image(b"PROG1 X10".to_vec())
    }

    #[test]
    fn round_trip_through_file() {
        let dir = tmpdir("rt");
        let path = dir.join("card1.sav");
        assert!(load(&path).unwrap().is_none());
        let img = sample();
        save(&path, &img).unwrap();
        let back = load(&path).unwrap().unwrap();
        assert_eq!(back, img);
        assert_eq!(back.ivars[130], 5000.0);
        assert_eq!(back.programs, b"PROG1 X10");
        assert!(!temp_path(&path).exists());
    }

    #[test]
    fn old_file_survives_an_unfinished_write() {
        let dir = tmpdir("crash");
        let path = dir.join("card.sav");
        let old = sample();
        save(&path, &old).unwrap();
        // Simulate a crash mid-SAVE: the temp file is written (partially) but never renamed.
        let mut newer = old.clone();
        newer.pvars[7] = 99.0;
        let bytes = encode(&newer);
        std::fs::write(temp_path(&path), &bytes[..bytes.len() / 3]).unwrap();
        assert_eq!(load(&path).unwrap().unwrap(), old);
        // The next successful SAVE replaces both.
        save(&path, &newer).unwrap();
        assert_eq!(load(&path).unwrap().unwrap().pvars[7], 99.0);
        assert!(!temp_path(&path).exists());
    }

    #[test]
    fn stale_temporaries_are_removed_and_bad_files_kept_aside() {
        let dir = tmpdir("stale");
        let path = dir.join("card.sav");
        std::fs::write(dir.join("card.sav.tmp12345"), b"partial").unwrap();
        std::fs::write(dir.join("card.sav.tmp999"), b"partial").unwrap();
        std::fs::write(dir.join("card.sav.tmpx"), b"not ours").unwrap();
        std::fs::write(&path, b"junk").unwrap();
        assert_eq!(remove_stale_temporaries(&path), 2);
        assert!(dir.join("card.sav.tmpx").exists());
        assert_eq!(keep_aside(&path), Some(dir.join("card.sav.bad-1")));
        std::fs::write(&path, b"junk2").unwrap();
        assert_eq!(keep_aside(&path), Some(dir.join("card.sav.bad-2")));
        assert!(!path.exists());
        assert_eq!(std::fs::read(dir.join("card.sav.bad-1")).unwrap(), b"junk");
    }

    #[test]
    fn truncated_file_on_disk_is_an_error() {
        let dir = tmpdir("trunc");
        let path = dir.join("card.sav");
        let bytes = encode(&sample());
        std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
        assert!(matches!(load(&path), Err(PersistError::Truncated { .. })));
    }

    fn send(c: &mut Card, s: &mut Session, line: &str) -> Vec<u8> {
        c.command_line(s, line.as_bytes())
    }

    #[test]
    fn save_and_reset_restore_state() {
        let dir = std::env::temp_dir().join(format!("mcc-interp-unit-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let path = dir.join("card.state");
        let _ = std::fs::remove_file(&path);
        let mut c = Card::with_storage(Profile::Pmac2, Box::new(FileStorage::new(&path)));
        let mut s = Session::default();
        assert_eq!(send(&mut c, &mut s, "I3=2 I6=1 I130=1500 P1=5"), b"\x06");
        assert_eq!(
            send(&mut c, &mut s, "OPEN PROG 7 CLEAR DWELL100 CLOSE"),
            b"\x06"
        );
        assert_eq!(send(&mut c, &mut s, "SAVE"), b"\x06");
        assert_eq!(send(&mut c, &mut s, "I130=1000 P1=6"), b"\x06");
        assert_eq!(send(&mut c, &mut s, "$$$"), b"");
        assert_eq!(send(&mut c, &mut s, "I130 P1"), b"1500\r5\r\x06");
        let mut c2 = Card::with_storage(Profile::Pmac2, Box::new(FileStorage::new(&path)));
        assert_eq!(send(&mut c2, &mut s, "I130"), b"1500\r\x06");
        let listed = send(&mut c2, &mut s, "LIST PROG 7");
        assert!(
            listed.starts_with(b"DWE"),
            "{:?}",
            String::from_utf8_lossy(&listed)
        );
        // $$$*** restores factory I-variables (I3=1, I6=3) but keeps P.
        assert_eq!(send(&mut c2, &mut s, "$$$***"), b"\n");
        assert_eq!(send(&mut c2, &mut s, "P1"), b"\n5\r\n");
        assert_eq!(send(&mut c2, &mut s, "LIST PROG 7"), b"\x07\r\nERR003\r");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn corrupt_state_file_gives_factory_defaults_and_earom_bit() {
        let dir = std::env::temp_dir().join(format!("mcc-interp-corrupt-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let path = dir.join("card.state");
        std::fs::write(&path, b"MCCSAVE\0garbage").unwrap();
        let mut c = Card::with_storage(Profile::Pmac2, Box::new(FileStorage::new(&path)));
        let mut s = Session::default();
        assert_eq!(
            send(&mut c, &mut s, "I130 ???"),
            b"\n2000\r\n000400000800\r\n"
        );
        // A fresh SAVE replaces the bad file; the next start is clean.
        assert_eq!(send(&mut c, &mut s, "SAVE"), b"\n");
        let mut c2 = Card::with_storage(Profile::Pmac2, Box::new(FileStorage::new(&path)));
        assert_eq!(send(&mut c2, &mut s, "???"), b"\n000000000800\r\n");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// What the golden save file holds (written by `golden_card`, checked by the test).
    const GOLDEN_SETUP: &[&str] = &[
        "I3=2 I6=1 I130=1500 I1001=16 P1=5 P1023=0.25 Q3=7 M3->Y:$1FF0,4,8,S M4->*",
        "OPEN PROG 3 CLEAR LINEAR INC TA200 TS50 F5000 X10 Y-2.5 CLOSE",
        "OPEN PROG 4 CLEAR",
        "IF (P1>2) X(P1*2) ELSE DWELL 10 ENDIF",
        "WHILE (P2<3) P2=P2+1 ENDWHILE",
        "CMD\"#1J+\" SEND\"DONE\"",
        "CLOSE",
        "OPEN PLC 17 CLEAR P2=P2+1 IF (M3=1) P3=SIN(30) ENDIF CLOSE",
        "&1 #1->1000X #2->8660X-5000Y+10",
        "DEFINE GATHER 100",
    ];

    /// The golden file of save format 2 (`tests/golden/`): later versions must load it.
    fn golden_path() -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/golden/card-pmac2-format2.sav")
    }

    /// Regenerate with `MCC_WRITE_GOLDEN=1 cargo test -p mcc-card golden` (only when a new
    /// format version is introduced: the old file stays and a new one is added).
    #[test]
    fn golden_save_file_of_format_2_loads() {
        let path = golden_path();
        if std::env::var_os("MCC_WRITE_GOLDEN").is_some() {
            let mut c = Card::new(Profile::Pmac2);
            let mut s = Session::default();
            for l in GOLDEN_SETUP {
                let r = c.command_line(&mut s, l.as_bytes());
                assert!(!r.contains(&7), "{l}: {:?}", String::from_utf8_lossy(&r));
            }
            write_atomic(&path, &c.save_image()).unwrap();
        }
        let bytes = std::fs::read(&path).expect("the golden file is committed");
        assert_eq!(&bytes[..8], b"MCCSAVE\0");
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 2);
        let mut c = Card::with_storage(Profile::Pmac2, Box::new(FileStorage::new(&path)));
        let mut s = Session::default();
        let ask = |c: &mut Card, s: &mut Session, l: &str| {
            String::from_utf8_lossy(&c.command_line(s, l.as_bytes())).into_owned()
        };
        assert_eq!(
            ask(&mut c, &mut s, "???"),
            "000000000800\r\x06",
            "loaded cleanly"
        );
        assert_eq!(
            ask(&mut c, &mut s, "I130 I1001 P1 Q3 M3-> M4->"),
            "1500\r16\r5\r7\rY:$1FF0,4,8,S\r*\r\x06"
        );
        let listings = [
            ("LIST PROG 3", "LIN INC TA200 TS50 F5000 X10 Y-2.5\rRET\r\x06"),
            (
                "LIST PROG 4",
                "IF (P1>2) X(P1*2) ELSE DWE10 ENDI\rWHILE (P2<3) P2=P2+1 ENDW\rCMD\"#1J+\" SEND\"DONE\"\rRET\r\x06",
            ),
            ("LIST PLC 17", "P2=P2+1\rIF (M3=1)\rP3=SIN(30)\rENDI\rRET\r\x06"),
        ];
        // The same text a card that never saved lists.
        let mut fresh = Card::new(Profile::Pmac2);
        let mut fs = Session::default();
        for l in GOLDEN_SETUP {
            let _ = fresh.command_line(&mut fs, l.as_bytes());
        }
        for (cmd, want) in listings {
            assert_eq!(ask(&mut c, &mut s, cmd), want, "{cmd}");
            assert_eq!(ask(&mut fresh, &mut fs, cmd), want, "{cmd} (never saved)");
        }
        assert_eq!(
            ask(&mut c, &mut s, "&1 #1-> #2->"),
            "1000X\r8660X-5000Y+10\r\x06"
        );
        // PROG 4 loaded valid: R stops at motor 1 being open loop (ERR012), not at ERR016.
        assert_eq!(ask(&mut c, &mut s, "&1B4R"), "\x07ERR012\r");
    }

    #[test]
    fn a_save_file_of_a_newer_format_is_refused_with_a_clear_message() {
        let mut bytes = Card::new(Profile::Pmac2).save_image();
        bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
        let e = crate::model::persist::decode(&bytes)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("format version 4") && e.contains("reads versions 1 to 3"),
            "{e}"
        );
        let mut c = Card::new(Profile::Pmac2);
        let r = c.apply_loaded(crate::lang::EffectResult::Loaded(Ok(Some(bytes))));
        assert_eq!(r.unwrap_err(), e);
    }
}
