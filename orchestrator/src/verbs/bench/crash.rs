//! `mcc bench save-crash --trials N [--seed S]`: card SAVE survives SIGKILL at random moments.
//!
//! One standalone card process (`mcc-card --standalone --state-file F`) with a large program
//! saves over and over; each save writes a new generation `k` everywhere at once (P1..P60 and
//! the one line of PROG 2), so a file that mixes two saves is seen. At a random moment the
//! process is killed with SIGKILL; a new process starts on the same file and must find:
//! - the old or the new state, never a mix and never a refused file: every P1..P60 and PROG 2
//!   hold the same generation, between the last acknowledged SAVE and the last one sent;
//! - the EAROM error bit (`???` word 1 bit 10) clear;
//! - no file beside the state file (a killed save's temporary is gone after the start).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::cli::BenchSaveCrashArgs;
use crate::cluster::launch::sibling_binary;

/// P-variables written with each generation.
const VARS: u32 = 60;
/// Lines of the large program saved with every SAVE.
const PROGRAM_LINES: u32 = 400;

/// The result of the trials.
#[derive(Debug, Default, Serialize)]
pub struct Report {
    /// Trials run (one SIGKILL each).
    pub trials: usize,
    /// SAVEs acknowledged over all trials.
    pub saves_acked: u64,
    /// Trials after which the file held the last acknowledged generation.
    pub found_old: usize,
    /// Trials after which the file held a generation whose SAVE was sent but not yet
    /// acknowledged (the kill came after the rename).
    pub found_new: usize,
    /// Trials killed while a SAVE was under way (sent, not acknowledged).
    pub killed_mid_save: usize,
    /// Temporary files a killed SAVE left, removed by the next start.
    pub temporaries_seen: usize,
    /// Size of the state file, bytes.
    pub file_bytes: u64,
    /// Wall time of the first SAVE, ms.
    pub save_ms: f64,
    /// Wall time of the first generation (its lines and its SAVE), ms: kills are spread over
    /// three of them.
    pub generation_ms: f64,
    /// What went wrong (empty: every trial found old or new state and no leaked file).
    pub failures: Vec<String>,
    /// Wall time, s.
    pub seconds: f64,
}

impl Report {
    /// Readable report.
    pub fn text(&self) -> String {
        let mut s = format!(
            "save-crash: {} trials (SIGKILL at a random moment), {} SAVEs acknowledged, state file {} bytes, a SAVE {:.1} ms, {:.0} s\n  \
             killed mid-SAVE: {}, found the last acknowledged state: {}, found the newer state: {}, \
             temporaries left by a kill and removed at the next start: {}\n",
            self.trials,
            self.saves_acked,
            self.file_bytes,
            self.save_ms,
            self.seconds,
            self.killed_mid_save,
            self.found_old,
            self.found_new,
            self.temporaries_seen,
        );
        if self.failures.is_empty() {
            s.push_str("  every trial: old or new state, never corrupt or mixed, no leaked file\n");
        } else {
            s.push_str(&format!("  {} failure(s):\n", self.failures.len()));
            for f in &self.failures {
                s.push_str(&format!("    {f}\n"));
            }
        }
        s
    }
}

/// Run the benchmark.
pub fn run(args: &BenchSaveCrashArgs) -> Result<()> {
    let dir = crate::cluster::rundir::base_dir().join(format!("save-crash-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let r = trials(&dir, args.trials as usize, args.seed);
    let _ = std::fs::remove_dir_all(&dir);
    let report = r?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.text());
    }
    if !report.failures.is_empty() {
        bail!("{} trial(s) found a bad state", report.failures.len());
    }
    Ok(())
}

/// A running standalone card and a connection to its ASCII port.
struct CardProc {
    child: Child,
    conn: TcpStream,
    /// Its stdout, kept open for its lifetime.
    _stdout: BufReader<std::process::ChildStdout>,
}

