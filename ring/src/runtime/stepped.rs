//! The synchronizing master of the `paced` and `lockstep` clocks: cycle k starts only once
//! cycle k-N's frame has come back around the ring (light or dark, with or without its sync
//! packet), N being the cycles allowed in flight (`in_flight`, 1 by default), so no scheduling
//! delay can look like a ring error.
//!
//! - `paced`: and never before its deadline `origin + k × period / rtf` on the wall clock
//!   ([`PaceGrid`]). After a stall the missed cycles run back to back (each still waiting for
//!   its return) until the ring is on schedule again; beyond [`PACED_BACKLOG_NS`] of lag the
//!   schedule is re-based to the present and the time counted as lost. Cycles starting more
//!   than a period late are counted (the real-time interrupt warning); none is ever skipped,
//!   and lateness is never an error.
//! - `lockstep`: as fast as the ring allows.
//!
//! The one wall-clock judgement: if nothing comes back within the frozen-member wait
//! (`member_timeout_ms`, counted as attended silence: time this loop was running to see it,
//! see [`super::silence`]), a member has stopped answering and the ring is down. The master then
//! runs cycles on its own clock (the paced grid, the nominal rate in lockstep) — its ring check
//! counts the silence — until a frame of the current cycle, or any cycle it started on its own
//! clock with light, comes back (a round trip longer than a period, e.g. across hosts, has
//! several own-clock cycles in flight: the current one is never first). On the own clock a
//! cycle starts at most once a period: a backlog is never run back to back there. When its
//! upstream neighbour is known dead it does not wait at all: every cycle is loss of light on
//! its input.
//!
//! A member that comes back (its liveliness token reappears: a restarted process) opens new
//! links, and frames sent before they are all up go nowhere; so does a frame sent the moment
//! a dead upstream is back. The master never waits for those: from a member's return (or its
//! upstream's death) on, cycles run on the own clock until the links are up — a decision on
//! facts ([`super::links_up`]: every token present, every link's publisher matched, a few
//! clean revolutions of the sync packet in a row), not on the first frame back lit, after
//! which a settling link could still lose one and hold the ring. (Waiting instead held the
//! ring for the whole frozen-member wait, and a member between the master and the restarted
//! one could judge its own, silent but healthy, upstream frozen and latch a fault nobody asked
//! for: campaign seed 1000, #346.)
//!
//! A sync master that (re)starts while the ring still carries another count (a restarted
//! process) continues from the ring's count: the first frame it gets back tells it.
//!
//! Pipelining: with N cycles in flight, cycle k starts once k-N is back, and always *between*
//! the returns of k-N and k-N+1 — a return that arrives while k waits for its deadline is held
//! until k has started. So every member sees the same frames in the same order whatever the
//! timing, and a program gives the same trajectory cycle for cycle; the servo loop of every
//! card is N-1 cycles longer (its feedback comes back N-1 cycles later). The ring check, lag
//! accounting and the frozen wait do not depend on N.
//!
//! The steps ([`Stepper`] and the `step_*` methods) are shared by this member's own loop
//! (`Driver::run_sync_master_stepped`) and the inline receive ([`super::inline`]), where a
//! returning frame starts the next cycle on zenoh's receive thread.

use std::time::Duration;

use tracing::{info, trace, warn};

use super::driver::{Driver, DriverExit};
use super::links_up::{LinkFacts, LinksUp, CLEAN_REVOLUTIONS};
use super::timing::{PaceGrid, PACED_BACKLOG_NS};
use crate::core::RingApp;
use crate::transport::TransportError;
use mcc_contracts::config::ClockMode;

/// Bring-up: until the first frame has come back (links still opening), the sync master
/// starts a new cycle this often rather than waiting.
pub const BRINGUP_RETRY_NS: u64 = 20_000_000;

pub use mcc_contracts::config::MAX_IN_FLIGHT;

