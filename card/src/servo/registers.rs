//! What a servo cycle leaves in the card's memory for `P`/`V`/`F`, `?`, CTRL-P/V/F/B, `R`/`RH`
//! and M-variables (pmac-variables §7.4-§7.6, suggested M-variables §7.8):
//!
//! | register (motor 1; stride $3C / $C0) | contents |
//! |---|---|
//! | D:$0028 (Mx61) | commanded position, 1/(Ix08·32) counts |
//! | D:$002B (Mx62) | actual position, 1/(Ix08·32) counts |
//! | X:$0033 (Mx66) | actual velocity, 1/(Ix09·32) counts per servo cycle |
//! | X:$0043 (Mx68) | filter output, DAC bits in bits 8-23 |
//! | D:$004B, D:$0840 | following error, 1/(Ix08·32) counts |
//! | D:$080B (Mx63) | target (pre-jog) position, 1/(Ix08·32) counts |
//! | X:$003D / Y:$0814 | status words (computed from the motor flags by `CardState`) |
//! | X:$0000 (M100) | servo cycle counter (24-bit) |
//!
//! Only motors with a register block (PMAC2: 1-8) get the memory registers; every motor gets
//! its `?` flags and its `P`/`V`/`F` report.

use crate::model::encode_fixed;
use crate::model::CardModel;
use crate::model::CardState;
use crate::model::MotorFlags;
use crate::model::Space;
use crate::model::{BLOCK_BASE, BLOCK_STRIDE, MOTOR_CALC_BASE, MOTOR_CALC_STRIDE};
use crate::motion::motor::{Motor, TickOutput};
use crate::motion::params::MotorParams;

/// Motors with a calculation block in the PMAC2 memory map.
pub(super) const MAPPED_MOTORS: u16 = 8;

/// Copy the motor-owned `?` bits of `src` into the card's flags (the C.S. assignment, dwell,
/// block request and data-block error belong to the interpreter and the program engine).
pub(super) fn sync_flags(dst: &mut MotorFlags, src: &MotorFlags) {
    dst.neg_limit = src.neg_limit;
    dst.pos_limit = src.pos_limit;
    dst.open_loop = src.open_loop;
    dst.move_timer = src.move_timer;
    dst.desired_velocity_zero = src.desired_velocity_zero;
    dst.abort_decel = src.abort_decel;
    dst.home_search = src.home_search;
    dst.amp_enabled = src.amp_enabled;
    dst.stopped_on_limit = src.stopped_on_limit;
    dst.home_complete = src.home_complete;
    dst.trigger_move = src.trigger_move;
    dst.integrated_fe = src.integrated_fe;
    dst.amp_fault = src.amp_fault;
    dst.fatal_fe = src.fatal_fe;
    dst.warning_fe = src.warning_fe;
    dst.in_position = src.in_position;
}

/// Write a D: register (48-bit fixed point, X high) straight into raw memory.
fn write_d(st: &mut CardState, addr: u16, v: f64) {
    let w = encode_fixed(v);
    st.memory
        .write(Space::X, addr, ((w >> 24) & 0xFF_FFFF) as u32);
    st.memory.write(Space::Y, addr, (w & 0xFF_FFFF) as u32);
}

/// Write motor `x`'s (1-based) registers.
pub(super) fn write_motor_registers(
    st: &mut CardState,
    x: u16,
    m: &Motor,
    p: &MotorParams,
    out: &TickOutput,
) {
    if x == 0 || x > MAPPED_MOTORS {
        return;
    }
    let calc = MOTOR_CALC_BASE + (x - 1) * MOTOR_CALC_STRIDE;
    let block = BLOCK_BASE + (x - 1) * BLOCK_STRIDE;
    let k08 = p.gains.ix08 * 32.0;
    let k09 = p.gains.ix09 * 32.0;
    write_d(st, calc + 0x08, m.commanded() * k08);
    write_d(st, calc + 0x0B, m.actual() * k08);
    let vel = (m.velocity() * k09)
        .round()
        .clamp(-8_388_608.0, 8_388_607.0) as i32;
    st.memory
        .write(Space::X, calc + 0x13, vel as u32 & 0xFF_FFFF);
    st.memory.write(Space::X, calc + 0x23, out.reg0);
    write_d(st, calc + 0x2B, m.following_error() * k08);
    write_d(st, block + 0x40, m.following_error() * k08);
    write_d(st, block + 0x0B, m.prejog * k08);
}

/// Motor `x`'s jog register Mx72 (L:$082B + stride), counts.
pub(super) fn jog_register(st: &mut CardState, x: u16) -> f64 {
    if x == 0 || x > MAPPED_MOTORS {
        return 0.0;
    }
    let a = BLOCK_BASE + (x - 1) * BLOCK_STRIDE + 0x2B;
    crate::model::decode_float(crate::model::long(st, a))
}

/// Report every motor's position/velocity/following error and copy its `?` flags.
pub(super) fn report(card: &mut CardModel, motors: &[Motor]) {
    for (k, m) in motors.iter().enumerate() {
        let x = k as u16 + 1;
        card.set_motor_report(x, m.actual(), m.velocity(), m.following_error());
        if let Some(f) = card.state.motors.get_mut(k) {
            sync_flags(f, &m.flags);
        }
    }
}

/// Advance the servo cycle counter X:$0000.
pub(super) fn count_cycle(st: &mut CardState) {
    let c = st.memory.read(Space::X, 0x0000);
    st.memory.write(Space::X, 0x0000, (c + 1) & 0xFF_FFFF);
}
