//! A real multi-process cluster measured as users run it: this very `mcc` binary starts it with
//! `mcc up --detach` (the `mcc-card` / `mcc-station` processes, their zenoh sessions and links),
//! the ring's cycle count is read from the sync master's status at the start and the end of a
//! window, each process's CPU time and context switches from `/proc`, and each member's hop
//! latency from its status (`hop`). The cluster is taken down again whatever happens.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_ring::control::{ctl_key, MemberStatus};

use super::bringup::{mcc, run_bounded};
use super::procstat::{self, ProcSample};
use crate::cluster::ctl;
use crate::cluster::rundir::RunDir;

/// What to start.
#[derive(Debug, Clone)]
pub struct ClusterSpec {
    /// Cards.
    pub cards: u8,
    /// Stations.
    pub stations: u8,
    /// `--clock` (None: the product default).
    pub clock: Option<String>,
    /// `--rate` (None: the product default).
    pub rate: Option<f64>,
    /// `--in-flight` (None: the product default).
    pub in_flight: Option<u64>,
}

impl ClusterSpec {
    /// `4 cards + 8 stations`.
    pub fn label(&self) -> String {
        let plural = |n: u8, w: &str| format!("{n} {w}{}", if n == 1 { "" } else { "s" });
        let mut l = format!(
            "{} + {}",
            plural(self.cards, "card"),
            plural(self.stations, "station")
        );
        if let Some(n) = self.in_flight.filter(|n| *n != 1) {
            l.push_str(&format!(", {n} in flight"));
        }
        l
    }

    /// Members in the ring.
    pub fn members(&self) -> usize {
        usize::from(self.cards) + usize::from(self.stations)
    }
}

/// One member's figures over the window.
#[derive(Debug, Clone)]
pub struct MemberFigures {
    /// `card` or `station`.
    pub kind: String,
    /// Share of one CPU used, %.
    pub cpu_pct: f64,
    /// CPU time per ring cycle, µs.
    pub cpu_us_per_cycle: f64,
    /// Context switches (all threads) per ring cycle.
    pub switches_per_cycle: f64,
    /// Hop latency into this member (its status `hop`), µs: p50, p99.
    pub hop_us: Option<(f64, f64)>,
}

/// A measured window of a running cluster.
#[derive(Debug, Clone)]
pub struct ClusterFigures {
    /// Ring cycles per second.
    pub cycles_per_s: f64,
    /// Per member, in ring order.
    pub members: Vec<MemberFigures>,
    /// The supervisor process (`mcc supervise`): share of one CPU, %.
    pub supervisor_cpu_pct: f64,
}

impl ClusterFigures {
    /// Median of the members' hop p50 and the largest hop p99, µs.
    pub fn hop_us(&self) -> Option<(f64, f64)> {
        let mut p50: Vec<f64> = self
            .members
            .iter()
            .filter_map(|m| m.hop_us.map(|h| h.0))
            .collect();
        let p99 = self
            .members
            .iter()
            .filter_map(|m| m.hop_us.map(|h| h.1))
            .fold(None, |a: Option<f64>, b| Some(a.map_or(b, |a| a.max(b))));
        p50.sort_by(f64::total_cmp);
        let mid = p50.get(p50.len() / 2).copied()?;
        Some((mid, p99?))
    }

    /// Mean and largest CPU share of the members of `kind`, %.
    pub fn cpu_of(&self, kind: &str) -> Option<(f64, f64)> {
        let v: Vec<f64> = self
            .members
            .iter()
            .filter(|m| m.kind == kind)
            .map(|m| m.cpu_pct)
            .collect();
        if v.is_empty() {
            return None;
        }
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        Some((mean, v.iter().copied().fold(0.0, f64::max)))
    }

    /// CPU µs per ring cycle summed over the members, and context switches per cycle.
    pub fn per_cycle(&self) -> (f64, f64) {
        (
            self.members.iter().map(|m| m.cpu_us_per_cycle).sum(),
            self.members.iter().map(|m| m.switches_per_cycle).sum(),
        )
    }
}

/// A running cluster; dropping it takes it down.
struct Running {
    name: String,
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Ok(mut down) = mcc() {
            down.args(["down", "--cluster", &self.name, "--timeout", "10"]);
            let _ = run_bounded(down, Duration::from_secs(30));
        }
    }
}

