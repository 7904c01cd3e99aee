//! Synchronized start, card side (architecture §6): lines scheduled for the servo tick of a
//! chosen ring cycle T, with a two-phase arm/commit protocol so a multi-card start never splits.
//!
//! Protocol (JSON over the zenoh queryable `mcc/<cluster>/card/<n>/at`; the wire types
//! [`AtRequest`]/[`AtReply`] live in `mcc_contracts::control::sync_start`):
//! 1. `arm {id, cycle: T, line}`: the card keeps the line, undecided. It refuses (`late`) when
//!    the tick of cycle T has already started (or the ring has not ticked yet).
//! 2. `commit {id}` once every card has armed, or `abort {id}` when one refused.
//! 3. At the start of the tick of cycle T the card executes committed lines. An armed line that
//!    is still undecided at T makes the tick wait (bounded by the stall limit) for the commit or
//!    abort, so a commit that arrives "late" still executes at T: lateness can only stall the
//!    ring briefly, never split the start. Only an orchestrator that vanishes between its
//!    commits for longer than the stall limit can split a start; the card then reports the
//!    line as `abandoned`.
//!
//! The card also records the ring cycle (and CLOCK_MONOTONIC time) of the tick in which its
//! most recent program start (`R`/`S` accepted by the interpreter, scheduled or not) reached
//! the servo loop: `info` returns it, `mcc status` shows it as `cards[].program_start_cycle`.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Duration;

use mcc_contracts::control::sync_start::{at_key, AtReply, AtRequest};
use zenoh::Wait;

use crate::domain::Refusal;
use crate::lang::{Card, MAX_LINE};
use crate::model::Action;

/// Most armed (pending) lines at once.
pub(crate) const MAX_PENDING: usize = 16;
/// Executed lines remembered for `result` queries.
pub(crate) const MAX_RESULTS: usize = 64;
/// Furthest ahead a line may be armed, in ring cycles.
pub(crate) const MAX_LEAD_CYCLES: u64 = 100_000_000;
/// Largest request accepted, bytes.
pub(crate) const MAX_REQUEST: usize = 4096;
/// Queries answered at once (more are refused as busy).
const MAX_IN_FLIGHT: usize = 64;
/// Test-only: answer each `at` query after a random delay of 0..=N ms.
pub(crate) const DELAY_ENV: &str = "MCC_TEST_AT_DELAY_MS";

#[derive(Debug, Clone)]
struct Pending {
    id: u64,
    cycle: u64,
    line: Vec<u8>,
    committed: bool,
}

#[derive(Debug, Clone)]
struct Done {
    id: u64,
    cycle: u64,
    ns: u64,
    reply: Option<Vec<u8>>,
    /// The line's refusal (whether or not the reply shows it).
    refusal: Option<Refusal>,
}

/// The pure bookkeeping of scheduled lines (no clock, no locks).
#[derive(Debug, Default)]
pub(crate) struct SyncCore {
    last_tick: Option<u64>,
    pending: Vec<Pending>,
    /// Lines that started in their tick and are not done yet (id, cycle): a long reply.
    running: Vec<(u64, u64)>,
    done: VecDeque<Done>,
    program_start_cycle: Option<u64>,
    program_start_ns: Option<u64>,
    pub(crate) stalls: u64,
    seen_actions: usize,
}

fn is_program_start(a: &Action) -> bool {
    a.kind.starts_program()
}

impl SyncCore {
    /// Handle a request that does not need the card (everything but the card part of `info`).
    pub(crate) fn request(&mut self, req: &AtRequest) -> AtReply {
        let mut r = match req {
            AtRequest::Info => AtReply {
                ok: true,
                ..AtReply::default()
            },
            AtRequest::Arm { id, cycle, line } => self.arm(*id, *cycle, line),
            AtRequest::Commit { id } => self.commit(*id),
            AtRequest::Abort { id } => self.abort(*id),
            AtRequest::Result { id } => self.result(*id),
        };
        r.cycle = self.last_tick;
        r.program_start_cycle = self.program_start_cycle;
        r.program_start_ns = self.program_start_ns;
        r.stalls = self.stalls;
        r
    }

