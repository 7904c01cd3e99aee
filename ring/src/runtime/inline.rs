//! Inline receive: a follower's frames are handled on the thread that receives them (zenoh's
//! receive thread) — forwarded at once, without a hand-off to the member's own thread. A ring
//! hop then wakes one thread instead of two: fewer context switches, and no wake-up of a
//! second thread on the ring's critical path.
//!
//! The member's state (its [`Driver`]) sits behind a mutex shared by both threads:
//! - the receive thread handles a frame inline only if it gets the lock at once, no frame is
//!   queued before it and no tick is pending: arrival order is kept and the receive thread
//!   never waits for the member's thread;
//! - otherwise the frame is queued, and the member's thread takes queued frames only while it
//!   holds the lock;
//! - the member's thread keeps control requests, the holdover clock and delayed frames.
//!
//! Where the tick runs depends on the application ([`run`] or [`run_send`]): with [`run`] the
//! application stays on the member's thread (it need not be `Send`) and the receive thread
//! leaves each tick to it (one wake-up per cycle, off the ring's critical path). That is the
//! right place for a card: its tick may wait for a synchronized-start commit that itself
//! arrives through zenoh, which must never block zenoh's receive thread. With [`run_send`] the
//! tick runs on the receive thread right after forwarding: for an application whose tick is
//! computation only (a station).
//!
//! The synchronizing master of the paced and lockstep clocks does the same with the frames that
//! come back: a return that lets the next cycle start starts it there and then (lockstep, or a
//! paced cycle already due); a paced cycle not due yet is started by the member's thread at its
//! deadline (see [`super::stepped`] for the order kept with several cycles in flight).
//!
//! Used on links that can deliver inline (zenoh), for the paced and lockstep clocks; realtime
//! followers align their ticks to the cycle's phase by sleeping, which must not happen on the
//! receive thread.

use std::sync::{Arc, Mutex, MutexGuard};

use tracing::{info, warn};

use super::driver::{Driver, DriverExit};
use super::stepped::Stepper;
use crate::core::RingApp;
use crate::member::RingMember;
use crate::transport::queue::QueueWaker;
use crate::transport::{InlineHandler, TransportError};
use mcc_contracts::config::ClockMode;

/// The application of the shared driver while the real one stays on the member's thread.
#[derive(Debug)]
struct Parked;

impl RingApp for Parked {
    fn tick(&mut self, _cycle: u64, _time_ns: u64, _regs: &mut RingMember, _ring_fault: bool) {}
}

/// The member's state shared with the receive thread.
struct Member<B: RingApp> {
    d: Driver<B>,
    /// The synchronizing master's cycle steps (None on a follower).
    st: Option<Stepper>,
}

type Shared<B> = Arc<Mutex<Option<Member<B>>>>;

fn lock<B: RingApp>(shared: &Shared<B>) -> MutexGuard<'_, Option<Member<B>>> {
    // The driver is only ever changed by whole-frame and whole-tick steps; a panic in one of
    // them ends the member anyway.
    shared.lock().unwrap_or_else(|e| e.into_inner())
}

struct Handler<B: RingApp> {
    shared: Shared<B>,
    /// Ticks are left to the member's thread.
    defer: bool,
    waker: QueueWaker,
    failed: Mutex<Option<TransportError>>,
}

impl<B: RingApp + Send> InlineHandler for Handler<B> {
    fn offer(&self, frame: &[u8], sent_ns: u64) -> bool {
        let Ok(mut g) = self.shared.try_lock() else {
            return false;
        };
        let Some(Member { d, st }) = g.as_mut() else {
            return false;
        };
        if !d.rx.is_empty() || d.has_pending_tick() {
            return false;
        }
        let res = match st {
            None => {
                d.rx.record_hop(sent_ns);
                d.follower_frame(frame, self.defer).map(|()| true)
            }
            Some(st) => {
                let now = d.now_ns();
                if d.step_due(st, now).hold_frames || !d.delayed.is_empty() {
                    // The next cycle starts first (or delayed frames are due): the member's
                    // thread takes it from here.
                    return false;
                }
                d.rx.record_hop(sent_ns);
                step_inline(d, st, frame, self.defer)
            }
        };
        // The member's thread looks again for a tick left to it, a delayed frame (a delay
        // fault) and, on the sync master, a next cycle not started here (its deadline).
        let wake = d.has_pending_tick() || !d.delayed.is_empty() || !matches!(res, Ok(true));
        drop(g);
        if let Err(e) = res {
            *self.failed.lock().unwrap_or_else(|e| e.into_inner()) = Some(e);
        }
        if wake {
            self.waker.poke();
        }
        true
    }
}