/// The status of member `name` of `cluster` (3 s to answer).
pub(crate) fn member_status(
    session: &zenoh::Session,
    cluster: &str,
    name: &str,
) -> Result<MemberStatus> {
    let text = ctl::query_text(
        session,
        &ctl_key(cluster, name, "status"),
        None,
        Duration::from_secs(3),
    )?;
    serde_json::from_str(&text).with_context(|| format!("status of {name}"))
}

/// Start the cluster, let it settle for `warmup`, measure `window`, take it down.
pub fn measure(
    spec: &ClusterSpec,
    tag: &str,
    warmup: Duration,
    window: Duration,
) -> Result<ClusterFigures> {
    let name = format!("bench-ring-{}-{tag}", std::process::id());
    let mut up = mcc()?;
    up.args(["up", "--detach", "--cluster", &name, "--timeout", "60"])
        .args(["--cards", &spec.cards.to_string()])
        .args(["--stations", &spec.stations.to_string()]);
    if let Some(c) = &spec.clock {
        up.args(["--clock", c]);
    }
    if let Some(r) = spec.rate {
        up.args(["--rate", &r.to_string()]);
    }
    if let Some(n) = spec.in_flight {
        up.args(["--in-flight", &n.to_string()]);
    }
    let running = Running { name: name.clone() };
    let (ok, err) = run_bounded(up, Duration::from_secs(90))?;
    if !ok {
        bail!("mcc up ({}) failed: {}", spec.label(), err.trim());
    }
    let rd = RunDir::for_cluster(&name)?;
    let info = rd
        .read_info()
        .ok_or_else(|| anyhow!("no supervisor record for {name}"))?;
    let endpoint = info
        .endpoint
        .clone()
        .ok_or_else(|| anyhow!("{name}: no zenoh endpoint"))?;
    let cfg = mcc_contracts::config::ClusterConfig::from_file(&rd.config_path())?;
    let session = ctl::connect(
        &cfg,
        info.host.as_deref(),
        &endpoint,
        info.members.len() + 1,
        Duration::from_secs(5),
    )?;
    let sync = info
        .members
        .first()
        .map(|m| m.name.clone())
        .ok_or_else(|| anyhow!("{name}: no members"))?;
    std::thread::sleep(warmup);

    let sample = |session: &zenoh::Session| -> Result<(u64, Instant, Vec<ProcSample>)> {
        let before = Instant::now();
        let s = member_status(session, &name, &sync)?;
        let after = Instant::now();
        let at = before + (after - before) / 2;
        let mut procs: Vec<ProcSample> = info
            .members
            .iter()
            .map(|m| procstat::sample(m.pid))
            .collect::<Result<_>>()?;
        procs.push(procstat::sample(info.pid)?);
        Ok((s.cycle, at, procs))
    };
    let (c0, t0, p0) = sample(&session)?;
    std::thread::sleep(window);
    let (c1, t1, p1) = sample(&session)?;
    let secs = (t1 - t0).as_secs_f64();
    let cycles = c1.saturating_sub(c0).max(1) as f64;
    let mut members = Vec::new();
    for (k, m) in info.members.iter().enumerate() {
        let d = p1[k].since(&p0[k]);
        let hop = member_status(&session, &name, &m.name)
            .ok()
            .and_then(|s| s.extra.get("hop").cloned())
            .and_then(|h| Some((h.get("p50_us")?.as_f64()?, h.get("p99_us")?.as_f64()?)));
        members.push(MemberFigures {
            kind: m.kind.clone(),
            cpu_pct: d.cpu_s / secs * 100.0,
            cpu_us_per_cycle: d.cpu_s * 1e6 / cycles,
            switches_per_cycle: d.switches as f64 / cycles,
            hop_us: hop,
        });
    }
    let sup = p1[info.members.len()].since(&p0[info.members.len()]);
    let _ = zenoh::Wait::wait(session.close());
    drop(running);
    Ok(ClusterFigures {
        cycles_per_s: c1.saturating_sub(c0) as f64 / secs,
        members,
        supervisor_cpu_pct: sup.cpu_s / secs * 100.0,
    })
}
