//! The drive's 1 ms tick (spec emcl.md §11, §6.4): tick timer, closed-loop initialisation,
//! serial heartbeat, RESET_IN, the ramp generator with its limit switches, virtual stops,
//! hard stops and stall detection, the reference search, POS_ERROR, and one program step.
//!
//! The motor model: the ramp generator's steps move the shaft one for one while the driver
//! is on, unless a mechanical end stop blocks it (the motor stalls: stallGuard2 reads 0).
//! Steps that do not move the shaft are lost (open loop: AP 1 runs on, AP 209 stays); in
//! closed loop (AP 129 = 1, initialised) the drive does not lose steps, so the position
//! counter stays with the shaft. POS_ERROR (GP 72 bit 2) latches when the lost steps exceed
//! AP 212 or the velocity deviation exceeds AP 213 (0 = that check off); it stops the motor.

use super::drive::Drive;
use super::motion::{Blocks, Mode, Ramp, StopKind};
use super::spec::MICROSTEPS;

/// Reference search phases (D18: encoder Z-phase search with AP 193/195).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RfsPhase {
    /// Turning at AP 195 toward the index.
    Search,
    /// Index seen: braking.
    Brake,
    /// Going back to the index position.
    Return,
}

/// A reference search in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rfs {
    /// Direction of the search (+1 CW = AP 193 9, −1 CCW = 10).
    pub dir: i64,
    /// Phase.
    pub phase: RfsPhase,
    /// Position counter value at the index.
    pub index_pos: i32,
    /// Reversed once after running into a limit.
    pub reversed: bool,
}

impl Drive {
    /// Advance the drive by one ms of ring time.
    pub fn tick_ms(&mut self) {
        self.now_ms += 1;
        self.gp[132] = self.gp[132].wrapping_add(1);
        if let Some(t) = self.cl_ready_at {
            if self.now_ms >= t {
                if let Some(i) = self.deferred.take() {
                    self.apply_motion(i);
                }
            }
        }
        let hb = u64::try_from(self.gp[68]).unwrap_or(0);
        if hb > 0 && !self.heartbeat_tripped && self.now_ms - self.last_command_ms >= hb {
            self.heartbeat_tripped = true;
            self.rfs = None;
            self.motion.soft_stop();
        }
        if self.plant.reset_in {
            self.clear_pos_error();
        }
        if !self.is_bound() {
            self.motion_tick();
        }
        self.program_tick();
    }

    /// Advance by `n` ms.
    pub fn run_ms(&mut self, n: u64) {
        for _ in 0..n {
            self.tick_ms();
        }
    }

    /// AP 133: closed-loop initialisation finished.
    pub fn cl_ready(&self) -> bool {
        self.ap[129] == 1 && self.cl_ready_at.is_some_and(|t| self.now_ms >= t)
    }

    /// The ramp parameters from AP 4, 5, 15–20.
    pub fn ramp(&self) -> Ramp {
        let a = |n: usize| i64::from(self.ap[n]).abs();
        Ramp {
            vmax: a(4),
            amax: a(5),
            vstart: a(15),
            a1: a(16),
            dmax: a(17),
            v1: a(18),
            d1: a(19),
            vstop: a(20),
        }
    }

    /// AP 8: on target and at rest (position counter = AP 0).
    pub fn target_reached(&self) -> bool {
        self.motion.at_target()
    }

    /// AP 3: the shaft's velocity (0 while blocked or unpowered).
    pub fn actual_velocity(&self) -> i64 {
        if self.is_bound() {
            return self.bound.velocity;
        }
        if self.plant.stalled || !self.driver_on() {
            0
        } else {
            self.motion.v
        }
    }

    /// AP 206: stallGuard2 load reading (0 = stalled).
    pub fn load_value(&self) -> i32 {
        if self.plant.stalled {
            0
        } else {
            i32::from(self.spec.load)
        }
    }

    /// AP 208: driver error flags.
    pub fn driver_flags(&self) -> u8 {
        let mut f = self.driver_faults & 0x7E;
        if self.stall_stop || self.plant.stalled {
            f |= 1;
        }
        if self.actual_velocity() == 0 {
            f |= 0x80;
        }
        f
    }

    /// POS_ERROR is latched.
    pub fn pos_error(&self) -> bool {
        self.pos_error
    }

    /// RESET_IN: clear POS_ERROR; the steps lost so far are accepted (the deviation
    /// starts again from 0).
    pub(crate) fn clear_pos_error(&mut self) {
        self.pos_error = false;
        self.plant.slip = 0;
    }

    fn stop_kind_limit(&self) -> StopKind {
        match self.ap[21] {
            0 => StopKind::Hard,
            a => StopKind::Soft(i64::from(a).abs()),
        }
    }

    fn blocks(&self, r: &Ramp) -> Blocks {
        let mut b = Blocks::default();
        if self.ap[12] != 0 && self.right_limit_active() {
            b.plus = Some(self.stop_kind_limit());
        }
        if self.ap[13] != 0 && self.left_limit_active() {
            b.minus = Some(self.stop_kind_limit());
        }
        let vs = self.ap[28];
        let kind = match self.ap[29] {
            1 => StopKind::Hard,
            2 => self.stop_kind_limit(),
            _ => StopKind::Soft(r.decel(self.motion.v.abs()).max(1)),
        };
        if vs & 2 != 0 && self.motion.pos >= self.ap[27] && b.plus.is_none() {
            b.plus = Some(kind);
        }
        if vs & 1 != 0 && self.motion.pos <= self.ap[26] && b.minus.is_none() {
            b.minus = Some(kind);
        }
        b
    }

