//! The machine's limit: a raw UDP loopback ring of as many processes as the cluster it is
//! compared with, forwarding frames of the same size hop by hop (decode, re-encode as the next
//! sender, send on) in lockstep: process 0 starts cycle k once cycle k-1 is back. Each process
//! is this `mcc` binary run as `mcc bench udp-member` (hidden); one thread, a blocking
//! `recv_from`, so every hop costs one wake-up of one thread — what a ring hop costs at least.
//!
//! Hop latency is measured like a zenoh member's: from the sender's stamp taken just before
//! `send_to` to the receiver's return from `recv_from`, both on `CLOCK_MONOTONIC`.

use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_ring::frame::{Frame, FORMAT_VERSION};
use mcc_ring::transport::hops::{HopStats, HopSummary};
use mcc_ring::transport::monotonic_ns;
use serde::{Deserialize, Serialize};

use super::bringup::mcc;
use super::procstat::{self, ProcSample};
use crate::cli::BenchUdpMemberArgs;

/// Bytes of packets per frame (9 nodes × 12 bytes, like a card's 8 nodes plus sync).
const PACKET_BYTES: usize = 108;

/// The cycle number of the frame that stops the ring.
const STOP: u64 = u64::MAX;

fn frame(sender: u16, cycle: u64) -> Vec<u8> {
    let t = monotonic_ns();
    Frame {
        version: FORMAT_VERSION,
        sender,
        seq: cycle,
        sent_ns: t,
        cycle,
        origin_ns: t,
        declared: (PACKET_BYTES / 12) as u16,
        packets: vec![0x5a; PACKET_BYTES],
    }
    .encode()
}

/// What one UDP ring process reports on stdout when it is done (one JSON line).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct MemberReport {
    /// Position in the ring.
    pub index: usize,
    /// Process 0: lockstep cycles per second over its measurement window.
    pub cycles_per_s: Option<f64>,
    /// Hop latency into this process.
    pub hop: HopSummary,
}

/// The UDP ring's figures.
#[derive(Debug, Clone)]
pub struct UdpFigures {
    /// Lockstep cycles per second.
    pub cycles_per_s: f64,
    /// Median of the processes' hop p50 and the largest hop p99, µs.
    pub hop_us: (f64, f64),
    /// CPU µs per cycle and context switches per cycle, summed over the processes.
    pub per_cycle: (f64, f64),
}

/// Run a ring of `n` processes: `warmup`, then a `window` measured.
pub fn run(n: usize, warmup: Duration, window: Duration) -> Result<UdpFigures> {
    let mut children: Vec<Child> = Vec::new();
    let res = run_children(n, warmup, window, &mut children);
    for c in &mut children {
        let _ = c.kill();
        let _ = c.wait();
    }
    res
}

fn run_children(
    n: usize,
    warmup: Duration,
    window: Duration,
    children: &mut Vec<Child>,
) -> Result<UdpFigures> {
    let mut outs = Vec::new();
    let mut ports = Vec::new();
    for k in 0..n {
        let mut cmd = mcc()?;
        cmd.args(["bench", "udp-member", "--index", &k.to_string()])
            .args(["--warmup-ms", &warmup.as_millis().to_string()])
            .args(["--window-ms", &window.as_millis().to_string()])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        let mut child = cmd.spawn().context("starting a UDP ring process")?;
        let out = child
            .stdout
            .take()
            .ok_or_else(|| anyhow!("no stdout from a UDP ring process"))?;
        children.push(child);
        let mut out = BufReader::new(out);
        let mut line = String::new();
        out.read_line(&mut line)?;
        let port: u16 = line
            .trim()
            .strip_prefix("port ")
            .and_then(|p| p.parse().ok())
            .ok_or_else(|| anyhow!("UDP ring process {k}: unexpected {line:?}"))?;
        ports.push(port.to_string());
        outs.push(out);
    }
    let peers = format!("peers {}\n", ports.join(" "));
    // Followers first: process 0 starts cycling as soon as it has its peers.
    for c in children.iter_mut().rev() {
        let stdin = c
            .stdin
            .as_mut()
            .ok_or_else(|| anyhow!("no stdin to a UDP ring process"))?;
        stdin.write_all(peers.as_bytes())?;
        stdin.flush()?;
    }
    let pids: Vec<u32> = children.iter().map(Child::id).collect();
    let sample =
        || -> Result<Vec<ProcSample>> { pids.iter().map(|p| procstat::sample(*p)).collect() };
    std::thread::sleep(warmup);
    let p0 = sample()?;
    let t0 = Instant::now();
    std::thread::sleep(window);
    let p1 = sample()?;
    let secs = t0.elapsed().as_secs_f64();
    let mut reports = Vec::new();
    for (k, out) in outs.iter_mut().enumerate() {
        let mut line = String::new();
        out.read_line(&mut line)?;
        let r: MemberReport = serde_json::from_str(line.trim())
            .with_context(|| format!("UDP ring process {k} report {line:?}"))?;
        reports.push(r);
    }
    let cps = reports
        .first()
        .and_then(|r| r.cycles_per_s)
        .ok_or_else(|| anyhow!("the UDP ring did not cycle"))?;
    let cycles = (cps * secs).max(1.0);
    let (mut cpu, mut sw) = (0.0, 0.0);
    for (a, b) in p0.iter().zip(&p1) {
        let d = b.since(a);
        cpu += d.cpu_s * 1e6 / cycles;
        sw += d.switches as f64 / cycles;
    }
    let mut p50: Vec<f64> = reports.iter().map(|r| r.hop.p50_ns as f64 / 1e3).collect();
    p50.sort_by(f64::total_cmp);
    let p99 = reports
        .iter()
        .map(|r| r.hop.p99_ns as f64 / 1e3)
        .fold(0.0, f64::max);
    Ok(UdpFigures {
        cycles_per_s: cps,
        hop_us: (p50.get(p50.len() / 2).copied().unwrap_or(0.0), p99),
        per_cycle: (cpu, sw),
    })
}

