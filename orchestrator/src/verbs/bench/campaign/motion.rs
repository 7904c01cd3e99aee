//! The motion the campaign keeps running on every card: program 1 moves motor 1 back and forth
//! for ever (counting its passes in P101); program 2 is a finite move list ending at a fixed
//! point (it sets P100 = 1 when done), run once before the campaign to get each card's end
//! position and again after every recovery, which must end at the same position. Power
//! cards get the same programs in Power syntax ([`POWER_SETUP`]) and are read in their own
//! status format (`#1?`: `Motor[1].Status[0..1]`, 8 hex digits each).

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::control::card_cmd_key;

use crate::cluster::ctl::query_card;

/// Largest reply accepted from a card's command queryable, bytes.
const MAX_REPLY: usize = 1 << 20;

/// Lines that (re)load both programs and close motor 1's loop. After `$$$` the programs are
/// gone (they were never saved), so every recovery sends them again.
pub const SETUP: &[&str] = &[
    "&1#1->1000X",
    "OPEN PROG 1 CLEAR",
    "LINEAR ABS TA20 TS0 F20",
    "WHILE (1 < 2)",
    "X2",
    "X0",
    "P101=P101+1",
    "ENDWHILE",
    "CLOSE",
    "OPEN PROG 2 CLEAR",
    "LINEAR ABS TA20 TS0 F20",
    "X1",
    "X3",
    "X2.5",
    "DWELL 20",
    "P100=1",
    "CLOSE",
    "#1J/",
];

/// [`SETUP`] in Power syntax (`while (…) {…}`, lower-case commands).
pub const POWER_SETUP: &[&str] = &[
    "&1#1->1000X",
    "open prog 1",
    "linear abs ta20 ts0 f20",
    "while (1 < 2) {",
    "X2",
    "X0",
    "P101=P101+1",
    "}",
    "close",
    "open prog 2",
    "linear abs ta20 ts0 f20",
    "X1",
    "X3",
    "X2.5",
    "dwell 20",
    "P100=1",
    "close",
    "#1j/",
];

/// Card `n` is a Power card.
pub fn is_power(cfg: &ClusterConfig, n: u8) -> bool {
    cfg.cards
        .iter()
        .any(|c| c.number == n && c.profile == "power")
}

/// How far program 2's end position may differ from the reference, counts.
pub const END_TOLERANCE: f64 = 2.0;

/// One line to card `number` through its command queryable; the reply text without framing.
/// A refused line (the card's refusal, whatever its I6 printed) is an error.
pub fn send(s: &zenoh::Session, cfg: &ClusterConfig, number: u8, line: &str) -> Result<String> {
    let r = send_framed(s, cfg, number, line)?;
    Ok(
        r.trim_matches(|c: char| c.is_control() || c.is_whitespace())
            .to_string(),
    )
}

/// [`send`] with the reply as the card frames it (what its host ports write).
pub fn send_framed(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    number: u8,
    line: &str,
) -> Result<String> {
    let key = card_cmd_key(&cfg.cluster, u32::from(number));
    let a = query_card(s, &key, line, Duration::from_secs(5), MAX_REPLY)?;
    let r = String::from_utf8_lossy(&a.bytes).into_owned();
    if let Some(e) = a.refusal {
        bail!("card {number}: {line:?} refused ({e}): {r:?}");
    }
    Ok(r)
}

/// A numeric reply.
pub fn number(s: &zenoh::Session, cfg: &ClusterConfig, n: u8, line: &str) -> Result<f64> {
    let r = send(s, cfg, n, line)?;
    // A Power card names what it prints (`P100=1`).
    r.rsplit('=')
        .next()
        .unwrap_or_default()
        .parse()
        .map_err(|_| anyhow!("card {n}: {line:?} answered {r:?}, not a number"))
}

