//! `mcc gather --card N [--motors 1,2] [--cycles K] [--period P] [--run LINE] [--out DIR]`:
//! record motor positions with the card's own data gathering (pmac-variables I19-I45,
//! `DEFINE GATHER` / `GATHER` / `ENDGATHER` / `LIST GATHER`) through its command queryable
//! `mcc/<cluster>/card/<n>/cmd`, then write `gather.csv` and `gather.png`.
//!
//! Sources: for each motor x (1-8, the motors with a register block) its commanded position
//! D:$0028 and actual position D:$002B (+ (x-1)·$3C), 48-bit words in 1/(Ix08·32) counts
//! (card/src/servo/registers.rs); I21.. = `$80xxxx` (the X:Y pair). One sample every I19 = P
//! servo cycles; the buffer holds exactly the samples of K cycles, so gathering stops by
//! itself when full. `GATHER` runs through the synchronized start (`mcc start-sync`): on every
//! card given in the tick of one ring cycle T, so sample k is ring cycle T + k·P on each of
//! them; `--run LINE` runs in that same tick (`GATHER LINE`, e.g. `#1J=2000` or `&1B1R`), so
//! the move is recorded from its start. `--json` prints the samples with their ring cycles.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};

use crate::cli::GatherArgs;
use crate::cluster::attach::attach;
use crate::cluster::ctl::query_card;

#[path = "gather_plot.rs"]
mod plot;

/// Motors with gatherable position registers (PMAC2 register blocks).
pub const MAX_MOTOR: u16 = 8;
/// Most servo cycles one gather may cover.
pub const MAX_CYCLES: u64 = 1_000_000;
/// Most samples one gather may hold.
pub const MAX_SAMPLES: u64 = 100_000;
/// Largest command reply accepted, bytes.
const MAX_REPLY: usize = 16 << 20;

/// Commanded position register of motor `x` (D:, 1/(Ix08·32) counts).
pub fn commanded_addr(x: u16) -> u32 {
    0x0028 + u32::from(x - 1) * 0x3C
}

/// Actual position register of motor `x`.
pub fn actual_addr(x: u16) -> u32 {
    0x002B + u32::from(x - 1) * 0x3C
}

/// A decoded recording: per sample, per motor (commanded, actual) in counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Motors, in column order.
    pub motors: Vec<u16>,
    /// Servo cycles between samples (I19).
    pub period: u32,
    /// Servo cycle length, ms (I10 / 8388608).
    pub cycle_ms: f64,
    /// Samples: per motor (commanded, actual), counts.
    pub samples: Vec<Vec<(f64, f64)>>,
}

/// Parse `--motors 1,2`: numbers 1-8, no repeats; a message naming the problem.
pub fn parse_motors(s: &str) -> Result<Vec<u16>, String> {
    let mut v = Vec::new();
    for w in s.split(',').map(str::trim).filter(|w| !w.is_empty()) {
        let m: u16 = w
            .parse()
            .map_err(|_| format!("motor {w:?} is not a number 1-{MAX_MOTOR}"))?;
        if !(1..=MAX_MOTOR).contains(&m) {
            return Err(format!(
                "motor {m}: only motors 1-{MAX_MOTOR} have gatherable registers"
            ));
        }
        if v.contains(&m) {
            return Err(format!("motor {m} is listed twice"));
        }
        v.push(m);
    }
    if v.is_empty() {
        return Err("no motors given (e.g. --motors 1,2)".into());
    }
    Ok(v)
}

/// The set-up line: period, source mask and sources (commanded, actual per motor).
pub fn setup_line(motors: &[u16], period: u32) -> String {
    let n = motors.len() * 2;
    let mut s = format!("I19={period} I20=${:X}", (1u32 << n) - 1);
    for (k, &m) in motors.iter().enumerate() {
        let i = 21 + 2 * k;
        s.push_str(&format!(
            " I{i}=$80{:04X} I{}=$80{:04X}",
            commanded_addr(m),
            i + 1,
            actual_addr(m)
        ));
    }
    s
}

