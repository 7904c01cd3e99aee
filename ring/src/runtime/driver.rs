//! The member's cycle loop: one dedicated thread per member that owns its [`MemberCore`] and
//! its application (card or station logic), moves frames between the transport and the core,
//! runs the clock (paced and lockstep in [`super::stepped`], realtime pacing, holdover) and
//! answers control requests.
//!
//! Forward first, compute after: a received frame is forwarded before the tick runs.
//!
//! Followers tick on every frame of a new ring cycle (locked when it carries the sync packet,
//! unlocked when it does not: a dropped sync packet or a dark frame). In paced and lockstep
//! mode they fall back to their own (holdover) clock only when their upstream member is known
//! dead (its liveliness went away) or has passed nothing on for the frozen-member wait; each
//! such cycle is loss of light on their input (a byte violation, a dark frame forwarded).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use tracing::{info, trace, warn};

use super::pacer::Pacer;
use crate::config::ClockMode;
use crate::control::{CtlReply, FaultRequest, MemberStatus};
use crate::core::{MemberCore, RingApp};
use crate::fault::Outgoing;
use crate::transport::{LinkRx, LinkTx, TransportError};

/// How a member's loop is clocked.
#[derive(Debug, Clone)]
pub struct DriverConfig {
    /// Member name (for logs).
    pub name: String,
    /// Clock mode.
    pub clock: ClockMode,
    /// Nominal ring rate (Hz).
    pub rate_hz: f64,
    /// Paced: the real-time factor (ring time advances at `rtf` × wall time).
    pub rtf: f64,
    /// Paced and lockstep: the frozen-member wait. A sync master whose cycle has not come back
    /// within it declares the ring down and runs cycles on its own clock.
    pub member_timeout: Duration,
    /// Raised while the upstream member is known dead (its liveliness token went away): its
    /// link carries no light.
    pub upstream_dead: Option<Arc<AtomicBool>>,
    /// Realtime: ask for SCHED_FIFO and locked memory for the cycle thread (process members).
    pub harden: bool,
    /// Stop after this many cycles (benchmarks); `None` = run until stopped.
    pub max_cycles: Option<u64>,
    /// Kind reported in status.
    pub kind: crate::control::MemberKind,
    /// Position in the ring order.
    pub position: usize,
    /// Extra status fields (card ports, station nodes, ...).
    pub extra: serde_json::Map<String, serde_json::Value>,
    /// Record up to this many `(cycle, ns)` timing samples (benchmarks; 0 = none): the sync
    /// master records each cycle's scheduled start, the others each sync packet's arrival, both
    /// on the system-wide monotonic clock.
    pub record: usize,
    /// Realtime phase alignment: every member runs its tick of cycle k at the sync master's
    /// start of cycle k plus this delay (the cycle's origin travels in the frame), so the cards
    /// of a ring act at the same instant whatever their ring position; a member whose sync
    /// packet arrives later than that ticks at once. 0 = tick on arrival.
    pub phase_delay_ns: u64,
}

/// Phase alignment spins (instead of sleeping) for the last this many ns before the moment.
const ALIGN_SPIN_NS: u64 = 60_000;

/// A request to the member's loop.
#[derive(Debug)]
pub enum DriverCmd {
    /// Report status.
    Status(Sender<MemberStatus>),
    /// Inject or clear faults on the send path.
    Fault(FaultRequest, Sender<CtlReply>),
    /// Reset the ring-fault latch (`$$$`).
    ResetRingFault(Sender<CtlReply>),
    /// Leave the loop.
    Stop,
}

/// Why the loop ended.
#[derive(Debug)]
pub enum DriverExit {
    /// A stop was requested.
    Stopped,
    /// `max_cycles` reached.
    Done,
    /// The transport went away.
    Transport(TransportError),
}

/// System-wide monotonic clock in nanoseconds (`CLOCK_MONOTONIC`): comparable across the
/// processes of one machine, used for frame send stamps and realtime measurements.
pub fn monotonic_ns() -> u64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .map(|t| (t.tv_sec() as u64).saturating_mul(1_000_000_000) + t.tv_nsec() as u64)
        .unwrap_or(0)
}

/// Everything the loop needs.
pub struct Driver<A: RingApp> {
    pub(super) cfg: DriverConfig,
    pub(super) core: MemberCore,
    app: A,
    tx: Box<dyn LinkTx>,
    pub(super) rx: LinkRx,
    cmds: Receiver<DriverCmd>,
    stop: Arc<AtomicBool>,
    /// Frames held back by a `delay-us` fault: (due time, bytes).
    pub(super) delayed: Vec<(Instant, Vec<u8>)>,
    cycles_run: u64,
    records: Vec<(u64, u64)>,
    /// The receive link closed (an in-process upstream whose loop ended): nothing will come.
    rx_closed: bool,
    /// What the cycle thread got from the scheduler.
    sched: Option<String>,
    /// Synchronizing master: the clock figures for the status report.
    pub(super) clock: Option<super::timing::ClockStats>,
}

