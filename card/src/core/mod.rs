//! The card core: the one owner of a card's state. It holds the card (model and interpreter)
//! and its servo loop; host work arrives as requests ([`HostRequest`]) with a token and leaves
//! as replies with the same token; effects that need the operating system (SAVE's write,
//! `$$$`'s image load) leave as [`Effect`]s with a token and come back as results. Pure: the
//! runtime's servo thread calls [`CardCore::serve`] with a work budget between ticks, so host
//! lines of any size are served in bounded slices and never delay a tick.

pub(crate) mod chain;
pub(crate) mod inputs;
pub mod rig;
pub(crate) mod ring_io;

#[cfg(test)]
#[path = "tests_core.rs"]
mod tests;
#[cfg(test)]
mod tests_servo;

use std::collections::{HashMap, VecDeque};

use crate::domain::Refusal;
use crate::lang::{
    Budget, Card, Dialect, Effect, EffectResult, HeldReply, LineRun, Session, Started, Step,
};
use crate::servo::Servo;

/// Work units one slice of host service may use between two servo ticks (about 50-100 µs of
/// interpreter work on the reference machine: a few hundred variables printed).
pub const SLICE_UNITS: u64 = 400;

/// A streamed line hands out its reply in parts of about this many bytes.
pub(crate) const STREAM_CHUNK: usize = 16 * 1024;

/// Connections the core keeps sessions for; the least recently used is forgotten beyond it.
pub(crate) const MAX_SESSIONS: usize = 512;

/// A host port's request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HostRequest {
    /// Execute a command line (without its `<CR>`).
    Line(Vec<u8>),
    /// Execute a control character.
    Control(u8),
    /// The connection closed: release a buffer it left open, forget its addressing.
    End,
    /// Execute a command line whose reply may come in parts of about `STREAM_CHUNK` bytes
    /// ([`HostReply::more`]), so a host port never holds more than a part of a long reply.
    LineStreamed(Vec<u8>),
    /// The next part of the connection's streamed line.
    More,
}

/// The answer to a [`HostRequest`].
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct HostReply {
    /// The framed reply bytes.
    pub bytes: Vec<u8>,
    /// Full-duplex echo (CTRL-T) after the request.
    pub echo: bool,
    /// A part of a streamed line: ask [`HostRequest::More`] for the rest.
    pub more: bool,
    /// The line's first refusal (`ERRnnn`, `error #n`), whether or not the framing printed
    /// it (I6): callers match on this, never on the reply bytes. `None` on a streamed part.
    pub error: Option<Refusal>,
}

#[derive(Debug)]
struct Job {
    token: u64,
    conn: u64,
    req: HostRequest,
    run: Option<LineRun>,
    /// Effect token this job waits for.
    waiting: Option<u64>,
    /// A streamed line whose last part is out: it waits for the host's [`HostRequest::More`].
    parked: bool,
    /// The line waits for a MACRO auxiliary access on the ring ([`Step::Wait`]): it is tried
    /// again at the next `serve`, and holds back only its own connection's later requests.
    aux_wait: bool,
    /// A streamed line's reply framed so far and not yet handed out.
    out: Vec<u8>,
    /// A whole line's reply held for its effect (a Power card's `save` or `$$$`).
    held: Option<HeldReply>,
}

/// The card core (see the module docs).
#[derive(Debug)]
pub struct CardCore {
    /// The card: data model and PMAC interpreter.
    pub card: Card,
    /// The servo loop (motors, program engine).
    pub servo: Servo,
    sessions: HashMap<u64, (Session, u64)>,
    jobs: VecDeque<Job>,
    replies: Vec<(u64, HostReply)>,
    effects: Vec<(u64, Effect)>,
    next_effect: u64,
    clock: u64,
    /// Why the last image load failed (`None`: it loaded or there was none).
    pub load_error: Option<String>,
    /// The card's command language ([`Dialect`]): every host line goes through it.
    pub dialect: Dialect,
    /// The hardware stop inputs (abort, feed hold) held active.
    pub inputs: inputs::CardInputs,
    /// The card's side of its ring link (`ring_io`).
    ring: ring_io::RingLink,
    /// The card's daisy-chain receivers, one per chain connection (`chain`).
    chain: chain::ChainPort,
}

/// Why a loaded image is refused (`None`: it is good, or there is none).
fn load_error_of(r: &EffectResult) -> Option<String> {
    match r {
        EffectResult::Loaded(Err(e)) => Some(e.clone()),
        EffectResult::Loaded(Ok(Some(bytes))) => crate::model::persist::decode(bytes)
            .err()
            .map(|e| e.to_string()),
        _ => None,
    }
}

