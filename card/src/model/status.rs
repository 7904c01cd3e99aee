//! Status words `?` (motor), `??` (coordinate system), `???` (global), bit-exact per
//! pmac-commands §4 and pmac-variables §7.1-§7.3. The flags are plain state that the motion
//! code sets; bits that follow I-variables (activated, handwheel, phased, integration mode)
//! are passed in by [`super::CardState`].

/// Bit helper: `1 << n` if `b`.
fn bit(b: bool, n: u32) -> u32 {
    (b as u32) << n
}
fn has(w: u32, n: u32) -> bool {
    w & (1 << n) != 0
}

/// Dynamic state of one motor (everything in `?` not derived from I-variables).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MotorFlags {
    /// Word 1 bit 22: negative end limit set.
    pub neg_limit: bool,
    /// Word 1 bit 21: positive end limit set.
    pub pos_limit: bool,
    /// Word 1 bit 18: open loop (killed or O-command). True at power-up (killed).
    pub open_loop: bool,
    /// Word 1 bit 17: move timer active / definite-time move.
    pub move_timer: bool,
    /// Word 1 bit 15: dwell in progress.
    pub dwell: bool,
    /// Word 1 bit 14: data block error.
    pub data_block_error: bool,
    /// Word 1 bit 13 (closed loop only): desired velocity zero.
    pub desired_velocity_zero: bool,
    /// Word 1 bit 12: abort deceleration in progress.
    pub abort_decel: bool,
    /// Word 1 bit 11: block request.
    pub block_request: bool,
    /// Word 1 bit 10: home search in progress.
    pub home_search: bool,
    /// Word 2 bits 23, 22-20: assigned coordinate system (1-based), if any.
    pub coord: Option<u8>,
    /// Word 2 bit 14: amplifier enabled.
    pub amp_enabled: bool,
    /// Word 2 bit 11: stopped on position limit.
    pub stopped_on_limit: bool,
    /// Word 2 bit 10: home complete.
    pub home_complete: bool,
    /// Word 2 bit 8: phasing search error.
    pub phasing_error: bool,
    /// Word 2 bit 7: trigger move.
    pub trigger_move: bool,
    /// Word 2 bit 6: integrated fatal following error.
    pub integrated_fe: bool,
    /// Word 2 bit 5: I²T fault.
    pub i2t_fault: bool,
    /// Word 2 bit 4: backlash direction.
    pub backlash_dir: bool,
    /// Word 2 bit 3: amplifier fault.
    pub amp_fault: bool,
    /// Word 2 bit 2: fatal following error.
    pub fatal_fe: bool,
    /// Word 2 bit 1: warning following error.
    pub warning_fe: bool,
    /// Word 2 bit 0: in position.
    pub in_position: bool,
}

impl Default for MotorFlags {
    fn default() -> Self {
        MotorFlags {
            neg_limit: false,
            pos_limit: false,
            open_loop: true,
            move_timer: false,
            dwell: false,
            data_block_error: false,
            desired_velocity_zero: false,
            abort_decel: false,
            block_request: false,
            home_search: false,
            coord: None,
            amp_enabled: false,
            stopped_on_limit: false,
            home_complete: false,
            phasing_error: false,
            trigger_move: false,
            integrated_fe: false,
            i2t_fault: false,
            backlash_dir: false,
            amp_fault: false,
            fatal_fe: false,
            warning_fe: false,
            in_position: false,
        }
    }
}

/// The I-variable-derived bits of motor status word 1.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MotorSetup {
    /// Ix00 = 1 (bit 23).
    pub activated: bool,
    /// Ix06 = 1 (bit 20).
    pub handwheel: bool,
    /// Ix01 = 1 (bit 19).
    pub phased: bool,
    /// Ix34 = 1 (bit 16).
    pub integration_mode: bool,
}

impl MotorFlags {
    /// Status word 1 (X:$003D for motor 1).
    pub fn word1(&self, s: MotorSetup) -> u32 {
        bit(s.activated, 23)
            | bit(self.neg_limit, 22)
            | bit(self.pos_limit, 21)
            | bit(s.handwheel, 20)
            | bit(s.phased, 19)
            | bit(self.open_loop, 18)
            | bit(self.move_timer, 17)
            | bit(s.integration_mode, 16)
            | bit(self.dwell, 15)
            | bit(self.data_block_error, 14)
            | bit(self.desired_velocity_zero && !self.open_loop, 13)
            | bit(self.abort_decel, 12)
            | bit(self.block_request, 11)
            | bit(self.home_search, 10)
    }