    fn arm(&mut self, id: u64, cycle: u64, line: &str) -> AtReply {
        if line.len() > MAX_LINE {
            return AtReply::err(format!("line longer than {MAX_LINE} characters"));
        }
        if line.bytes().any(|b| !(0x20..0x7F).contains(&b)) {
            return AtReply::err("line must be printable ASCII (no control characters)");
        }
        if let Some(p) = self.pending.iter().find(|p| p.id == id) {
            return if p.cycle == cycle && p.line == line.as_bytes() {
                AtReply {
                    ok: true,
                    message: "already armed".into(),
                    ..AtReply::default()
                }
            } else {
                AtReply::err(format!("start {id} is already armed differently"))
            };
        }
        if self.done.iter().any(|d| d.id == id) {
            return AtReply::err(format!("start {id} has already run"));
        }
        let Some(now) = self.last_tick else {
            return AtReply {
                late: true,
                ..AtReply::err("the ring has not ticked yet")
            };
        };
        if cycle <= now {
            return AtReply {
                late: true,
                ..AtReply::err(format!("too late: cycle {cycle} has started (now {now})"))
            };
        }
        if cycle - now > MAX_LEAD_CYCLES {
            return AtReply::err(format!(
                "cycle {cycle} is more than {MAX_LEAD_CYCLES} cycles ahead"
            ));
        }
        if self.pending.len() >= MAX_PENDING {
            return AtReply::err(format!("{MAX_PENDING} starts are already armed"));
        }
        self.pending.push(Pending {
            id,
            cycle,
            line: line.as_bytes().to_vec(),
            committed: false,
        });
        AtReply {
            ok: true,
            message: format!("armed for cycle {cycle}"),
            ..AtReply::default()
        }
    }

    fn commit(&mut self, id: u64) -> AtReply {
        if let Some(p) = self.pending.iter_mut().find(|p| p.id == id) {
            p.committed = true;
            return AtReply {
                ok: true,
                message: format!("committed for cycle {}", p.cycle),
                ..AtReply::default()
            };
        }
        match self.done.iter().find(|d| d.id == id) {
            Some(d) if d.reply.is_some() => AtReply {
                ok: true,
                message: format!("already ran at cycle {}", d.cycle),
                ..AtReply::default()
            },
            Some(d) => AtReply::err(format!("start {id} was abandoned at cycle {}", d.cycle)),
            None => AtReply::err(format!("start {id} is not armed")),
        }
    }

    fn abort(&mut self, id: u64) -> AtReply {
        match self.pending.iter().position(|p| p.id == id) {
            Some(i) if self.pending.get(i).is_some_and(|p| p.committed) => {
                AtReply::err(format!("start {id} is committed"))
            }
            Some(i) => {
                self.pending.remove(i);
                AtReply {
                    ok: true,
                    message: "aborted".into(),
                    ..AtReply::default()
                }
            }
            None => AtReply {
                ok: !self.done.iter().any(|d| d.id == id && d.reply.is_some()),
                message: format!("start {id} is not armed"),
                ..AtReply::default()
            },
        }
    }

    fn result(&self, id: u64) -> AtReply {
        if let Some(d) = self.done.iter().find(|d| d.id == id) {
            return AtReply {
                ok: d.reply.is_some(),
                message: if d.reply.is_some() {
                    "executed"
                } else {
                    "abandoned"
                }
                .into(),
                executed_cycle: Some(d.cycle),
                executed_ns: d.reply.as_ref().map(|_| d.ns),
                reply: d
                    .reply
                    .as_ref()
                    .map(|r| String::from_utf8_lossy(r).into_owned()),
                refusal: d.refusal.map(Into::into),
                abandoned: d.reply.is_none(),
                ..AtReply::default()
            };
        }
        if let Some((_, cycle)) = self.running.iter().find(|r| r.0 == id) {
            return AtReply {
                ok: true,
                message: format!("running since cycle {cycle}"),
                ..AtReply::default()
            };
        }
        match self.pending.iter().find(|p| p.id == id) {
            Some(p) => AtReply {
                ok: true,
                message: format!("pending for cycle {}", p.cycle),
                ..AtReply::default()
            },
            None => AtReply::err(format!("start {id} is unknown")),
        }
    }

    /// The tick of `cycle` begins: from now on arms for `cycle` are late.
    pub(crate) fn begin_tick(&mut self, cycle: u64) {
        self.last_tick = Some(cycle);
    }