/// CTRL-I: execute the last command line again.
const CTRL_I: u8 = 0x09;

/// Effect tokens of detached effects (no job waits) have this bit set.
const DETACHED: u64 = 1 << 63;

impl CardCore {
    /// A core for `card`.
    pub fn new(mut card: Card) -> Self {
        let servo = Servo::new(&card.model);
        let dialect = Dialect::for_card(&mut card);
        let ring = ring_io::RingLink::new(card.resets());
        CardCore {
            ring,
            chain: chain::ChainPort::new(),
            dialect,
            card,
            servo,
            sessions: HashMap::new(),
            jobs: VecDeque::new(),
            replies: Vec::new(),
            effects: Vec::new(),
            next_effect: 1,
            clock: 0,
            load_error: None,
            inputs: inputs::CardInputs::default(),
        }
    }

    /// Make hardware input `kind` active from ring cycle `cycle` (for `cycles` cycles, or
    /// until `CardInputs::clear`); `select` is the C.S. the FPD lines select
    /// (PMAC2/Turbo). See `core::inputs`.
    pub fn press_input(
        &mut self,
        kind: inputs::InputKind,
        select: u16,
        cycle: u64,
        cycles: Option<u64>,
    ) -> Result<String, String> {
        let (profile, coords) = (self.card.profile(), self.card.state.limits().coords);
        self.inputs
            .press(profile, coords, kind, select, cycle, cycles)
    }

    /// Queue request `token` of connection `conn`. [`HostRequest::More`] resumes the
    /// connection's streamed line (its next part answers `token`); any other request of a
    /// connection whose streamed line is parked abandons the rest of that line (the host moved
    /// on without reading it).
    pub fn submit(&mut self, token: u64, conn: u64, req: HostRequest) {
        let parked = self.jobs.iter().position(|j| j.conn == conn && j.parked);
        if let Some(i) = parked {
            if req == HostRequest::More {
                if let Some(j) = self.jobs.get_mut(i) {
                    j.token = token;
                    j.parked = false;
                }
                return;
            }
            self.jobs.remove(i);
        }
        self.jobs.push_back(Job {
            token,
            conn,
            req,
            run: None,
            waiting: None,
            parked: false,
            aux_wait: false,
            out: Vec::new(),
            held: None,
        });
    }

    /// Requests queued or under way (not counting streamed lines waiting for their host).
    pub fn pending(&self) -> usize {
        self.jobs.iter().filter(|j| !j.parked).count()
    }

    fn session(&mut self, conn: u64) -> Session {
        self.clock += 1;
        if !self.sessions.contains_key(&conn) && self.sessions.len() >= MAX_SESSIONS {
            let oldest = self
                .sessions
                .iter()
                .min_by_key(|(_, (_, t))| *t)
                .map(|(k, _)| *k);
            if let Some(k) = oldest {
                self.sessions.remove(&k);
            }
        }
        let clock = self.clock;
        let e = self
            .sessions
            .entry(conn)
            .or_insert_with(|| (Session::with_id(conn), clock));
        e.1 = clock;
        e.0.clone()
    }

    fn put_session(&mut self, conn: u64, s: Session) {
        if let Some(e) = self.sessions.get_mut(&conn) {
            e.0 = s;
        }
    }

