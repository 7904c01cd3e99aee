//! Loss of light on a member's input, judged on facts rather than timeouts:
//! - the upstream process died: its zenoh liveliness token (`mcc/<cluster>/alive/<upstream>`)
//!   goes away when its transport closes;
//! - the upstream process is stopped (SIGSTOP, a debugger): on the same machine its state in
//!   `/proc/<pid>/stat` says so. The pid and the machine (boot id) come from the upstream's own
//!   status report, asked again whenever its liveliness token (re)appears.
//!
//! A member that is merely slow (descheduled on a loaded machine) is neither: the ring waits for
//! it. And a liveliness token that goes away while the upstream process (on this machine) still
//! exists is no death (a zenoh lease that expired during a stall, a routing change): only a
//! process that is gone or a zombie is dead. Only a member on another machine, or one that runs but never answers, is left to the
//! frozen-member wait.

use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use tracing::{info, warn};
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;
use zenoh::Wait;

use crate::control::{alive_key, ctl_key, MemberStatus};

/// This machine's identity for "same host" checks: the kernel's boot id.
pub fn host_id() -> Option<String> {
    static ID: OnceLock<Option<String>> = OnceLock::new();
    ID.get_or_init(|| {
        std::fs::read_to_string("/proc/sys/kernel/random/boot_id")
            .ok()
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
    })
    .clone()
}

/// Whether process `pid` (of this machine) is stopped: state `T` (stopped by a signal) or `t`
/// (stopped by a tracer) in `/proc/<pid>/stat`. A process that does not exist is not stopped
/// (its death is the liveliness watch's business).
pub fn process_stopped(pid: u32) -> bool {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    // "pid (comm) S ...": comm may contain spaces or parentheses; the state follows the last ')'.
    stat.rfind(')')
        .and_then(|i| stat.get(i + 1..))
        .and_then(|rest| rest.trim_start().chars().next())
        .is_some_and(|c| c == 'T' || c == 't')
}

/// Whether process `pid` (of this machine) exists and is not a zombie: a process whose zenoh
/// liveliness token went away while it still runs has not died (a lease that expired during a
/// stall, a routing change): its silence is left to the frozen-member wait.
pub fn process_alive(pid: u32) -> bool {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    stat.rfind(')')
        .and_then(|i| stat.get(i + 1..))
        .and_then(|rest| rest.trim_start().chars().next())
        .is_some_and(|c| !matches!(c, 'Z' | 'X' | 'x'))
}

/// The upstream's process, when it runs on this machine: is it stopped?
#[derive(Debug, Clone, Default)]
pub struct StopProbe {
    pid: Arc<AtomicU32>,
}

impl StopProbe {
    /// A probe on a known local pid (tests).
    pub fn with_pid(pid: u32) -> Self {
        StopProbe {
            pid: Arc::new(AtomicU32::new(pid)),
        }
    }

    /// The upstream process is known, local and stopped.
    pub fn stopped(&self) -> bool {
        match self.pid.load(Ordering::Relaxed) {
            0 => false,
            pid => process_stopped(pid),
        }
    }

    /// The upstream process is known, local and still there (not dead, not a zombie).
    pub fn alive(&self) -> bool {
        match self.pid.load(Ordering::Relaxed) {
            0 => false,
            pid => process_alive(pid),
        }
    }
}

/// Keeps the watch declared; drop it to undeclare.
pub struct UpstreamWatch {
    _subscriber: Subscriber<()>,
    /// Raised while the upstream member is known dead.
    pub dead: Arc<AtomicBool>,
    /// Whether the upstream process is stopped (local upstreams only).
    pub probe: StopProbe,
}

impl std::fmt::Debug for UpstreamWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UpstreamWatch")
            .field("dead", &self.dead)
            .field("probe", &self.probe)
            .finish_non_exhaustive()
    }
}

/// Ask `upstream` for its status until it answers (or `stop`), and remember its pid if it runs
/// on this machine.
fn learn_pid(session: zenoh::Session, key: String, pid: Arc<AtomicU32>, stop: Arc<AtomicBool>) {
    for _ in 0..40 {
        if stop.load(Ordering::Relaxed) {
            return;
        }
        let answer = session
            .get(&key)
            .timeout(Duration::from_millis(500))
            .wait()
            .ok()
            .and_then(|r| r.recv().ok())
            .and_then(|reply| reply.result().ok().map(|s| s.payload().to_bytes().to_vec()))
            .and_then(|b| serde_json::from_slice::<MemberStatus>(&b).ok());
        if let Some(s) = answer {
            let local = s.host_id.is_some() && s.host_id == host_id();
            pid.store(if local { s.pid } else { 0 }, Ordering::Relaxed);
            return;
        }
        std::thread::sleep(Duration::from_millis(250));
    }
}

