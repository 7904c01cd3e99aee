//! `mcc bench bringup`: cluster bring-up time. Runs this very `mcc` binary as a user would,
//! `mcc up --detach --cards C --stations S` (returns once every member is locked), timing it
//! from spawn to exit, then `mcc down`; RUNS times, each with a unique cluster name. The
//! target (4 cards + 8 stations, ≤ 2 s) is meant for a release build. Every cluster is taken
//! down again even when a run fails.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};

use crate::cli::BenchBringupArgs;
use crate::verbs::bench::stats::percentile;

/// Target bring-up time, ms.
pub const TARGET_MS: u64 = 2000;

pub(crate) fn mcc() -> Result<Command> {
    let exe = std::env::current_exe().context("finding the mcc binary")?;
    let mut c = Command::new(exe);
    c.stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    Ok(c)
}

/// Run `cmd`, killing it after `timeout`; its exit success and stderr.
pub(crate) fn run_bounded(mut cmd: Command, timeout: Duration) -> Result<(bool, String)> {
    let child = cmd.spawn().context("starting mcc")?;
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(timeout) {
        Ok(out) => {
            let out = out?;
            Ok((
                out.status.success(),
                String::from_utf8_lossy(&out.stderr).into_owned(),
            ))
        }
        Err(_) => {
            let _ = crate::cluster::sys::signal(pid, libc::SIGKILL);
            Ok((
                false,
                format!("did not finish within {} s", timeout.as_secs()),
            ))
        }
    }
}

/// One bring-up: the time `mcc up --detach` took, then the cluster is taken down.
fn once(name: &str, args: &BenchBringupArgs) -> Result<Duration> {
    let mut up = mcc()?;
    up.args(["up", "--detach", "--cluster", name, "--timeout", "60"])
        .args(["--cards", &args.cards.to_string()])
        .args(["--stations", &args.stations.to_string()]);
    up.args(["--clock", args.clock.as_str()])
        .args(["--rate", &args.rate.to_string()]);
    let t = Instant::now();
    let res = run_bounded(up, Duration::from_secs(90));
    let took = t.elapsed();
    let mut down = mcc()?;
    down.args(["down", "--cluster", name, "--timeout", "10"]);
    let downed = run_bounded(down, Duration::from_secs(30));
    let (ok, err) = res?;
    if !ok {
        bail!("mcc up failed: {}", err.trim());
    }
    match downed {
        Ok((true, _)) => Ok(took),
        Ok((false, e)) => Err(anyhow!("mcc down failed: {}", e.trim())),
        Err(e) => Err(e),
    }
}

/// Run the benchmark and print min/p50/max against the target.
pub fn run(args: &BenchBringupArgs) -> Result<()> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number of Hz");
    }
    let mut ms = Vec::new();
    for k in 0..args.runs {
        let name = format!("bench-bringup-{}-{k}", std::process::id());
        let d = once(&name, args).with_context(|| format!("run {k} ({name})"))?;
        ms.push(u64::try_from(d.as_millis()).unwrap_or(u64::MAX));
    }
    ms.sort_unstable();
    let p50 = percentile(&ms, 50.0);
    let build = if cfg!(debug_assertions) {
        "debug build: the target is for a release build"
    } else {
        "release build"
    };
    println!(
        "bench bringup: `mcc up --detach` with {} cards + {} stations ({} ring at {} Hz) until every member is locked, {} runs ({build})",
        args.cards,
        args.stations,
        args.clock.as_str(),
        args.rate,
        ms.len()
    );
    println!(
        "  bring-up time: min {} ms  p50 {p50} ms  max {} ms",
        ms.first().copied().unwrap_or(0),
        ms.last().copied().unwrap_or(0)
    );
    println!(
        "  target <= {TARGET_MS} ms: {} (p50/target = {:.2})",
        if p50 <= TARGET_MS { "met" } else { "MISSED" },
        p50 as f64 / TARGET_MS as f64
    );
    Ok(())
}
