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

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use tracing::{info, trace, warn};

use super::pacer::Pacer;
use crate::control::{CtlReply, FaultRequest, MemberStatus};
use crate::core::{MemberCore, RingApp};
use crate::fault::Outgoing;
use crate::transport::{LinkRx, LinkTx, TransportError};
use mcc_contracts::config::ClockMode;

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
    /// Paced and lockstep sync master: how many times a ring member came back (its
    /// liveliness token reappeared, see [`super::light::watch_rejoins`]).
    pub rejoins: Option<Arc<AtomicU64>>,
    /// Paced and lockstep sync master: every ring member's liveliness token is present.
    pub members_present: Option<Arc<AtomicBool>>,
    /// Paced and lockstep sync master: 1 + the latest rejoin count (see `rejoins`) for which
    /// every other member reported its link's publisher matched (see [`super::links_up`]).
    pub links_matched: Option<Arc<AtomicU64>>,
    /// Paced and lockstep sync master: ring cycles in flight (see [`super::stepped`]).
    pub in_flight: u64,
    /// Whether the upstream process (on this machine) is stopped: consulted once nothing has
    /// come from upstream for [`STOP_PROBE_AFTER`].
    pub upstream_probe: Option<super::light::StopProbe>,
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

/// Silence from upstream after which the member looks at whether the upstream process is
/// stopped (a fact on this machine, not a timeout: a slow process is never "stopped").
pub const STOP_PROBE_AFTER: Duration = Duration::from_millis(20);
/// How often a silent member looks again.
const STOP_PROBE_EVERY_NS: u64 = 10_000_000;

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
    /// Frames held back by a `delay-us` fault: (due time, bytes). Held on the wall clock only:
    /// the frame still belongs to the cycle it was sent in (`docs/ring.md`, Faults).
    pub(super) delayed: Vec<(Instant, Vec<u8>)>,
    cycles_run: u64,
    records: Vec<(u64, u64)>,
    /// The receive link closed (an in-process upstream whose loop ended): nothing will come.
    rx_closed: bool,
    /// When the last frame came from upstream (monotonic ns).
    last_rx_ns: u64,
    /// The stop probe's last look: (when, upstream stopped).
    probed: (u64, bool),
    /// The dead flag's last check: (when, the upstream process was still there).
    dead_checked: (u64, bool),
    /// Attended silence on the input (the frozen-member judgement).
    pub(super) silence: super::silence::Silence,
    /// The upstream member has been judged frozen (for logging the change once).
    frozen: bool,
    /// What the cycle thread got from the scheduler.
    sched: Option<String>,
    /// Synchronizing master: the clock figures for the status report.
    pub(super) clock: Option<super::timing::ClockStats>,
    /// The tick of a frame handled on the receive thread, left for the member's thread (see
    /// [`super::inline`]), not run yet.
    pending_tick: Option<u64>,
    /// The application is kept outside the driver (inline receive keeps it on the member's
    /// thread): a status request or an application fault waits in [`Driver::app_waiting`]
    /// until that thread answers it ([`Driver::answer_app`]).
    pub(super) app_elsewhere: bool,
    /// Requests waiting for the application, in arrival order (only with `app_elsewhere`).
    app_waiting: Vec<AppQuery>,
}

