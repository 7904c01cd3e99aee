//! `mcc status`: the cluster status document (JSON contract, architecture §6) built from the
//! config, the supervisor record and each member's [`MemberStatus`], plus the text table.

use std::fmt::Write as _;

use mcc_contracts::config::{ClusterConfig, MemberRef};
use mcc_ring::control::{ClockReport, ErrorCounters, MemberStatus};
use mcc_ring::fault::ActiveFault;
use serde::Serialize;

use crate::cluster::rundir::SupervisorInfo;

/// The whole `mcc status --json` document.
#[derive(Debug, Clone, Serialize)]
pub struct ClusterStatus {
    /// Cluster name.
    pub cluster: String,
    /// `paced`, `lockstep` or `realtime`.
    pub clock: String,
    /// Nominal ring rate, Hz.
    pub rate: f64,
    /// Real-time factor asked for (paced; 1 otherwise).
    pub rtf_requested: f64,
    /// Real-time factor achieved over the last second (ring time / wall time), from the
    /// synchronizing master; null when it did not answer.
    pub rtf: Option<f64>,
    /// Cycles that started more than a period late (the real-time interrupt warning).
    pub late_cycles: u64,
    /// Worst start lag behind the wall-clock schedule, µs.
    pub max_lag_us: u64,
    /// The synchronizing master's full clock report (lag percentiles, lost time, longest
    /// stall, ring down, scheduling), null when it did not answer.
    pub timing: Option<ClockReport>,
    /// Ring summary.
    pub ring: RingState,
    /// Every member in ring order.
    pub members: Vec<MemberRow>,
    /// Cards and their host ports.
    pub cards: Vec<CardRow>,
    /// Stations.
    pub stations: Vec<StationRow>,
    /// Daisy-chain TCP endpoint, `127.0.0.1:PORT`.
    pub daisy_chain: Option<String>,
    /// Daisy-chain pseudo-terminal path (`mcc up --pty`), else null.
    pub daisy_chain_pty: Option<String>,
    /// EMCL bus TCP endpoint, `127.0.0.1:PORT` (null without drives).
    pub emcl_bus: Option<String>,
    /// EMCL bus pseudo-terminal path (`mcc up --pty`, `[emcl] pty`), else null.
    pub emcl_bus_pty: Option<String>,
    /// Host-link faults of the daisy chain and the EMCL bus (`mcc fault chain|bus link`),
    /// null when the supervisor was not asked or did not answer.
    pub link_faults: Option<crate::cluster::link_ctl::LinkFaults>,
    /// EDB drives on the EMCL bus (address, mode, position, velocity, program, flags).
    pub drives: Vec<mcc_contracts::control::emcl::DriveStatus>,
    /// The supervising process (of this machine's share on several hosts).
    pub supervisor: SupervisorRow,
    /// A cluster on several hosts: each host's share as it answers (empty on one machine).
    pub hosts: Vec<HostRow>,
}

/// One host of a cluster on several hosts.
#[derive(Debug, Clone, Serialize)]
pub struct HostRow {
    /// Host name from the config.
    pub name: String,
    /// Its share answered (supervisor running and reachable).
    pub alive: bool,
    /// The machine's own name, as the share reports it.
    pub machine: Option<String>,
    /// Its supervisor's pid (on that machine).
    pub pid: Option<u32>,
    /// `starting`, `running`, `stopping`.
    pub phase: Option<String>,
    /// It runs the same config as this host.
    pub same_config: Option<bool>,
    /// Its members (ring members and stand-alone drives).
    pub members: Vec<String>,
    /// Its daisy chain and EMCL bus endpoints (on that machine).
    pub daisy_chain: Option<String>,
    /// EMCL bus endpoint (on that machine).
    pub emcl_bus: Option<String>,
}

