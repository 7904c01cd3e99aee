//! `mcc up` (foreground or `--detach`) and the hidden `mcc supervise` daemon.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_ring::config::ClusterConfig;
use mcc_ring::control::MemberStatus;

use crate::cli::{UpArgs, DEFAULT_CLUSTER};
use crate::failure::Failure;
use crate::owner::Owner;
use crate::rundir::RunDir;
use crate::supervisor::{stop_signals, Supervisor};
use crate::{ctl, down, launch, status, sys};

/// Seconds the supervisor gives members for an orderly stop.
const STOP_TIMEOUT: Duration = Duration::from_secs(6);

/// The config `up` will run: the file or the embedded default, with CLI overrides applied,
/// resolved and validated.
pub fn resolve_config(cluster_flag: Option<&str>, args: &UpArgs) -> Result<ClusterConfig> {
    let mut cfg = match &args.config {
        Some(path) => ClusterConfig::from_file(path)?,
        None => ClusterConfig::default_cluster(
            usize::from(args.cards.unwrap_or(2)),
            usize::from(args.stations.unwrap_or(2)),
        ),
    };
    match cluster_flag {
        Some(c) => cfg.cluster = c.to_string(),
        None if args.config.is_none() => cfg.cluster = DEFAULT_CLUSTER.to_string(),
        None => {}
    }
    if let Some(clock) = args.clock {
        cfg.clock = clock;
    }
    if let Some(rate) = args.rate {
        if !rate.is_finite() || rate <= 0.0 {
            bail!("--rate {rate}: must be a positive number of Hz");
        }
        cfg.rate_hz = rate;
    }
    if let Some(rtf) = args.rtf {
        cfg.rtf = rtf;
    }
    // A value given on the command line is named as the option that gave it.
    let flag = |key: &str| match key {
        "cluster" => cluster_flag.map(|_| "--cluster"),
        "rtf" => args.rtf.map(|_| "--rtf"),
        "rate_hz" => args.rate.map(|_| "--rate"),
        _ => None,
    };
    let cfg = cfg.resolve().map_err(|e| match e {
        mcc_ring::config::ConfigError::Invalid { key, problem } if flag(&key).is_some() => {
            anyhow!("{}: {problem}", flag(&key).unwrap_or_default())
        }
        mcc_ring::config::ConfigError::Invalid { key, problem } if key == "cluster" => {
            anyhow!("--cluster: {problem}")
        }
        other => anyhow!(other),
    })?;
    crate::emcl::validate(&cfg)?;
    Ok(cfg)
}