/// A request that needs the application, queued while it is kept on another thread.
#[derive(Debug)]
enum AppQuery {
    /// A status report with the application's fields.
    Status(Sender<MemberStatus>),
    /// [`FaultRequest::App`].
    Fault(serde_json::Value, Sender<CtlReply>),
    /// [`FaultRequest::Clear`]: the application's part.
    Clear,
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
            last_rx_ns: monotonic_ns(),
            probed: (0, false),
            dead_checked: (0, false),
            silence: super::silence::Silence::default(),
            frozen: false,
            sched: None,
            clock: None,
            pending_tick: None,
            app_elsewhere: false,
            app_waiting: Vec::new(),
        }
    }

    /// The same driver with application `app` instead of its own, which is given back (the
    /// inline receive shares the driver with zenoh's receive thread but keeps the application
    /// on the member's thread).
    pub(super) fn swap_app<B: RingApp>(self, app: B) -> (Driver<B>, A) {
        let Driver {
            cfg,
            core,
            app: old,
            tx,
            rx,
            cmds,
            stop,
            delayed,
            cycles_run,
            records,
            rx_closed,
            last_rx_ns,
            probed,
            dead_checked,
            silence,
            frozen,
            sched,
            clock,
            pending_tick,
            app_elsewhere,
            app_waiting,
        } = self;
        (
            Driver {
                cfg,
                core,
                app,
                tx,
                rx,
                cmds,
                stop,
                delayed,
                cycles_run,
                records,
                rx_closed,
                last_rx_ns,
                probed,
                dead_checked,
                silence,
                frozen,
                sched,
                clock,
                pending_tick,
                app_elsewhere,
                app_waiting,
            },
            old,
        )
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

    /// The upstream member is known dead, or its process is stopped and nothing comes from it:
    /// its link carries no light.
    /// Whether this member's outgoing link has a receiver (see [`LinkTx::matched`]).
    pub(super) fn link_matched(&self) -> Option<bool> {
        self.tx.matched()
    }

    pub(super) fn upstream_dead(&mut self) -> bool {
        if self.rx_closed {
            return true;
        }
        let now = monotonic_ns();
        if self
            .cfg
            .upstream_dead
            .as_ref()
            .is_some_and(|f| f.load(Ordering::Relaxed))
        {
            // Its liveliness went away: dead unless its process (on this machine) is still
            // there. Looked at every 10 ms.
            if now.saturating_sub(self.dead_checked.0) >= STOP_PROBE_EVERY_NS {
                let alive = self.cfg.upstream_probe.as_ref().is_some_and(|p| p.alive());
                if alive && !self.dead_checked.1 {
                    warn!(member = %self.cfg.name,
                        "upstream liveliness went away but its process is still there: not dead");
                }
                self.dead_checked = (now, alive);
            }
            if !self.dead_checked.1 {
                return true;
            }
        } else {
            self.dead_checked = (0, false);
        }
        let Some(probe) = &self.cfg.upstream_probe else {
            return false;
        };
        if now.saturating_sub(self.last_rx_ns) < STOP_PROBE_AFTER.as_nanos() as u64 {
            return false;
        }
        if now.saturating_sub(self.probed.0) >= STOP_PROBE_EVERY_NS {
            let stopped = probe.stopped();
            if stopped && !self.probed.1 {
                warn!(member = %self.cfg.name, "upstream process is stopped: loss of light");
            }
            self.probed = (now, stopped);
        }
        self.probed.1
    }

    /// Follower, paced and lockstep: the upstream member has stopped answering — nothing came
    /// from it for the frozen-member wait of attended silence (see [`super::silence`]).
    fn upstream_frozen(&mut self) -> bool {
        let attended = self.silence.look(monotonic_ns());
        let frozen = attended >= self.cfg.member_timeout.as_nanos() as u64;
        if frozen != self.frozen {
            self.frozen = frozen;
            if frozen {
                warn!(
                    member = %self.cfg.name,
                    "nothing from upstream for {} ms: the upstream member stopped answering, \
                     cycles run on the own clock",
                    attended / 1_000_000
                );
            }
        }
        frozen
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
                Ok(Some(frame)) => {
                    self.last_rx_ns = monotonic_ns();
                    self.silence.reset(self.last_rx_ns);
                    self.probed.1 = false;
                    return Ok(Some(frame));
                }
                other => return other,
            }
        }
        std::thread::sleep(wait);
        Ok(None)
    }

    /// Run until stopped. Blocks the calling thread.
    pub fn run(&mut self) -> DriverExit {
        self.prepare();
        info!(member = %self.cfg.name, clock = self.cfg.clock.as_str(), "ring member running");
        let r = if self.core.is_sync_master() {
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

    /// Before the loop: the cycle thread's timer slack and scheduling, the sync master's clock
    /// figures.
    pub(super) fn prepare(&mut self) {
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
            self.sched = Some(super::rt::current_scheduling());
        }
        if self.core.is_sync_master() {
            let rtf = match self.cfg.clock {
                ClockMode::Paced => self.cfg.rtf,
                _ => 1.0,
            };
            self.clock = Some(super::timing::ClockStats::new(
                self.cfg.clock.as_str(),
                self.period_ns(),
                rtf,
            ));
        }
    }

    pub(super) fn send_all(&mut self, out: Vec<Outgoing>) -> Result<(), TransportError> {
        for o in out {
            if o.delay_us > 0 {
                let due = Instant::now() + Duration::from_micros(u64::from(o.delay_us));
                self.delayed.push((due, o.frame_bytes));
            } else {
                self.tx.send(o.frame_bytes)?;
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
                self.tx.send(bytes)?;
            } else {
                i += 1;
            }
        }
        Ok(())
    }

    /// The member's status with the application's fields `app`.
    fn status_report(&self, app: serde_json::Map<String, serde_json::Value>) -> MemberStatus {
        let mut s = self.core.status();
        s.name = self.cfg.name.clone();
        s.kind = Some(self.cfg.kind);
        s.pid = std::process::id();
        s.ring_position = self.cfg.position;
        s.extra = self.cfg.extra.clone();
        s.extra.extend(app);
        s.extra
            .insert("hop".into(), self.rx.hop_summary().to_json());
        s.clock = self.clock.as_ref().map(|c| c.report(monotonic_ns()));
        s.sched = self.sched.clone();
        s.host_id = super::light::host_id();
        s.link_matched = self.tx.matched();
        s.cpu_percent = super::cpu::percent_last_second();
        if let Some(c) = &s.clock {
            s.late_cycles = s.late_cycles.max(c.late_cycles);
        }
        s
    }

    /// Requests are waiting for the application (see `app_elsewhere`).
    pub(super) fn app_wanted(&self) -> bool {
        !self.app_waiting.is_empty()
    }

    /// Answer the waiting requests, in order, with `app`, on the thread that holds it.
    pub(super) fn answer_app(&mut self, app: &mut dyn RingApp) {
        for q in std::mem::take(&mut self.app_waiting) {
            match q {
                AppQuery::Status(reply) => {
                    let _ = reply.send(self.status_report(app.status_extra()));
                }
                AppQuery::Fault(fault, reply) => {
                    let _ = reply.send(self.app_fault_reply(app.app_fault(&fault)));
                }
                AppQuery::Clear => app.clear_app_faults(),
            }
        }
    }

    fn app_fault_reply(&self, r: Result<String, String>) -> CtlReply {
        match r {
            Ok(message) => {
                info!(member = %self.cfg.name, %message, "application fault");
                CtlReply { ok: true, message }
            }
            Err(message) => CtlReply { ok: false, message },
        }
    }

    /// Handle control requests; true when the loop must stop.
    pub(super) fn service(&mut self) -> bool {
        if self.stop.load(Ordering::Relaxed) {
            return true;
        }
        while let Ok(cmd) = self.cmds.try_recv() {
            match cmd {
                DriverCmd::Status(reply) => {
                    if self.app_elsewhere {
                        self.app_waiting.push(AppQuery::Status(reply));
                    } else {
                        let extra = self.app.status_extra();
                        let _ = reply.send(self.status_report(extra));
                    }
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
                            if self.app_elsewhere {
                                self.app_waiting.push(AppQuery::Clear);
                            } else {
                                self.app.clear_app_faults();
                            }
                            "faults cleared".to_string()
                        }
                        FaultRequest::App { fault } => {
                            if self.app_elsewhere {
                                self.app_waiting.push(AppQuery::Fault(fault, reply));
                            } else {
                                let r = self.app.app_fault(&fault);
                                let _ = reply.send(self.app_fault_reply(r));
                            }
                            continue;
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
        self.tick_with(None, cycle);
    }

    /// [`Self::tick`] with `app`, an application held outside the driver (see
    /// [`Self::swap_app`]), or the driver's own (None).
    pub(super) fn tick_with(&mut self, app: Option<&mut dyn RingApp>, cycle: u64) {
        let t = self.time_for(cycle);
        let was = self.core.ring_fault();
        let fault = match app {
            Some(app) => self.core.tick_app(app, cycle, t),
            None => self.core.tick_app(&mut self.app, cycle, t),
        };
        if let Some(fault) = fault {
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
        loop {
            let wait = match self.follower_housekeeping() {
                Ok(w) => w,
                Err(exit) => return exit,
            };
            match self.recv(wait) {
                Ok(Some(bytes)) => {
                    if let Err(e) = self.follower_frame(&bytes, false) {
                        return DriverExit::Transport(e);
                    }
                }
                Ok(None) => {}
                Err(e) => return DriverExit::Transport(e),
            }
            if let Err(e) = self.follower_holdover_with(None) {
                return DriverExit::Transport(e);
            }
        }
    }

    /// Follower, between frames: control requests, the cycle limit, delayed frames, a dead
    /// upstream; how long to wait for the next frame (until the holdover clock is due), or why
    /// to stop.
    pub(super) fn follower_housekeeping(&mut self) -> Result<Duration, DriverExit> {
        if let Some(exit) = self.stop_or_done() {
            return Err(exit);
        }
        self.flush_delayed().map_err(DriverExit::Transport)?;
        // Paced and lockstep: the own clock runs only once the upstream member is known dead
        // (or stopped), or stopped answering (attended silence, not wall time).
        let stepped = self.cfg.clock.is_stepped();
        let own_clock = self.upstream_dead() || (stepped && self.upstream_frozen());
        if own_clock {
            // Nothing will come: run the own clock now.
            self.core.expedite_holdover(self.now_ns());
        }
        Ok(if self.delayed.is_empty() {
            let until_holdover = self
                .core
                .holdover_due_ns()
                .filter(|_| own_clock || !stepped)
                .map(|due| Duration::from_nanos(due.saturating_sub(self.now_ns())))
                .unwrap_or(Duration::from_millis(2));
            until_holdover.clamp(Duration::from_micros(20), Duration::from_millis(2))
        } else {
            Duration::from_micros(50)
        })
    }

    /// Follower: one frame from upstream — forward it, then run the cycle's tick, or with
    /// `defer` leave the tick for the member's thread ([`Self::take_pending_tick`]).
    pub(super) fn follower_frame(
        &mut self,
        bytes: &[u8],
        defer: bool,
    ) -> Result<(), TransportError> {
        let dropped = self.rx.take_dropped();
        for _ in 0..dropped {
            self.core.note_overrun();
        }
        let now = self.now_ns();
        // Upstream is answering (also for frames handled on the receive thread).
        self.last_rx_ns = monotonic_ns();
        self.silence.reset(self.last_rx_ns);
        self.probed.1 = false;
        let ev = self.core.on_frame(bytes, now);
        self.send_all(ev.outgoing)?;
        if let Some(cycle) = ev.sync.or(ev.unlocked) {
            if self.cfg.record > 0 {
                self.record(cycle, now);
            }
            if defer {
                self.defer_tick(cycle);
            } else {
                if ev.sync.is_some() {
                    self.align(ev.origin_ns);
                }
                self.tick(cycle);
            }
        }
        Ok(())
    }

    /// Follower: holdover — no frame for too long → tick on the local clock, with `app` held
    /// outside the driver (None: its own). In paced and lockstep mode that only happens once
    /// the upstream member stopped answering (the frozen wait) or is known dead: its link is
    /// dark, each such cycle a byte violation.
    pub(super) fn follower_holdover_with(
        &mut self,
        mut app: Option<&mut dyn RingApp>,
    ) -> Result<(), TransportError> {
        let stepped = self.cfg.clock.is_stepped();
        if stepped && !(self.upstream_dead() || self.upstream_frozen()) {
            return Ok(());
        }
        let now = self.now_ns();
        while let Some(cycle) = self.core.on_holdover(now) {
            trace!(member = %self.cfg.name, cycle, "holdover tick");
            if stepped || self.upstream_dead() {
                let ev = self.core.dark_input(cycle, now);
                self.send_all(ev.outgoing)?;
            }
            let app: Option<&mut dyn RingApp> = match app.as_mut() {
                Some(a) => Some(&mut **a),
                None => None,
            };
            self.tick_with(app, cycle);
            if self.done() {
                break;
            }
        }
        Ok(())
    }

    /// Leave the tick of `cycle` for the member's thread.
    pub(super) fn defer_tick(&mut self, cycle: u64) {
        self.pending_tick = Some(cycle);
    }

    /// A tick [`Self::follower_frame`] left for the member's thread: run it now with `app`
    /// (None: the driver's own).
    pub(super) fn take_pending_tick(&mut self, app: Option<&mut dyn RingApp>) {
        if let Some(cycle) = self.pending_tick.take() {
            self.tick_with(app, cycle);
        }
    }

    /// A frame handled on the receive thread left a tick for the member's thread.
    pub(super) fn has_pending_tick(&self) -> bool {
        self.pending_tick.is_some()
    }
}