/// Reset every card (`$$$`: programs stop, motors are killed), load the programs and close
/// the motors' loops.
pub fn setup(s: &zenoh::Session, cfg: &ClusterConfig) -> Result<()> {
    for c in &cfg.cards {
        send(s, cfg, c.number, "$$$")?;
    }
    // A motor killed at speed coasts: closing its loop before it stands still trips the
    // fatal following error.
    for c in &cfg.cards {
        let t0 = Instant::now();
        let mut still = 0;
        while still < 3 {
            let v = number(s, cfg, c.number, "#1V")?;
            still = if v.abs() < 0.5 { still + 1 } else { 0 };
            if t0.elapsed() > Duration::from_secs(60) {
                bail!(
                    "card {}: motor 1 still moving ({v}) a minute after the reset",
                    c.number
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    for c in &cfg.cards {
        let lines = if c.profile == "power" {
            POWER_SETUP
        } else {
            SETUP
        };
        for line in lines {
            send(s, cfg, c.number, line)?;
        }
    }
    // Let the `#1J/` settle (a jog in progress refuses R).
    std::thread::sleep(Duration::from_millis(100));
    Ok(())
}

/// Run program 2 on every card; the end position of each card's motor 1.
pub fn run_to_end(s: &zenoh::Session, cfg: &ClusterConfig, timeout: Duration) -> Result<Vec<f64>> {
    for c in &cfg.cards {
        send(s, cfg, c.number, "P100=0")?;
        // The jog that closed the loop may still be under way (ring cycles are slow on a
        // loaded machine): wait for its move timer, then retry R for a while.
        let t0 = Instant::now();
        while moving(s, cfg, c.number)? {
            if t0.elapsed() > timeout {
                bail!("card {}: motor 1's jog did not end", c.number);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let t0 = Instant::now();
        loop {
            match send(s, cfg, c.number, "&1b2r") {
                Ok(_) => break,
                Err(e) if t0.elapsed() > Duration::from_secs(30) => {
                    let why = ["#1?", "#1P", "??", "???"]
                        .iter()
                        .map(|q| format!("{q} {}", send(s, cfg, c.number, q).unwrap_or_default()))
                        .collect::<Vec<_>>()
                        .join(", ");
                    return Err(e.context(format!("card {}: {why}", c.number)));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        }
    }
    let deadline = Instant::now() + timeout;
    let mut ends = Vec::new();
    for c in &cfg.cards {
        loop {
            // The program has passed its last line and the motor is in position (no move or
            // dwell timer running, following error small).
            if number(s, cfg, c.number, "P100")? == 1.0 && in_position(s, cfg, c.number)? {
                break;
            }
            if Instant::now() > deadline {
                let why = [
                    "P100", "#1?", "#1P", "#1F", "&1?", "??", "???", "I1001", "I1004",
                ]
                .iter()
                .map(|q| format!("{q} {}", send(s, cfg, c.number, q).unwrap_or_default()))
                .collect::<Vec<_>>()
                .join(", ");
                bail!("card {}: program 2 did not end ({why})", c.number);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        ends.push(number(s, cfg, c.number, "#1P")?);
    }
    Ok(ends)
}

/// `#1?` word 1 bit 17: move timer active.
const MOVE_TIMER: u32 = 1 << 17;

/// Motor 1's status words (`#1?`: two 24-bit words, a Power card's two 32-bit ones).
fn motor_words(s: &zenoh::Session, cfg: &ClusterConfig, n: u8) -> Result<[u32; 2]> {
    let r = send(s, cfg, n, "#1?")?;
    let w = if is_power(cfg, n) { 8 } else { 6 };
    let word = |k: usize| {
        r.get(w * k..w * k + w)
            .and_then(|w| u32::from_str_radix(w, 16).ok())
            .ok_or_else(|| anyhow!("card {n}: #1? answered {r:?}"))
    };
    Ok([word(0)?, word(1)?])
}

/// Power `Motor[x].Status[0]` bit 14: desired velocity zero; bit 11: in position.
const POWER_DES_VEL_ZERO: u32 = 1 << 14;
const POWER_IN_POS: u32 = 1 << 11;

/// Motor 1's jog is still under way (PMAC: move timer; Power: desired velocity not zero).
fn moving(s: &zenoh::Session, cfg: &ClusterConfig, n: u8) -> Result<bool> {
    let w = motor_words(s, cfg, n)?[0];
    Ok(if is_power(cfg, n) {
        w & POWER_DES_VEL_ZERO == 0
    } else {
        w & MOVE_TIMER != 0
    })
}

/// Motor 1 is in position (`#1?` second word, bit 0; Power `Status[0]` bit 11).
pub fn in_position(s: &zenoh::Session, cfg: &ClusterConfig, n: u8) -> Result<bool> {
    let w = motor_words(s, cfg, n)?;
    Ok(if is_power(cfg, n) {
        w[0] & POWER_IN_POS != 0
    } else {
        w[1] & 1 == 1
    })
}

/// Start program 1 (endless) on every card.
pub fn start_endless(s: &zenoh::Session, cfg: &ClusterConfig) -> Result<()> {
    for c in &cfg.cards {
        send(s, cfg, c.number, "&1b1r")?;
    }
    Ok(())
}