/// Ring summary.
#[derive(Debug, Clone, Serialize)]
pub struct RingState {
    /// Ring name.
    pub name: String,
    /// Every member alive and phase-locked.
    pub locked: bool,
    /// Ring cycle of the synchronizing master.
    pub cycle: u64,
    /// A member latched a ring fault, or a link is broken.
    pub faulted: bool,
    /// The broken link, e.g. `"station0 → card1"`.
    pub broken_link: Option<String>,
    /// Every link where light is lost (see [`dark_links`]): on several hosts, each host's
    /// view names the links that cross a cut network.
    pub dark_links: Vec<String>,
}

/// One member.
#[derive(Debug, Clone, Serialize)]
pub struct MemberRow {
    /// Member name.
    pub name: String,
    /// `card` or `station`.
    pub kind: String,
    /// OS pid (from the supervisor, else the member's own report).
    pub pid: Option<u32>,
    /// Answered its status query.
    pub alive: bool,
    /// Did not answer this status query in time but holds its zenoh liveliness token: busy
    /// (a loaded machine), not gone. Never a broken link by itself: a member that truly
    /// stopped shows through the ring (its downstream goes dark after the frozen-member wait).
    pub slow: bool,
    /// Position in the ring.
    pub ring_position: usize,
    /// The synchronizing master.
    pub sync_master: bool,
    /// Phase-locked to the sync packet.
    pub locked: bool,
    /// Current ring cycle known to the member.
    pub cycle: u64,
    /// Sync packets received.
    pub sync_count: u64,
    /// Ring cycle of the last frame from upstream.
    pub last_rx_cycle: Option<u64>,
    /// Receive error counters.
    pub errors: ErrorCounters,
    /// Ring fault latched.
    pub ring_fault: bool,
    /// Ring faults since start.
    pub ring_fault_count: u64,
    /// Ring cycle at which the latest ring fault was detected.
    pub ring_fault_cycle: Option<u64>,
    /// Cycles run on the holdover clock.
    pub holdover_cycles: u64,
    /// Cycles that started late on the wall clock.
    pub late_cycles: u64,
    /// Its input carries no light (loss of light upstream: a byte violation every cycle).
    pub dark: bool,
    /// First cycle it ran with a dark input.
    pub dark_since_cycle: Option<u64>,
    /// The last dark spell that ended, `[first, last]` cycle without light.
    pub last_dark_spell: Option<(u64, u64)>,
    /// While latched: the first dark cycle of the spell it was in when it latched.
    pub ring_fault_dark_since: Option<u64>,
    /// Latest cycle in which the link into it delivered bad data (packet errors, dark or
    /// extra frames, silence).
    pub link_error_cycle: Option<u64>,
    /// Why its ring fault latched (while latched).
    pub fault_reason: Option<String>,
    /// What its cycle thread got from the scheduler (realtime: SCHED_FIFO, locked memory).
    pub sched: Option<String>,
    /// Faults injected on its send path.
    pub faults: Vec<ActiveFault>,
    /// The host it runs on (a cluster on several hosts), else null.
    pub host: Option<String>,
    /// CPU its process used over the last second, percent of one core (the member's own
    /// reading of `/proc/self/stat`); null before its first second or when it did not answer.
    pub cpu_percent: Option<f64>,
}