/// The 12-hex-digit words of a `LIST GATHER` reply, in order (framing characters ignored).
pub fn parse_words(reply: &[u8]) -> Result<Vec<u64>, String> {
    let text = String::from_utf8_lossy(reply);
    let mut out = Vec::new();
    for tok in text.split(|c: char| !c.is_ascii_alphanumeric()) {
        if tok.is_empty() {
            continue;
        }
        if tok.len() != 12 {
            return Err(format!("unexpected {tok:?} in the LIST GATHER reply"));
        }
        out.push(u64::from_str_radix(tok, 16).map_err(|_| format!("{tok:?} is not hex"))?);
    }
    Ok(out)
}

/// A 48-bit two's-complement word in 1/(Ix08·32) counts, as counts.
pub fn counts(word: u64, ix08: f64) -> f64 {
    let w = word & 0xFFFF_FFFF_FFFF;
    let v = if w & (1 << 47) != 0 {
        (w as i64 - (1i64 << 48)) as f64
    } else {
        w as f64
    };
    v / (ix08 * 32.0)
}

/// Group words into samples (commanded, actual per motor); a trailing partial sample is
/// dropped. `ix08[k]` is motor k's position scale.
pub fn decode(words: &[u64], ix08: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let per = ix08.len() * 2;
    if per == 0 {
        return Vec::new();
    }
    words
        .chunks_exact(per)
        .map(|s| {
            s.chunks_exact(2)
                .zip(ix08)
                .map(|(p, &k)| (counts(p[0], k), counts(p[1], k)))
                .collect()
        })
        .collect()
}

impl Recording {
    /// The CSV text: `cycle,time_ms,m{x}_commanded,m{x}_actual,...` (cycle: servo cycles
    /// after the first sample).
    pub fn csv(&self) -> String {
        let mut s = String::from("cycle,time_ms");
        for m in &self.motors {
            s.push_str(&format!(",m{m}_commanded,m{m}_actual"));
        }
        s.push('\n');
        for (k, row) in self.samples.iter().enumerate() {
            let cycle = k as u64 * u64::from(self.period);
            s.push_str(&format!("{cycle},{:.4}", cycle as f64 * self.cycle_ms));
            for (c, a) in row {
                s.push_str(&format!(",{c:.4},{a:.4}"));
            }
            s.push('\n');
        }
        s
    }
}

/// One command line on the card's cmd queryable; its reply, or the card's refusal.
fn cmd(session: &zenoh::Session, key: &str, line: &str) -> Result<Vec<u8>> {
    let a = query_card(session, key, line, Duration::from_secs(5), MAX_REPLY)?;
    if let Some(r) = a.refusal {
        let text: String = String::from_utf8_lossy(&a.bytes)
            .chars()
            .filter(|c| !c.is_control())
            .collect();
        bail!("the card refused {line:?}: {r} {text}");
    }
    Ok(a.bytes)
}

/// A numeric reply (`I108` → 96).
fn value(session: &zenoh::Session, key: &str, line: &str) -> Result<f64> {
    let r = cmd(session, key, line)?;
    let text = String::from_utf8_lossy(&r);
    text.split(|c: char| c.is_control() || c.is_whitespace())
        .find_map(|t| t.parse::<f64>().ok())
        .ok_or_else(|| anyhow!("no number in the card's answer to {line:?}: {text:?}"))
}

/// The card's latest ring cycle (its `at` queryable).
fn card_cycle(session: &zenoh::Session, cluster: &str, n: u32) -> Result<u64> {
    let body = mcc_contracts::control::AtRequest::Info.to_json();
    let (r, _) = crate::cluster::sync_start::query_all(
        session,
        cluster,
        &[(n, body)],
        Duration::from_secs(2),
    )
    .pop()
    .ok_or_else(|| anyhow!("card {n}: no answer"))?;
    r?.cycle
        .ok_or_else(|| anyhow!("card {n} has not ticked yet: is the ring running?"))
}

/// Wait until card `n` has run ring cycle `target` (bounded: the ring must move).
fn wait_cycle(session: &zenoh::Session, cluster: &str, n: u32, target: u64) -> Result<()> {
    let mut last = card_cycle(session, cluster, n)?;
    let mut moved = Instant::now();
    while last < target {
        std::thread::sleep(Duration::from_millis(20));
        let c = card_cycle(session, cluster, n)?;
        if c != last {
            (last, moved) = (c, Instant::now());
        } else if moved.elapsed() > Duration::from_secs(10) {
            bail!("card {n}'s ring cycle stayed at {c} for 10 s: is the ring running?");
        }
    }
    Ok(())
}

