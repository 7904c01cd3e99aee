//! The servo thread owns the card: everything else reaches it through a [`CardHandle`], which
//! sends a request over a bounded channel and waits for the reply. The [`Runner`] lives on the
//! servo thread (the ring driver's, or the standalone card's own), drains requests between
//! ticks, serves host lines in bounded slices ([`crate::core::CardCore::serve`]) and hands
//! effects that touch the operating system (SAVE's file write, `$$$`'s image load) to an
//! I/O thread ([`IoWorker`]), which reports completion back. No lock is held across I/O: the
//! only shared state is the unsolicited-output log, locked for a copy.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender, TrySendError};
use mcc_contracts::control::chain::OP_CLOSE;
use mcc_contracts::control::sync_start::{AtReply, AtRequest};

use super::storage::FileStorage;
use super::sync_start::SyncShared;
use crate::core::chain::Encoded;
use crate::core::{CardCore, HostReply, HostRequest, SLICE_UNITS};
use crate::lang::{Budget, Effect, EffectResult, LineRun, Session, Started, Storage};
use crate::model::Unsolicited;

/// Requests waiting for the servo thread at most.
pub(crate) const QUEUE: usize = 1024;
/// Longest a caller waits for a reply (a heavy line takes seconds; a dead card never answers).
pub(crate) const REPLY_TIMEOUT: Duration = Duration::from_secs(120);
/// Requests taken from the channel per pump (the rest wait for the next one).
const DRAIN_PER_PUMP: usize = 256;

/// The dialect thread synchronized starts run on (beside the chain's threads, see
/// `lang::CHAIN_THREAD`).
const SYNC_THREAD: u64 = crate::lang::CHAIN_THREAD - 1;

/// What reaches the servo thread.
#[derive(Debug)]
pub enum Request {
    /// A host port's line, control character or close.
    Host {
        /// The connection.
        conn: u64,
        /// What it asks.
        req: HostRequest,
    },
    /// A daisy-chain request (`mcc_contracts::control::chain` wire format).
    Chain(Vec<u8>),
    /// A synchronized-start request.
    At(AtRequest),
}

/// What comes back.
#[derive(Debug)]
pub enum Response {
    /// To a host request.
    Host(HostReply),
    /// To a chain request: the encoded reply (payload and refusal attachment), or the wire
    /// error.
    Chain(Result<Encoded, String>),
    /// To a synchronized-start request.
    At(AtReply),
}

#[derive(Debug)]
struct Envelope {
    req: Request,
    reply: Sender<Response>,
}

/// State shared with the host side that is not the card's: the unsolicited-output log.
#[derive(Debug, Default)]
pub(crate) struct Shared {
    unsolicited: Mutex<Unsolicited>,
    next_conn: AtomicU64,
}

/// A cloneable way to the card on its servo thread.
#[derive(Debug, Clone)]
pub struct CardHandle {
    tx: Sender<Envelope>,
    shared: Arc<Shared>,
}

impl CardHandle {
    /// A fresh connection id (for a host port's session on the card).
    pub fn new_conn(&self) -> u64 {
        self.shared.next_conn.fetch_add(1, Ordering::Relaxed) + 1
    }

    /// Send `req` and wait for its reply (`None`: the card is gone or did not answer in time).
    pub fn call(&self, req: Request, timeout: Duration) -> Option<Response> {
        let (tx, rx) = bounded(1);
        let env = Envelope { req, reply: tx };
        let deadline = Instant::now() + timeout;
        let mut env = Some(env);
        // Bounded queue: a full one makes the caller wait (back-pressure), not the card.
        while let Some(e) = env.take() {
            match self.tx.try_send(e) {
                Ok(()) => {}
                Err(TrySendError::Full(e)) => {
                    if Instant::now() >= deadline {
                        return None;
                    }
                    env = Some(e);
                    std::thread::sleep(Duration::from_millis(1));
                }
                Err(TrySendError::Disconnected(_)) => return None,
            }
        }
        rx.recv_deadline(deadline).ok()
    }