/// One card.
#[derive(Debug, Clone, Serialize)]
pub struct CardRow {
    /// Member name.
    pub name: String,
    /// Card number (I0).
    pub number: u8,
    /// `pmac2` or `turbo`.
    pub profile: String,
    /// ASCII terminal TCP port.
    pub ascii: Option<u16>,
    /// PMAC Ethernet protocol TCP port.
    pub pmac_eth: Option<u16>,
    /// Power cards: raw TCP `gpascii` port.
    pub gpascii: Option<u16>,
    /// Power cards: SSH port.
    pub ssh: Option<u16>,
    /// Address both ports bind (`127.0.0.1` unless the config opens them).
    pub bind: String,
    /// The host it runs on (a cluster on several hosts), else null.
    pub host: Option<String>,
    /// OS pid.
    pub pid: Option<u32>,
    /// Ring-fault bit of the card (X:$0003 bit 4), from its `at` queryable.
    pub ring_fault: Option<bool>,
    /// The ring fault killed every activated motor.
    pub motors_killed: Option<bool>,
    /// Activated motors that are killed.
    pub killed_motors: Vec<u16>,
    /// Ring cycle at which its most recent program start executed.
    pub program_start_cycle: Option<u64>,
    /// CLOCK_MONOTONIC ns of that start.
    pub program_start_ns: Option<u64>,
    /// Why the card's state file was refused at start-up (it started from factory defaults;
    /// the file was kept aside), `null` when it loaded or there was none.
    pub state_file_error: Option<String>,
    /// Hardware stop inputs held active (`mcc fault CARD input KIND`): each with `kind`,
    /// `since`, `until` (cycles) and on PMAC2/Turbo the FPD `select`; a Power card also
    /// reports `abort_all_count` (`Sys.AbortAllCount`). `null` when the card did not answer.
    pub inputs: Option<serde_json::Value>,
    /// Its host-link fault (`mcc fault CARD link KIND`: kind, probability, seed, replies,
    /// delay_ms, seen, hits), null when none.
    pub link_fault: Option<serde_json::Value>,
}

/// One station.
#[derive(Debug, Clone, Serialize)]
pub struct StationRow {
    /// Member name.
    pub name: String,
    /// OS pid.
    pub pid: Option<u32>,
    /// Master number it serves.
    pub master: u8,
    /// Servo nodes.
    pub nodes: Vec<u8>,
    /// The station's fault latch (ring check MI8-MI10 or MI6), null when it did not answer.
    pub ring_fault: Option<bool>,
    /// The latest fault was localised to the link directly upstream of the station (at least
    /// half of the period's errors were byte violations).
    pub suspected_break: Option<bool>,
    /// MI-level state: status word (MI4), ring errors since reset (MI5) and in the last
    /// second (MI12), check settings (MI8/MI9/MI10, MI6), configuration number (MI2), firmware
    /// version, state-file problems.
    pub mi: Option<serde_json::Value>,
    /// Injected axis faults (`mcc fault STATION axis …`, `power-loss`): node (null for
    /// power loss), kind, value, cycles, since_cycle, until_cycle (null: until cleared).
    pub axis_faults: Vec<serde_json::Value>,
    /// Station-wide power loss injected (null when it did not answer).
    pub power_loss: Option<bool>,
}

/// The supervisor.
#[derive(Debug, Clone, Serialize)]
pub struct SupervisorRow {
    /// Its pid.
    pub pid: u32,
    /// Its zenoh endpoint (members connect to it).
    pub endpoint: Option<String>,
    /// Run directory.
    pub run_dir: String,
}

/// Cycles of lag behind which a member's incoming link counts as broken: four check periods
/// (the smallest station check period or card check period: I1001, Turbo I80), at least 32 cycles, so that the skew
/// between concurrent status queries never looks like a break.
pub fn lag_threshold(cfg: &ClusterConfig) -> u64 {
    let station = cfg.stations.iter().map(|s| u64::from(s.check.period));
    let cards = cfg.cards.iter().filter_map(|c| {
        let v = c.ring_check()[0]?;
        (v >= 1.0).then_some(v as u64)
    });
    let period = station.chain(cards).min().unwrap_or(8);
    (4 * period).max(32)
}