    /// Status word 2 (Y:$0814 for motor 1).
    pub fn word2(&self) -> u32 {
        let cs = match self.coord {
            Some(c) if c >= 1 => (1 << 23) | ((((c - 1) & 7) as u32) << 20),
            _ => 0,
        };
        cs | bit(self.amp_enabled, 14)
            | bit(self.stopped_on_limit, 11)
            | bit(self.home_complete, 10)
            | bit(self.phasing_error, 8)
            | bit(self.trigger_move, 7)
            | bit(self.integrated_fe, 6)
            | bit(self.i2t_fault, 5)
            | bit(self.backlash_dir, 4)
            | bit(self.amp_fault, 3)
            | bit(self.fatal_fe, 2)
            | bit(self.warning_fe, 1)
            | bit(self.in_position, 0)
    }

    /// Turbo status word 1 (X:$00B0 for motor 1, the first six `?` digits on a Turbo card):
    /// as PMAC2's word 1 for bits 10-18 and 21-23, but bit 19 = amplifier enabled, bit 6 =
    /// phased motor, bit 4 = following (handwheel) enabled (Turbo SRM `?`).
    pub fn turbo_word1(&self, s: MotorSetup) -> u32 {
        (self.word1(s) & !((1 << 20) | (1 << 19)))
            | bit(self.amp_enabled, 19)
            | bit(s.phased, 6)
            | bit(s.handwheel, 4)
    }

    /// Turbo status word 2 (Y:$00C0 for motor 1): (C.S. − 1) in bits 20-23, bit 15 = assigned
    /// to a C.S., no amplifier-enabled bit (it is word 1 bit 19); bits 0-13 as PMAC2's.
    pub fn turbo_word2(&self) -> u32 {
        let cs = match self.coord {
            Some(c) if c >= 1 => (1 << 15) | ((((c - 1) & 15) as u32) << 20),
            _ => 0,
        };
        cs | (self.word2() & 0x3FFF & !(1 << 14))
    }

    /// Take the dynamic bits of a written Turbo word 1.
    pub fn set_turbo_word1(&mut self, w: u32) {
        self.set_word1(w);
        self.amp_enabled = has(w, 19);
    }

    /// Take every bit of a written Turbo word 2.
    pub fn set_turbo_word2(&mut self, w: u32) {
        let amp = self.amp_enabled;
        self.set_word2(w & 0x3FFF);
        self.amp_enabled = amp;
        self.coord = has(w, 15).then(|| (((w >> 20) & 15) + 1) as u8);
    }

    /// Take the dynamic bits from a written word 1 (W/M-variable write); setup bits ignored.
    pub fn set_word1(&mut self, w: u32) {
        self.neg_limit = has(w, 22);
        self.pos_limit = has(w, 21);
        self.open_loop = has(w, 18);
        self.move_timer = has(w, 17);
        self.dwell = has(w, 15);
        self.data_block_error = has(w, 14);
        self.desired_velocity_zero = has(w, 13);
        self.abort_decel = has(w, 12);
        self.block_request = has(w, 11);
        self.home_search = has(w, 10);
    }

    /// Take every bit from a written word 2.
    pub fn set_word2(&mut self, w: u32) {
        self.coord = if has(w, 23) {
            Some((((w >> 20) & 7) + 1) as u8)
        } else {
            None
        };
        self.amp_enabled = has(w, 14);
        self.stopped_on_limit = has(w, 11);
        self.home_complete = has(w, 10);
        self.phasing_error = has(w, 8);
        self.trigger_move = has(w, 7);
        self.integrated_fe = has(w, 6);
        self.i2t_fault = has(w, 5);
        self.backlash_dir = has(w, 4);
        self.amp_fault = has(w, 3);
        self.fatal_fe = has(w, 2);
        self.warning_fe = has(w, 1);
        self.in_position = has(w, 0);
    }
}

/// Move mode of a coordinate system (word 2 bits 4, 1, 0).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum MoveMode {
    /// 000 (power-up).
    #[default]
    Linear,
    /// 010.
    Rapid,
    /// 001.
    Circle1,
    /// 011.
    Circle2,
    /// 110.
    Pvt,
    /// 101.
    Spline,
}