    /// Queue `req` without waiting: the receiver of its reply (`None`: the queue is full or
    /// the card is gone). A lockstep test that steps the card itself gets the reply in the
    /// step that served it, with no thread in between.
    pub fn submit(&self, req: Request) -> Option<Receiver<Response>> {
        let (tx, rx) = bounded(1);
        self.tx.try_send(Envelope { req, reply: tx }).ok()?;
        Some(rx)
    }

    /// A host request of connection `conn`; an empty reply when the card is gone.
    pub fn host(&self, conn: u64, req: HostRequest) -> HostReply {
        match self.call(Request::Host { conn, req }, REPLY_TIMEOUT) {
            Some(Response::Host(r)) => r,
            _ => HostReply::default(),
        }
    }

    /// Position after the newest unsolicited output.
    pub fn unsolicited_position(&self) -> u64 {
        self.log().position()
    }

    /// Unsolicited output after `pos`, and the new position.
    pub fn unsolicited_since(&self, pos: u64) -> (Vec<u8>, u64) {
        self.log().since(pos)
    }

    /// Append unsolicited output as the card's program output would (tests, tools).
    pub fn publish(&self, bytes: Vec<u8>) {
        self.log().push(bytes);
    }

    fn log(&self) -> std::sync::MutexGuard<'_, Unsolicited> {
        self.shared
            .unsolicited
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }
}

/// The thread that performs effects (file writes and reads) for the servo thread.
#[derive(Debug)]
pub(crate) struct IoWorker {
    tx: Sender<(u64, Effect)>,
    rx: Receiver<(u64, EffectResult)>,
}

impl IoWorker {
    /// Start the worker over `storage` (none: a SAVE fails, as there is nowhere to keep it,
    /// and nothing was saved).
    pub(crate) fn start(storage: Option<FileStorage>) -> Self {
        let (tx, jobs) = bounded::<(u64, Effect)>(64);
        let (done, rx) = bounded::<(u64, EffectResult)>(64);
        let spawned = std::thread::Builder::new()
            .name("mcc-card-io".into())
            .spawn(move || {
                let mut storage = storage;
                for (token, effect) in jobs {
                    let r = match (&effect, storage.as_mut()) {
                        (Effect::Save(bytes), Some(st)) => match st.save(bytes) {
                            Ok(()) => EffectResult::Saved(true),
                            Err(e) => {
                                tracing::warn!("SAVE failed: {e}");
                                EffectResult::Saved(false)
                            }
                        },
                        (Effect::Save(_), None) => {
                            tracing::warn!("SAVE refused: this card has no state file");
                            EffectResult::Saved(false)
                        }
                        (Effect::Load, Some(st)) => EffectResult::Loaded(st.load()),
                        (Effect::Load, None) => EffectResult::Loaded(Ok(None)),
                    };
                    if done.send((token, r)).is_err() {
                        return;
                    }
                }
            });
        if let Err(e) = spawned {
            tracing::error!("cannot start the card's i/o thread: {e}");
        }
        IoWorker { tx, rx }
    }
}

/// Chain requests (payload, reply channel) of one connection, waiting in order.
type ChainQueue = VecDeque<(Vec<u8>, Sender<Response>)>;

/// A synchronized start's line still running after its tick.
#[derive(Debug)]
struct StartedRun {
    id: u64,
    /// The ring cycle it started in.
    cycle: u64,
    ns: u64,
    run: Box<LineRun>,
    session: Session,
}

/// The servo thread's side: owns the [`CardCore`].
pub struct Runner {
    /// The card core.
    pub core: CardCore,
    rx: Receiver<Envelope>,
    pending: HashMap<u64, Sender<Response>>,
    next_token: u64,
    io: IoWorker,
    shared: Arc<Shared>,
    /// Daisy-chain requests waiting behind a line that waits for the ring, per connection
    /// (the first is the parked line's own request).
    chain_wait: HashMap<u64, ChainQueue>,
    /// What chain lines may still do in this pump (its share of the pump's budget).
    chain_budget: Budget,
    /// Synchronized starts' lines not done in their tick (a long reply).
    started: Vec<StartedRun>,
    /// Synchronized start (shared with the `at` queryable).
    pub sync: Arc<SyncShared>,
    sync_session: Session,
    /// Every handle is gone.
    orphaned: bool,
}