/// Name the broken link: walk the ring from the member after the sync master; the first
/// member that is gone (no answer, and no liveliness token: `slow[i]` false) ends the walk
/// (`"<dead> → <next>"`: nothing leaves it), else the first whose last received frame lags its
/// own current cycle by more than `threshold`, whose input is dark, that lost the sync packets,
/// or that latched a ring fault while the link into it delivered bad data (within the last
/// `threshold` cycles, or within `threshold` cycles of the latch: a break that healed still
/// names its link until the reset) names `"<upstream> → <member>"` (its upstream, visited
/// before, is fine). A member that is slow to answer (`slow[i]`) is passed over: its link is
/// judged by the members downstream of it. The lag is measured against the member's own
/// cycle, never the sync master's: a member running behind the master (scheduled late on a
/// busy machine) has received what it ran, and is not cut off. A card that only misses its
/// own packets is not the break: they were lost further round the ring.
pub fn broken_link(
    cfg: &ClusterConfig,
    st: &[Option<MemberStatus>],
    slow: &[bool],
    threshold: u64,
) -> Option<String> {
    let order = &cfg.ring.order;
    let n = order.len();
    if n == 0 || st.len() != n {
        return None;
    }
    let sm = cfg.position(&cfg.ring.sync_master)?;
    // Content (a dead member, a dark input, bad data, lost sync) names the link first; lag
    // alone only when no member shows content: a member between the sync master and the break
    // that is starved of CPU lags the master's own-clock count without being cut off.
    let mut lagging: Option<String> = None;
    for k in 1..=n {
        let idx = (sm + k) % n;
        let up = (idx + n - 1) % n;
        let Some(s) = st.get(idx)? else {
            if slow.get(idx).copied().unwrap_or(false) {
                continue;
            }
            return Some(format!(
                "{} → {}",
                order.get(idx)?,
                order.get((idx + 1) % n)?
            ));
        };
        let reference = s.cycle;
        let lag = match s.last_rx_cycle {
            Some(rx) => reference.saturating_sub(rx),
            None => reference,
        };
        // Frames still arrive but sync packets do not (drop-sync upstream): the member runs on
        // its holdover clock, unlocked, with a ring fault. A dark input: loss of light.
        // A fault latched on bad data from the link into it (corrupt, byte violation, overrun,
        // underrun, delayed frames).
        // Also, while the latch holds, once the link is whole again (a restarted member, a
        // cleared fault): the bad data that made the latch names the link until the reset.
        // A dark spell that ended (light back) holding the latch names it too.
        let near_latch = |c: u64| {
            s.ring_fault_cycle
                .is_some_and(|f| c <= f.saturating_add(threshold) && f <= c + threshold)
        };
        let dark_latch = s.last_dark_spell.is_some_and(|(from, to)| {
            s.ring_fault_cycle
                .is_some_and(|f| from <= f && f <= to.saturating_add(threshold))
        });
        let bad_input = s.ring_fault
            && (dark_latch
                || s.link_error_cycle.is_some_and(|c| {
                    // A stamp beyond the member's own cycle is from before a renumbering (a
                    // restarted sync master): stale, no evidence of this break.
                    c <= s.cycle && (s.cycle - c <= threshold || near_latch(c))
                }));
        if s.dark || bad_input || (!s.locked && s.ring_fault && s.sync_count > 0) {
            return Some(format!("{} → {}", order.get(up)?, order.get(idx)?));
        }
        if lag > threshold && lagging.is_none() {
            lagging = Some(format!("{} → {}", order.get(up)?, order.get(idx)?));
        }
    }
    lagging
}

/// Links `u → m` where light is lost: `m` answers and its input is dark, while `u` does not
/// answer (dead, or unreachable from here) or answers with light on its own input. A member
/// that only passes on the darkness of a dark upstream does not name its link.
pub fn dark_links(cfg: &ClusterConfig, st: &[Option<MemberStatus>]) -> Vec<String> {
    let order = &cfg.ring.order;
    let n = order.len();
    if st.len() != n {
        return Vec::new();
    }
    (0..n)
        .filter_map(|i| {
            let up = (i + n - 1) % n;
            let m = st.get(i)?.as_ref()?;
            let lit_or_gone = st.get(up)?.as_ref().is_none_or(|u| !u.dark);
            (m.dark && lit_or_gone).then(|| format!("{} → {}", order[up], order[i]))
        })
        .collect()
}

