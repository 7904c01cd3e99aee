//! The campaign's host-link faults: one reply of a card's text port (the ASCII port of a
//! PMAC2/Turbo card, a Power card's raw gpascii port) faulted as `mcc fault CARD link KIND`
//! does, judged against the link-fault model ([`mcc_ring::linkfault`]) on the card's true
//! reply. The host:
//! 1. asks the card's command queryable for the replies to `P199=w P199` (a write and a read
//!    on one line) and to the sentinel `P197`, and sends the same `P199=w P199` on the port
//!    with no fault installed: the port must write exactly the queryable's bytes, so the
//!    model is applied to what the port really writes;
//! 2. installs the fault (one reply, probability 1) and sends `P199=v P199` (its true reply:
//!    `w`'s with `v`'s digits, both of four), then the sentinel `P197`;
//! 3. must read exactly the model's bytes for the faulted reply (nothing, late by the delay,
//!    cut short, a stray byte, a flipped bit; a reset closes the connection with nothing
//!    written), then the sentinel's whole reply;
//! 4. reads `P199` back through the queryable: the write is stored whatever the reply went
//!    through.
//!
//! Every wait is a generous bound on a reply that is due, never the thing judged, except
//! the late kind's delay, which is a lower bound the port must keep.

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::control::FaultRequest;
use mcc_ring::linkfault::{LinkFaultSpec, LinkFaulter};

use super::motion::send_framed;
use super::observe;
use super::plan::Planned;
use super::report::Outcome;

/// What a Power card's gpascii port writes first (not a reply: never faulted).
const GPASCII_BANNER: &[u8] = b"STDIN Open for ASCII Input\n";

/// How long a due reply may take on a loaded machine.
const DUE: Duration = Duration::from_secs(20);

/// Judge one host-link fault on card `p.target` (see the module docs); violations go to `o`.
pub fn judge(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    p: &Planned,
    spec: &LinkFaultSpec,
    o: &mut Outcome,
) -> Result<()> {
    let (target, card) = super::target_card(cfg, p)?;
    let power = card.profile == "power";
    let snap = observe::snapshot(s, cfg);
    let port = snap
        .member(p.target)
        .and_then(|m| m.extra.get(if power { "gpascii" } else { "ascii" }))
        .and_then(serde_json::Value::as_u64)
        .ok_or_else(|| anyhow!("{target}: mcc status gives no text port"))?;
    // Values of their own per fault, so a stale reply cannot pass for a fresh one.
    let v = 1000 + p.index as u64 % 8000;
    let (w, sentinel) = (v + 1, v + 2);
    let w_line = format!("P199={w} P199");
    let raw = |line: &str| send_framed(s, cfg, card.number, line);
    let w_reply = raw(&w_line)?;
    raw(&format!("P197={sentinel}"))?;
    let sentinel_reply = raw("P197")?.into_bytes();

    let port = u16::try_from(port).map_err(|_| anyhow!("{target}: text port {port}"))?;
    let mut conn = TcpStream::connect(("127.0.0.1", port))
        .with_context(|| format!("{target}: connect to its text port {port}"))?;
    conn.set_nodelay(true)?;
    if power {
        expect_exactly(&mut conn, GPASCII_BANNER, DUE)
            .with_context(|| format!("{target}: the gpascii banner"))?;
    }
    // The port writes what the queryable answers (the model's input is the port's own reply).
    conn.write_all(format!("{w_line}\r").as_bytes())?;
    let got = expect_exactly(&mut conn, w_reply.as_bytes(), DUE)
        .with_context(|| format!("{target}: unfaulted {w_line:?} on the port"))?;
    if got != w_reply.as_bytes() {
        o.violations.push(format!(
            "{target}: the port answered {w_line:?} with {got:?}, the card with {w_reply:?}"
        ));
        return Ok(());
    }

    let fault = serde_json::json!({ "link": spec });
    super::fault_request(s, cfg, &target, &FaultRequest::App { fault })?;
    // The faulted line writes v and reads it: its true reply is w's with v's digits.
    let line_truth = w_reply.replace(&w.to_string(), &v.to_string()).into_bytes();
    let want = LinkFaulter::new(spec.clone()).on_reply(&line_truth);
    let t0 = Instant::now();
    conn.write_all(format!("P199={v} P199\r").as_bytes())?;
    if want.reset {
        let got = read_to_end(&mut conn, DUE)?;
        if got != want.bytes {
            o.violations.push(format!(
                "{target}: link {} wrote {got:?} before the reset, the model {:?}",
                spec.kind, want.bytes
            ));
        }
    } else {
        conn.write_all(b"P197\r")?;
        let mut expect = want.bytes.clone();
        expect.extend_from_slice(&sentinel_reply);
        let due = DUE + Duration::from_millis(want.delay_ms);
        let got = expect_exactly(&mut conn, &expect, due).unwrap_or_else(|e| {
            o.violations
                .push(format!("{target}: link {}: {e:#}", spec.kind));
            Vec::new()
        });
        let late = t0.elapsed();
        if !got.is_empty() && got != expect {
            o.violations.push(format!(
                "{target}: link {} (seed {}): the host read {got:?}, the model says {expect:?}",
                spec.kind, spec.seed
            ));
        }
        if late < Duration::from_millis(want.delay_ms) {
            o.violations.push(format!(
                "{target}: link late by {} ms answered after {} ms",
                want.delay_ms,
                late.as_millis()
            ));
        }
        let _ = conn.shutdown(Shutdown::Both);
    }
    let stored = super::motion::number(s, cfg, card.number, "P199")?;
    if stored != v as f64 {
        o.violations.push(format!(
            "{target}: P199 reads {stored} after `P199={v}` through link {}: a host-link fault changed what is stored",
            spec.kind
        ));
    }
    Ok(())
}

/// Read until `want.len()` bytes came (or the connection ended, or `due` passed), then a
/// moment more for bytes beyond them; what was read.
fn expect_exactly(conn: &mut TcpStream, want: &[u8], due: Duration) -> Result<Vec<u8>> {
    let start = Instant::now();
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    while got.len() < want.len() {
        let left = due.saturating_sub(start.elapsed());
        if left.is_zero() {
            bail!("read {got:?} of {want:?} within {} s", due.as_secs());
        }
        conn.set_read_timeout(Some(left.min(Duration::from_millis(200))))?;
        match conn.read(&mut buf) {
            Ok(0) => bail!("the connection ended after {got:?}, {want:?} expected"),
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => bail!("read after {got:?}: {e}"),
        }
    }
    // Anything more already on its way shows as a difference.
    conn.set_read_timeout(Some(Duration::from_millis(100)))?;
    if let Ok(n) = conn.read(&mut buf) {
        got.extend_from_slice(&buf[..n]);
    }
    Ok(got)
}

/// Read until the peer closes or resets the connection (within `due`).
fn read_to_end(conn: &mut TcpStream, due: Duration) -> Result<Vec<u8>> {
    let start = Instant::now();
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    loop {
        let left = due.saturating_sub(start.elapsed());
        if left.is_zero() {
            bail!("the connection was not reset within {} s", due.as_secs());
        }
        conn.set_read_timeout(Some(left.min(Duration::from_millis(200))))?;
        match conn.read(&mut buf) {
            Ok(0) => return Ok(got),
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => return Ok(got),
        }
    }
}
