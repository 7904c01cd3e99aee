//! The member's cycle loop: one dedicated thread per member that owns its [`MemberCore`] and
//! its application (card or station logic), moves frames between the transport and the core,
//! runs the clock (realtime pacing, lockstep, holdover) and answers control requests.
//!
//! Forward first, compute after: a received frame is forwarded before the tick runs.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use tracing::{debug, info, trace, warn};

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
    /// Lockstep: how long the sync master waits for its sync packet to come back before it
    /// starts the next cycle anyway; also the holdover period of the other members.
    pub lockstep_timeout: Duration,
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
    cfg: DriverConfig,
    core: MemberCore,
    app: A,
    tx: Box<dyn LinkTx>,
    rx: LinkRx,
    cmds: Receiver<DriverCmd>,
    stop: Arc<AtomicBool>,
    /// Frames held back by a `delay-us` fault: (due time, bytes).
    delayed: Vec<(Instant, Vec<u8>)>,
    cycles_run: u64,
    records: Vec<(u64, u64)>,
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
        }
    }

    /// The application (after the loop ended).
    pub fn into_parts(self) -> (MemberCore, A) {
        (self.core, self.app)
    }

    /// Timing samples recorded so far (see [`DriverConfig::record`]).
    pub fn take_records(&mut self) -> Vec<(u64, u64)> {
        std::mem::take(&mut self.records)
    }

    fn record(&mut self, cycle: u64, ns: u64) {
        if self.records.len() < self.cfg.record {
            self.records.push((cycle, ns));
        }
    }

    fn now_ns(&self) -> u64 {
        monotonic_ns()
    }

    fn period_ns(&self) -> u64 {
        (1e9 / self.cfg.rate_hz.max(1e-3)) as u64
    }

    /// Time the core and the application see for ring cycle `cycle`: simulated (one nominal
    /// period per cycle) in lockstep, the monotonic clock in realtime.
    fn time_for(&self, cycle: u64) -> u64 {
        match self.cfg.clock {
            ClockMode::Lockstep => cycle.saturating_mul(self.period_ns()),
            ClockMode::Realtime => self.now_ns(),
        }
    }

    /// Run until stopped. Blocks the calling thread.
    pub fn run(&mut self) -> DriverExit {
        if self.cfg.clock == ClockMode::Realtime && self.cfg.phase_delay_ns > 0 {
            // Sleeps end within a few µs of their deadline instead of the default 50 µs slack.
            #[cfg(target_os = "linux")]
            let _ = nix::sys::prctl::set_timerslack(1);
        }
        info!(member = %self.cfg.name, clock = self.cfg.clock.as_str(), "ring member running");
        let r = if self.core.is_sync_master() {
            match self.cfg.clock {
                ClockMode::Lockstep => self.run_sync_master_lockstep(),
                ClockMode::Realtime => self.run_sync_master_realtime(),
            }
        } else {
            self.run_follower()
        };
        info!(member = %self.cfg.name, ?r, "ring member stopped");
        r
    }

    fn send_all(&mut self, out: Vec<Outgoing>) -> Result<(), TransportError> {
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

    fn flush_delayed(&mut self) -> Result<(), TransportError> {
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
    fn service(&mut self) -> bool {
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
                    s.extra.extend(self.app.status_extra());
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
                                        message: e,
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
    fn tick(&mut self, cycle: u64) {
        let t = self.time_for(cycle);
        let was = self.core.ring_fault();
        if let Some(fault) = self.core.tick_app(&mut self.app, cycle, t) {
            if !was {
                warn!(member = %self.cfg.name, cycle, ?fault, "ring fault");
            }
        }
        self.cycles_run += 1;
    }

    fn done(&self) -> bool {
        self.cfg.max_cycles.is_some_and(|m| self.cycles_run >= m)
    }

    fn run_sync_master_lockstep(&mut self) -> DriverExit {
        let mut cycle: u64 = 0;
        loop {
            if self.service() {
                return DriverExit::Stopped;
            }
            if self.done() {
                return DriverExit::Done;
            }
            let t = self.time_for(cycle);
            let out = self.core.start_cycle(cycle, t);
            if let Err(e) = self.send_all(out) {
                return DriverExit::Transport(e);
            }
            self.tick(cycle);
            // Wait for the sync packet to come back around (or give up after the timeout).
            let deadline = Instant::now() + self.cfg.lockstep_timeout;
            loop {
                if let Err(e) = self.flush_delayed() {
                    return DriverExit::Transport(e);
                }
                let left = deadline.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    debug!(member = %self.cfg.name, cycle, "sync packet did not come back");
                    break;
                }
                let wait = if self.delayed.is_empty() {
                    left.min(Duration::from_millis(5))
                } else {
                    Duration::from_micros(50)
                };
                match self.rx.recv_timeout(wait) {
                    Ok(Some(bytes)) => {
                        let now = self.time_for(cycle);
                        let ev = self.core.on_frame(&bytes, now);
                        if let Err(e) = self.send_all(ev.outgoing) {
                            return DriverExit::Transport(e);
                        }
                        if ev.cycle_complete.is_some_and(|c| c >= cycle) {
                            break;
                        }
                    }
                    Ok(None) => {
                        if self.service() {
                            return DriverExit::Stopped;
                        }
                    }
                    Err(e) => return DriverExit::Transport(e),
                }
            }
            cycle += 1;
        }
    }

    fn run_sync_master_realtime(&mut self) -> DriverExit {
        let mut pacer = Pacer::new(self.cfg.rate_hz);
        loop {
            if self.service() {
                return DriverExit::Stopped;
            }
            if self.done() {
                return DriverExit::Done;
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
                match self.rx.recv_timeout(left - Duration::from_micros(100)) {
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
            let out = self.core.start_cycle(cycle, t);
            if let Err(e) = self.send_all(out) {
                return DriverExit::Transport(e);
            }
            self.align(t);
            self.tick(cycle);
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
            if self.service() {
                return DriverExit::Stopped;
            }
            if self.done() {
                return DriverExit::Done;
            }
            if let Err(e) = self.flush_delayed() {
                return DriverExit::Transport(e);
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
            match self.rx.recv_timeout(wait) {
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
                    if let Some(cycle) = ev.sync {
                        if self.cfg.record > 0 {
                            self.record(cycle, now);
                        }
                        self.align(ev.origin_ns);
                        self.tick(cycle);
                    }
                }
                Ok(None) => {}
                Err(e) => return DriverExit::Transport(e),
            }
            // Holdover: no sync packet for too long → tick on the local clock.
            let now = self.now_ns();
            while let Some(cycle) = self.core.on_holdover(now) {
                trace!(member = %self.cfg.name, cycle, "holdover tick");
                self.tick(cycle);
                if self.done() {
                    break;
                }
            }
        }
    }
}