fn port_of(v: Option<&serde_json::Value>) -> Option<u16> {
    match v? {
        serde_json::Value::Number(n) => n.as_u64().and_then(|p| u16::try_from(p).ok()),
        serde_json::Value::String(s) => s.rsplit(':').next()?.parse().ok(),
        _ => None,
    }
}

fn extra_port(s: Option<&MemberStatus>, keys: &[&str]) -> Option<u16> {
    let s = s?;
    keys.iter().find_map(|k| port_of(s.extra.get(*k)))
}

/// Assemble the status document from one status round: `st` the answers in ring order,
/// `slow` the members that did not answer but hold their liveliness token (empty: none).
pub fn build(
    cfg: &ClusterConfig,
    info: &SupervisorInfo,
    run_dir: &str,
    st: &[Option<MemberStatus>],
    slow: &[bool],
) -> ClusterStatus {
    let pid_of = |name: &str, s: Option<&MemberStatus>| {
        info.members
            .iter()
            .find(|m| m.name == name)
            .map(|m| m.pid)
            .or_else(|| s.map(|s| s.pid))
    };
    let host_of =
        |name: &str| c_multi(cfg).then(|| cfg.member_host(name).unwrap_or_default().to_string());
    let status_of = |name: &str| {
        cfg.position(name)
            .and_then(|i| st.get(i))
            .and_then(Option::as_ref)
    };
    let members: Vec<MemberRow> = cfg
        .ring
        .order
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let s = st.get(i).and_then(Option::as_ref);
            let d = MemberStatus::default();
            let v = s.unwrap_or(&d);
            let kind = match cfg.member(name) {
                Some(MemberRef::Card(_)) => "card",
                _ => "station",
            };
            MemberRow {
                name: name.clone(),
                kind: kind.into(),
                pid: pid_of(name, s),
                alive: s.is_some(),
                cpu_percent: v.cpu_percent,
                slow: s.is_none() && slow.get(i).copied().unwrap_or(false),
                ring_position: i,
                sync_master: cfg.ring.sync_master == *name,
                locked: v.locked,
                cycle: v.cycle,
                sync_count: v.sync_count,
                last_rx_cycle: v.last_rx_cycle,
                errors: v.errors,
                ring_fault: v.ring_fault,
                ring_fault_count: v.ring_fault_count,
                ring_fault_cycle: v.ring_fault_cycle,
                holdover_cycles: v.holdover_cycles,
                late_cycles: v.late_cycles,
                dark: v.dark,
                dark_since_cycle: v.dark_since_cycle,
                link_error_cycle: v.link_error_cycle,
                last_dark_spell: v.last_dark_spell,
                ring_fault_dark_since: v.ring_fault_dark_since,
                fault_reason: v.fault_reason.clone(),
                sched: v.sched.clone(),
                faults: v.faults.clone(),
                host: host_of(name),
            }
        })
        .collect();
    let link = broken_link(cfg, st, slow, lag_threshold(cfg));
    let sm_cycle = status_of(&cfg.ring.sync_master).map(|s| s.cycle);
    let timing = status_of(&cfg.ring.sync_master).and_then(|s| s.clock.clone());
    let ring = RingState {
        name: cfg.ring.name.clone(),
        locked: !members.is_empty() && members.iter().all(|m| m.alive && m.locked),
        cycle: sm_cycle.unwrap_or_else(|| members.iter().map(|m| m.cycle).max().unwrap_or(0)),
        faulted: link.is_some() || members.iter().any(|m| m.ring_fault),
        broken_link: link,
        dark_links: dark_links(cfg, st),
    };
    let cards = cfg
        .cards
        .iter()
        .map(|c| {
            let s = status_of(&c.name);
            CardRow {
                name: c.name.clone(),
                number: c.number,
                profile: c.profile.clone(),
                ascii: extra_port(s, &["ascii", "ascii_port"]),
                pmac_eth: extra_port(s, &["pmac_eth", "pmac_eth_port"]),
                gpascii: extra_port(s, &["gpascii"]),
                ssh: extra_port(s, &["ssh"]),
                bind: c.bind.clone().unwrap_or_else(|| "127.0.0.1".into()),
                host: host_of(&c.name),
                pid: pid_of(&c.name, s),
                ring_fault: None,
                motors_killed: None,
                killed_motors: Vec::new(),
                program_start_cycle: None,
                program_start_ns: None,
                state_file_error: s
                    .and_then(|s| s.extra.get("state_file_error"))
                    .and_then(|v| v.as_str())
                    .map(str::to_string),
                inputs: s.and_then(|s| s.extra.get("inputs")).cloned(),
                link_fault: s
                    .and_then(|s| s.extra.get("link_fault"))
                    .filter(|v| !v.is_null())
                    .cloned(),
            }
        })
        .collect();
    let stations = cfg
        .stations
        .iter()
        .map(|s| {
            let st = status_of(&s.name);
            let extra = |k: &str| st.and_then(|m| m.extra.get(k)).cloned();
            StationRow {
                name: s.name.clone(),
                pid: pid_of(&s.name, st),
                master: s.master,
                nodes: s.nodes.clone(),
                ring_fault: extra("ring_fault").and_then(|v| v.as_bool()),
                suspected_break: extra("suspected_break").and_then(|v| v.as_bool()),
                mi: extra("mi"),
                axis_faults: extra("axis_faults")
                    .and_then(|v| v.as_array().cloned())
                    .unwrap_or_default(),
                power_loss: extra("power_loss").and_then(|v| v.as_bool()),
            }
        })
        .collect();
    ClusterStatus {
        cluster: cfg.cluster.clone(),
        clock: cfg.clock.as_str().into(),
        rate: cfg.rate_hz,
        rtf_requested: match cfg.clock {
            mcc_contracts::config::ClockMode::Paced => cfg.rtf,
            _ => 1.0,
        },
        rtf: timing.as_ref().map(|t| t.rtf),
        late_cycles: timing.as_ref().map_or(0, |t| t.late_cycles),
        max_lag_us: timing.as_ref().map_or(0, |t| t.max_lag_us),
        timing,
        ring,
        members,
        cards,
        stations,
        daisy_chain: info.daisy_chain.clone(),
        daisy_chain_pty: info.daisy_chain_pty.clone(),
        emcl_bus: info.emcl_bus.clone(),
        emcl_bus_pty: info.emcl_bus_pty.clone(),
        drives: Vec::new(),
        link_faults: None,
        supervisor: SupervisorRow {
            pid: info.pid,
            endpoint: info.endpoint.clone(),
            run_dir: run_dir.into(),
        },
        hosts: Vec::new(),
    }
}

