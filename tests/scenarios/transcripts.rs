//! Scenario tests: transcripts. Every `tests/transcripts/*.txt` file drives an in-process
//! `mcc_card::interp::Card` and compares its replies byte for byte.
//!
//! Format, one item per line:
//! - `# ...` comment; blank lines are ignored;
//! - `> text` send `text` followed by `<CR>` (escapes allowed, see below);
//! - `^X` send the control character CTRL-X (`^A` .. `^Z`);
//! - `< bytes` expected reply piece; consecutive `<` lines are concatenated (no newline added);
//!   a send followed by no `<` line must produce no reply at all;
//! - `@profile pmac2|turbo` start a fresh card with that profile (fresh state file);
//! - `@session n` switch to connection n (each has its own `#`/`&` addressing);
//! - `@restart` power-cycle: a new card loading the state file of the previous one.
//!
//! Escapes in `>` and `<` text: `\r`, `\n`, `\\`, `\xHH`.

use mcc_card::{Card, FileStorage, Profile, Session};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Decode the escapes of a transcript text.
fn unescape(s: &str) -> Result<Vec<u8>, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'\\' {
            out.push(b[i]);
            i += 1;
            continue;
        }
        match b.get(i + 1) {
            Some(b'r') => out.push(b'\r'),
            Some(b'n') => out.push(b'\n'),
            Some(b'\\') => out.push(b'\\'),
            Some(b'x') => {
                let hex = s.get(i + 2..i + 4).ok_or("short \\x escape")?;
                out.push(u8::from_str_radix(hex, 16).map_err(|e| format!("bad \\x{hex}: {e}"))?);
                i += 2;
            }
            other => return Err(format!("unknown escape {:?}", other.map(|c| *c as char))),
        }
        i += 2;
    }
    Ok(out)
}

/// Printable rendering of bytes for failure messages (same escapes as the format).
fn escape(b: &[u8]) -> String {
    let mut s = String::new();
    for &c in b {
        match c {
            b'\r' => s.push_str("\\r"),
            b'\n' => s.push_str("\\n"),
            b'\\' => s.push_str("\\\\"),
            0x20..=0x7E => s.push(c as char),
            _ => s.push_str(&format!("\\x{c:02X}")),
        }
    }
    s
}

enum Input {
    Line(Vec<u8>),
    Ctrl(u8),
}

struct Runner {
    name: String,
    dir: PathBuf,
    profile: Profile,
    generation: u32,
    card: Card,
    sessions: BTreeMap<u32, Session>,
    current: u32,
}

impl Runner {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("mcc-transcript-{}-{}", std::process::id(), name));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        let mut r = Runner {
            name: name.to_string(),
            card: Card::new(Profile::Pmac2),
            dir,
            profile: Profile::Pmac2,
            generation: 0,
            sessions: BTreeMap::new(),
            current: 0,
        };
        r.fresh(Profile::Pmac2);
        r
    }

    fn state_file(&self) -> PathBuf {
        self.dir.join(format!("card{}.state", self.generation))
    }

    fn fresh(&mut self, p: Profile) {
        self.generation += 1;
        self.profile = p;
        self.card = Card::with_storage(p, Box::new(FileStorage::new(self.state_file())));
        self.sessions.clear();
    }

    fn restart(&mut self) {
        self.card = Card::with_storage(self.profile, Box::new(FileStorage::new(self.state_file())));
        self.sessions.clear();
    }

    fn send(&mut self, input: &Input) -> Vec<u8> {
        let s = self.sessions.entry(self.current).or_default();
        match input {
            Input::Line(l) => self.card.command_line(s, l),
            Input::Ctrl(c) => self.card.control_char(s, *c),
        }
    }
}