impl CardProc {
    fn start(state: &Path) -> Result<CardProc> {
        let mut child = Command::new(sibling_binary("mcc-card"))
            .args(["--standalone", "--ascii-port", "0", "--exit-on-stdin-eof"])
            .arg("--state-file")
            .arg(state)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .context("starting mcc-card")?;
        let out = child.stdout.take().ok_or_else(|| anyhow!("no stdout"))?;
        let mut line = String::new();
        let mut out = BufReader::new(out);
        out.read_line(&mut line)?;
        let ports: serde_json::Value = serde_json::from_str(line.trim())
            .with_context(|| format!("mcc-card printed {line:?}"))?;
        let port = ports["ascii"]
            .as_u64()
            .ok_or_else(|| anyhow!("no ascii port in {line:?}"))?;
        let conn = TcpStream::connect(("127.0.0.1", port as u16))?;
        conn.set_read_timeout(Some(Duration::from_secs(30)))?;
        let mut card = CardProc {
            child,
            conn,
            _stdout: out,
        };
        // Replies end in ACK from here on (the reply to this line already does).
        card.line("I3=2")?;
        Ok(card)
    }

    /// Send one line; the reply up to its ACK (an `ERRnnn` reply is an error).
    fn line(&mut self, line: &str) -> Result<String> {
        self.exchange(line)
            .with_context(|| format!("card: {line:?}"))
    }

    fn exchange(&mut self, line: &str) -> Result<String> {
        self.conn.write_all(line.as_bytes())?;
        self.conn.write_all(b"\r")?;
        let mut reply = Vec::new();
        let mut b = [0u8; 4096];
        loop {
            let n = self.conn.read(&mut b)?;
            if n == 0 {
                bail!("connection closed");
            }
            reply.extend_from_slice(&b[..n]);
            if reply.last() == Some(&0x06) {
                return Ok(String::from_utf8_lossy(&reply[..reply.len() - 1]).into_owned());
            }
            // A raw ASCII host port has no channel beside the bytes: its framing (I6=3
            // here, the card's default) is how it says ERRnnn.
            if reply.contains(&0x07) && reply.ends_with(b"\r") {
                bail!("{line:?} answered {:?}", String::from_utf8_lossy(&reply));
            }
        }
    }

    fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for CardProc {
    fn drop(&mut self) {
        self.kill();
    }
}

fn numbers(reply: &str) -> Vec<f64> {
    reply
        .split(|c: char| c.is_whitespace() || c.is_control())
        .filter(|s| !s.is_empty())
        .filter_map(|s| s.parse().ok())
        .collect()
}

/// Files in `dir` other than `state`.
fn others(dir: &Path, state: &Path) -> Result<Vec<PathBuf>> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir)? {
        let p = e?.path();
        if p != state {
            v.push(p);
        }
    }
    Ok(v)
}

/// The generation the card holds: P1..P60 and PROG 2's line agree, or an error naming the mix.
fn generation(card: &mut CardProc) -> Result<u64> {
    let p = numbers(&card.line(&format!("P1..{VARS}"))?);
    if p.len() != VARS as usize {
        bail!("P1..{VARS} answered {} values", p.len());
    }
    let listing = card.line("LIST PROG 2")?;
    let prog: Vec<f64> = listing
        .split(['=', '\r', '\n'])
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let g = p[0];
    if p.iter().any(|v| *v != g) || prog.first() != Some(&g) {
        bail!(
            "mixed state: P1..P{VARS} {:?}.., PROG 2 {listing:?}",
            &p[..p.len().min(8)]
        );
    }
    Ok(g as u64)
}

fn earom_error(card: &mut CardProc) -> Result<bool> {
    let r = card.line("???")?;
    let hex: String = r.chars().filter(char::is_ascii_hexdigit).collect();
    let w1 = hex
        .get(0..6)
        .and_then(|w| u32::from_str_radix(w, 16).ok())
        .ok_or_else(|| anyhow!("??? answered {r:?}"))?;
    Ok(w1 & (1 << 10) != 0)
}

fn save_generation(card: &mut CardProc, g: u64) -> Result<()> {
    let vars: Vec<String> = (1..=VARS).map(|n| format!("P{n}={g}")).collect();
    card.line(&vars.join(" "))?;
    card.line("OPEN PROG 2 CLEAR")?;
    card.line(&format!("P0={g}"))?;
    card.line("CLOSE")?;
    Ok(())
}