/// State of one coordinate system as shown by `??`. The raw word fields hold bits that have
/// no named flag; named flags are OR-ed over them.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct CsFlags {
    /// Word 1 bits 23-6: per-axis feedrate/incremental pairs (Z,Y,X,W,V,U,C,B,A).
    pub axis_bits: u32,
    /// Word 1 bit 5: circle centre vector incremental.
    pub radius_inc: bool,
    /// Word 1 bit 4: continuous motion request.
    pub continuous_request: bool,
    /// Word 1 bit 3: move specified by time.
    pub move_by_time: bool,
    /// Word 1 bit 2: continuous motion mode.
    pub continuous_mode: bool,
    /// Word 1 bit 1: single-step mode.
    pub single_step: bool,
    /// Word 1 bit 0: program running.
    pub running: bool,
    /// The program engine has moves of this C.S. still to execute (after its calculation
    /// ended: the last moves of a program). Not a `??` bit: Power `Coord[x].ProgRunning`.
    pub moves_pending: bool,
    /// Word 2 bit 23: program hold.
    pub program_hold: bool,
    /// Word 2 bit 22: run-time error.
    pub runtime_error: bool,
    /// Word 2 bit 21: circle radius error.
    pub circle_radius_error: bool,
    /// Word 2 bit 20: amp fault (OR over motors).
    pub amp_fault: bool,
    /// Word 2 bit 19: fatal FE (OR).
    pub fatal_fe: bool,
    /// Word 2 bit 18: warning FE (OR).
    pub warning_fe: bool,
    /// Word 2 bit 17: in position (AND).
    pub in_position: bool,
    /// Word 2 bit 16: rotary buffer full.
    pub rotary_full: bool,
    /// Word 2 bit 14: end-of-block stop.
    pub block_stop: bool,
    /// Word 2 bits 15, 13-5, 3, 2 (internal, cutter comp, segmentation), as raw bits.
    pub other2: u32,
    /// Move mode (word 2 bits 4, 1, 0).
    pub mode: MoveMode,
}

/// Word 1 bits for FRAX(X,Y,Z): Z, Y, X feedrate-axis bits.
pub(crate) const FRAX_XYZ: u32 = (1 << 23) | (1 << 21) | (1 << 19);

impl Default for CsFlags {
    fn default() -> Self {
        CsFlags {
            axis_bits: FRAX_XYZ,
            radius_inc: true,
            continuous_request: false,
            move_by_time: false,
            continuous_mode: false,
            single_step: false,
            running: false,
            moves_pending: false,
            program_hold: false,
            runtime_error: false,
            circle_radius_error: false,
            amp_fault: false,
            fatal_fe: false,
            warning_fe: false,
            in_position: true,
            rotary_full: false,
            block_stop: false,
            other2: 0,
            mode: MoveMode::Linear,
        }
    }
}

/// Word 2 bits owned by `other2`.
const OTHER2_MASK: u32 = (1 << 15) | 0x3FE0 | (1 << 3) | (1 << 2);

impl CsFlags {
    /// Status word 1 (X:$0818 for C.S. 1).
    pub fn word1(&self) -> u32 {
        (self.axis_bits & 0xFF_FFC0)
            | bit(self.radius_inc, 5)
            | bit(self.continuous_request, 4)
            | bit(self.move_by_time, 3)
            | bit(self.continuous_mode, 2)
            | bit(self.single_step, 1)
            | bit(self.running, 0)
    }

    /// Status word 2 (Y:$0817 for C.S. 1).
    pub fn word2(&self) -> u32 {
        let mode = match self.mode {
            MoveMode::Linear => 0,
            MoveMode::Rapid => 0b00010,
            MoveMode::Circle1 => 0b00001,
            MoveMode::Circle2 => 0b00011,
            MoveMode::Pvt => 0b10010,
            MoveMode::Spline => 0b10001,
        };
        bit(self.program_hold, 23)
            | bit(self.runtime_error, 22)
            | bit(self.circle_radius_error, 21)
            | bit(self.amp_fault, 20)
            | bit(self.fatal_fe, 19)
            | bit(self.warning_fe, 18)
            | bit(self.in_position, 17)
            | bit(self.rotary_full, 16)
            | bit(self.block_stop, 14)
            | (self.other2 & OTHER2_MASK)
            | mode
    }

    /// Take every bit from a written word 1.
    pub fn set_word1(&mut self, w: u32) {
        self.axis_bits = w & 0xFF_FFC0;
        self.radius_inc = has(w, 5);
        self.continuous_request = has(w, 4);
        self.move_by_time = has(w, 3);
        self.continuous_mode = has(w, 2);
        self.single_step = has(w, 1);
        self.running = has(w, 0);
    }