/// One card's part of a gather: its cmd key and the position scales of the motors.
struct Source {
    card: u32,
    key: String,
    ix08: Vec<f64>,
    cycle_ms: f64,
}

/// Read the scales and set up (but not start) gathering on one card.
fn prepare(
    s: &zenoh::Session,
    key: String,
    card: u32,
    motors: &[u16],
    args: &GatherArgs,
    words: u64,
) -> Result<Source> {
    let mut ix08 = Vec::new();
    for &m in motors {
        let k = value(s, &key, &format!("I{m}08"))?;
        if !(k.is_finite() && k > 0.0) {
            bail!("card {card}: motor {m}: I{m}08 = {k} is not a usable position scale");
        }
        ix08.push(k);
    }
    let i10 = value(s, &key, "I10")?;
    // A gather left running or defined by someone else goes first.
    let _ = cmd(s, &key, "ENDGATHER");
    let _ = cmd(s, &key, "DELETE GATHER");
    cmd(s, &key, &setup_line(motors, args.period))?;
    cmd(s, &key, &format!("DEFINE GATHER {words}"))?;
    Ok(Source {
        card,
        key,
        ix08,
        cycle_ms: if i10 > 0.0 { i10 / 8_388_608.0 } else { 0.0 },
    })
}

/// `mcc gather`.
pub fn cmd_gather(cluster: &str, args: &GatherArgs) -> Result<()> {
    let motors = parse_motors(&args.motors).map_err(anyhow::Error::msg)?;
    let cards = crate::cluster::sync_start::parse_cards(&args.card).map_err(anyhow::Error::msg)?;
    if cards.is_empty() {
        bail!("--card: no card given (e.g. --card 0 or --card 0,1)");
    }
    if args.cycles == 0 || args.cycles > MAX_CYCLES {
        bail!("--cycles must be 1-{MAX_CYCLES}");
    }
    if args.period == 0 || u64::from(args.period) > args.cycles {
        bail!("--period must be 1-{} (the cycles to record)", args.cycles);
    }
    let samples = args.cycles / u64::from(args.period) + 1;
    if samples > MAX_SAMPLES {
        bail!("{samples} samples are too many (at most {MAX_SAMPLES}: raise --period)");
    }
    if args
        .run
        .as_deref()
        .is_some_and(|r| r.contains(['\r', '\n']))
    {
        bail!("--run: one command line (no line breaks)");
    }
    let a = attach(cluster)?;
    for &n in &cards {
        if !a.cfg.cards.iter().any(|c| u32::from(c.number) == n) {
            let have: Vec<String> = a.cfg.cards.iter().map(|c| c.number.to_string()).collect();
            bail!(
                "cluster {cluster:?} has no card {n} (cards: {})",
                have.join(", ")
            );
        }
    }
    let s = &a.session;
    let words = samples * motors.len() as u64 * 2;
    let mut sources = Vec::new();
    for &n in &cards {
        let key = mcc_ring::control::card_cmd_key(&a.cfg.cluster, n);
        sources.push(prepare(s, key, n, &motors, args, words)?);
    }
    // GATHER (and the --run line) on every card in the tick of one ring cycle T: the first
    // sample is taken in that tick, sample k at T + k·period.
    let line = match &args.run {
        Some(r) => format!("GATHER {r}"),
        None => "GATHER".to_string(),
    };
    let res = (|| {
        let start = crate::cluster::sync_start::start_sync(
            s,
            &a.cfg.cluster,
            &cards,
            &line,
            &crate::cluster::sync_start::SyncOptions::default(),
        )
        .context("starting the gather")?;
        for c in &start.cards {
            if c.raw_reply.contains('\u{7}') {
                bail!("card {} refused {line:?}: {}", c.card, c.reply);
            }
        }
        // For scripts that start motion of their own while this records.
        eprintln!(
            "mcc gather: gathering from ring cycle {} on card(s) {}",
            start.cycle, args.card
        );
        let end = start.cycle + args.cycles + 1;
        for &n in &cards {
            wait_cycle(s, &a.cfg.cluster, n, end)?;
        }
        let mut listed = Vec::new();
        for src in &sources {
            cmd(s, &src.key, "ENDGATHER")?;
            listed.push(cmd(s, &src.key, "LIST GATHER")?);
        }
        Ok((start.cycle, listed))
    })();
    for src in &sources {
        let _ = cmd(s, &src.key, "ENDGATHER");
        let _ = cmd(s, &src.key, "DELETE GATHER");
    }
    let (first_cycle, listed) = res?;
    let mut recs = Vec::new();
    for (src, reply) in sources.iter().zip(&listed) {
        let words = parse_words(reply).map_err(anyhow::Error::msg)?;
        let rec = Recording {
            samples: decode(&words, &src.ix08),
            motors: motors.clone(),
            period: args.period,
            cycle_ms: src.cycle_ms,
        };
        if rec.samples.is_empty() {
            bail!(
                "card {} gathered no samples: is its servo loop running?",
                src.card
            );
        }
        recs.push((src.card, rec));
    }
    if args.json {
        println!("{}", json_doc(first_cycle, &recs));
    }
    let out = match (&args.out, args.json) {
        (Some(d), _) => Some(d.clone()),
        (None, false) => Some(PathBuf::from(".")),
        (None, true) => None,
    };
    if let Some(dir) = out {
        let several = recs.len() > 1;
        for (card, rec) in &recs {
            let stem = if several {
                format!("gather-card{card}")
            } else {
                "gather".to_string()
            };
            write_outputs(rec, &dir, *card, &stem, !args.json)?;
        }
    }
    Ok(())
}