/// Run one transcript; returns the list of mismatches.
fn run_transcript(path: &Path) -> Vec<String> {
    let name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("x")
        .to_string();
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => return vec![format!("{}: cannot read: {e}", path.display())],
    };
    let mut r = Runner::new(&name);
    let mut failures = Vec::new();
    // (line number, sent text, actual reply, expected pieces)
    let mut pending: Option<(usize, String, Vec<u8>, Vec<u8>)> = None;
    let check = |p: Option<(usize, String, Vec<u8>, Vec<u8>)>, failures: &mut Vec<String>| {
        if let Some((ln, sent, got, want)) = p {
            if got != want {
                failures.push(format!(
                    "{}:{ln}: `{sent}`\n     got: {}\n    want: {}",
                    r_name(path),
                    escape(&got),
                    escape(&want)
                ));
            }
        }
    };
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        if let Some(rest) = line.strip_prefix('<') {
            let piece = rest.strip_prefix(' ').unwrap_or(rest);
            match (&mut pending, unescape(piece)) {
                (Some(p), Ok(b)) => p.3.extend_from_slice(&b),
                (None, _) => failures.push(format!("{}:{ln}: `<` without a send", r_name(path))),
                (_, Err(e)) => failures.push(format!("{}:{ln}: {e}", r_name(path))),
            }
            continue;
        }
        check(pending.take(), &mut failures);
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let input = if let Some(rest) = line.strip_prefix('>') {
            let t = rest.strip_prefix(' ').unwrap_or(rest);
            match unescape(t) {
                Ok(b) => Input::Line(b),
                Err(e) => {
                    failures.push(format!("{}:{ln}: {e}", r_name(path)));
                    continue;
                }
            }
        } else if let Some(rest) = line.strip_prefix('^') {
            match rest.trim().as_bytes() {
                [c @ b'A'..=b'Z'] => Input::Ctrl(c - b'@'),
                _ => {
                    failures.push(format!("{}:{ln}: bad control line", r_name(path)));
                    continue;
                }
            }
        } else if let Some(rest) = line.strip_prefix('@') {
            let mut w = rest.split_whitespace();
            match (w.next(), w.next()) {
                (Some("profile"), Some("pmac2")) => r.fresh(Profile::Pmac2),
                (Some("profile"), Some("turbo")) => r.fresh(Profile::Turbo),
                (Some("session"), Some(n)) => match n.parse() {
                    Ok(n) => r.current = n,
                    Err(_) => failures.push(format!("{}:{ln}: bad session", r_name(path))),
                },
                (Some("restart"), None) => r.restart(),
                _ => failures.push(format!("{}:{ln}: unknown directive", r_name(path))),
            }
            continue;
        } else {
            failures.push(format!(
                "{}:{ln}: unrecognised transcript line",
                r_name(path)
            ));
            continue;
        };
        let got = r.send(&input);
        pending = Some((ln, line.to_string(), got, Vec::new()));
    }
    check(pending.take(), &mut failures);
    let _ = std::fs::remove_dir_all(&r.dir);
    let _ = r.name;
    failures
}

fn r_name(p: &Path) -> String {
    p.file_name()
        .and_then(|s| s.to_str())
        .unwrap_or("?")
        .to_string()
}

fn transcript_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("transcripts")
}

fn transcript_files() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(transcript_dir())
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "txt"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn transcript_escapes_round_trip() {
    assert_eq!(unescape(r"\x07ERR003\r").unwrap(), b"\x07ERR003\r");
    assert_eq!(unescape(r"a\\b\n").unwrap(), b"a\\b\n");
    assert!(unescape(r"\q").is_err());
    assert!(unescape(r"\x4").is_err());
    assert_eq!(escape(b"\x06\r\n\\"), r"\x06\r\n\\");
}

#[test]
fn all_transcripts_replay_byte_exact() {
    let files = transcript_files();
    assert!(
        files.len() >= 5,
        "expected transcript files in {}",
        transcript_dir().display()
    );
    let mut failures = Vec::new();
    for f in &files {
        failures.extend(run_transcript(f));
    }
    assert!(
        failures.is_empty(),
        "{} transcript mismatches:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