fn c_multi(cfg: &ClusterConfig) -> bool {
    cfg.is_multi_host()
}

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map(|v| v.to_string()).unwrap_or_else(|| "-".into())
}

/// A card's host ports: `gpascii …  ssh …` for a Power card, `ascii …  pmac_eth …` otherwise.
fn card_ports_text(c: &CardRow) -> String {
    if c.gpascii.is_some() || c.ssh.is_some() {
        format!(
            "gpascii {}:{}  ssh {}:{}",
            c.bind,
            opt(c.gpascii),
            c.bind,
            opt(c.ssh)
        )
    } else {
        format!(
            "ascii {}:{}  pmac_eth {}:{}",
            c.bind,
            opt(c.ascii),
            c.bind,
            opt(c.pmac_eth)
        )
    }
}

/// `  RING FAULT, motors killed  program start @cycle N` (empty when nothing is known).
fn card_state_text(c: &CardRow) -> String {
    let mut t = String::new();
    if c.ring_fault == Some(true) {
        t.push_str("  RING FAULT");
        if c.motors_killed == Some(true) {
            t.push_str(", motors killed");
        }
    }
    if let Some(p) = c.program_start_cycle {
        let _ = write!(t, "  program start @cycle {p}");
    }
    let held = c.inputs.as_ref().and_then(|i| i["held"].as_array());
    for h in held.into_iter().flatten() {
        let _ = write!(t, "  INPUT {}", h["kind"].as_str().unwrap_or("?"));
        if let Some(cs) = h["select"].as_u64() {
            let _ = write!(t, " (C.S. {cs})");
        }
        if let Some(u) = h["until"].as_u64() {
            let _ = write!(t, " until cycle {u}");
        }
    }
    t
}

