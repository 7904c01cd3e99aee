//! Asynchronous cluster events for the terminals (`mcc up` in the foreground, `mcc term`): a
//! ring fault latched (member, error class, cycle), the ring healthy again, a member gone, back
//! or not answering, the ring down, the clock below the requested real-time factor for more
//! than a second. A watcher thread polls the members' status and their liveliness tokens and
//! prints each event on its own line through a [`Printer`] (the line editor's external printer
//! while one is active, so the line being typed is kept).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use mcc_contracts::config::ClusterConfig;
use mcc_ring::control::{alive_key, ErrorCounters, MemberStatus};
use zenoh::sample::SampleKind;
use zenoh::Wait;

use crate::cluster::ctl;

/// How often the watcher asks every member for its status.
pub const POLL: Duration = Duration::from_millis(300);

/// Prefix of every event line.
pub const PREFIX: &str = "mcc event:";

type Sink = Box<dyn FnMut(String) + Send>;

/// Where event lines go: the line editor's external printer once the terminal installs one,
/// stdout until then (and when reading from a pipe).
#[derive(Clone, Default)]
pub struct Printer(Arc<Mutex<Option<Sink>>>);

impl std::fmt::Debug for Printer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Printer").finish_non_exhaustive()
    }
}

impl Printer {
    /// Print one line.
    pub fn line(&self, text: &str) {
        let mut g = self.0.lock().unwrap_or_else(|e| e.into_inner());
        match g.as_mut() {
            Some(sink) => sink(format!("{text}\n")),
            None => println!("{text}"),
        }
    }

    /// From now on, lines go to `sink` (e.g. rustyline's external printer).
    pub fn install(&self, sink: Sink) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(sink);
    }

    /// Back to stdout (the editor is gone).
    pub fn uninstall(&self) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
}

/// What the watcher remembers between polls.
#[derive(Debug, Default)]
pub struct Watch {
    prev: Option<Vec<Option<MemberStatus>>>,
    silent: Vec<u32>,
    faulted: bool,
    below: bool,
    down: bool,
}

fn classes(before: &ErrorCounters, now: &ErrorCounters, dark: bool) -> String {
    let mut v = Vec::new();
    if now.byte_violation > before.byte_violation {
        v.push(if dark {
            "byte violations (loss of light)"
        } else {
            "byte violations"
        });
    }
    if now.checksum > before.checksum {
        v.push("checksum errors");
    }
    if now.overrun > before.overrun {
        v.push("overruns");
    }
    if now.underrun > before.underrun {
        v.push("underruns");
    }
    v.join(", ")
}

impl Watch {
    /// The events between the last statuses seen and `now` (in ring order); the first call
    /// only takes note of the state.
    pub fn step(&mut self, cfg: &ClusterConfig, now: &[Option<MemberStatus>]) -> Vec<String> {
        let mut out = Vec::new();
        let Some(prev) = self.prev.replace(now.to_vec()) else {
            self.silent = vec![0; now.len()];
            self.faulted = now.iter().flatten().any(|m| m.ring_fault);
            return out;
        };
        self.silent.resize(now.len(), 0);
        for (i, (name, cur)) in cfg.ring.order.iter().zip(now).enumerate() {
            let before = prev.get(i).and_then(Option::as_ref);
            match (before, cur) {
                (_, None) => {
                    self.silent[i] += 1;
                    // Two polls in a row without an answer (and not gone: liveliness says so).
                    if self.silent[i] == 2 {
                        out.push(format!(
                            "{PREFIX} {name} does not answer (frozen or overloaded)"
                        ));
                    }
                }
                (Some(b), Some(c)) => {
                    if self.silent[i] >= 2 {
                        out.push(format!("{PREFIX} {name} answers again (pid {})", c.pid));
                    }
                    self.silent[i] = 0;
                    if c.ring_fault_count > b.ring_fault_count
                        || (c.ring_fault && !b.ring_fault && c.pid == b.pid)
                    {
                        out.push(fault_line(name, c, &b.errors));
                    }
                }
                (None, Some(c)) => {
                    if self.silent[i] >= 2 {
                        out.push(format!("{PREFIX} {name} answers again (pid {})", c.pid));
                    }
                    self.silent[i] = 0;
                }
            }
        }
        let all = now.iter().all(Option::is_some);
        let faulted = now.iter().flatten().any(|m| m.ring_fault || m.dark);
        let locked = all && now.iter().flatten().all(|m| m.locked);
        if self.faulted && !faulted && locked {
            let cycle = now.iter().flatten().map(|m| m.cycle).max().unwrap_or(0);
            out.push(format!(
                "{PREFIX} ring healthy again at cycle {cycle}: every latch clear, every member locked"
            ));
            self.faulted = false;
        } else if faulted {
            self.faulted = true;
        }
        let sm = cfg
            .position(&cfg.ring.sync_master)
            .and_then(|i| now.get(i))
            .and_then(Option::as_ref)
            .and_then(|s| s.clock.as_ref());
        if let Some(t) = sm {
            if t.below_rtf_ms >= 1000 && !self.below {
                self.below = true;
                // Issue 27 item 3: said once, with the rate it reaches and what would help.
                out.push(format!(
                    "{PREFIX} clock below the requested real-time factor for {:.1} s: rtf {:.2} of {} \
                     ({:.0} of {:.0} cycles/s, {} members); what helps: a less busy machine, fewer \
                     members, ring.in_flight = 2, real-time priority (chrt -f 10 mcc up)",
                    t.below_rtf_ms as f64 / 1000.0,
                    t.rtf,
                    t.rtf_requested,
                    t.rtf * cfg.rate_hz,
                    cfg.rate_hz * t.rtf_requested,
                    cfg.ring.order.len()
                ));
            } else if t.below_rtf_ms == 0 && self.below {
                self.below = false;
                out.push(format!("{PREFIX} clock back at rtf {:.2}", t.rtf));
            }
            if t.ring_down != self.down {
                self.down = t.ring_down;
                out.push(if t.ring_down {
                    format!(
                        "{PREFIX} ring down: nothing came back within {} ms; the sync master runs cycles on its own clock",
                        cfg.member_timeout_ms
                    )
                } else {
                    format!("{PREFIX} ring cycling again")
                });
            }
        }
        out
    }
}

