//! A ring of `n` members run in this process, one thread and one zenoh session each, over the
//! real zenoh transport and the runtime's member driver — the cores from the one ring builder
//! (`mcc_ring::builder`) with the clock set-up of a member process, run by
//! `mcc_ring::runtime::local` — minus the process. The drivers record their timing samples.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use mcc_contracts::config::{ClockMode, ClusterConfig};
use mcc_ring::builder;
use mcc_ring::core::RingApp;
use mcc_ring::member::RingMember;
use mcc_ring::runtime::driver::DriverConfig;
use mcc_ring::runtime::local::{LocalRing, LocalTransport};
use mcc_ring::runtime::process::apply_clock;

/// A member that computes nothing: the bench measures the ring, not the servo.
struct Idle;

impl RingApp for Idle {
    fn tick(&mut self, _cycle: u64, _time_ns: u64, _regs: &mut RingMember, _ring_fault: bool) {}
}

/// The default mix for `n` members: a third cards (at least one), the rest stations.
pub fn bench_config(n: usize, clock: ClockMode, rate_hz: f64) -> ClusterConfig {
    let cards = (n / 3).max(1);
    let mut cfg = ClusterConfig::default_cluster(cards, n.saturating_sub(cards));
    cfg.cluster = format!("bench-{}", std::process::id());
    cfg.clock = clock;
    cfg.rate_hz = rate_hz;
    cfg
}

/// What a bench ring run measured, per member in ring order.
#[derive(Debug, Default)]
pub struct RingRun {
    /// The driver's timing records on the monotonic clock: the sync master's scheduled cycle
    /// starts (realtime), the others' sync-packet arrivals.
    pub records: Vec<Vec<(u64, u64)>>,
}

/// Run the ring until the sync master has run `cycles` cycles.
pub fn run(cfg: &ClusterConfig, cycles: u64) -> Result<RingRun> {
    let members = builder::members(cfg, |core, _| {
        let sync = core.settings.is_sync_master();
        DriverConfig {
            name: core.name.clone(),
            clock: cfg.clock,
            rate_hz: cfg.rate_hz,
            rtf: cfg.rtf,
            member_timeout: cfg.member_timeout(),
            upstream_dead: None,
            rejoins: None,
            members_present: None,
            links_matched: None,
            in_flight: cfg.ring.in_flight,
            upstream_probe: None,
            harden: false,
            max_cycles: sync.then_some(cycles),
            kind: core.kind,
            position: usize::from(core.position),
            extra: serde_json::Map::new(),
            record: cycles as usize + 64,
            phase_delay_ns: cfg.phase_delay_ns(),
        }
    })?
    .into_iter()
    .map(|(mut core, dcfg)| {
        apply_clock(&mut core, cfg);
        (core, Idle, dcfg)
    })
    .collect();
    let sync = cfg
        .position(&cfg.ring.sync_master)
        .ok_or_else(|| anyhow!("the sync master is not in the ring"))?;
    let ring = LocalRing::start(
        members,
        LocalTransport::Zenoh {
            cluster: cfg.cluster.clone(),
        },
    )
    .map_err(|e| anyhow!("{e}"))?;
    // A generous bound: the sync master runs `cycles` at the config's rate.
    let bound = Duration::from_secs_f64(cycles as f64 / cfg.rate_hz.max(1.0) * 4.0 + 60.0);
    let results = ring.join_member(sync, bound);
    if results.len() != cfg.ring.order.len() {
        return Err(anyhow!("a bench member thread panicked"));
    }
    Ok(RingRun {
        records: results.into_iter().map(|r| r.records).collect(),
    })
}

/// The bare OS timer at `period_ns`: sleep to each absolute deadline, record wake − deadline
/// (sorted), until `stop`.
pub fn timer_probe(period_ns: u64, stop: Arc<AtomicBool>) -> Vec<u64> {
    let start = Instant::now();
    let mut late = Vec::new();
    let mut k: u64 = 1;
    while !stop.load(Ordering::Relaxed) {
        let deadline = start + Duration::from_nanos(period_ns.saturating_mul(k));
        let now = Instant::now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        }
        late.push(
            u64::try_from(
                Instant::now()
                    .saturating_duration_since(deadline)
                    .as_nanos(),
            )
            .unwrap_or(u64::MAX),
        );
        k += 1;
    }
    late.sort_unstable();
    late
}