impl std::fmt::Debug for Runner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Runner")
            .field("pending", &self.pending.len())
            .finish_non_exhaustive()
    }
}

/// A runner for `core` and the handle that reaches it.
pub(crate) fn channel(core: CardCore, storage: Option<FileStorage>) -> (Runner, CardHandle) {
    let (tx, rx) = bounded(QUEUE);
    let shared = Arc::new(Shared::default());
    let runner = Runner {
        core,
        rx,
        pending: HashMap::new(),
        next_token: 1,
        io: IoWorker::start(storage),
        shared: Arc::clone(&shared),
        chain_wait: HashMap::new(),
        chain_budget: Budget::new(0),
        started: Vec::new(),
        sync: Arc::new(SyncShared::default()),
        sync_session: Session::default(),
        orphaned: false,
    };
    (runner, CardHandle { tx, shared })
}

impl Runner {
    fn accept(&mut self, env: Envelope) {
        match env.req {
            Request::Host { conn, req } => {
                let t = self.next_token;
                self.next_token += 1;
                self.pending.insert(t, env.reply);
                self.core.submit(t, conn, req);
            }
            Request::Chain(payload) => {
                let req = match mcc_contracts::control::chain::decode_request(&payload) {
                    Ok(req) => req,
                    Err(e) => {
                        let _ = env.reply.send(Response::Chain(Err(e.to_string())));
                        return;
                    }
                };
                let conn = req.conn;
                // A connection whose line waits for the ring: its later data waits too.
                if self.core.chain_is_parked(conn) && req.op != OP_CLOSE {
                    self.chain_wait
                        .entry(conn)
                        .or_default()
                        .push_back((payload, env.reply));
                    return;
                }
                let closing = req.op == OP_CLOSE;
                match self.core.chain_request(&req, &mut self.chain_budget) {
                    Some(r) => {
                        let _ = env.reply.send(Response::Chain(Ok(r)));
                    }
                    None => {
                        self.chain_wait
                            .entry(conn)
                            .or_default()
                            .push_front((payload, env.reply));
                    }
                }
                if closing {
                    // whatever waited behind a dropped line is answered empty
                    for (_, tx) in self.chain_wait.remove(&conn).unwrap_or_default() {
                        let _ = tx.send(Response::Chain(Ok(Encoded::default())));
                    }
                }
            }
            Request::At(req) => {
                let _ = env.reply.send(Response::At(self.sync.handle(&req)));
            }
        }
    }

    /// Take what arrived (bounded), serve host work within `budget`, dispatch replies and
    /// effects, publish program output. \[DECISION\] The daisy chain is one more host port:
    /// its lines (parked ones first, then what arrived) run within half of `budget`, and what
    /// they leave goes to the host ports' requests, so neither a chain flood nor a host flood
    /// holds the other back by more than a share of a slice.
    pub fn pump(&mut self, budget: &mut Budget) {
        let share = (budget.left() / 2).max(1);
        self.chain_budget = Budget::new(share);
        self.resume_chain();
        for _ in 0..DRAIN_PER_PUMP {
            match self.rx.try_recv() {
                Ok(env) => self.accept(env),
                Err(_) => break,
            }
        }
        while let Ok((t, r)) = self.io.rx.try_recv() {
            self.core.effect_done(t, r);
        }
        budget.spend(share - self.chain_budget.left());
        self.resume_started(budget);
        self.core.serve(budget);
        self.dispatch();
    }