/// The stepped sync master's state between cycles.
#[derive(Debug, Clone)]
pub struct Stepper {
    paced: bool,
    frozen_ns: u64,
    in_flight: u64,
    grid: PaceGrid,
    /// The next cycle to start.
    k: u64,
    /// Latest cycle whose frame came back; None while the ring is coming up.
    returned: Option<u64>,
    /// When the latest cycle started.
    last_start: u64,
    /// Nothing came back within the frozen wait: cycles run on the own clock.
    down: bool,
    /// The first cycle started on the own clock (the latest ring down).
    down_from: u64,
    /// Lockstep: the grid is only followed on the own clock; re-based when that begins.
    grid_live: bool,
    /// A member came back (or the upstream died): its new links lose frames until they are
    /// up, so cycles run on the own clock until [`LinksUp`] says they are.
    await_links: Option<LinksUp>,
    /// Rejoins counted so far (see [`super::light::watch_rejoins`]).
    rejoins_seen: u64,
}

/// When the next cycle may start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Due {
    /// Not before this moment (monotonic ns); None: not before a frame comes back, waiting at
    /// most until `frozen_at`.
    pub at: Option<u64>,
    /// When the frozen-member wait runs out.
    pub frozen_at: u64,
    /// Frames must stay queued until the cycle has started (pipelining order).
    pub hold_frames: bool,
}

impl Due {
    /// The cycle may start at `now`.
    pub fn now(&self, now: u64) -> bool {
        self.at.is_some_and(|d| now >= d)
    }

    /// How long to sleep from `now` before looking again (at most `cap`).
    pub fn wait(&self, now: u64, cap: Duration) -> Duration {
        let until = self.at.unwrap_or(self.frozen_at).saturating_sub(now);
        Duration::from_nanos(until).min(cap)
    }
}

impl<A: RingApp> Driver<A> {
    /// A fresh stepper for this member's clock and ring.
    pub(super) fn stepper(&self) -> Stepper {
        let paced = self.cfg.clock == ClockMode::Paced;
        Stepper {
            paced,
            frozen_ns: self.cfg.member_timeout.as_nanos().min(u128::from(u64::MAX)) as u64,
            in_flight: self.cfg.in_flight.clamp(1, MAX_IN_FLIGHT),
            grid: PaceGrid::new(self.wall_period_ns(), 0, self.now_ns(), PACED_BACKLOG_NS),
            k: 0,
            returned: None,
            last_start: self.now_ns(),
            down: false,
            down_from: 0,
            grid_live: paced,
            await_links: None,
            rejoins_seen: self.rejoins(),
        }
    }

    /// When cycle `st.k` may start (declares the ring down when the frozen wait ran out).
    pub(super) fn step_due(&mut self, st: &mut Stepper, now: u64) -> Due {
        let rejoins = self.rejoins();
        if rejoins != st.rejoins_seen {
            st.rejoins_seen = rejoins;
            if st.returned.is_some() {
                info!(member = %self.cfg.name, cycle = st.k,
                    "a ring member came back: cycles run on the own clock until its links are up");
                // (A newer rejoin: the links are judged again.)
                st.await_links = Some(LinksUp::new(CLEAN_REVOLUTIONS));
            }
        }
        loop {
            let own_clock = st.down || st.await_links.is_some() || self.upstream_dead();
            if !st.paced && own_clock != st.grid_live {
                st.grid_live = own_clock;
                st.grid.rebase(st.k, now);
            }
            // Silence since the cycle in flight started, counted only while this member's
            // loop was running to see it (a stall of this process is no frozen member).
            let attended = self.silence.look(now);
            let frozen_at = now.saturating_add(st.frozen_ns.saturating_sub(attended));
            let back = st
                .returned
                .is_some_and(|r| r.saturating_add(st.in_flight) >= st.k);
            let (at, hold_frames) = if st.k == 0 {
                (Some(now), false)
            } else if own_clock {
                // Free-running, as a real sync master: one cycle a period at most. A backlog
                // is never run back to back here — nothing waits for those frames to come
                // back, so hundreds would leave at once and overflow the links' queues (the
                // lost ones then held the ring once it stepped again). The grid keeps the lag
                // (late cycles, re-based beyond the backlog).
                let next = st.last_start.saturating_add(self.wall_period_ns());
                (Some(st.grid.deadline(st.k).max(next)), false)
            } else if st.returned.is_none() {
                (Some(st.last_start.saturating_add(BRINGUP_RETRY_NS)), false)
            } else if back {
                let at = if st.paced {
                    st.grid.deadline(st.k)
                } else {
                    now
                };
                (Some(at), st.in_flight > 1)
            } else if attended >= st.frozen_ns {
                warn!(
                    member = %self.cfg.name,
                    cycle = st.k - 1,
                    "nothing came back within {} ms: ring down, cycles run on the own clock",
                    st.frozen_ns / 1_000_000
                );
                st.down = true;
                st.down_from = st.k;
                if let Some(c) = self.clock.as_mut() {
                    c.set_ring_down(true);
                }
                continue;
            } else {
                (None, false)
            };
            return Due {
                at,
                frozen_at,
                hold_frames,
            };
        }
    }

