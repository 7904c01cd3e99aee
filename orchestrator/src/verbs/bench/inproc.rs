//! A ring of `n` members run in this process, one thread and one zenoh session each, over the
//! real zenoh transport and the runtime's member driver — exactly the code a member process
//! runs, minus the process. The drivers record their timing samples.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use mcc_ring::config::{ClockMode, ClusterConfig, MemberRef};
use mcc_ring::control::MemberKind;
use mcc_ring::core::{CoreConfig, MemberCore, RingApp};
use mcc_ring::member::RingMember;
use mcc_ring::runtime::driver::{Driver, DriverConfig};
use mcc_ring::settings::RingSettings;
use mcc_ring::transport::session::{free_loopback_endpoint, open_session, SessionOptions};
use mcc_ring::transport::zenoh_link;
use zenoh::Wait;

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
    let n = cfg.ring.order.len();
    let first = free_loopback_endpoint().map_err(|e| anyhow!("{e}"))?;
    let mut sessions = Vec::new();
    for k in 0..n {
        let listen = if k == 0 {
            first.clone()
        } else {
            free_loopback_endpoint().map_err(|e| anyhow!("{e}"))?
        };
        let connect = if k == 0 { vec![] } else { vec![first.clone()] };
        sessions.push(
            open_session(&SessionOptions {
                listen: vec![listen],
                connect,
                ..Default::default()
            })
            .map_err(|e| anyhow!("{e}"))?,
        );
    }
    // Gossip connects every peer to every other; wait for the mesh (bounded).
    let deadline = Instant::now() + Duration::from_secs(15);
    while Instant::now() < deadline
        && sessions
            .iter()
            .any(|s| s.info().peers_zid().wait().count() + 1 < n)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    let stop = Arc::new(AtomicBool::new(false));
    let mut guards = Vec::new();
    let mut cmd_senders = Vec::new();
    let mut drivers = Vec::new();
    for (k, name) in cfg.ring.order.iter().enumerate() {
        let (tx, rx, guard) = zenoh_link::join(&sessions[k], &cfg.cluster, &cfg.ring.name, k, n)
            .map_err(|e| anyhow!("{e}"))?;
        guards.push(guard);
        let kind = match cfg.member(name) {
            Some(MemberRef::Card(_)) => MemberKind::Card,
            _ => MemberKind::Station,
        };
        let cs = cfg
            .ring_settings(name)
            .ok_or_else(|| anyhow!("no ring settings for {name}"))?;
        let settings = RingSettings::new(u32::from(cs.i995), cs.i996);
        let mut core_cfg = CoreConfig::new(name, kind, k as u16, settings, cfg.period_ns());
        core_cfg.sync_source = cfg.sync_source();
        mcc_ring::runtime::process::apply_clock(&mut core_cfg, cfg);
        let core = MemberCore::new(core_cfg);
        let sync = cfg.ring.sync_master == *name;
        let dcfg = DriverConfig {
            name: name.clone(),
            clock: cfg.clock,
            rate_hz: cfg.rate_hz,
            rtf: cfg.rtf,
            member_timeout: cfg.member_timeout(),
            upstream_dead: None,
            in_flight: cfg.ring.in_flight,
            upstream_probe: None,
            harden: false,
            max_cycles: sync.then_some(cycles),
            kind,
            position: k,
            extra: serde_json::Map::new(),
            record: cycles as usize + 64,
            phase_delay_ns: cfg.phase_delay_ns(),
        };
        let (cmd_tx, cmd_rx) = crossbeam_channel::unbounded();
        cmd_senders.push(cmd_tx);
        drivers.push((
            k,
            sync,
            Driver::new(
                dcfg,
                core,
                Idle,
                Box::new(tx),
                rx,
                cmd_rx,
                Arc::clone(&stop),
            ),
        ));
    }
    // Followers first, the sync master last, so that the first cycles find everyone listening.
    drivers.sort_by_key(|(_, sync, _)| *sync);
    let mut handles = Vec::new();
    for (k, sync, mut d) in drivers {
        if sync {
            std::thread::sleep(Duration::from_millis(200));
        }
        let stop = Arc::clone(&stop);
        handles.push((
            k,
            std::thread::spawn(move || {
                let _ = d.run();
                if sync {
                    stop.store(true, Ordering::Relaxed);
                }
                d.take_records()
            }),
        ));
    }
    let mut records = vec![Vec::new(); n];
    for (k, h) in handles {
        let r = h
            .join()
            .map_err(|_| anyhow!("a bench member thread panicked"))?;
        if let Some(slot) = records.get_mut(k) {
            *slot = r;
        }
    }
    drop(guards);
    drop(cmd_senders);
    for s in sessions {
        let _ = s.close().wait();
    }
    Ok(RingRun { records })
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