impl<A: RingApp> std::fmt::Debug for Driver<A> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Driver")
            .field("cfg", &self.cfg)
            .finish_non_exhaustive()
    }
}

impl<A: RingApp> Driver<A> {
    /// Assemble a driver. `stop` may be shared with signal handlers and watchdogs.
    pub fn new(
        cfg: DriverConfig,
        core: MemberCore,
        app: A,
        tx: Box<dyn LinkTx>,
        rx: LinkRx,
        cmds: Receiver<DriverCmd>,
        stop: Arc<AtomicBool>,
    ) -> Self {
        Driver {
            cfg,
            core,
            app,
            tx,
            rx,
            cmds,
            stop,
            delayed: Vec::new(),
            cycles_run: 0,
            records: Vec::new(),
            rx_closed: false,
            sched: None,
            clock: None,
        }
    }

    /// The application (after the loop ended).
    pub fn into_parts(self) -> (MemberCore, A) {
        (self.core, self.app)
    }

    /// The synchronizing master's clock report (None on other members).
    pub fn clock_report(&self) -> Option<crate::control::ClockReport> {
        self.clock.as_ref().map(|c| c.report(monotonic_ns()))
    }

    /// Timing samples recorded so far (see [`DriverConfig::record`]).
    pub fn take_records(&mut self) -> Vec<(u64, u64)> {
        std::mem::take(&mut self.records)
    }

    pub(super) fn record(&mut self, cycle: u64, ns: u64) {
        if self.records.len() < self.cfg.record {
            self.records.push((cycle, ns));
        }
    }

    pub(super) fn now_ns(&self) -> u64 {
        monotonic_ns()
    }

    pub(super) fn period_ns(&self) -> u64 {
        (1e9 / self.cfg.rate_hz.max(1e-3)) as u64
    }

    /// Wall time of one ring cycle: the period divided by the real-time factor when paced.
    pub(super) fn wall_period_ns(&self) -> u64 {
        match self.cfg.clock {
            ClockMode::Paced if self.cfg.rtf.is_finite() && self.cfg.rtf > 0.0 => {
                ((self.period_ns() as f64 / self.cfg.rtf) as u64).max(1)
            }
            _ => self.period_ns(),
        }
    }

    /// Time the core and the application see for ring cycle `cycle`: ring time (one nominal
    /// period per cycle) in paced and lockstep mode — so one program gives the same trajectory
    /// cycle for cycle in both — the monotonic clock in realtime.
    pub(super) fn time_for(&self, cycle: u64) -> u64 {
        match self.cfg.clock {
            ClockMode::Paced | ClockMode::Lockstep => cycle.saturating_mul(self.period_ns()),
            ClockMode::Realtime => self.now_ns(),
        }
    }