/// The `--json` document: `first_cycle` (ring cycle of sample 0), `period`, `cycle_ms`,
/// `motors`, and per card `cycle` (ring cycle of each sample), `commanded`/`actual` per motor.
pub fn json_doc(first_cycle: u64, recs: &[(u32, Recording)]) -> serde_json::Value {
    let cards: Vec<serde_json::Value> = recs
        .iter()
        .map(|(card, rec)| {
            let cycles: Vec<u64> = (0..rec.samples.len() as u64)
                .map(|k| first_cycle + k * u64::from(rec.period))
                .collect();
            let mut commanded = serde_json::Map::new();
            let mut actual = serde_json::Map::new();
            for (i, m) in rec.motors.iter().enumerate() {
                let col = |f: fn(&(f64, f64)) -> f64| -> Vec<f64> {
                    rec.samples.iter().filter_map(|r| r.get(i).map(f)).collect()
                };
                commanded.insert(m.to_string(), col(|p| p.0).into());
                actual.insert(m.to_string(), col(|p| p.1).into());
            }
            serde_json::json!({
                "card": card,
                "cycle_ms": rec.cycle_ms,
                "cycle": cycles,
                "commanded": commanded,
                "actual": actual,
            })
        })
        .collect();
    let first = recs.first().map(|(_, r)| r);
    serde_json::json!({
        "first_cycle": first_cycle,
        "period": first.map(|r| r.period).unwrap_or(1),
        "motors": first.map(|r| r.motors.clone()).unwrap_or_default(),
        "cards": cards,
    })
}

fn write_outputs(rec: &Recording, dir: &Path, card: u32, stem: &str, talk: bool) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let csv: PathBuf = dir.join(format!("{stem}.csv"));
    std::fs::write(&csv, rec.csv()).with_context(|| format!("writing {}", csv.display()))?;
    let png = dir.join(format!("{stem}.png"));
    let labelled = plot::draw(rec, &png, &format!("card {card}"))
        .with_context(|| format!("drawing {}", png.display()))?;
    if talk {
        println!(
            "card {card}: {} samples of motor(s) {:?} every {} servo cycle(s) ({:.3} ms)",
            rec.samples.len(),
            rec.motors,
            rec.period,
            rec.cycle_ms * f64::from(rec.period)
        );
        println!("wrote {} and {}", csv.display(), png.display());
    }
    if !labelled {
        eprintln!("mcc gather: no TrueType font found (set MCC_PLOT_FONT=FILE.ttf): plot drawn without text");
    }
    Ok(())
}

#[cfg(test)]
#[path = "gather_tests.rs"]
mod tests;