    /// An armed line due at or before `cycle` is still undecided.
    pub(crate) fn undecided_due(&self, cycle: u64) -> bool {
        self.pending
            .iter()
            .any(|p| p.cycle <= cycle && !p.committed)
    }

    /// Give up on undecided lines due at `cycle` (stall limit reached).
    pub(crate) fn abandon_due(&mut self, cycle: u64) {
        let (gone, keep): (Vec<_>, Vec<_>) = std::mem::take(&mut self.pending)
            .into_iter()
            .partition(|p| p.cycle <= cycle && !p.committed);
        self.pending = keep;
        for p in gone {
            tracing::warn!(
                id = p.id,
                cycle,
                "synchronized start abandoned: no commit in time"
            );
            self.push_done(Done {
                id: p.id,
                cycle,
                ns: 0,
                reply: None,
                refusal: None,
            });
        }
    }

    /// Take the committed lines due at `cycle` (in arming order).
    pub(crate) fn take_due(&mut self, cycle: u64) -> Vec<(u64, Vec<u8>)> {
        let (due, keep): (Vec<_>, Vec<_>) = std::mem::take(&mut self.pending)
            .into_iter()
            .partition(|p| p.cycle <= cycle && p.committed);
        self.pending = keep;
        due.into_iter().map(|p| (p.id, p.line)).collect()
    }

    /// Line `id` started in the tick of `cycle` and goes on in the slices after it.
    pub(crate) fn running(&mut self, id: u64, cycle: u64) {
        self.running.push((id, cycle));
    }

    /// Record a line's execution.
    pub(crate) fn executed(
        &mut self,
        id: u64,
        cycle: u64,
        ns: u64,
        reply: Vec<u8>,
        refusal: Option<Refusal>,
    ) {
        self.running.retain(|r| r.0 != id);
        self.push_done(Done {
            id,
            cycle,
            ns,
            reply: Some(reply),
            refusal,
        });
    }

    fn push_done(&mut self, d: Done) {
        if self.done.len() >= MAX_RESULTS {
            self.done.pop_front();
        }
        self.done.push_back(d);
    }

    /// Scan the interpreter's queued actions not seen at the previous tick (the servo loop
    /// drains them after this hook); a program start among them, or `scheduled_start`, records
    /// `cycle`/`now_ns` as the most recent program start.
    pub(crate) fn note_starts(
        &mut self,
        actions: &[Action],
        cycle: u64,
        now_ns: u64,
        scheduled_start: bool,
    ) {
        let from = if actions.len() < self.seen_actions {
            0
        } else {
            self.seen_actions
        };
        let fresh = actions.get(from..).unwrap_or(&[]);
        if scheduled_start || fresh.iter().any(is_program_start) {
            self.program_start_cycle = Some(cycle);
            self.program_start_ns = Some(now_ns);
        }
    }

    /// The tick has ended with `remaining` actions left queued.
    pub(crate) fn end_tick(&mut self, remaining: usize) {
        self.seen_actions = remaining;
    }

    /// Most recent program start (cycle, monotonic ns).
    #[cfg(test)]
    pub(crate) fn program_start(&self) -> (Option<u64>, Option<u64>) {
        (self.program_start_cycle, self.program_start_ns)
    }
}

/// Ring fault and killed motors from the card's state.
pub(crate) fn fill_card_info(card: &Card, r: &mut AtReply) {
    r.ring_fault = card.state.global.ring_fault;
    let mut activated = 0;
    let motors = usize::from(card.state.limits().motors);
    for (k, f) in card.state.motors.iter().enumerate().take(motors) {
        let m = (k + 1) as u16;
        if card.state.peek_ivar(100 * u32::from(m)).unwrap_or(0.0) == 0.0 {
            continue;
        }
        activated += 1;
        if f.open_loop && !f.amp_enabled {
            r.killed_motors.push(m);
        }
    }
    r.motors_killed = r.ring_fault && r.killed_motors.len() == activated;
}

/// The synchronized-start state, shared by the card's servo thread and the `at` queryable:
/// `at` requests are answered at once, whatever the ring is doing (a follower card waiting for
/// the sync packet still answers its arm and commit; a stalled tick waits on the condvar). The
/// lock is held for bookkeeping only, never across I/O or a wait for the card.
#[derive(Debug, Default)]
pub struct SyncShared {
    core: Mutex<SyncCore>,
    cv: Condvar,
    /// The card's ring fault and killed motors as of its last tick (for `info`).
    card_info: Mutex<AtReply>,
}