/// Run `n` trials in `dir`.
pub fn trials(dir: &Path, n: usize, seed: u64) -> Result<Report> {
    let t0 = Instant::now();
    let mut rng = StdRng::seed_from_u64(seed);
    let state = dir.join("card.sav");
    let mut report = Report::default();
    // Generation 1 and the large program, saved once before the first kill.
    {
        let mut card = CardProc::start(&state)?;
        card.line("OPEN PROG 1 CLEAR")?;
        for i in 0..PROGRAM_LINES {
            card.line(&format!("LINEAR X{i}.25 Y(P1+{i}) F10 DWELL 0"))?;
        }
        card.line("CLOSE")?;
        let t = Instant::now();
        save_generation(&mut card, 1)?;
        let lines = t.elapsed();
        card.line("SAVE")?;
        report.save_ms = (t.elapsed() - lines).as_secs_f64() * 1e3;
        report.generation_ms = t.elapsed().as_secs_f64() * 1e3;
    }
    // Kills land anywhere in the first three generations (their lines and SAVEs).
    let window_us = (report.generation_ms * 3.0 * 1e3) as u64 + 1;
    let mut acked = 1u64;
    let mut next = 2u64;
    for trial in 0..n {
        let mut card = CardProc::start(&state)?;
        // The state the last process left.
        let left = others(dir, &state)?;
        if !left.is_empty() {
            report
                .failures
                .push(format!("trial {trial}: files left after a start: {left:?}"));
        }
        match (generation(&mut card), earom_error(&mut card)) {
            (Ok(g), Ok(false)) if g == acked => report.found_old += usize::from(trial > 0),
            (Ok(g), Ok(false)) if g > acked && g < next => report.found_new += 1,
            (Ok(g), Ok(false)) => report.failures.push(format!(
                "trial {trial}: generation {g}, expected {acked}..{}",
                next - 1
            )),
            (Ok(_), Ok(true)) => report
                .failures
                .push(format!("trial {trial}: the state file was refused")),
            (Err(e), _) | (_, Err(e)) => report.failures.push(format!("trial {trial}: {e:#}")),
        }
        if let Ok(g) = generation(&mut card) {
            acked = acked.max(g);
        }
        // Save generations until a random moment, then SIGKILL.
        let pid = card.child.id();
        let delay = Duration::from_micros(rng.random_range(0..window_us));
        let killer = std::thread::spawn(move || {
            std::thread::sleep(delay);
            let _ = crate::cluster::sys::signal(pid, libc::SIGKILL);
        });
        let mut mid = false;
        loop {
            let g = next;
            next += 1;
            if let Err(e) = save_generation(&mut card, g) {
                tracing::debug!("trial {trial}: {e:#}");
                break;
            }
            mid = true;
            match card.line("SAVE") {
                Ok(_) => {
                    acked = g;
                    report.saves_acked += 1;
                    mid = false;
                }
                Err(e) => {
                    tracing::debug!("trial {trial}: {e:#}");
                    break;
                }
            }
        }
        let _ = killer.join();
        card.kill();
        report.killed_mid_save += usize::from(mid);
        report.temporaries_seen += others(dir, &state)?
            .iter()
            .filter(|p| p.to_string_lossy().contains(".tmp"))
            .count();
        report.trials += 1;
    }
    // The last kill, checked once more.
    let mut card = CardProc::start(&state)?;
    match (generation(&mut card), earom_error(&mut card)) {
        (Ok(g), Ok(false)) if g == acked => report.found_old += 1,
        (Ok(g), Ok(false)) if g > acked && g < next => report.found_new += 1,
        (Ok(g), Ok(false)) => report.failures.push(format!(
            "after the last trial: generation {g}, expected {acked}..{}",
            next - 1
        )),
        (Ok(_), Ok(true)) => report
            .failures
            .push("after the last trial: the state file was refused".into()),
        (Err(e), _) | (_, Err(e)) => report.failures.push(format!("after the last trial: {e:#}")),
    }
    drop(card);
    report.file_bytes = std::fs::metadata(&state).map(|m| m.len()).unwrap_or(0);
    report.seconds = t0.elapsed().as_secs_f64();
    Ok(report)
}