/// Poll member status until every member is locked. Prints a progress line whenever the set
/// of locked members changes. `dead` reports a reason to give up early (a member or the
/// supervisor died).
pub fn wait_locked(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    timeout: Duration,
    mut dead: impl FnMut() -> Option<String>,
) -> Result<Vec<Option<MemberStatus>>> {
    let start = Instant::now();
    let mut last: Option<usize> = None;
    loop {
        let st = ctl::query_statuses(
            session,
            cfg,
            Duration::from_millis(300),
            Duration::from_millis(600),
        );
        let locked = st
            .iter()
            .filter(|s| s.as_ref().is_some_and(|s| s.locked))
            .count();
        if last != Some(locked) {
            let waiting: Vec<&str> = cfg
                .ring
                .order
                .iter()
                .zip(&st)
                .filter(|(_, s)| !s.as_ref().is_some_and(|s| s.locked))
                .map(|(n, _)| n.as_str())
                .collect();
            eprintln!(
                "mcc: ring {}: {locked}/{} members locked{}",
                cfg.ring.name,
                st.len(),
                if waiting.is_empty() {
                    String::new()
                } else {
                    format!(" (waiting for {})", waiting.join(", "))
                }
            );
            last = Some(locked);
        }
        if locked == st.len() {
            crate::emcl::status::wait_ready(session, cfg, timeout.saturating_sub(start.elapsed()))?;
            return Ok(st);
        }
        if let Some(why) = dead() {
            bail!("{why}");
        }
        if start.elapsed() >= timeout {
            bail!("the ring did not lock within {} s", timeout.as_secs());
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn print_ready(
    rd: &RunDir,
    cfg: &ClusterConfig,
    info: &crate::rundir::SupervisorInfo,
    st: &[Option<MemberStatus>],
) {
    let doc = status::build(cfg, info, &rd.dir.display().to_string(), st, &[]);
    let clock = match cfg.clock {
        mcc_ring::config::ClockMode::Paced => format!("paced at rtf {}", cfg.rtf),
        other => other.as_str().to_string(),
    };
    println!(
        "cluster {} up: {} members locked on ring {} at cycle {} ({clock}, {} Hz)",
        cfg.cluster,
        doc.members.len(),
        cfg.ring.name,
        doc.ring.cycle,
        cfg.rate_hz
    );
    let port = |p: Option<u16>| {
        p.map(|p| format!("127.0.0.1:{p}"))
            .unwrap_or_else(|| "-".into())
    };
    for c in &doc.cards {
        println!(
            "  {} (card {}, {}, pid {}): {}",
            c.name,
            c.number,
            c.profile,
            c.pid.map(|p| p.to_string()).unwrap_or_else(|| "-".into()),
            if c.gpascii.is_some() || c.ssh.is_some() {
                format!("gpascii {}  ssh {}", port(c.gpascii), port(c.ssh))
            } else {
                format!("ascii {}  pmac_eth {}", port(c.ascii), port(c.pmac_eth))
            }
        );
    }
    for s in &doc.stations {
        let pid = s.pid.map(|p| p.to_string()).unwrap_or_else(|| "-".into());
        println!(
            "  {} (station, master {}, pid {pid}): nodes {:?}",
            s.name, s.master, s.nodes
        );
    }
    if let Some(d) = &info.daisy_chain {
        match &info.daisy_chain_pty {
            Some(p) => println!("  daisy chain {d}  pty {p}"),
            None => println!("  daisy chain {d}"),
        }
    }
    if cfg.clock == mcc_ring::config::ClockMode::Realtime {
        // What the realtime cycle threads got (SCHED_FIFO and locked memory when permitted).
        let mut got: Vec<(String, Vec<&str>)> = Vec::new();
        for m in &doc.members {
            let s = m.sched.clone().unwrap_or_else(|| "unknown".into());
            match got.iter_mut().find(|(k, _)| *k == s) {
                Some((_, v)) => v.push(&m.name),
                None => got.push((s, vec![&m.name])),
            }
        }
        for (s, who) in got {
            println!("  realtime cycle threads: {s} ({})", who.join(", "));
        }
    }
    crate::emcl::status::print_ready(cfg, info);
    println!(
        "  zenoh endpoint {}",
        info.endpoint.as_deref().unwrap_or("-")
    );
    println!("  run dir {}", rd.dir.display());
}

/// `mcc up`.
pub fn cmd_up(cluster_flag: Option<&str>, args: &UpArgs) -> Result<()> {
    let config = |e: anyhow::Error| anyhow::Error::new(Failure::new("config", e));
    let cfg = resolve_config(cluster_flag, args).map_err(config)?;
    crate::precheck::check_members(&cfg).map_err(config)?;
    if args.print_config {
        print!("{}", cfg.to_toml_string()?);
        return Ok(());
    }
    let owner = args.owner_pid.map(Owner::new).transpose().map_err(config)?;
    let rd = RunDir::for_cluster(&cfg.cluster).map_err(config)?;
    rd.claim(std::process::id())
        .map_err(|e| anyhow::Error::new(Failure::new("running", e)))?;
    if let Err(e) = rd.write_config(&cfg.to_toml_string()?) {
        let _ = rd.cleanup();
        return Err(e);
    }
    let timeout = Duration::from_secs(args.timeout.max(1));
    if args.detach {
        up_detached(&rd, &cfg, timeout, owner, args.json)
    } else {
        up_foreground(rd, cfg, timeout, args.show_framing, owner)
    }
}

fn up_detached(
    rd: &RunDir,
    cfg: &ClusterConfig,
    timeout: Duration,
    owner: Option<Owner>,
    json: bool,
) -> Result<()> {
    let fail = |rd: &RunDir, e: anyhow::Error| -> Result<()> {
        let kind = if e.to_string().contains("did not lock") {
            "lock-timeout"
        } else {
            "start"
        };
        let e = e.context(format!("cluster {} failed to start", rd.cluster));
        let failure = Failure::new(kind, e).with_logs(rd, &cfg.ring.order);
        let _ = down::stop(rd, STOP_TIMEOUT, false);
        Err(anyhow::Error::new(failure))
    };
    let pid = match launch::spawn_supervisor(rd, owner.map(|o| o.pid)) {
        Ok(p) => p,
        Err(e) => return fail(rd, e),
    };
    // Wait for the daemon to publish its endpoint.
    let deadline = Instant::now() + Duration::from_secs(20);
    let info = loop {
        match rd.read_info() {
            Some(i) if i.pid == pid && i.phase == "running" => break i,
            Some(i) if i.pid == pid && i.phase == "failed" => {
                return fail(
                    rd,
                    anyhow!(i.message.unwrap_or_else(|| "supervisor failed".into())),
                )
            }
            _ => {}
        }
        if !sys::pid_alive(pid) {
            return fail(
                rd,
                anyhow!("the supervisor (pid {pid}) exited during start-up"),
            );
        }
        if Instant::now() > deadline {
            return fail(rd, anyhow!("the supervisor did not start within 20 s"));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let endpoint = info.endpoint.clone().unwrap_or_default();
    let session = match ctl::connect(&endpoint, cfg.ring.order.len() + 1, Duration::from_secs(3)) {
        Ok(s) => s,
        Err(e) => return fail(rd, e),
    };
    let dead = || {
        if !sys::pid_alive(pid) {
            return Some(format!("the supervisor (pid {pid}) exited"));
        }
        info.members
            .iter()
            .find(|m| !sys::pid_alive(m.pid))
            .map(|m| format!("member {} (pid {}) exited", m.name, m.pid))
    };
    let st = match wait_locked(&session, cfg, timeout, dead) {
        Ok(st) => st,
        Err(e) => {
            drop(session);
            return fail(rd, e);
        }
    };
    if json {
        let mut doc = status::build(cfg, &info, &rd.dir.display().to_string(), &st, &[]);
        crate::drills::enrich_status(&session, cfg, &mut doc);
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    print_ready(rd, cfg, &info, &st);
    println!("  stop with: mcc down --cluster {}", cfg.cluster);
    Ok(())
}

fn up_foreground(
    rd: RunDir,
    cfg: ClusterConfig,
    timeout: Duration,
    show_framing: bool,
    owner: Option<Owner>,
) -> Result<()> {
    let (_rt, signals) = stop_signals()?;
    let mut sup = match Supervisor::start(rd.clone(), cfg) {
        Ok(s) => s,
        Err(e) => {
            let _ = rd.cleanup();
            return Err(e);
        }
    };
    let cfg = sup.config().clone();
    let session = sup.session().clone();
    let res = wait_locked(&session, &cfg, timeout, || {
        if let Ok(sig) = signals.try_recv() {
            return Some(format!("interrupted ({sig})"));
        }
        sup.poll().into_iter().next()
    });
    let st = match res {
        Ok(st) => st,
        Err(e) => {
            sup.shutdown(STOP_TIMEOUT);
            return Err(e);
        }
    };
    print_ready(sup.run_dir(), &cfg, sup.info(), &st);
    println!("  type PMAC commands for the daisy chain (.help); Ctrl-D, .quit, end of input or SIGINT stops the cluster");
    // The terminal on the daisy chain; leaving it (or end of input) stops the cluster. Cluster
    // events are printed on their own lines as they happen.
    let printer = crate::events::Printer::default();
    let watcher = crate::events::spawn(session.clone(), cfg.clone(), printer.clone());
    let eof_rx = crate::term::spawn_foreground(
        session.clone(),
        cfg.clone(),
        sup.info().clone(),
        sup.run_dir().dir.display().to_string(),
        show_framing,
        printer.clone(),
    );
    run_until_stopped(&mut sup, &signals, Some(&eof_rx), owner, Some(&printer));
    drop(watcher);
    sup.shutdown(STOP_TIMEOUT);
    println!("cluster {} stopped", cfg.cluster);
    Ok(())
}

fn run_until_stopped(
    sup: &mut Supervisor,
    signals: &mpsc::Receiver<String>,
    eof: Option<&mpsc::Receiver<()>>,
    owner: Option<Owner>,
    printer: Option<&crate::events::Printer>,
) {
    loop {
        match signals.recv_timeout(Duration::from_millis(200)) {
            Ok(sig) => {
                tracing::info!("{sig}: stopping the cluster");
                return;
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => return,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
        if eof.is_some_and(|r| r.try_recv().is_ok()) {
            return;
        }
        if let Some(o) = owner.filter(|o| !o.alive()) {
            eprintln!("mcc: owner process {} exited: stopping the cluster", o.pid);
            return;
        }
        for msg in sup.poll() {
            match printer {
                Some(p) => p.line(&format!("{} {msg}", crate::events::PREFIX)),
                None => eprintln!("mcc: {msg}"),
            }
        }
    }
}

/// `mcc supervise` (hidden): the detached supervisor. The run dir was claimed and the config
/// written by `mcc up --detach`.
pub fn cmd_supervise(cluster: &str, args: &crate::cli::SuperviseArgs) -> Result<()> {
    // The owner may already be gone (then the cluster stops at once).
    let owner = args
        .owner_pid
        .map(|pid| Owner::new(pid).unwrap_or(Owner::gone(pid)));
    let rd = RunDir::for_cluster(cluster)?;
    let (_rt, signals) = stop_signals()?;
    let cfg = ClusterConfig::from_file(&rd.config_path()).context("supervise")?;
    let mut sup = match Supervisor::start(rd.clone(), cfg) {
        Ok(s) => s,
        Err(e) => {
            let mut info = crate::rundir::SupervisorInfo::starting(std::process::id(), cluster);
            info.phase = "failed".into();
            info.message = Some(format!("{e:#}"));
            let _ = rd.write_info(&info);
            return Err(e);
        }
    };
    eprintln!(
        "mcc supervise: cluster {cluster} running (pid {})",
        std::process::id()
    );
    run_until_stopped(&mut sup, &signals, None, owner, None);
    sup.shutdown(STOP_TIMEOUT);
    eprintln!("mcc supervise: cluster {cluster} stopped");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn resolve(args: &[&str]) -> Result<ClusterConfig> {
        let mut full = vec!["mcc", "up"];
        full.extend_from_slice(args);
        let cli = crate::cli::Cli::try_parse_from(full).map_err(|e| anyhow!("{e}"))?;
        let crate::cli::Command::Up(up) = &cli.command else {
            bail!("not up")
        };
        resolve_config(cli.cluster.as_deref(), up)
    }

    #[test]
    fn the_default_clock_is_paced_at_real_time() {
        let c = resolve(&[]).unwrap();
        assert_eq!(c.clock, mcc_ring::config::ClockMode::Paced);
        assert_eq!(c.rtf, 1.0);
        let c = resolve(&["--rtf", "0.5"]).unwrap();
        assert_eq!(c.rtf, 0.5);
        let c = resolve(&["--clock", "lockstep"]).unwrap();
        assert_eq!(c.clock, mcc_ring::config::ClockMode::Lockstep);
    }

    #[test]
    fn bad_clock_options_are_refused_naming_the_option() {
        for (args, want) in [
            (&["--rtf", "0"][..], "--rtf"),
            (&["--rtf=-2"][..], "--rtf"),
            (&["--rtf", "NaN"][..], "--rtf"),
            (&["--rtf", "inf"][..], "--rtf"),
            (&["--rtf", "1e12"][..], "--rtf"),
            (
                &["--clock", "lockstep", "--rtf", "3"][..],
                "only the paced clock",
            ),
            (&["--clock", "sometimes"][..], "sometimes"),
            (&["--rate", "0"][..], "--rate"),
        ] {
            let e = format!("{:#}", resolve(args).unwrap_err());
            assert!(e.contains(want), "{args:?}: {e}");
        }
        let e = format!("{:#}", resolve(&["--rtf", "0"]).unwrap_err());
        assert!(e.contains("real-time factor"), "{e}");
    }
}
