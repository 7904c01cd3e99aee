//! `mcc bench emcl`: EMCL bus round trip and throughput. Starts a cluster of its own (one
//! card, one station hosting drive0), then times `GAP 1` round trips on one TCP connection
//! (p50/p99, frames/s) and the frames per second several connections get together through
//! the one half-duplex line, against the in-process cost of the same frame on a drive model
//! (codec + drive, measured in the same run: the ratio shows what the bus path costs).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_contracts::config::{ClockMode, ClusterConfig};
use mcc_station::emcl::codec::{Instr, Reply, Request, FRAME_LEN};
use mcc_station::emcl::{Drive, DriveSpec};

use crate::cli::BenchEmclArgs;
use crate::cluster::rundir::RunDir;
use crate::cluster::supervisor::Supervisor;
use crate::verbs::bench::stats::{percentile, us};

/// Run the benchmark and print the report.
pub fn run(args: &BenchEmclArgs) -> Result<()> {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    cfg.cluster = format!("bench-emcl-{}", std::process::id());
    cfg.clock = args.clock.unwrap_or(ClockMode::Lockstep);
    let rd = RunDir::for_cluster(&cfg.cluster)?;
    let res = crate::verbs::bench::syncstart::with_cluster(cfg, |sup, cfg| measure(sup, cfg, args));
    // The bench's drive image is not worth keeping.
    let _ = std::fs::remove_dir_all(rd.dir.join("drives"));
    let _ = std::fs::remove_dir(&rd.dir);
    res
}

fn gap1() -> [u8; FRAME_LEN] {
    Request {
        addr: 1,
        instr: Instr::new(6, 1, 0, 0),
    }
    .to_bytes()
}

fn round_trip(s: &mut TcpStream) -> Result<u64> {
    let t = Instant::now();
    s.write_all(&gap1())?;
    let mut r = [0u8; FRAME_LEN];
    s.read_exact(&mut r).context("no reply from drive0")?;
    let ns = u64::try_from(t.elapsed().as_nanos()).unwrap_or(u64::MAX);
    match Reply::parse(&r) {
        Some(p) if p.status == 100 => Ok(ns),
        _ => bail!("bad reply {r:02X?}"),
    }
}

fn measure(sup: &mut Supervisor, cfg: &ClusterConfig, args: &BenchEmclArgs) -> Result<()> {
    let addr = sup
        .info()
        .emcl_bus
        .clone()
        .ok_or_else(|| anyhow!("no EMCL bus"))?;
    let connect = || -> Result<TcpStream> {
        let s = TcpStream::connect(&addr)?;
        s.set_nodelay(true)?;
        s.set_read_timeout(Some(Duration::from_secs(5)))?;
        Ok(s)
    };
    let mut s = connect()?;
    for _ in 0..50 {
        round_trip(&mut s)?;
    }
    let mut rtt = Vec::with_capacity(args.count as usize);
    let t0 = Instant::now();
    for _ in 0..args.count {
        rtt.push(round_trip(&mut s)?);
    }
    let one_fps = f64::from(args.count) / t0.elapsed().as_secs_f64();
    rtt.sort_unstable();

    // Several hosts at once: the line serves one frame at a time.
    let n = args.connections;
    let per = (args.count / n).max(1);
    let t1 = Instant::now();
    let workers: Vec<_> = (0..n)
        .map(|_| {
            let mut c = connect();
            std::thread::spawn(move || -> Result<u64> {
                let c = c.as_mut().map_err(|e| anyhow!("{e}"))?;
                let mut worst = 0;
                for _ in 0..per {
                    worst = worst.max(round_trip(c)?);
                }
                Ok(worst)
            })
        })
        .collect();
    let mut worst = 0;
    for w in workers {
        worst = worst.max(w.join().map_err(|_| anyhow!("worker panicked"))??);
    }
    let many_fps = f64::from(per * n) / t1.elapsed().as_secs_f64();

    // The same frame handled in-process by the drive model.
    let mut d = Drive::new(DriveSpec::default());
    let f = gap1();
    let k = 200_000u32;
    let t2 = Instant::now();
    let mut ok = 0u32;
    for _ in 0..k {
        if d.handle_frame(&f).is_some() {
            ok += 1;
        }
    }
    let model_fps = f64::from(ok) / t2.elapsed().as_secs_f64();

    println!(
        "EMCL bus ({}, drive0 on station0, GAP 1 round trips over TCP):",
        cfg.clock.as_str()
    );
    println!(
        "  one connection, {} frames: p50 {} µs  p99 {} µs  max {} µs  {:.0} frames/s",
        rtt.len(),
        us(percentile(&rtt, 50.0)),
        us(percentile(&rtt, 99.0)),
        us(rtt.last().copied().unwrap_or(0)),
        one_fps
    );
    println!(
        "  {n} connections sharing the line, {} frames: {:.0} frames/s (slowest round trip {} µs)",
        per * n,
        many_fps,
        us(worst)
    );
    println!(
        "  drive model in-process (codec + drive, same frame): {:.0} frames/s; the bus path costs {:.0}× that",
        model_fps,
        model_fps / one_fps.max(1e-9)
    );
    Ok(())
}