    /// Daisy-chain lines not done (waiting for the ring or for their next slice): answer
    /// those that are done, then run what their connections sent meanwhile (in order, until
    /// one waits again).
    fn resume_chain(&mut self) {
        for conn in self.core.chain_parked() {
            let Some(reply) = self.core.chain_resume(conn, &mut self.chain_budget) else {
                continue;
            };
            let Some(queue) = self.chain_wait.get_mut(&conn) else {
                continue;
            };
            if let Some((_, tx)) = queue.pop_front() {
                let _ = tx.send(Response::Chain(Ok(reply)));
            }
            while let Some((payload, _)) = queue.front() {
                let r = match mcc_contracts::control::chain::decode_request(payload) {
                    Ok(req) => self
                        .core
                        .chain_request(&req, &mut self.chain_budget)
                        .map(Ok),
                    Err(e) => Some(Err(e.to_string())),
                };
                let Some(r) = r else {
                    break;
                };
                if let Some((_, tx)) = queue.pop_front() {
                    let _ = tx.send(Response::Chain(r));
                }
            }
            if queue.is_empty() {
                self.chain_wait.remove(&conn);
            }
        }
    }

    fn dispatch(&mut self) {
        for (t, r) in self.core.take_replies() {
            if let Some(tx) = self.pending.remove(&t) {
                let _ = tx.send(Response::Host(r));
            }
        }
        for (t, e) in self.core.take_effects() {
            if self.io.tx.send(t_e(t, e)).is_err() {
                tracing::error!("the card's i/o thread is gone");
            }
        }
        let out = self.core.card.model.take_output();
        if !out.is_empty() {
            self.shared
                .unsolicited
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(out);
        }
    }

    /// Wait up to `timeout` for something to arrive (the standalone card's idle wait).
    pub fn wait(&mut self, timeout: Duration) {
        let io_busy = !self.pending.is_empty() || self.core.pending() > 0;
        let t = if io_busy {
            timeout.min(Duration::from_millis(1))
        } else {
            timeout
        };
        match self.rx.recv_timeout(t) {
            Ok(env) => self.accept(env),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => self.orphaned = true,
        }
    }

    /// Synchronized start at the start of the tick of `cycle`: wait (at most `stall`) for a
    /// decision on lines due now (the `at` queryable answers on its own threads and wakes
    /// this wait); run the committed lines; record program starts.
    pub fn sync_tick_start(&mut self, cycle: u64, stall: Duration) {
        let sync = Arc::clone(&self.sync);
        let undecided = {
            let mut core = sync.lock();
            core.begin_tick(cycle);
            let u = core.undecided_due(cycle);
            if u {
                core.stalls += 1;
            }
            u
        };
        if undecided && !sync.wait_decided(cycle, Instant::now() + stall) {
            sync.lock().abandon_due(cycle);
        }
        let due = sync.lock().take_due(cycle);
        let mut scheduled_start = false;
        let mut done = Vec::with_capacity(due.len());
        if !due.is_empty() {
            let saved = self.core.card.model.take_actions();
            for (id, line) in due {
                let ns = mcc_ring::runtime::driver::monotonic_ns();
                // A Power card runs the line in its own dialect, on the synchronized-start
                // thread (its `Ldata` persists from start to start, as a session does). Each
                // line has a slice of its own in this tick; what is left of a long one runs
                // in the slices after it (its commands in order, its reply when done).
                let mut session = self.sync_session.clone();
                match self.core.synced_line(
                    &mut session,
                    SYNC_THREAD,
                    &line,
                    &mut Budget::new(SLICE_UNITS),
                ) {
                    Started::Done(reply, refusal) => {
                        self.sync_session = session;
                        done.push((id, ns, reply, refusal));
                    }
                    Started::Running(run) => self.started.push(StartedRun {
                        id,
                        cycle,
                        ns,
                        run,
                        session,
                    }),
                }
            }
            let fresh = self.core.card.model.take_actions();
            scheduled_start = fresh.iter().any(|a| a.kind.starts_program());
            for a in saved.into_iter().chain(fresh) {
                self.core.card.model.push_action(a);
            }
        }
        let now = mcc_ring::runtime::driver::monotonic_ns();
        // Results and the program start are published together: a query never sees a line
        // executed without the start it made.
        let mut core = sync.lock();
        for (id, ns, reply, refusal) in done {
            core.executed(id, cycle, ns, reply, refusal);
        }
        for r in self.started.iter().filter(|r| r.cycle == cycle) {
            core.running(r.id, cycle);
        }
        core.note_starts(self.core.card.model.actions(), cycle, now, scheduled_start);
    }