    fn motion_tick(&mut self) {
        let r = self.ramp();
        if let Some(rfs) = self.rfs {
            self.rfs_before(rfs, &r);
        }
        let blocks = self.blocks(&r);
        let before = self.plant.shaft;
        let steps = self.motion.step(&r, blocks);
        self.move_shaft(steps);
        if let Some(rfs) = self.rfs {
            self.rfs_after(rfs, before, &r);
        }
        // Stall stop (AP 181): above that speed a stallGuard2 reading of 0 stops the motor.
        let sg = i64::from(self.ap[181]).abs();
        if sg > 0 && self.plant.stalled && self.motion.v.abs() >= sg {
            self.motion.hard_stop();
            self.rfs = None;
            self.stall_stop = true;
        }
        if self.gp[72] & 4 != 0 && !self.pos_error {
            let pos_dev = self.ap[212] > 0 && self.plant.slip.abs() > i64::from(self.ap[212]);
            let vel_dev = self.ap[213] > 0
                && (self.motion.v - self.actual_velocity()).abs() > i64::from(self.ap[213]);
            if pos_dev || vel_dev {
                self.pos_error = true;
                self.prog.flags.edv = true;
                self.rfs = None;
                self.motion.hard_stop();
            }
        }
    }

    /// Move the shaft by the generator's `steps`, within the end stops, if the driver is on.
    pub(crate) fn move_shaft(&mut self, steps: i64) {
        let p = &mut self.plant;
        p.stalled = false;
        p.last_move = 0;
        if steps == 0 {
            return;
        }
        let on = self.plant_driver_on();
        let p = &mut self.plant;
        if !on {
            p.slip += steps;
            return;
        }
        let mut to = p.shaft + steps;
        if let Some(hi) = self.spec.hard_stop_plus {
            if steps > 0 && to > hi {
                to = hi.max(p.shaft);
                p.stalled = true;
            }
        }
        if let Some(lo) = self.spec.hard_stop_minus {
            if steps < 0 && to < lo {
                to = lo.min(p.shaft);
                p.stalled = true;
            }
        }
        let moved = to - p.shaft;
        p.shaft = to;
        p.last_move = moved;
        let lost = steps - moved;
        if lost != 0 {
            if self.ap[129] == 1 && self.cl_ready() {
                // Closed loop keeps the counter on the shaft: the ramp waits.
                let pos = self.motion.pos.wrapping_sub(lost as i32);
                self.motion.set_position(pos);
            } else {
                self.plant.slip += lost;
            }
        }
    }

    fn plant_driver_on(&self) -> bool {
        self.driver_on()
    }

    /// RFS START (D18): search the encoder index at AP 195 in the AP 193 direction.
    pub(crate) fn start_rfs(&mut self) {
        let dir = if self.ap[193] == 10 { -1 } else { 1 };
        self.rfs = Some(Rfs {
            dir,
            phase: RfsPhase::Search,
            index_pos: 0,
            reversed: false,
        });
        self.motion.rotate(dir * i64::from(self.ap[195]).abs());
    }

    fn rfs_before(&mut self, mut rfs: Rfs, r: &Ramp) {
        match rfs.phase {
            RfsPhase::Search => {
                let b = self.blocks(r);
                let blocked = if rfs.dir > 0 { b.plus } else { b.minus };
                if blocked.is_some() && self.motion.v == 0 {
                    if rfs.reversed {
                        // Limits both ways and no index: give up.
                        self.rfs = None;
                        self.motion.soft_stop();
                        return;
                    }
                    rfs.dir = -rfs.dir;
                    rfs.reversed = true;
                    self.motion.rotate(rfs.dir * i64::from(self.ap[195]).abs());
                }
            }
            RfsPhase::Brake => {
                if self.motion.v == 0 {
                    rfs.phase = RfsPhase::Return;
                    self.motion.move_to(rfs.index_pos);
                }
            }
            RfsPhase::Return => {
                if self.motion.at_target() {
                    // At the index: it becomes position 0 (AP 1 and AP 209).
                    self.motion.set_position(0);
                    self.motion.target_pos = 0;
                    self.motion.mode = Mode::Idle;
                    self.plant.enc_offset = -self.enc_scale(self.plant.shaft);
                    self.plant.slip = 0;
                    self.rfs = None;
                    return;
                }
            }
        }
        self.rfs = Some(rfs);
    }

    fn rfs_after(&mut self, mut rfs: Rfs, before: i64, _r: &Ramp) {
        if rfs.phase != RfsPhase::Search {
            return;
        }
        let after = self.plant.shaft;
        if after == before {
            return;
        }
        let per = i64::from(self.ap[202].max(1)) * MICROSTEPS;
        let off = self.spec.index_offset;
        let k0 = (before - off).div_euclid(per);
        let k1 = (after - off).div_euclid(per);
        if k0 == k1 {
            return;
        }
        // The index between the two positions, nearest to where the search came from.
        let index = off + per * k0.max(k1);
        let past = after - index;
        rfs.index_pos = self.motion.pos.wrapping_sub(past as i32);
        rfs.phase = RfsPhase::Brake;
        self.motion.soft_stop();
        self.rfs = Some(rfs);
    }
}
