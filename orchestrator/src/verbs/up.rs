//! `mcc up` (foreground or `--detach`) and the hidden `mcc supervise` daemon.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::control::MemberStatus;

use crate::cli::{UpArgs, DEFAULT_CLUSTER};
use crate::cluster::ctl;
use crate::cluster::failure::Failure;
use crate::cluster::launch;
use crate::cluster::owner::Owner;
use crate::cluster::ready::wait_locked_on;
use crate::cluster::rundir::RunDir;
use crate::cluster::status;
use crate::cluster::supervisor::{stop_signals, Supervisor};
use crate::cluster::sys;

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
    if let Some(n) = args.in_flight {
        cfg.ring.in_flight = n;
    }
    // A value given on the command line is named as the option that gave it.
    let flag = |key: &str| match key {
        "cluster" => cluster_flag.map(|_| "--cluster"),
        "rtf" => args.rtf.map(|_| "--rtf"),
        "rate_hz" => args.rate.map(|_| "--rate"),
        "ring.in_flight" => args.in_flight.map(|_| "--in-flight"),
        _ => None,
    };
    let cfg = cfg.resolve().map_err(|e| match e {
        mcc_contracts::config::ConfigError::Invalid { key, problem } if flag(&key).is_some() => {
            anyhow!("{}: {problem}", flag(&key).unwrap_or_default())
        }
        mcc_contracts::config::ConfigError::Invalid { key, problem } if key == "cluster" => {
            anyhow!("--cluster: {problem}")
        }
        other => anyhow!(other),
    })?;
    crate::cluster::emcl::validate(&cfg)?;
    Ok(cfg)
}

