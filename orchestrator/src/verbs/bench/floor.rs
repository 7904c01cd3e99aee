//! The floor of a ring hop (issue 27 item 1): what zenoh itself costs on this machine, in the
//! same run as the clusters it is compared with. Two processes (this `mcc` binary run as `mcc
//! bench zenoh-member`, hidden) configured exactly as ring members — peer mode, no scouting, a
//! unix-socket link, a publisher with express, Drop and real-time priority, the members'
//! zenoh runtime of one thread (`ZENOH_RUNTIME` = `MEMBER_RUNTIME`) — bounce a ring-frame-sized
//! message; the answer is put from zenoh's receive callback, as a member forwards a frame
//! inline. Two runs:
//! - back to back: each message goes out the moment the previous one came back (the fastest
//!   a hop can go);
//! - paced at the ring rate (a message every ring period).
//!
//! Reported: one-way latency p50/p99 (half the round trip, both ends on `CLOCK_MONOTONIC` of
//! the pinging process) and CPU per message (both processes' CPU, from `/proc`, over the
//! messages each received: every message is one receive and one send in one process, a hop).

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_ring::transport::monotonic_ns;
use mcc_ring::transport::session::{open_session, SessionOptions, MEMBER_RUNTIME, RUNTIME_ENV};
use serde::{Deserialize, Serialize};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::Wait;

use super::bringup::mcc;
use super::procstat;
use super::stats::percentile;
use crate::cli::BenchZenohMemberArgs;

/// Bytes of each message: an encoded ring frame of a card's 8 nodes plus sync (the UDP ring's).
const MESSAGE_BYTES: usize = 160;
/// Back-to-back messages before the measured ones.
const WARMUP: u64 = 2_000;

/// One run's figures.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct FloorRun {
    /// One-way latency p50, µs.
    pub p50_us: f64,
    /// One-way latency p99, µs.
    pub p99_us: f64,
    /// CPU of both processes per message received, µs (one receive and one send).
    pub cpu_us_per_msg: f64,
    /// Messages per second over the run (both directions).
    pub msgs_per_s: f64,
    /// Messages counted.
    pub msgs: u64,
}

/// The floor: back to back and paced at `rate_hz`.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct FloorFigures {
    /// Back to back.
    pub b2b: FloorRun,
    /// Paced.
    pub paced: FloorRun,
    /// The pace, Hz.
    pub rate_hz: f64,
}

impl FloorFigures {
    /// CPU percent of one core one process spends on the floor's messages at the ring rate.
    pub fn cpu_pct_at_rate(&self) -> f64 {
        self.paced.cpu_us_per_msg * self.rate_hz / 1e4
    }
}

/// Measure the floor: `msgs` back-to-back round trips, then `window` paced at `rate_hz`.
pub fn run(rate_hz: f64, msgs: u64, window: Duration) -> Result<FloorFigures> {
    let dir = std::env::temp_dir().join(format!("mcc-floor-{}", std::process::id()));
    std::fs::create_dir_all(&dir).context("creating the floor's socket directory")?;
    let mut children = Vec::new();
    let res = run_children(&dir, rate_hz, msgs, window, &mut children);
    for c in &mut children {
        let _ = c.kill();
        let _ = c.wait();
    }
    let _ = std::fs::remove_dir_all(&dir);
    res
}

fn spawn(
    dir: &std::path::Path,
    index: u32,
    extra: &[String],
    children: &mut Vec<Child>,
) -> Result<BufReader<std::process::ChildStdout>> {
    let mut cmd = mcc()?;
    cmd.args(["bench", "zenoh-member", "--index", &index.to_string()])
        .arg("--dir")
        .arg(dir)
        .args(extra)
        .env(RUNTIME_ENV, MEMBER_RUNTIME)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null());
    let mut child = cmd.spawn().context("starting a floor process")?;
    let out = child
        .stdout
        .take()
        .ok_or_else(|| anyhow!("no stdout from a floor process"))?;
    children.push(child);
    Ok(BufReader::new(out))
}