    /// The upstream member is known dead (its link carries no light).
    pub(super) fn upstream_dead(&self) -> bool {
        self.rx_closed
            || self
                .cfg
                .upstream_dead
                .as_ref()
                .is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// The next frame from upstream within `wait`. A closed link is a dead upstream (loss of
    /// light), not the end of this member: it then just waits.
    pub(super) fn recv(&mut self, wait: Duration) -> Result<Option<Vec<u8>>, TransportError> {
        if !self.rx_closed {
            match self.rx.recv_timeout(wait) {
                Err(TransportError::Closed) => {
                    warn!(member = %self.cfg.name, "receive link closed: loss of light");
                    self.rx_closed = true;
                }
                other => return other,
            }
        }
        std::thread::sleep(wait);
        Ok(None)
    }

    /// Run until stopped. Blocks the calling thread.
    pub fn run(&mut self) -> DriverExit {
        if self.cfg.clock == ClockMode::Paced
            || (self.cfg.clock == ClockMode::Realtime && self.cfg.phase_delay_ns > 0)
        {
            // Sleeps end within a few µs of their deadline instead of the default 50 µs slack.
            #[cfg(target_os = "linux")]
            let _ = nix::sys::prctl::set_timerslack(1);
        }
        if self.cfg.harden && self.cfg.clock == ClockMode::Realtime {
            let got = super::rt::harden_cycle_thread();
            info!(member = %self.cfg.name, "realtime cycle thread: {got}");
            self.sched = Some(got);
        } else if self.cfg.harden {
            self.sched = Some(super::rt::NORMAL.to_string());
        }
        info!(member = %self.cfg.name, clock = self.cfg.clock.as_str(), "ring member running");
        let r = if self.core.is_sync_master() {
            let rtf = match self.cfg.clock {
                ClockMode::Paced => self.cfg.rtf,
                _ => 1.0,
            };
            self.clock = Some(super::timing::ClockStats::new(
                self.cfg.clock.as_str(),
                self.period_ns(),
                rtf,
            ));
            match self.cfg.clock {
                ClockMode::Paced | ClockMode::Lockstep => self.run_sync_master_stepped(),
                ClockMode::Realtime => self.run_sync_master_realtime(),
            }
        } else {
            self.run_follower()
        };
        info!(member = %self.cfg.name, ?r, "ring member stopped");
        r
    }

    pub(super) fn send_all(&mut self, out: Vec<Outgoing>) -> Result<(), TransportError> {
        for o in out {
            if o.delay_us > 0 {
                let due = Instant::now() + Duration::from_micros(u64::from(o.delay_us));
                self.delayed.push((due, o.frame_bytes));
            } else {
                self.tx.send(&o.frame_bytes)?;
            }
        }
        Ok(())
    }

    pub(super) fn flush_delayed(&mut self) -> Result<(), TransportError> {
        let released = self.core.poll_faults();
        self.send_all(released)?;
        if self.delayed.is_empty() {
            return Ok(());
        }
        let now = Instant::now();
        let mut i = 0;
        while i < self.delayed.len() {
            if self.delayed[i].0 <= now {
                let (_, bytes) = self.delayed.remove(i);
                self.tx.send(&bytes)?;
            } else {
                i += 1;
            }
        }
        Ok(())
    }

    /// Handle control requests; true when the loop must stop.
    pub(super) fn service(&mut self) -> bool {
        if self.stop.load(Ordering::Relaxed) {
            return true;
        }
        while let Ok(cmd) = self.cmds.try_recv() {
            match cmd {
                DriverCmd::Status(reply) => {
                    let mut s = self.core.status();
                    s.name = self.cfg.name.clone();
                    s.kind = Some(self.cfg.kind);
                    s.pid = std::process::id();
                    s.ring_position = self.cfg.position;
                    s.extra = self.cfg.extra.clone();
                    s.clock = self.clock.as_ref().map(|c| c.report(monotonic_ns()));
                    s.sched = self.sched.clone();
                    if let Some(c) = &s.clock {
                        s.late_cycles = s.late_cycles.max(c.late_cycles);
                    }
                    let _ = reply.send(s);
                }
                DriverCmd::Fault(req, reply) => {
                    let msg = match req {
                        FaultRequest::Inject { spec } => {
                            info!(member = %self.cfg.name, ?spec, "fault injected");
                            match self.core.inject_fault(spec) {
                                Ok(()) => "fault injected".to_string(),
                                Err(e) => {
                                    let _ = reply.send(CtlReply {
                                        ok: false,
                                        message: e.to_string(),
                                    });
                                    continue;
                                }
                            }
                        }
                        FaultRequest::Clear => {
                            info!(member = %self.cfg.name, "faults cleared");
                            self.core.clear_faults();
                            "faults cleared".to_string()
                        }
                    };
                    let _ = reply.send(CtlReply {
                        ok: true,
                        message: msg,
                    });
                }
                DriverCmd::ResetRingFault(reply) => {
                    let cleared = self.core.reset();
                    let _ = reply.send(CtlReply {
                        ok: cleared,
                        message: if cleared {
                            "ring fault cleared".into()
                        } else {
                            "ring still unhealthy: fault stays latched".into()
                        },
                    });
                }
                DriverCmd::Stop => return true,
            }
        }
        false
    }

    /// One servo tick of this member for `cycle` (after forwarding).
    pub(super) fn tick(&mut self, cycle: u64) {
        let t = self.time_for(cycle);
        let was = self.core.ring_fault();
        if let Some(fault) = self.core.tick_app(&mut self.app, cycle, t) {
            if !was {
                warn!(member = %self.cfg.name, cycle, ?fault, "ring fault");
            }
        }
        self.cycles_run += 1;
    }

    /// Why the loop must end now, if it must (a stop request, or `max_cycles` reached).
    pub(super) fn stop_or_done(&mut self) -> Option<DriverExit> {
        if self.service() {
            return Some(DriverExit::Stopped);
        }
        self.done().then_some(DriverExit::Done)
    }

    pub(super) fn done(&self) -> bool {
        self.cfg.max_cycles.is_some_and(|m| self.cycles_run >= m)
    }

    fn run_sync_master_realtime(&mut self) -> DriverExit {
        let mut pacer = Pacer::new(self.cfg.rate_hz);
        loop {
            if let Some(exit) = self.stop_or_done() {
                return exit;
            }
            // Receive until the next cycle is due, then start it.
            loop {
                if let Err(e) = self.flush_delayed() {
                    return DriverExit::Transport(e);
                }
                let left = pacer.until_next();
                if left < Duration::from_micros(150) {
                    break;
                }
                match self.recv(left - Duration::from_micros(100)) {
                    Ok(Some(bytes)) => {
                        let now = self.now_ns();
                        let ev = self.core.on_frame(&bytes, now);
                        if let Err(e) = self.send_all(ev.outgoing) {
                            return DriverExit::Transport(e);
                        }
                    }
                    Ok(None) => {}
                    Err(e) => return DriverExit::Transport(e),
                }
            }
            let before = pacer.late_cycles();
            let (cycle, lateness) = pacer.wait_next();
            if self.cfg.record > 0 {
                let due = pacer.deadline_ns(cycle);
                self.record(cycle, due);
            }
            trace!(cycle, lateness, "cycle start");
            for _ in before..pacer.late_cycles() {
                self.core.note_late();
            }
            let t = self.now_ns();
            if let Some(c) = self.clock.as_mut() {
                c.on_start(
                    cycle,
                    t,
                    Some(super::timing::Start {
                        lag_ns: lateness,
                        late: lateness as f64 > pacer.period_ns() * 0.5,
                        lost_ns: 0,
                    }),
                );
            }
            let out = self.core.start_cycle(cycle, t);
            if let Err(e) = self.send_all(out) {
                return DriverExit::Transport(e);
            }
            self.align(t);
            self.tick(cycle);
            if self.upstream_dead() {
                // Loss of light on the way back: nothing returns.
                let _ = self.core.dark_input(cycle, t);
            }
        }
    }

    /// Realtime phase alignment: wait until `origin_ns + phase_delay_ns` (no wait when the
    /// delay is 0, the origin unknown, or the moment already past).
    fn align(&self, origin_ns: u64) {
        if self.cfg.phase_delay_ns == 0 || origin_ns == 0 || self.cfg.clock != ClockMode::Realtime {
            return;
        }
        let target = origin_ns.saturating_add(self.cfg.phase_delay_ns);
        // Sleep to just before the moment, then spin the rest: a wake-up from sleep alone can be
        // tens of µs late, which would show as skew between cards.
        let now = self.now_ns();
        if target > now + ALIGN_SPIN_NS {
            std::thread::sleep(Duration::from_nanos(target - now - ALIGN_SPIN_NS));
        }
        while self.now_ns() < target {
            std::hint::spin_loop();
        }
    }

    fn run_follower(&mut self) -> DriverExit {
        let stepped = self.cfg.clock.is_stepped();
        loop {
            if let Some(exit) = self.stop_or_done() {
                return exit;
            }
            if let Err(e) = self.flush_delayed() {
                return DriverExit::Transport(e);
            }
            let dead = self.upstream_dead();
            if dead {
                // Nothing will come: run the own clock now, not after the frozen-member wait.
                self.core.expedite_holdover(self.now_ns());
            }
            let wait = if self.delayed.is_empty() {
                let until_holdover = self
                    .core
                    .holdover_due_ns()
                    .map(|due| Duration::from_nanos(due.saturating_sub(self.now_ns())))
                    .unwrap_or(Duration::from_millis(2));
                until_holdover.clamp(Duration::from_micros(20), Duration::from_millis(2))
            } else {
                Duration::from_micros(50)
            };
            match self.recv(wait) {
                Ok(Some(bytes)) => {
                    let dropped = self.rx.take_dropped();
                    for _ in 0..dropped {
                        self.core.note_overrun();
                    }
                    let now = self.now_ns();
                    let ev = self.core.on_frame(&bytes, now);
                    if let Err(e) = self.send_all(ev.outgoing) {
                        return DriverExit::Transport(e);
                    }
                    if let Some(cycle) = ev.sync.or(ev.unlocked) {
                        if self.cfg.record > 0 {
                            self.record(cycle, now);
                        }
                        if ev.sync.is_some() {
                            self.align(ev.origin_ns);
                        }
                        self.tick(cycle);
                    }
                }
                Ok(None) => {}
                Err(e) => return DriverExit::Transport(e),
            }
            // Holdover: no frame for too long → tick on the local clock. In paced and lockstep
            // mode that only happens once the upstream member stopped answering (the frozen
            // wait) or is known dead: its link is dark, each such cycle a byte violation.
            let now = self.now_ns();
            while let Some(cycle) = self.core.on_holdover(now) {
                trace!(member = %self.cfg.name, cycle, "holdover tick");
                if stepped || self.upstream_dead() {
                    let ev = self.core.dark_input(cycle, now);
                    if let Err(e) = self.send_all(ev.outgoing) {
                        return DriverExit::Transport(e);
                    }
                }
                self.tick(cycle);
                if self.done() {
                    break;
                }
            }
        }
    }
}