/// Watch `upstream`: its liveliness token (the flag rises when a token that was seen goes
/// away and falls when it comes back) and, once it has said who it is, its process state.
pub fn watch_upstream(
    session: &zenoh::Session,
    cluster: &str,
    upstream: &str,
    stop: Arc<AtomicBool>,
) -> Result<UpstreamWatch, super::DeclareError> {
    let dead = Arc::new(AtomicBool::new(false));
    let probe = StopProbe::default();
    let seen = AtomicBool::new(false);
    let flag = Arc::clone(&dead);
    let pid = Arc::clone(&probe.pid);
    let name = upstream.to_string();
    let status_key = ctl_key(cluster, upstream, "status");
    let s2 = session.clone();
    let subscriber = session
        .liveliness()
        .declare_subscriber(alive_key(cluster, upstream))
        .history(true)
        .callback(move |sample| match sample.kind() {
            SampleKind::Put => {
                seen.store(true, Ordering::Relaxed);
                if flag.swap(false, Ordering::Relaxed) {
                    info!(upstream = %name, "upstream member is back: light on the input");
                }
                // (Re)learn who it is, off zenoh's callback thread.
                pid.store(0, Ordering::Relaxed);
                let (s, k, p, st) = (
                    s2.clone(),
                    status_key.clone(),
                    Arc::clone(&pid),
                    Arc::clone(&stop),
                );
                let _ = std::thread::Builder::new()
                    .name("mcc-upstream".into())
                    .spawn(move || learn_pid(s, k, p, st));
            }
            SampleKind::Delete => {
                // (The pid stays known: the member checks the process really is gone.)
                if seen.load(Ordering::Relaxed) && !flag.swap(true, Ordering::Relaxed) {
                    warn!(upstream = %name, "upstream member went away: loss of light on the input");
                }
            }
        })
        .wait()
        .map_err(super::DeclareError::of("upstream liveliness watch"))?;
    Ok(UpstreamWatch {
        _subscriber: subscriber,
        dead,
        probe,
    })
}

/// Keeps the watch declared; drop it to undeclare.
pub struct RejoinWatch {
    _subscriber: Subscriber<()>,
    /// How many times a ring member's liveliness token reappeared after it had been seen.
    pub rejoins: Arc<AtomicU64>,
    /// Every ring member's liveliness token is present.
    pub present: Arc<AtomicBool>,
    /// 1 + the latest rejoin count for which every other member reported a matching link
    /// publisher (0: not even at start; see [`super::links_up`]).
    pub matched_for: Arc<AtomicU64>,
}

impl std::fmt::Debug for RejoinWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RejoinWatch")
            .field("rejoins", &self.rejoins)
            .field("present", &self.present)
            .field("matched_for", &self.matched_for)
            .finish_non_exhaustive()
    }
}

/// How often the sync master asks the members again whose link publisher did not match yet.
const MATCHED_ASK_EVERY: Duration = Duration::from_millis(10);

/// Whether `member` reports a matching link publisher (None: it did not answer).
fn link_matched(session: &zenoh::Session, key: &str) -> Option<bool> {
    session
        .get(key)
        .timeout(Duration::from_millis(500))
        .wait()
        .ok()
        .and_then(|r| r.recv().ok())
        .and_then(|reply| reply.result().ok().map(|s| s.payload().to_bytes().to_vec()))
        .and_then(|b| serde_json::from_slice::<MemberStatus>(&b).ok())
        // A transport that cannot tell (none in a process ring) has nothing to wait for.
        .map(|s| s.link_matched.unwrap_or(true))
}

/// Ask every member in `keys` for its link's matching status until all have a subscriber,
/// then record `rejoin + 1` in `matched_for`; gives up when a newer rejoin came (or `stop`).
fn ask_matched(
    session: zenoh::Session,
    keys: Vec<String>,
    rejoin: u64,
    rejoins: Arc<AtomicU64>,
    matched_for: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
) {
    let mut waiting = keys;
    while !stop.load(Ordering::Relaxed) && rejoins.load(Ordering::Relaxed) == rejoin {
        waiting.retain(|k| link_matched(&session, k) != Some(true));
        if waiting.is_empty() {
            info!(rejoin, "every ring link's publisher has a subscriber");
            matched_for.fetch_max(rejoin + 1, Ordering::Relaxed);
            return;
        }
        std::thread::sleep(MATCHED_ASK_EVERY);
    }
}