    /// Serve queued requests within `budget`, round robin between connections: a line that
    /// needs more than its slice goes behind the requests of other connections, so a host
    /// waiting on a long reply delays another host's one-line query by at most one slice per
    /// connection with work queued (\[DECISION\] the fairness bound: a short request is answered
    /// within `(k + 1)` slices when `k` other connections have work queued). A connection's own
    /// requests run in order. A request whose line waits for an effect holds every request
    /// (effects are short, and `$$$` must not interleave with other lines). A line waiting
    /// for a MACRO auxiliary access ([`Step::Wait`], many ring cycles) holds back only its own
    /// connection's later requests; it is looked at again once per `serve`.
    pub fn serve(&mut self, budget: &mut Budget) {
        for j in self.jobs.iter_mut() {
            j.aux_wait = false;
        }
        while !budget.exhausted() {
            if self.jobs.iter().any(|j| j.waiting.is_some()) {
                return;
            }
            let Some(i) = self.next_runnable() else {
                return;
            };
            let Some(mut job) = self.jobs.remove(i) else {
                return;
            };
            let conn = job.conn;
            let mut s = self.session(conn);
            let mut error = None;
            if job.req == HostRequest::Control(CTRL_I) && self.dialect.has_control_commands() {
                // CTRL-I runs the last line again (not remembered anew), sliced as a line.
                let last = self.card.last_line().to_vec();
                job.run = Some(self.card.start_line(&mut s, &last, false));
                job.req = HostRequest::Line(last);
            }
            let done = match job.req.clone() {
                HostRequest::End => {
                    self.dialect.end(&mut self.card, &s, conn);
                    self.sessions.remove(&conn);
                    Some(Vec::new())
                }
                HostRequest::Control(c) => {
                    budget.spend(1);
                    Some(self.dialect.control(&mut self.card, &mut s, c))
                }
                HostRequest::Line(line) | HostRequest::LineStreamed(line)
                    if self.dialect.answers_whole_lines() =>
                {
                    let w = self.dialect.whole_line(&mut self.card, conn, &line);
                    budget.spend(w.as_ref().map_or(1, |w| w.units));
                    let (out, refused, held) =
                        w.map_or((Vec::new(), None, None), |w| (w.bytes, w.error, w.held));
                    error = refused;
                    match held {
                        // Answered once the effect is done ([`CardCore::effect_done`]).
                        Some(held) => {
                            let t = self.next_effect;
                            self.next_effect += 1;
                            self.effects.push((t, held.effect().clone()));
                            job.waiting = Some(t);
                            job.held = Some(held);
                            None
                        }
                        None => Some(out),
                    }
                }
                HostRequest::More => Some(Vec::new()),
                HostRequest::Line(line) | HostRequest::LineStreamed(line) => {
                    let mut run = match job.run.take() {
                        Some(r) => r,
                        None => self.card.start_line(&mut s, &line, true),
                    };
                    let step = self.card.step_line(&mut run, &mut s, budget);
                    if matches!(step, Step::Done(_)) {
                        error = run.refusal().map(Refusal::Pmac);
                    }
                    match step {
                        Step::Done(r) if job.out.is_empty() => Some(r),
                        Step::Done(r) => {
                            let mut all = std::mem::take(&mut job.out);
                            all.extend_from_slice(&r);
                            Some(all)
                        }
                        Step::Yield => {
                            let streamed = matches!(job.req, HostRequest::LineStreamed(_));
                            // Framed at once: a data line waiting as text costs ~20 times
                            // its bytes.
                            if streamed {
                                let framed = self.card.take_output(&mut run, &s);
                                job.out.extend_from_slice(&framed);
                            }
                            if streamed && job.out.len() >= STREAM_CHUNK {
                                let mut part = std::mem::take(&mut job.out);
                                part.shrink_to_fit();
                                let echo = s.echo;
                                self.replies.push((
                                    job.token,
                                    HostReply {
                                        bytes: part,
                                        echo,
                                        more: true,
                                        error: None,
                                    },
                                ));
                                job.parked = true;
                            }
                            job.run = Some(run);
                            None
                        }
                        Step::Wait => {
                            job.run = Some(run);
                            job.aux_wait = true;
                            None
                        }
                        Step::Effect(e) => {
                            let t = self.next_effect;
                            self.next_effect += 1;
                            self.effects.push((t, e));
                            job.run = Some(run);
                            job.waiting = Some(t);
                            None
                        }
                    }
                }
            };
            // The connection's own duplex mode (CTRL-T), not another host's.
            let echo = s.echo;
            self.put_session(conn, s);
            self.collect_detached();
            match done {
                Some(bytes) => {
                    self.replies.push((
                        job.token,
                        HostReply {
                            bytes,
                            echo,
                            more: false,
                            error,
                        },
                    ));
                }
                // A line waiting for its effect keeps its place; one that used its slice
                // goes behind the others (round robin).
                None if job.waiting.is_some() || job.aux_wait => self.jobs.insert(i, job),
                None => {
                    // The connection's later requests go behind with it, still in order.
                    let (mut same, others): (VecDeque<Job>, VecDeque<Job>) =
                        std::mem::take(&mut self.jobs)
                            .into_iter()
                            .partition(|j| j.conn == conn);
                    self.jobs = others;
                    self.jobs.push_back(job);
                    self.jobs.append(&mut same);
                }
            }
        }
    }

    /// The oldest job that may run now: not parked, not waiting for the ring, and no earlier
    /// job of its connection.
    fn next_runnable(&self) -> Option<usize> {
        let mut seen = std::collections::HashSet::new();
        for (i, j) in self.jobs.iter().enumerate() {
            if seen.insert(j.conn) && !j.parked && !j.aux_wait {
                return Some(i);
            }
        }
        None
    }

    fn collect_detached(&mut self) {
        for e in self.card.take_detached_effects() {
            let t = self.next_effect | DETACHED;
            self.next_effect += 1;
            self.effects.push((t, e));
        }
    }

    /// Effects to perform (off the servo thread), with their tokens.
    pub fn take_effects(&mut self) -> Vec<(u64, Effect)> {
        self.collect_detached();
        std::mem::take(&mut self.effects)
    }