    /// A frame came back around the ring.
    pub(super) fn step_frame(
        &mut self,
        st: &mut Stepper,
        bytes: &[u8],
    ) -> Result<(), TransportError> {
        let now = self.now_ns();
        let ev = self.core.on_frame(bytes, now);
        self.send_all(ev.outgoing)?;
        let Some(c) = ev.returned else {
            return Ok(());
        };
        if st.returned.is_none() {
            if c >= st.k {
                // The ring counts further than this (restarted) sync master: go on from the
                // ring's count.
                info!(member = %self.cfg.name, from = st.k, to = c + 1,
                    "continuing the ring's cycle count: the own clock until the links are up");
                st.k = c + 1;
                // A restarted sync master: its new links may still lose frames.
                st.await_links = Some(LinksUp::new(CLEAN_REVOLUTIONS));
            }
            // The ring is up: the schedule starts now.
            st.grid.rebase(st.k, now);
        }
        // A frame numbered beyond the cycle in flight (a member that ran on its own clock) is
        // the return of the cycle in flight, no more: the ring's count is this master's.
        st.returned = st.returned.max(Some(c.min(st.k.saturating_sub(1))));
        // Back to normal once a cycle of the current window comes back (with N in flight the
        // frame of k-N is the newest that can), or — a round trip longer than a period (across
        // hosts): several own-clock cycles in flight, the current window never comes back
        // first — once any cycle started on the own clock comes back lit.
        //
        // Cycles still out from the own clock are not waited for: nothing held them back, so
        // on a loaded machine some may have been dropped from a link's queue (a send task
        // descheduled while cycles kept coming), and the one the master waited for could be
        // among them — the ring then stood still for the whole frozen-member wait (paced
        // restart campaign under load). The ring carries light again: stepping resumes from
        // the next cycle, and the returns still on their way are taken as they come.
        let lit = !self.core.is_dark();
        let mut resumed = false;
        if st.await_links.is_some() {
            let clean = lit && ev.errors.is_empty() && self.core.last_sync_return() == Some(c);
            let facts = self.link_facts();
            if st
                .await_links
                .as_mut()
                .is_some_and(|l| l.on_return(c, clean, facts))
            {
                info!(member = %self.cfg.name, cycle = c, "the links are up");
                st.await_links = None;
                resumed = true;
            }
        }
        if st.down && (c.saturating_add(st.in_flight) >= st.k || (lit && c >= st.down_from)) {
            info!(member = %self.cfg.name, cycle = c, "ring cycling again");
            st.down = false;
            if let Some(s) = self.clock.as_mut() {
                s.set_ring_down(false);
            }
            resumed = true;
        }
        if resumed && !st.down && st.await_links.is_none() {
            st.returned = st.returned.max(Some(st.k.saturating_sub(1)));
        }
        Ok(())
    }