impl SyncShared {
    pub(crate) fn lock(&self) -> MutexGuard<'_, SyncCore> {
        self.core.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Answer one request (arm/commit/abort wake a waiting tick).
    pub fn handle(&self, req: &AtRequest) -> AtReply {
        let mut r = {
            let mut core = self.lock();
            let r = core.request(req);
            self.cv.notify_all();
            r
        };
        if matches!(req, AtRequest::Info) {
            let info = self.card_info.lock().unwrap_or_else(|e| e.into_inner());
            r.ring_fault = info.ring_fault;
            r.killed_motors.clone_from(&info.killed_motors);
            r.motors_killed = info.motors_killed;
        }
        r
    }

    /// The servo thread: wait (at most until `deadline`) while a line due at `cycle` is
    /// undecided; `true` when it was decided in time.
    pub(crate) fn wait_decided(&self, cycle: u64, deadline: std::time::Instant) -> bool {
        let mut core = self.lock();
        while core.undecided_due(cycle) {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return false;
            }
            core = self
                .cv
                .wait_timeout(core, left)
                .map(|(g, _)| g)
                .unwrap_or_else(|e| e.into_inner().0);
        }
        true
    }

    /// The servo thread publishes the card's state `info` reports.
    pub(crate) fn publish(&self, card: &Card) {
        let mut r = AtReply::default();
        fill_card_info(card, &mut r);
        *self.card_info.lock().unwrap_or_else(|e| e.into_inner()) = r;
    }
}

/// Parse one query payload and answer it.
pub(crate) fn answer_payload(sync: &SyncShared, payload: &[u8]) -> AtReply {
    if payload.len() > MAX_REQUEST {
        return AtReply::err(format!("request longer than {MAX_REQUEST} bytes"));
    }
    match serde_json::from_slice::<AtRequest>(payload) {
        Ok(req) => sync.handle(&req),
        Err(e) => AtReply::err(format!("bad request: {e}")),
    }
}

fn test_delay() -> Option<Duration> {
    let max: u64 = std::env::var(DELAY_ENV).ok()?.trim().parse().ok()?;
    if max == 0 {
        return None;
    }
    let seed = mcc_ring::runtime::driver::monotonic_ns() ^ u64::from(std::process::id()) << 32;
    let mut x = seed | 1;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    Some(Duration::from_millis(x % (max.min(10_000) + 1)))
}

/// Declare the `at` queryable of card `n`. Each query is answered on a short-lived thread
/// (never blocking zenoh's callback thread). Keep the returned value alive.
pub(crate) fn declare_at_queryable(
    zsession: &zenoh::Session,
    cluster: &str,
    n: u32,
    sync: Arc<SyncShared>,
) -> zenoh::Result<zenoh::query::Queryable<()>> {
    let in_flight = Arc::new(AtomicUsize::new(0));
    zsession
        .declare_queryable(at_key(cluster, n))
        .callback(move |query| {
            let payload = query
                .payload()
                .map(|p| p.to_bytes().into_owned())
                .unwrap_or_default();
            if in_flight.fetch_add(1, Ordering::AcqRel) >= MAX_IN_FLIGHT {
                in_flight.fetch_sub(1, Ordering::AcqRel);
                let r = AtReply::err("busy: too many requests in flight");
                let _ = query
                    .reply(
                        query.key_expr().clone(),
                        serde_json::to_vec(&r).unwrap_or_default(),
                    )
                    .wait();
                return;
            }
            let (sync, flight) = (Arc::clone(&sync), Arc::clone(&in_flight));
            let spawned = std::thread::Builder::new()
                .name("mcc-card-at".into())
                .spawn(move || {
                    if let Some(d) = test_delay() {
                        std::thread::sleep(d);
                    }
                    let r = answer_payload(&sync, &payload);
                    let body = serde_json::to_vec(&r).unwrap_or_default();
                    if let Err(e) = query.reply(query.key_expr().clone(), body).wait() {
                        tracing::warn!("card at reply failed: {e}");
                    }
                    flight.fetch_sub(1, Ordering::AcqRel);
                });
            if spawned.is_err() {
                in_flight.fetch_sub(1, Ordering::AcqRel);
            }
        })
        .wait()
}

#[cfg(test)]
#[path = "tests_sync_start.rs"]
mod tests;