    /// Synchronized starts' lines left over from their tick go on within `budget`; a line
    /// done is reported executed in the cycle it started in.
    fn resume_started(&mut self, budget: &mut Budget) {
        for mut r in std::mem::take(&mut self.started) {
            if budget.exhausted() {
                self.started.push(r);
                continue;
            }
            match self.core.synced_step(&mut r.session, r.run, budget) {
                Started::Done(reply, refusal) => {
                    self.sync_session = r.session;
                    self.sync
                        .lock()
                        .executed(r.id, r.cycle, r.ns, reply, refusal);
                }
                Started::Running(run) => self.started.push(StartedRun { run, ..r }),
            }
        }
    }

    /// Publish the card's state `info` reports (done at every tick end).
    pub fn sync_tick_end_info(&mut self) {
        self.sync.publish(&self.core.card);
    }

    /// End of the tick: the card's state for `info`, the actions left queued.
    pub fn sync_tick_end(&mut self) {
        self.sync.publish(&self.core.card);
        self.sync
            .lock()
            .end_tick(self.core.card.model.actions().len());
    }

    /// The standalone card (no ring, no servo loop): serve requests until `stop`, or until
    /// every handle is gone and nothing is left to do.
    pub fn run_until(&mut self, stop: &std::sync::atomic::AtomicBool) {
        while !stop.load(Ordering::Relaxed) {
            if self.orphaned && self.pending.is_empty() && self.core.pending() == 0 {
                return;
            }
            self.wait(Duration::from_millis(20));
            // No ring: a MACRO auxiliary access never gets an answer and times out.
            self.core.aux_tick((0, 0));
            self.pump(&mut Budget::new(SLICE_UNITS * 16));
        }
    }
}

fn t_e(t: u64, e: Effect) -> (u64, Effect) {
    (t, e)
}

/// A card on a thread of its own (no ring, no servo loop: the standalone card, tests); the
/// thread ends when every handle is dropped.
pub fn spawn_card_thread(card: crate::lang::Card) -> CardHandle {
    let (mut runner, handle) = channel(CardCore::new(card), None);
    let never = std::sync::atomic::AtomicBool::new(false);
    let spawned = std::thread::Builder::new()
        .name("mcc-card".into())
        .spawn(move || runner.run_until(&never));
    if let Err(e) = spawned {
        tracing::error!("cannot start the card thread: {e}");
    }
    handle
}

/// Queries a queryable's worker takes at most; beyond that a query is answered with an error
/// at once (the callback never blocks).
pub(crate) const QUERY_BACKLOG: usize = 256;

/// Run `work` for each query on one worker thread of its own, in arrival order: a zenoh
/// callback must never wait for the card (the card's tick may be waiting for a ring frame that
/// the same zenoh threads deliver). Returns the callback to declare the queryable with.
pub(crate) fn query_worker(
    name: &str,
    mut work: impl FnMut(zenoh::query::Query) + Send + 'static,
) -> impl Fn(zenoh::query::Query) + Send + Sync + 'static {
    let (tx, rx) = bounded::<zenoh::query::Query>(QUERY_BACKLOG);
    let spawned = std::thread::Builder::new()
        .name(format!("mcc-card-{name}"))
        .spawn(move || {
            for q in rx {
                work(q);
            }
        });
    if let Err(e) = spawned {
        tracing::error!("cannot start the {name} query worker: {e}");
    }
    move |query: zenoh::query::Query| {
        if let Err(e) = tx.try_send(query) {
            let q = e.into_inner();
            let _ = zenoh::Wait::wait(q.reply_err("busy: too many queries waiting for the card"));
        }
    }
}