fn run_children(
    dir: &std::path::Path,
    rate_hz: f64,
    msgs: u64,
    window: Duration,
    children: &mut Vec<Child>,
) -> Result<FloorFigures> {
    let mut pong = spawn(dir, 1, &[], children)?;
    let mut line = String::new();
    pong.read_line(&mut line)?;
    if line.trim() != "ready" {
        bail!("floor process 1: unexpected {line:?}");
    }
    let peer_pid = children[0].id();
    let extra = [
        "--peer-pid".to_string(),
        peer_pid.to_string(),
        "--msgs".into(),
        msgs.to_string(),
        "--rate".into(),
        rate_hz.to_string(),
        "--window-ms".into(),
        window.as_millis().to_string(),
    ];
    let mut ping = spawn(dir, 0, &extra, children)?;
    line.clear();
    ping.read_line(&mut line)?;
    let figures: FloorFigures = serde_json::from_str(line.trim())
        .with_context(|| format!("floor process 0 report {line:?}"))?;
    Ok(figures)
}

/// The pinging process's shared state: round trips in ns, and where a chain ends.
struct Ping {
    rtts: Vec<u64>,
    /// Back to back: the sequence number after which the chain stops.
    last: u64,
    b2b: bool,
    done: Option<mpsc::Sender<()>>,
}

fn message(seq: u64) -> Vec<u8> {
    let mut m = vec![0x5a; MESSAGE_BYTES];
    m[..8].copy_from_slice(&seq.to_le_bytes());
    m[8..16].copy_from_slice(&monotonic_ns().to_le_bytes());
    m
}

fn header(bytes: &[u8]) -> Option<(u64, u64)> {
    let seq = u64::from_le_bytes(bytes.get(..8)?.try_into().ok()?);
    let t = u64::from_le_bytes(bytes.get(8..16)?.try_into().ok()?);
    Some((seq, t))
}

/// Both processes' CPU seconds now.
fn cpu_pair(peer: u32) -> Result<f64> {
    Ok(procstat::sample(std::process::id())?.cpu_s + procstat::sample(peer)?.cpu_s)
}