    /// Take every bit from a written word 2 (mode bits combinations outside the table read
    /// back as LINEAR).
    pub fn set_word2(&mut self, w: u32) {
        self.program_hold = has(w, 23);
        self.runtime_error = has(w, 22);
        self.circle_radius_error = has(w, 21);
        self.amp_fault = has(w, 20);
        self.fatal_fe = has(w, 19);
        self.warning_fe = has(w, 18);
        self.in_position = has(w, 17);
        self.rotary_full = has(w, 16);
        self.block_stop = has(w, 14);
        self.other2 = w & OTHER2_MASK;
        self.mode = match w & 0b10011 {
            0b00010 => MoveMode::Rapid,
            0b00001 => MoveMode::Circle1,
            0b00011 => MoveMode::Circle2,
            0b10010 => MoveMode::Pvt,
            0b10001 => MoveMode::Spline,
            _ => MoveMode::Linear,
        };
    }
}

/// Global status (`???`): X:$0003 word 1, Y:$0003 word 2.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct GlobalFlags {
    /// Word 1 raw bits other than the MACRO bits (RTI re-entry, servo error, gather, ...).
    pub word1_other: u32,
    /// Word 1 bit 5: MACRO auxiliary communications error.
    pub macro_aux_error: bool,
    /// Word 1 bit 4: MACRO ring check error.
    pub ring_fault: bool,
    /// Word 2 bit 22: host (bus) communication mode.
    pub host_mode: bool,
    /// Word 2 bit 19: a motion program buffer (PROG or ROT) is open.
    pub motion_buffer_open: bool,
    /// Word 2 bit 18: rotary buffer(s) open.
    pub rotary_open: bool,
    /// Word 2 bit 17: a PLC buffer is open.
    pub plc_open: bool,
    /// Word 2 bit 16: processing a CMD-issued command.
    pub from_cmd: bool,
    /// Free words of the open PROG/PLC buffer is ≤ I18 (only meaningful when one is open).
    pub buffer_nearly_full: bool,
    /// Word 2 bit 6: rotary buffers open for binary entry.
    pub binary_rotary: bool,
}

/// Word-1 bits owned by `word1_other` (23 and 21 always read 0 from the host).
const GLOBAL1_OTHER: u32 = 0xFF_FFCF & !(1 << 23) & !(1 << 21);

impl GlobalFlags {
    /// Word 1 (X:$0003).
    pub fn word1(&self) -> u32 {
        (self.word1_other & GLOBAL1_OTHER) | bit(self.macro_aux_error, 5) | bit(self.ring_fault, 4)
    }

    /// Word 2 (Y:$0003). Bit 11 (fixed buffer full) is 1 when no PROG/PLC buffer is open or
    /// the open one has ≤ I18 free words.
    pub fn word2(&self) -> u32 {
        let prog_or_plc_open = (self.motion_buffer_open && !self.rotary_open) || self.plc_open;
        let full = !prog_or_plc_open || self.buffer_nearly_full;
        bit(self.host_mode, 22)
            | bit(self.motion_buffer_open, 19)
            | bit(self.rotary_open, 18)
            | bit(self.plc_open, 17)
            | bit(self.from_cmd, 16)
            | bit(full, 11)
            | bit(self.binary_rotary, 6)
    }

    /// Take the bits of a written word 1.
    pub fn set_word1(&mut self, w: u32) {
        self.word1_other = w & GLOBAL1_OTHER;
        self.macro_aux_error = has(w, 5);
        self.ring_fault = has(w, 4);
    }
}

#[cfg(test)]
mod turbo_tests {
    use super::*;

    /// Issue 14 item 4: the Turbo `?` layout (dls-pmaccontrol's labels: word 1 bit 19
    /// "Amplifier enabled", word 2 bit 15 "Assigned to C.S.", bits 20-23 "(C.S. -1) Number").
    #[test]
    fn turbo_motor_words() {
        let f = MotorFlags {
            amp_enabled: true,
            open_loop: false,
            coord: Some(3),
            in_position: true,
            ..MotorFlags::default()
        };
        let s = MotorSetup {
            activated: true,
            phased: true,
            ..MotorSetup::default()
        };
        assert_eq!(f.turbo_word1(s), (1 << 23) | (1 << 19) | (1 << 6));
        assert_eq!(f.turbo_word2(), (2 << 20) | (1 << 15) | 1);
        assert_eq!(f.word2(), (1 << 23) | (2 << 20) | (1 << 14) | 1);
        let mut g = MotorFlags::default();
        g.set_turbo_word1(f.turbo_word1(s));
        g.set_turbo_word2(f.turbo_word2());
        assert_eq!(
            (g.amp_enabled, g.coord, g.in_position),
            (true, Some(3), true)
        );
    }
}