    /// Effect `token` is done.
    pub fn effect_done(&mut self, token: u64, result: EffectResult) {
        if token & DETACHED != 0 {
            if let EffectResult::Loaded(_) = result {
                self.load_error = self.card.apply_loaded(result).err();
            }
            return;
        }
        let Some(i) = self.jobs.iter().position(|j| j.waiting == Some(token)) else {
            return;
        };
        if self.jobs.get(i).is_some_and(|j| j.held.is_some()) {
            let Some(job) = self.jobs.remove(i) else {
                return;
            };
            let Some(held) = job.held else {
                return;
            };
            let (bytes, error) = match result {
                EffectResult::Saved(ok) => held.answer(ok),
                loaded @ EffectResult::Loaded(_) => {
                    self.load_error = self.card.apply_loaded(loaded).err();
                    held.answer(true)
                }
            };
            self.replies.push((
                job.token,
                HostReply {
                    bytes,
                    echo: false,
                    more: false,
                    error,
                },
            ));
            return;
        }
        let Some(job) = self.jobs.get_mut(i) else {
            return;
        };
        job.waiting = None;
        let conn = job.conn;
        let is_load = matches!(result, EffectResult::Loaded(_));
        let mut s = self.session(conn);
        let Some(job) = self
            .jobs
            .iter_mut()
            .find(|j| j.conn == conn && j.run.is_some())
        else {
            return;
        };
        if let Some(run) = job.run.as_mut() {
            if is_load {
                self.load_error = load_error_of(&result);
            }
            self.card.finish_effect(run, &mut s, result);
        }
        self.put_session(conn, s);
    }

    /// Replies ready, with their request tokens.
    pub fn take_replies(&mut self) -> Vec<(u64, HostReply)> {
        std::mem::take(&mut self.replies)
    }

    /// One servo cycle of the MACRO auxiliary channel: `returned` = registers 2 and 3 of this
    /// card's node-15 packet as it came back around the ring (the latched copy); returns the
    /// registers 2 and 3 to send in this cycle's node-15 packet.
    pub fn aux_tick(&mut self, returned: (u16, u16)) -> (u16, u16) {
        self.card.model.aux.servo_tick(returned)
    }

    /// One servo cycle at ring cycle `cycle` (program `CMD`s run through the card's language).
    pub fn tick(&mut self, cycle: u64) {
        self.inputs.before_tick(&mut self.card.model, cycle);
        // Program `CMD`s run through the card's own language.
        let servo = &mut self.servo;
        self.dialect
            .tick(&mut self.card, |model, cmds| servo.tick(model, cmds, cycle));
        self.collect_detached();
    }

    /// Run daisy-chain request `req` (`mcc_contracts::control::chain`), its lines within
    /// `budget`: the encoded reply, or `None` when a line is not done (it waits for the ring
    /// or for its next slice; [`CardCore::chain_resume`] answers it).
    pub fn chain_request(
        &mut self,
        req: &mcc_contracts::control::chain::Request<'_>,
        budget: &mut Budget,
    ) -> Option<chain::Encoded> {
        self.chain
            .handle(&mut self.card, &mut self.dialect, req, budget)
    }

    /// Go on with chain connection `conn`'s line that was not done, within `budget`: the
    /// encoded reply of its request once it and the rest of the request are done.
    pub fn chain_resume(&mut self, conn: u64, budget: &mut Budget) -> Option<chain::Encoded> {
        self.chain
            .resume(&mut self.card, &mut self.dialect, conn, budget)
    }

    /// Chain connection `conn` has a line not done: its later requests wait.
    pub fn chain_is_parked(&self, conn: u64) -> bool {
        self.chain.is_parked(conn)
    }

    /// Chain connections with a line not done.
    pub fn chain_parked(&self) -> Vec<u64> {
        self.chain.parked()
    }

    /// A synchronized start's line, in the tick of its cycle, within `budget` (one slice):
    /// done, or a run to go on with ([`CardCore::synced_step`]) in later slices. `session` is
    /// the synchronized-start session, `thread` its Power thread.
    pub fn synced_line(
        &mut self,
        session: &mut Session,
        thread: u64,
        line: &[u8],
        budget: &mut Budget,
    ) -> Started {
        self.dialect
            .started_line(&mut self.card, session, thread, line, budget)
    }

    /// Go on with a synchronized start's line within `budget`.
    pub fn synced_step(
        &mut self,
        session: &mut Session,
        run: Box<LineRun>,
        budget: &mut Budget,
    ) -> Started {
        Dialect::step_started(&mut self.card, session, run, budget)
    }
}