/// `mcc bench udp-member`: one process of the UDP ring (stdin/stdout protocol with `run`).
pub fn member(args: &BenchUdpMemberArgs) -> Result<()> {
    let sock = UdpSocket::bind("127.0.0.1:0").context("binding a UDP socket")?;
    let mut stdout = std::io::stdout();
    writeln!(stdout, "port {}", sock.local_addr()?.port())?;
    stdout.flush()?;
    let mut line = String::new();
    std::io::stdin().lock().read_line(&mut line)?;
    let peers: Vec<u16> = line
        .trim()
        .strip_prefix("peers ")
        .ok_or_else(|| anyhow!("expected the peer list, got {line:?}"))?
        .split_whitespace()
        .map(|p| p.parse().context("peer port"))
        .collect::<Result<_>>()?;
    let n = peers.len();
    let k = args.index as usize;
    if k >= n {
        bail!("--index {k}: the ring has {n} processes");
    }
    let next = SocketAddr::from(([127, 0, 0, 1], peers[(k + 1) % n]));
    let mut hops = HopStats::default();
    let mut buf = vec![0u8; 4096];
    let mut report = MemberReport {
        index: k,
        ..MemberReport::default()
    };
    if k == 0 {
        std::thread::sleep(Duration::from_millis(100));
        sock.set_read_timeout(Some(Duration::from_millis(50)))?;
        let start = Instant::now();
        let warmup = Duration::from_millis(args.warmup_ms);
        let end = warmup + Duration::from_millis(args.window_ms);
        let mut mark: Option<(u64, Instant)> = None;
        let mut c: u64 = 1;
        loop {
            let el = start.elapsed();
            if mark.is_none() && el >= warmup {
                mark = Some((c, Instant::now()));
            }
            if el >= end {
                if let Some((c0, t0)) = mark {
                    report.cycles_per_s = Some((c - c0) as f64 / t0.elapsed().as_secs_f64());
                }
                break;
            }
            sock.send_to(&frame(0, c), next)?;
            // Wait for this cycle's frame to come back (timeout: go on, like lockstep).
            while let Ok((len, _)) = sock.recv_from(&mut buf) {
                let now = monotonic_ns();
                let back = buf.get(..len).and_then(|b| Frame::decode(b).ok());
                if let Some(f) = back {
                    hops.record(f.sent_ns, now);
                    if f.cycle == c {
                        break;
                    }
                }
            }
            c += 1;
        }
        sock.set_read_timeout(Some(Duration::from_secs(2)))?;
        sock.send_to(&frame(0, STOP), next)?;
        let _ = sock.recv_from(&mut buf);
    } else {
        // Bounded: a follower whose ring stopped without it leaves after a while.
        sock.set_read_timeout(Some(Duration::from_secs(10)))?;
        while let Ok((len, _)) = sock.recv_from(&mut buf) {
            let now = monotonic_ns();
            let Some(f) = buf.get(..len).and_then(|b| Frame::decode(b).ok()) else {
                continue;
            };
            // Re-encode as the next sender, as a ring member would.
            sock.send_to(&frame(k as u16, f.cycle), next)?;
            if f.cycle == STOP {
                break;
            }
            hops.record(f.sent_ns, now);
        }
    }
    report.hop = hops.summary();
    writeln!(stdout, "{}", serde_json::to_string(&report)?)?;
    stdout.flush()?;
    Ok(())
}