/// Sync master `me`: watch the liveliness tokens of the ring's `members` and count each one
/// that comes back after it was first seen (a member restarted or reconnected). A member that
/// rejoins opens new links, and frames sent before they are up are lost: the sync master then
/// runs on its own clock until the links are up ([`super::links_up`], [`super::stepped`])
/// instead of waiting for a cycle that went nowhere. The watch keeps the facts of that
/// decision: whether every token is present, and — asked of the other members after each
/// rejoin — whether every link's publisher has a matching subscriber.
pub fn watch_rejoins(
    session: &zenoh::Session,
    cluster: &str,
    me: &str,
    members: &[String],
    stop: Arc<AtomicBool>,
) -> Result<RejoinWatch, super::DeclareError> {
    let rejoins = Arc::new(AtomicU64::new(0));
    let present = Arc::new(AtomicBool::new(false));
    let matched_for = Arc::new(AtomicU64::new(0));
    let (count, all) = (Arc::clone(&rejoins), Arc::clone(&present));
    let keys: Vec<(String, String)> = members
        .iter()
        .map(|m| (alive_key(cluster, m), m.clone()))
        .collect();
    let status_keys: Vec<String> = members
        .iter()
        .filter(|m| m.as_str() != me)
        .map(|m| ctl_key(cluster, m, "status"))
        .collect();
    let seen = Mutex::new((HashSet::<String>::new(), HashSet::<String>::new()));
    let spawn_ask = {
        let (s, k, c, m, st) = (
            session.clone(),
            status_keys.clone(),
            Arc::clone(&rejoins),
            Arc::clone(&matched_for),
            Arc::clone(&stop),
        );
        move |r: u64| {
            // Off zenoh's callback thread.
            let (s, k, c, m, st) = (
                s.clone(),
                k.clone(),
                Arc::clone(&c),
                Arc::clone(&m),
                Arc::clone(&st),
            );
            let _ = std::thread::Builder::new()
                .name("mcc-links-up".into())
                .spawn(move || ask_matched(s, k, r, c, m, st));
        }
    };
    // The links at start (a restarted sync master judges them too).
    spawn_ask(0);
    let subscriber = session
        .liveliness()
        .declare_subscriber(alive_key(cluster, "*"))
        .history(true)
        .callback(move |sample| {
            let key = sample.key_expr().as_str();
            let Some((_, name)) = keys.iter().find(|(k, _)| k == key) else {
                return;
            };
            let mut guard = seen.lock().unwrap_or_else(|e| e.into_inner());
            let (seen, here) = &mut *guard;
            if sample.kind() == SampleKind::Delete {
                here.remove(name);
                all.store(false, Ordering::Relaxed);
                return;
            }
            here.insert(name.clone());
            all.store(here.len() == keys.len(), Ordering::Relaxed);
            if !seen.insert(name.clone()) {
                info!(member = %name, "ring member rejoined");
                spawn_ask(count.fetch_add(1, Ordering::Relaxed) + 1);
            }
        })
        .wait()
        .map_err(super::DeclareError::of("ring member liveliness watch"))?;
    Ok(RejoinWatch {
        _subscriber: subscriber,
        rejoins,
        present,
        matched_for,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stopped_process_is_seen_stopped_and_a_running_one_is_not() {
        let mut child = std::process::Command::new("sleep")
            .arg("30")
            .spawn()
            .expect("spawn sleep");
        let pid = child.id();
        let probe = StopProbe::with_pid(pid);
        assert!(!probe.stopped(), "sleeping is not stopped");
        nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(pid as i32),
            nix::sys::signal::Signal::SIGSTOP,
        )
        .unwrap();
        let t0 = std::time::Instant::now();
        while !probe.stopped() && t0.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(probe.stopped());
        assert!(probe.alive(), "a stopped process is alive");
        nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(pid as i32),
            nix::sys::signal::Signal::SIGCONT,
        )
        .unwrap();
        let t0 = std::time::Instant::now();
        while probe.stopped() && t0.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(!probe.stopped());
        assert!(probe.alive());
        let _ = child.kill();
        // Killed but not yet reaped: a zombie is dead.
        let t0 = std::time::Instant::now();
        while probe.alive() && t0.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(!probe.alive(), "a zombie is not alive");
        let _ = child.wait();
        assert!(!probe.alive(), "a reaped process is not alive");
        assert!(!StopProbe::default().alive(), "unknown pid");
        assert!(!process_stopped(u32::MAX), "no such process");
        assert!(!StopProbe::default().stopped(), "unknown pid");
        assert!(host_id().is_some_and(|h| h.len() > 8));
    }
}