/// `mcc bench zenoh-member`: one process of the floor (stdin/stdout protocol with `run`).
pub fn member(args: &BenchZenohMemberArgs) -> Result<()> {
    let k = args.index;
    if k > 1 {
        bail!("--index {k}: the floor has two processes, 0 and 1");
    }
    let sock = |i: u32| format!("unixsock-stream/{}/z{i}.sock", args.dir.display());
    let opts = SessionOptions {
        listen: vec![sock(k)],
        connect: if k == 0 { vec![sock(1)] } else { Vec::new() },
        ..SessionOptions::default()
    };
    let session = open_session(&opts).map_err(|e| anyhow!("{e}"))?;
    // Keys of this floor only: its socket directory's name is unique to the `bench ring` run.
    let tag = args
        .dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "floor".into());
    let key = |i: u32| format!("mcc/{tag}/link/{i}");
    let publisher = Arc::new(
        session
            .declare_publisher(key(k))
            .congestion_control(CongestionControl::Drop)
            .priority(Priority::RealTime)
            .express(true)
            .wait()
            .map_err(|e| anyhow!("declare publisher: {e}"))?,
    );
    let mut stdout = std::io::stdout();
    if k == 1 {
        // Echo every message from the receive callback, as a member forwards a frame inline.
        let p = Arc::clone(&publisher);
        let _sub = session
            .declare_subscriber(key(0))
            .callback(move |s| {
                let _ = p.put(s.payload().to_bytes().into_owned()).wait();
            })
            .wait()
            .map_err(|e| anyhow!("declare subscriber: {e}"))?;
        writeln!(stdout, "ready")?;
        stdout.flush()?;
        // Until the parent closes stdin (or 5 minutes, bounded).
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut l = String::new();
            let _ = std::io::stdin().lock().read_line(&mut l);
            let _ = tx.send(());
        });
        let _ = rx.recv_timeout(Duration::from_secs(300));
        return Ok(());
    }
    let peer = args
        .peer_pid
        .ok_or_else(|| anyhow!("--peer-pid is required for process 0"))?;
    let state = Arc::new(Mutex::new(Ping {
        rtts: Vec::new(),
        last: 0,
        b2b: false,
        done: None,
    }));
    let st = Arc::clone(&state);
    let p = Arc::clone(&publisher);
    let _sub = session
        .declare_subscriber(key(1))
        .callback(move |s| {
            let now = monotonic_ns();
            let Some((seq, t)) = header(&s.payload().to_bytes()) else {
                return;
            };
            let mut g = match st.lock() {
                Ok(g) => g,
                Err(e) => e.into_inner(),
            };
            g.rtts.push(now.saturating_sub(t));
            if g.b2b && seq < g.last {
                let _ = p.put(message(seq + 1)).wait();
            } else if seq >= g.last {
                if let Some(d) = g.done.take() {
                    let _ = d.send(());
                }
            }
        })
        .wait()
        .map_err(|e| anyhow!("declare subscriber: {e}"))?;
    // Wait for the link: the publisher matches the peer's subscriber.
    let deadline = Instant::now() + Duration::from_secs(20);
    while !publisher
        .matching_status()
        .wait()
        .map(|m| m.matching())
        .unwrap_or(false)
    {
        if Instant::now() > deadline {
            bail!("the floor's two processes did not connect within 20 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let chain = |first: u64, n: u64| -> Result<()> {
        let (tx, rx) = mpsc::channel();
        {
            let mut g = state.lock().map_err(|_| anyhow!("poisoned"))?;
            g.rtts.clear();
            g.last = first + n - 1;
            g.b2b = true;
            g.done = Some(tx);
        }
        publisher
            .put(message(first))
            .wait()
            .map_err(|e| anyhow!("put: {e}"))?;
        rx.recv_timeout(Duration::from_secs(120))
            .map_err(|_| anyhow!("the back-to-back chain stalled (a message lost?)"))
    };
    let summary = |rtts: &[u64], cpu_s: f64, secs: f64| -> FloorRun {
        let mut one_way: Vec<u64> = rtts.iter().map(|r| r / 2).collect();
        one_way.sort_unstable();
        let n = rtts.len() as u64;
        FloorRun {
            p50_us: percentile(&one_way, 50.0) as f64 / 1e3,
            p99_us: percentile(&one_way, 99.0) as f64 / 1e3,
            cpu_us_per_msg: cpu_s * 1e6 / (2 * n).max(1) as f64,
            msgs_per_s: (2 * n) as f64 / secs.max(1e-9),
            msgs: 2 * n,
        }
    };
    // Back to back: a warm-up chain, then the measured one.
    chain(1, WARMUP)?;
    let c0 = cpu_pair(peer)?;
    let t0 = Instant::now();
    chain(WARMUP + 1, args.msgs.max(100))?;
    let secs = t0.elapsed().as_secs_f64();
    let cpu = cpu_pair(peer)? - c0;
    let b2b = summary(
        &state.lock().map_err(|_| anyhow!("poisoned"))?.rtts,
        cpu,
        secs,
    );
    // Paced: one message a ring period for the window.
    {
        let mut g = state.lock().map_err(|_| anyhow!("poisoned"))?;
        g.rtts.clear();
        g.b2b = false;
        g.last = u64::MAX;
        g.done = None;
    }
    let rate = if args.rate.is_finite() && args.rate > 0.0 {
        args.rate
    } else {
        mcc_contracts::config::DEFAULT_RATE_HZ
    };
    let period = Duration::from_secs_f64(1.0 / rate);
    let window = Duration::from_millis(args.window_ms.max(100));
    let c0 = cpu_pair(peer)?;
    let t0 = Instant::now();
    let mut seq = 1_000_000_000u64;
    let mut next = t0;
    loop {
        let now = Instant::now();
        if now >= t0 + window {
            break;
        }
        if now < next {
            std::thread::sleep(next - now);
        }
        publisher
            .put(message(seq))
            .wait()
            .map_err(|e| anyhow!("put: {e}"))?;
        seq += 1;
        next += period;
    }
    // The last answers.
    std::thread::sleep(Duration::from_millis(50));
    let secs = t0.elapsed().as_secs_f64();
    let cpu = cpu_pair(peer)? - c0;
    let paced = summary(
        &state.lock().map_err(|_| anyhow!("poisoned"))?.rtts,
        cpu,
        secs,
    );
    let figures = FloorFigures {
        b2b,
        paced,
        rate_hz: rate,
    };
    writeln!(stdout, "{}", serde_json::to_string(&figures)?)?;
    stdout.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_carries_its_number_and_send_time() {
        let m = message(42);
        assert_eq!(m.len(), MESSAGE_BYTES);
        let (seq, t) = header(&m).unwrap();
        assert_eq!(seq, 42);
        assert!(t > 0 && t <= monotonic_ns());
        assert_eq!(header(&m[..10]), None);
    }

    #[test]
    fn cpu_at_the_ring_rate_is_cpu_per_message_times_the_rate() {
        let f = FloorFigures {
            paced: FloorRun {
                cpu_us_per_msg: 30.0,
                ..FloorRun::default()
            },
            rate_hz: 2000.0,
            ..FloorFigures::default()
        };
        // 30 µs × 2000/s = 60 ms/s = 6 % of a core.
        assert!((f.cpu_pct_at_rate() - 6.0).abs() < 1e-9);
    }
}