    /// Start cycle `st.k` now. Its tick runs now, or with `defer` is left for the member's
    /// thread ([`Driver::take_pending_tick`]).
    pub(super) fn step_start(
        &mut self,
        st: &mut Stepper,
        defer: bool,
    ) -> Result<(), TransportError> {
        let k = st.k;
        let now = self.now_ns();
        let dead = self.upstream_dead();
        if st.await_links.is_some() {
            let facts = self.link_facts();
            if let Some(l) = st.await_links.as_mut() {
                l.on_start(k, facts);
            }
        }
        let on_grid =
            (st.paced && st.returned.is_some()) || st.down || st.await_links.is_some() || dead;
        let start = on_grid.then(|| st.grid.on_start(k, now));
        if let Some(s) = start {
            if s.late {
                self.core.note_late();
            }
            if s.lost_ns > 0 {
                trace!(cycle = k, lost_ns = s.lost_ns, "paced clock re-based");
            }
        }
        if let Some(c) = self.clock.as_mut().filter(|_| st.returned.is_some()) {
            // (From the moment the ring first closed: bring-up retries are not stalls.)
            c.on_start(k, now, start);
        }
        if self.cfg.record > 0 {
            self.record(k, now);
        }
        let t = self.time_for(k);
        let out = self.core.start_cycle(k, t);
        self.send_all(out)?;
        if defer {
            self.defer_tick(k);
        } else {
            self.tick(k);
        }
        if dead {
            // Loss of light on the input: this cycle comes back dark. Once the upstream is
            // back, its new links may lose frames: the own clock goes on until they are up.
            let _ = self.core.dark_input(k, now);
            st.returned = st.returned.max(Some(k));
            st.await_links
                .get_or_insert_with(|| LinksUp::new(CLEAN_REVOLUTIONS));
        }
        st.last_start = now;
        self.silence.reset(now);
        st.k += 1;
        Ok(())
    }

    /// The facts of "the links are up" now ([`super::links_up`]): every ring member's token
    /// present and the upstream not dead; every link's publisher matched since the latest
    /// rejoin (this member's own from its transport). A fact without a watch (in-process
    /// rings) holds.
    fn link_facts(&mut self) -> LinkFacts {
        use std::sync::atomic::Ordering::Relaxed;
        let present = self
            .cfg
            .members_present
            .as_ref()
            .is_none_or(|p| p.load(Relaxed));
        let rejoins = self.rejoins();
        let others = self
            .cfg
            .links_matched
            .as_ref()
            .is_none_or(|m| m.load(Relaxed) > rejoins);
        LinkFacts {
            tokens: present && !self.upstream_dead(),
            matched: others && self.link_matched() != Some(false),
        }
    }

    /// Rejoins of ring members seen so far (0 without a watch).
    fn rejoins(&self) -> u64 {
        self.cfg
            .rejoins
            .as_ref()
            .map_or(0, |r| r.load(std::sync::atomic::Ordering::Relaxed))
    }

    pub(super) fn run_sync_master_stepped(&mut self) -> DriverExit {
        let mut st = self.stepper();
        loop {
            if let Some(exit) = self.stop_or_done() {
                return exit;
            }
            // Wait until cycle k may start, passing frames to the core meanwhile.
            loop {
                if let Err(e) = self.flush_delayed() {
                    return DriverExit::Transport(e);
                }
                let now = self.now_ns();
                let due = self.step_due(&mut st, now);
                if due.now(now) {
                    break;
                }
                let wait = if self.delayed.is_empty() {
                    due.wait(now, Duration::from_millis(5))
                } else {
                    Duration::from_micros(50)
                };
                if due.hold_frames {
                    // The next cycle must start before any further return is looked at.
                    std::thread::sleep(wait);
                    if self.service() {
                        return DriverExit::Stopped;
                    }
                    continue;
                }
                match self.recv(wait) {
                    Ok(Some(bytes)) => {
                        if let Err(e) = self.step_frame(&mut st, &bytes) {
                            return DriverExit::Transport(e);
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
            if let Err(e) = self.step_start(&mut st, false) {
                return DriverExit::Transport(e);
            }
        }
    }
}

#[cfg(test)]
#[path = "tests_stepped.rs"]
mod tests;
