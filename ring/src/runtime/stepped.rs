//! The synchronizing master of the `paced` and `lockstep` clocks: cycle k starts only once
//! cycle k-1's frame has come back around the ring (light or dark, with or without its sync
//! packet), so no scheduling delay can look like a ring error.
//!
//! - `paced`: and never before its deadline `origin + k × period / rtf` on the wall clock
//!   ([`PaceGrid`]). After a stall the missed cycles run back to back until the ring is on
//!   schedule again; beyond [`PACED_BACKLOG_NS`] of lag the schedule is re-based to the
//!   present and the time counted as lost. Cycles starting more than a period late are counted
//!   (the real-time interrupt warning); none is ever skipped, and lateness is never an error.
//! - `lockstep`: as fast as the ring allows.
//!
//! The one wall-clock judgement: if nothing comes back within the frozen-member wait
//! (`member_timeout_ms`), a member has stopped answering and the ring is down. The master then
//! runs cycles on its own clock (the paced grid, the nominal rate in lockstep) — its ring check
//! counts the silence — until a frame of the current cycle, or any cycle it started on its
//! own clock with light, comes back (a round trip longer than a period, e.g. across hosts,
//! has several own-clock cycles in flight: the current one is never first). When its upstream
//! neighbour is known dead it does not wait at all: every cycle is loss of light on its input.
//!
//! A sync master that (re)starts while the ring still carries another count (a restarted
//! process) continues from the ring's count: the first frame it gets back tells it.
//!
//! Pipelining hook: one cycle is in flight at a time (`returned + 1 >= k`). Letting N cycles be
//! in flight means starting k once `returned + N >= k`; the ring check, lag accounting and
//! the frozen wait do not depend on N.

use std::time::Duration;

use tracing::{info, trace, warn};

use super::driver::{Driver, DriverExit};
use super::timing::{PaceGrid, PACED_BACKLOG_NS};
use crate::config::ClockMode;
use crate::core::RingApp;

/// Bring-up: until the first frame has come back (links still opening), the sync master
/// starts a new cycle this often rather than waiting.
pub const BRINGUP_RETRY_NS: u64 = 20_000_000;

impl<A: RingApp> Driver<A> {
    pub(super) fn run_sync_master_stepped(&mut self) -> DriverExit {
        let paced = self.cfg.clock == ClockMode::Paced;
        let wall = self.wall_period_ns();
        let frozen_ns = self.cfg.member_timeout.as_nanos().min(u128::from(u64::MAX)) as u64;
        let mut grid = PaceGrid::new(wall, 0, self.now_ns(), PACED_BACKLOG_NS);
        let mut k: u64 = 0;
        // Latest cycle whose frame came back; None while the ring is coming up.
        let mut returned: Option<u64> = None;
        // When the cycle in flight started.
        let mut last_start = self.now_ns();
        // Nothing came back within the frozen wait: cycles run on the own clock.
        let mut down = false;
        // The first cycle started on the own clock.
        let mut down_from = 0;
        // Lockstep: the grid is only followed on the own clock; re-based when that begins.
        let mut grid_live = paced;
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
                let own_clock = down || self.upstream_dead();
                if !paced && own_clock != grid_live {
                    grid_live = own_clock;
                    grid.rebase(k, now);
                }
                let since = now.saturating_sub(last_start);
                let back = returned.is_some_and(|r| r.saturating_add(1) >= k);
                // When may k start (None: not before a frame comes back)?
                let due = if k == 0 {
                    Some(now)
                } else if own_clock {
                    Some(grid.deadline(k))
                } else if returned.is_none() {
                    Some(last_start.saturating_add(BRINGUP_RETRY_NS))
                } else if back {
                    Some(if paced { grid.deadline(k) } else { now })
                } else if since >= frozen_ns {
                    warn!(
                        member = %self.cfg.name,
                        cycle = k - 1,
                        "nothing came back within {} ms: ring down, cycles run on the own clock",
                        frozen_ns / 1_000_000
                    );
                    down = true;
                    down_from = k;
                    if let Some(c) = self.clock.as_mut() {
                        c.set_ring_down(true);
                    }
                    continue;
                } else {
                    None
                };
                if due.is_some_and(|d| now >= d) {
                    break;
                }
                let until = due.unwrap_or(last_start.saturating_add(frozen_ns)) - now;
                let wait = if self.delayed.is_empty() {
                    Duration::from_nanos(until).min(Duration::from_millis(5))
                } else {
                    Duration::from_micros(50)
                };
                match self.recv(wait) {
                    Ok(Some(bytes)) => {
                        let now = self.now_ns();
                        let ev = self.core.on_frame(&bytes, now);
                        if let Err(e) = self.send_all(ev.outgoing) {
                            return DriverExit::Transport(e);
                        }
                        let Some(c) = ev.returned else { continue };
                        if returned.is_none() {
                            if c >= k {
                                // The ring counts further than this (restarted) sync master:
                                // go on from the ring's count.
                                info!(member = %self.cfg.name, from = k, to = c + 1,
                                    "continuing the ring's cycle count");
                                k = c + 1;
                            }
                            // The ring is up: the schedule starts now.
                            grid.rebase(k, now);
                        }
                        returned = returned.max(Some(c));
                        // Back: the current cycle came round, or (a round trip longer than
                        // a period: several own-clock cycles in flight) any of them lit.
                        // The ones still in flight drain before the next start.
                        let lit = c >= down_from && !self.core.is_dark();
                        if down && (c.saturating_add(1) >= k || lit) {
                            info!(member = %self.cfg.name, cycle = c, "ring cycling again");
                            down = false;
                            if let Some(s) = self.clock.as_mut() {
                                s.set_ring_down(false);
                            }
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
            let now = self.now_ns();
            let dead = self.upstream_dead();
            let on_grid = (paced && returned.is_some()) || down || dead;
            let start = on_grid.then(|| grid.on_start(k, now));
            if let Some(s) = start {
                if s.late {
                    self.core.note_late();
                }
                if s.lost_ns > 0 {
                    trace!(cycle = k, lost_ns = s.lost_ns, "paced clock re-based");
                }
            }
            if let Some(c) = self.clock.as_mut().filter(|_| returned.is_some()) {
                // (From the moment the ring first closed: bring-up retries are not stalls.)
                c.on_start(k, now, start);
            }
            if self.cfg.record > 0 {
                self.record(k, now);
            }
            let t = self.time_for(k);
            let out = self.core.start_cycle(k, t);
            if let Err(e) = self.send_all(out) {
                return DriverExit::Transport(e);
            }
            self.tick(k);
            if dead {
                // Loss of light on the input: this cycle comes back dark.
                let _ = self.core.dark_input(k, now);
                returned = returned.max(Some(k));
            }
            last_start = now;
            k += 1;
        }
    }
}