/// `rtf 1.00 of 1 requested, 3 late cycles, worst lag 1.2 ms` plus what is unusual.
pub fn timing_text(s: &ClusterStatus) -> String {
    let Some(t) = &s.timing else {
        return "unknown (the synchronizing master did not answer)".into();
    };
    let mut out = if s.clock == "lockstep" {
        format!("rtf {:.2} (lockstep: unthrottled)", t.rtf)
    } else {
        format!("rtf {:.2} of {} requested", t.rtf, t.rtf_requested)
    };
    let _ = write!(
        out,
        ", {} late cycles, worst lag {:.1} ms (p99 {:.1} ms), longest stall {:.1} ms",
        t.late_cycles,
        t.max_lag_us as f64 / 1000.0,
        t.lag_p99_us as f64 / 1000.0,
        t.longest_stall_us as f64 / 1000.0
    );
    if t.lost_ms > 0 {
        let _ = write!(out, ", {} ms lost in {} re-bases", t.lost_ms, t.rebases);
    }
    if t.below_rtf_ms >= 1000 {
        let _ = write!(
            out,
            ", BELOW the requested rtf for {:.1} s",
            t.below_rtf_ms as f64 / 1000.0
        );
    }
    if t.ring_down {
        out.push_str(", RING DOWN (nothing comes back: cycles on the sync master's own clock)");
    }
    out
}

/// A station's injected axis faults as `node 0 load=0.5 (cycles 100-199), power-loss (since
/// 42)`; none when it has none.
fn axis_faults_text(st: &StationRow) -> Option<String> {
    if st.axis_faults.is_empty() {
        return None;
    }
    let one = |f: &serde_json::Value| {
        let kind = f["kind"].as_str().unwrap_or("?");
        let what = match (f["node"].as_u64(), f["value"].as_f64()) {
            (Some(n), Some(v)) => format!("node {n} {kind}={v}"),
            (Some(n), None) => format!("node {n} {kind}"),
            (None, _) => kind.to_string(),
        };
        let when = match (f["since_cycle"].as_u64(), f["until_cycle"].as_u64()) {
            (Some(a), Some(b)) => format!("cycles {a}-{}", b.saturating_sub(1)),
            (Some(a), None) => format!("since {a}, until cleared"),
            (None, _) => "starting".to_string(),
        };
        format!("{what} ({when})")
    };
    Some(
        st.axis_faults
            .iter()
            .map(one)
            .collect::<Vec<_>>()
            .join(", "),
    )
}