fn fault_line(name: &str, s: &MemberStatus, before: &ErrorCounters) -> String {
    let class = classes(before, &s.errors, s.dark);
    let reason = s.fault_reason.as_deref().unwrap_or("ring check");
    let at = s
        .ring_fault_cycle
        .map(|c| format!(" at cycle {c}"))
        .unwrap_or_default();
    if class.is_empty() {
        format!("{PREFIX} ring fault latched: {name}{at} ({reason})")
    } else {
        format!("{PREFIX} ring fault latched: {name}{at} ({class}; {reason})")
    }
}

/// A liveliness change of `member`: gone, or back after being gone.
fn liveliness_line(member: &str, gone: bool) -> String {
    if gone {
        format!("{PREFIX} {member} is gone: its process died or its session closed")
    } else {
        format!("{PREFIX} {member} is back (restarted)")
    }
}

/// Keeps the watcher running; dropping it stops the thread.
pub struct Watcher {
    stop: Arc<AtomicBool>,
    _liveliness: Option<zenoh::pubsub::Subscriber<()>>,
}

impl std::fmt::Debug for Watcher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Watcher").finish_non_exhaustive()
    }
}

impl Drop for Watcher {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// Watch cluster `cfg` through `session`, printing events with `printer`.
pub fn spawn(session: zenoh::Session, cfg: ClusterConfig, printer: Printer) -> Watcher {
    let stop = Arc::new(AtomicBool::new(false));
    let members: Vec<String> = cfg.ring.order.clone();
    let prefix = alive_key(&cfg.cluster, "");
    let gone: Arc<Mutex<Vec<String>>> = Arc::default();
    let (p2, g2) = (printer.clone(), Arc::clone(&gone));
    let liveliness = session
        .liveliness()
        .declare_subscriber(alive_key(&cfg.cluster, "*"))
        .callback(move |sample| {
            let key = sample.key_expr().as_str();
            let Some(name) = key.strip_prefix(&prefix) else {
                return;
            };
            if !members.iter().any(|m| m == name) {
                return;
            }
            let mut g = g2.lock().unwrap_or_else(|e| e.into_inner());
            match sample.kind() {
                SampleKind::Delete if !g.iter().any(|m| m == name) => {
                    g.push(name.to_string());
                    p2.line(&liveliness_line(name, true));
                }
                SampleKind::Put if g.iter().any(|m| m == name) => {
                    g.retain(|m| m != name);
                    p2.line(&liveliness_line(name, false));
                }
                _ => {}
            }
        })
        .wait()
        .ok();
    let s2 = Arc::clone(&stop);
    let _ = std::thread::Builder::new()
        .name("mcc-events".into())
        .spawn(move || {
            let mut w = Watch::default();
            while !s2.load(Ordering::Relaxed) {
                let st = ctl::query_statuses(
                    &session,
                    &cfg,
                    Duration::from_millis(250),
                    Duration::from_millis(500),
                );
                if s2.load(Ordering::Relaxed) {
                    break;
                }
                // A member that is gone is reported by its liveliness, not as silent.
                let st: Vec<Option<MemberStatus>> = st;
                for line in w.step(&cfg, &st) {
                    let g = gone.lock().unwrap_or_else(|e| e.into_inner());
                    let about_gone = g.iter().any(|m| {
                        line.starts_with(&format!("{PREFIX} {m} does not answer"))
                            || line.starts_with(&format!("{PREFIX} {m} answers again"))
                    });
                    drop(g);
                    if !about_gone {
                        printer.line(&line);
                    }
                }
                std::thread::sleep(POLL);
            }
        });
    Watcher {
        stop,
        _liveliness: liveliness,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcc_ring::control::ClockReport;

    fn healthy(cfg: &ClusterConfig, cycle: u64) -> Vec<Option<MemberStatus>> {
        cfg.ring
            .order
            .iter()
            .map(|n| {
                Some(MemberStatus {
                    name: n.clone(),
                    pid: 7,
                    locked: true,
                    cycle,
                    ..Default::default()
                })
            })
            .collect()
    }

    #[test]
    fn events_from_status_changes() {
        let cfg = ClusterConfig::default_cluster(2, 2);
        let mut w = Watch::default();
        assert!(
            w.step(&cfg, &healthy(&cfg, 10)).is_empty(),
            "first poll: notes only"
        );
        assert!(w.step(&cfg, &healthy(&cfg, 20)).is_empty());
        // station0 cut: card1 latches with byte violations (dark input).
        let mut st = healthy(&cfg, 30);
        {
            let c1 = st[2].as_mut().unwrap();
            c1.ring_fault = true;
            c1.ring_fault_count = 1;
            c1.ring_fault_cycle = Some(27);
            c1.dark = true;
            c1.locked = false;
            c1.errors.byte_violation = 4;
            c1.fault_reason = Some("ring errors: 2 in the check period (shutdown count 2)".into());
        }
        let ev = w.step(&cfg, &st);
        assert_eq!(
            ev,
            vec![format!(
                "{PREFIX} ring fault latched: card1 at cycle 27 (byte violations (loss of light); ring errors: 2 in the check period (shutdown count 2))"
            )]
        );
        // Still latched: nothing new.
        assert!(w.step(&cfg, &st).is_empty());
        // card0 stops answering for two polls, then answers again.
        let mut quiet = st.clone();
        quiet[0] = None;
        assert!(w.step(&cfg, &quiet).is_empty());
        assert_eq!(
            w.step(&cfg, &quiet),
            vec![format!(
                "{PREFIX} card0 does not answer (frozen or overloaded)"
            )]
        );
        assert_eq!(
            w.step(&cfg, &st),
            vec![format!("{PREFIX} card0 answers again (pid 7)")]
        );
        // Mended and reset: healthy again.
        let ev = w.step(&cfg, &healthy(&cfg, 90));
        assert_eq!(
            ev,
            vec![format!(
                "{PREFIX} ring healthy again at cycle 90: every latch clear, every member locked"
            )]
        );
    }

    #[test]
    fn clock_events_from_the_sync_master() {
        let cfg = ClusterConfig::default_cluster(1, 1);
        let mut w = Watch::default();
        let with = |below: u64, down: bool, rtf: f64| {
            let mut st = healthy(&cfg, 5);
            st[0].as_mut().unwrap().clock = Some(ClockReport {
                mode: "paced".into(),
                rtf_requested: 1.0,
                rtf,
                below_rtf_ms: below,
                ring_down: down,
                ..Default::default()
            });
            st
        };
        w.step(&cfg, &with(0, false, 1.0));
        assert!(
            w.step(&cfg, &with(600, false, 0.7)).is_empty(),
            "not yet a second"
        );
        assert_eq!(
            w.step(&cfg, &with(1200, false, 0.62)),
            vec![format!(
                "{PREFIX} clock below the requested real-time factor for 1.2 s: rtf 0.62 of 1 \
                 (1400 of 2259 cycles/s, 2 members); what helps: a less busy machine, fewer \
                 members, ring.in_flight = 2, real-time priority (chrt -f 10 mcc up)"
            )]
        );
        assert!(
            w.step(&cfg, &with(1500, false, 0.6)).is_empty(),
            "said once"
        );
        let ev = w.step(&cfg, &with(0, true, 1.0));
        assert_eq!(ev.len(), 2, "{ev:?}");
        assert!(ev[0].contains("clock back at rtf 1.00"));
        assert!(ev[1].contains("ring down: nothing came back within 10000 ms"));
        assert_eq!(
            w.step(&cfg, &with(0, false, 1.0)),
            vec![format!("{PREFIX} ring cycling again")]
        );
        assert_eq!(
            liveliness_line("station0", true),
            format!("{PREFIX} station0 is gone: its process died or its session closed")
        );
    }
}