/// Sync master, on the receive thread: a frame came back; start the next cycle if it may
/// start now (with `defer`, its tick left for the member's thread). Whether it started.
fn step_inline<B: RingApp>(
    d: &mut Driver<B>,
    st: &mut Stepper,
    frame: &[u8],
    defer: bool,
) -> Result<bool, TransportError> {
    d.step_frame(st, frame)?;
    let now = d.now_ns();
    if d.step_due(st, now).now(now) && !d.done() {
        d.step_start(st, defer)?;
        return Ok(true);
    }
    Ok(false)
}

/// Whether `d` runs with inline receive (see the module documentation).
fn eligible<A: RingApp>(d: &Driver<A>) -> bool {
    d.cfg.clock != ClockMode::Realtime && d.rx.supports_inline()
}

/// Run the member's loop until it ends — with inline receive where it applies, ticks on the
/// member's thread; else [`Driver::run`] — and give the driver back.
pub fn run<A: RingApp>(mut driver: Driver<A>) -> (DriverExit, Driver<A>) {
    if !eligible(&driver) {
        let exit = driver.run();
        return (exit, driver);
    }
    let (mut parked, mut app) = driver.swap_app(Parked);
    parked.app_elsewhere = true;
    let (exit, mut parked) = shared_loop(parked, true, Some(&mut app));
    parked.app_elsewhere = false;
    (exit, parked.swap_app(app).0)
}

/// [`run`] for an application whose tick is computation only: it runs on the receive thread
/// right after forwarding.
pub fn run_send<A: RingApp + Send + 'static>(mut driver: Driver<A>) -> (DriverExit, Driver<A>) {
    if !eligible(&driver) {
        let exit = driver.run();
        return (exit, driver);
    }
    shared_loop(driver, false, None)
}

fn shared_loop<B: RingApp + Send + 'static>(
    mut driver: Driver<B>,
    defer: bool,
    app: Option<&mut dyn RingApp>,
) -> (DriverExit, Driver<B>) {
    let shared: Shared<B> = Arc::new(Mutex::new(None));
    let handler = Arc::new(Handler {
        shared: Arc::clone(&shared),
        defer,
        waker: driver.rx.waker(),
        failed: Mutex::new(None),
    });
    if !driver
        .rx
        .set_inline(Arc::clone(&handler) as Arc<dyn InlineHandler>)
    {
        driver.app_elsewhere = false;
        let exit = driver.run();
        return (exit, driver);
    }
    info!(member = %driver.cfg.name, clock = driver.cfg.clock.as_str(), ticks = if defer {
        "on the member's thread" } else { "on the receive thread" },
        "ring member running, frames handled on the receive thread");
    driver.prepare();
    let name = driver.cfg.name.clone();
    let st = driver.core.is_sync_master().then(|| driver.stepper());
    let sync = st.is_some();
    *lock(&shared) = Some(Member { d: driver, st });
    let exit = if sync {
        lead(&shared, &handler, app)
    } else {
        follow(&shared, &handler, app)
    };
    // From here the receive thread finds no driver and queues what still arrives.
    info!(member = %name, ?exit, "ring member stopped");
    let member = lock(&shared).take();
    match member {
        Some(m) => (exit, m.d),
        // Only this function takes the driver out.
        None => unreachable!("the member's driver disappeared"),
    }
}