/// The human-readable table.
pub fn render_table(s: &ClusterStatus) -> String {
    let mut o = String::new();
    let r = &s.ring;
    let state = match (r.locked, r.faulted) {
        (_, true) => "FAULTED",
        (true, false) => "locked",
        (false, false) => "NOT LOCKED",
    };
    let _ = writeln!(
        o,
        "cluster {}  clock {}  rate {} Hz  ring {}: {state}  cycle {}{}",
        s.cluster,
        s.clock,
        s.rate,
        r.name,
        r.cycle,
        r.broken_link
            .as_ref()
            .map(|l| format!("  broken link: {l}"))
            .unwrap_or_default()
    );
    let _ = writeln!(o, "time: {}", timing_text(s));
    for h in &s.hosts {
        let state = match (h.alive, h.same_config) {
            (false, _) => "NOT REACHED".to_string(),
            (true, Some(false)) => "ANOTHER CONFIG".to_string(),
            (true, _) => format!(
                "{} on {} (supervisor pid {})",
                h.phase.as_deref().unwrap_or("up"),
                h.machine.as_deref().unwrap_or("?"),
                opt(h.pid)
            ),
        };
        let _ = writeln!(o, "host {}: {state}: {}", h.name, h.members.join(", "));
    }
    let _ = writeln!(
        o,
        "{:>3} {:<12} {:<7} {:>7} {:<5} {:<6} {:>10} {:>10} {:>5} {:>5} {:>5} {:>5} {:>5}  {:<5} faults",
        "pos", "member", "kind", "pid", "alive", "locked", "cycle", "syncs", "bytev", "cksum", "ovr", "und", "badf", "rfault"
    );
    for m in &s.members {
        let e = &m.errors;
        let faults: Vec<String> = m.faults.iter().map(|f| f.spec.kind.to_string()).collect();
        let _ = writeln!(
            o,
            "{:>3} {:<12} {:<7} {:>7} {:<5} {:<6} {:>10} {:>10} {:>5} {:>5} {:>5} {:>5} {:>5}  {:<5} {}",
            m.ring_position,
            format!("{}{}", m.name, if m.sync_master { "*" } else { "" }),
            m.kind,
            opt(m.pid),
            if m.alive {
                "yes"
            } else if m.slow {
                "slow"
            } else {
                "NO"
            },
            if m.locked { "yes" } else { "no" },
            m.cycle,
            m.sync_count,
            e.byte_violation,
            e.checksum,
            e.overrun,
            e.underrun,
            e.bad_frames,
            if m.ring_fault { "YES" } else if m.dark { "dark" } else { "no" },
            if faults.is_empty() { "-".into() } else { faults.join(",") }
        );
    }
    for c in &s.cards {
        let _ = writeln!(
            o,
            "card {} ({}, #{} {}): {}{}",
            c.name,
            opt(c.pid),
            c.number,
            c.profile,
            card_ports_text(c),
            card_state_text(c)
        );
    }
    for st in &s.stations {
        if let Some(line) = axis_faults_text(st) {
            let _ = writeln!(o, "station {}: axis faults: {line}", st.name);
        }
    }
    if let Some(d) = &s.daisy_chain {
        let pty = s.daisy_chain_pty.as_deref().unwrap_or("-");
        let _ = writeln!(o, "daisy chain {d}  pty {pty}");
    }
    o.push_str(&crate::cluster::emcl::status::render(s));
    if let Some(t) = link_faults_text(s) {
        let _ = writeln!(o, "host-link faults: {t}");
    }
    let _ = writeln!(
        o,
        "zenoh {}  run dir {}  (* = synchronizing master)",
        s.supervisor.endpoint.as_deref().unwrap_or("-"),
        s.supervisor.run_dir
    );
    o
}

/// The active host-link faults, one `target kind (p P, seen/replies, hits)` each; None if none.
fn link_faults_text(s: &ClusterStatus) -> Option<String> {
    let one = |target: &str, f: &mcc_ring::linkfault::ActiveLinkFault| {
        let of = f.spec.replies.map_or(String::new(), |n| format!("/{n}"));
        format!(
            "{target} {} (p {}, {}{of} replies seen, {} hit)",
            f.spec.kind, f.spec.probability, f.seen, f.hits
        )
    };
    let mut all: Vec<String> = s
        .cards
        .iter()
        .filter_map(|c| {
            let f = serde_json::from_value(c.link_fault.clone()?).ok()?;
            Some(one(&c.name, &f))
        })
        .collect();
    if let Some(l) = &s.link_faults {
        all.extend(l.chain.iter().map(|f| one("chain", f)));
        all.extend(l.bus.iter().map(|f| one("bus", f)));
    }
    (!all.is_empty()).then(|| all.join("; "))
}

#[cfg(test)]
#[path = "status_tests.rs"]
mod tests;