fn print_ready(
    rd: &RunDir,
    cfg: &ClusterConfig,
    info: &crate::cluster::rundir::SupervisorInfo,
    st: &[Option<MemberStatus>],
) {
    let doc = status::build(cfg, info, &rd.dir.display().to_string(), st, &[]);
    let clock = match cfg.clock {
        mcc_contracts::config::ClockMode::Paced => format!("paced at rtf {}", cfg.rtf),
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
    let port =
        |b: &str, p: Option<u16>| p.map(|p| format!("{b}:{p}")).unwrap_or_else(|| "-".into());
    for c in &doc.cards {
        let on = c
            .host
            .as_ref()
            .map(|h| format!(" on {h}"))
            .unwrap_or_default();
        println!(
            "  {} (card {}, {}, pid {}{on}): {}",
            c.name,
            c.number,
            c.profile,
            c.pid.map(|p| p.to_string()).unwrap_or_else(|| "-".into()),
            if c.gpascii.is_some() || c.ssh.is_some() {
                format!(
                    "gpascii {}  ssh {}",
                    port(&c.bind, c.gpascii),
                    port(&c.bind, c.ssh)
                )
            } else {
                format!(
                    "ascii {}  pmac_eth {}",
                    port(&c.bind, c.ascii),
                    port(&c.bind, c.pmac_eth)
                )
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
    if cfg.clock == mcc_contracts::config::ClockMode::Realtime {
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
    crate::cluster::emcl::status::print_ready(cfg, info);
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
    crate::cluster::precheck::check_members(&cfg).map_err(config)?;
    if args.print_config {
        print!("{}", cfg.to_toml_string()?);
        return Ok(());
    }
    let host = crate::cluster::hosts::check_host(&cfg, args.host.as_deref()).map_err(config)?;
    let owner = args.owner_pid.map(Owner::new).transpose().map_err(config)?;
    let rd = RunDir::for_share(&cfg.cluster, host.as_deref()).map_err(config)?;
    rd.claim(std::process::id())
        .map_err(|e| anyhow::Error::new(Failure::new("running", e)))?;
    if let Err(e) = rd.write_config(&cfg.to_toml_string()?) {
        let _ = rd.cleanup();
        return Err(e);
    }
    // A fixed port another program holds, named by its key before any member starts (after
    // the claim: a cluster already running on these ports is "running", not "in use").
    if let Err(e) = crate::cluster::fixed_ports::check_up(&cfg, host.as_deref()) {
        let _ = rd.cleanup();
        return Err(config(e.context("config")));
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
        let _ = crate::cluster::stop::stop(rd, STOP_TIMEOUT, false);
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
    let expected = cfg.ring.order.len() + 1 + cfg.host_names().len().saturating_sub(1);
    let session = match ctl::connect(
        cfg,
        rd.host.as_deref(),
        &endpoint,
        expected,
        Duration::from_secs(3),
    ) {
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
    let st = match wait_locked_on(&session, cfg, rd.host.as_deref(), timeout, dead) {
        Ok(st) => st,
        Err(e) => {
            drop(session);
            return fail(rd, e);
        }
    };
    if json {
        let mut doc = status::build(cfg, &info, &rd.dir.display().to_string(), &st, &[]);
        crate::cluster::drills::enrich_status(&session, cfg, &mut doc);
        crate::cluster::hosts::enrich_status(&session, cfg, &mut doc);
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
    let host = sup.run_dir().host.clone();
    let res = wait_locked_on(&session, &cfg, host.as_deref(), timeout, || {
        if let Ok(sig) = signals.try_recv() {
            return Some(format!("interrupted ({sig})"));
        }
        if sup.stop_requested() {
            return Some("stopped from another host (mcc down)".into());
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
    let printer = crate::cluster::events::Printer::default();
    let watcher = crate::cluster::events::spawn(session.clone(), cfg.clone(), printer.clone());
    let eof_rx = crate::cluster::terminal::spawn_foreground(
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
    printer: Option<&crate::cluster::events::Printer>,
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
        if sup.stop_requested() {
            tracing::info!("another host asked this share to stop: stopping");
            if let Some(p) = printer {
                p.line(&format!(
                    "{} stopped from another host (mcc down)",
                    crate::cluster::events::PREFIX
                ));
            }
            return;
        }
        if let Some(o) = owner.filter(|o| !o.alive()) {
            eprintln!("mcc: owner process {} exited: stopping the cluster", o.pid);
            return;
        }
        for msg in sup.poll() {
            match printer {
                Some(p) => p.line(&format!("{} {msg}", crate::cluster::events::PREFIX)),
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
    let rd = RunDir::for_share(cluster, args.host.as_deref())?;
    let (_rt, signals) = stop_signals()?;
    let cfg = ClusterConfig::from_file(&rd.config_path()).context("supervise")?;
    let mut sup = match Supervisor::start(rd.clone(), cfg) {
        Ok(s) => s,
        Err(e) => {
            let mut info =
                crate::cluster::rundir::SupervisorInfo::starting(std::process::id(), cluster);
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
        assert_eq!(c.clock, mcc_contracts::config::ClockMode::Paced);
        assert_eq!(c.rtf, 1.0);
        let c = resolve(&["--rtf", "0.5"]).unwrap();
        assert_eq!(c.rtf, 0.5);
        let c = resolve(&["--clock", "lockstep"]).unwrap();
        assert_eq!(c.clock, mcc_contracts::config::ClockMode::Lockstep);
        assert_eq!(c.ring.in_flight, 1);
        let c = resolve(&["--in-flight", "4"]).unwrap();
        assert_eq!(c.ring.in_flight, 4);
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
            (&["--in-flight", "0"][..], "--in-flight"),
            (&["--in-flight", "9"][..], "--in-flight"),
            (&["--in-flight", "two"][..], "two"),
        ] {
            let e = format!("{:#}", resolve(args).unwrap_err());
            assert!(e.contains(want), "{args:?}: {e}");
        }
        let e = format!("{:#}", resolve(&["--rtf", "0"]).unwrap_err());
        assert!(e.contains("real-time factor"), "{e}");
    }
}