/// The member's thread: pending ticks and queued frames (in order), control requests, the
/// holdover clock; sleeps until a frame is queued, a tick is left for it or a timer is due.
fn follow<B: RingApp>(
    shared: &Shared<B>,
    handler: &Handler<B>,
    mut app: Option<&mut dyn RingApp>,
) -> DriverExit {
    loop {
        let wait = {
            let mut g = lock(shared);
            let Some(Member { d, .. }) = g.as_mut() else {
                return DriverExit::Stopped;
            };
            if let Some(exit) = failed(handler, d) {
                return exit;
            }
            d.take_pending_tick(reborrow(&mut app));
            loop {
                match d.recv(std::time::Duration::ZERO) {
                    Ok(Some(bytes)) => {
                        if let Err(e) = d.follower_frame(&bytes, true) {
                            return DriverExit::Transport(e);
                        }
                        d.take_pending_tick(reborrow(&mut app));
                    }
                    Ok(None) => break,
                    Err(e) => return DriverExit::Transport(e),
                }
            }
            if let Err(e) = d.follower_holdover_with(reborrow(&mut app)) {
                return DriverExit::Transport(e);
            }
            let wait = match d.follower_housekeeping() {
                Ok(w) => w,
                Err(exit) => return exit,
            };
            answer_app(d, &mut app);
            wait
        };
        // Waiting needs no lock on the driver: the queue has its own.
        handler.waker.wait(wait);
    }
}

/// The synchronizing master's thread: the ticks the receive thread left, cycles whose start
/// is due (paced deadlines, the own clock), frames the receive thread handed over (in order);
/// sleeps until the next start is due, a frame is queued or the receive thread pokes it.
fn lead<B: RingApp>(
    shared: &Shared<B>,
    handler: &Handler<B>,
    mut app: Option<&mut dyn RingApp>,
) -> DriverExit {
    loop {
        let (wait, hold) = {
            let mut g = lock(shared);
            let Some(Member { d, st: Some(st) }) = g.as_mut() else {
                return DriverExit::Stopped;
            };
            if let Some(exit) = failed(handler, d) {
                return exit;
            }
            d.take_pending_tick(reborrow(&mut app));
            let due = loop {
                if let Some(exit) = d.stop_or_done() {
                    return exit;
                }
                // A lockstep ring may keep this loop busy cycle after cycle: requests taken
                // by `stop_or_done` are answered here, not when it ends.
                answer_app(d, &mut app);
                if let Err(e) = d.flush_delayed() {
                    return DriverExit::Transport(e);
                }
                let now = d.now_ns();
                let due = d.step_due(st, now);
                if due.now(now) {
                    if let Err(e) = d.step_start(st, true) {
                        return DriverExit::Transport(e);
                    }
                    d.take_pending_tick(reborrow(&mut app));
                    continue;
                }
                if due.hold_frames {
                    break due;
                }
                match d.recv(std::time::Duration::ZERO) {
                    Ok(Some(bytes)) => {
                        if let Err(e) = d.step_frame(st, &bytes) {
                            return DriverExit::Transport(e);
                        }
                    }
                    Ok(None) => break due,
                    Err(e) => return DriverExit::Transport(e),
                }
            };
            answer_app(d, &mut app);
            let now = d.now_ns();
            let wait = if d.delayed.is_empty() {
                due.wait(now, std::time::Duration::from_millis(5))
            } else {
                std::time::Duration::from_micros(50)
            };
            (wait, due.hold_frames)
        };
        // Waiting needs no lock on the driver: the queue has its own. While the next start
        // waits for its deadline, queued returns stay where they are.
        if hold {
            handler.waker.wait_poke(wait);
        } else {
            handler.waker.wait(wait);
        }
    }
}

/// Answer the requests the driver took for the application (it holds a stand-in) with the
/// application kept on the member's thread: status fields, application faults. Nothing is
/// built unless a request waits: never on the hot path of a wake-up without one.
fn answer_app<B: RingApp>(d: &mut Driver<B>, app: &mut Option<&mut dyn RingApp>) {
    if d.app_wanted() {
        if let Some(a) = app.as_mut() {
            d.answer_app(&mut **a);
        }
    }
}

/// The receive thread failed to send: the loop ends.
fn failed<B: RingApp>(handler: &Handler<B>, d: &Driver<B>) -> Option<DriverExit> {
    let e = handler
        .failed
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take()?;
    warn!(member = %d.cfg.name, "ring transport failed on the receive thread: {e}");
    Some(DriverExit::Transport(e))
}

fn reborrow<'a>(app: &'a mut Option<&mut dyn RingApp>) -> Option<&'a mut dyn RingApp> {
    match app {
        Some(a) => Some(&mut **a),
        None => None,
    }
}

#[cfg(test)]
#[path = "inline_tests.rs"]
mod tests;
