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
//! | D:$0813 (Mx64) | position bias, 1/(Ix08·32) counts (`P` = actual + bias) |
//! | X:$003D / Y:$0814 | status words (computed from the motor flags by `CardState`) |
//! | X:$0000 (M100) | servo cycle counter (24-bit) |
//!
//! On Turbo the same registers sit in the motor blocks of the Turbo map (see
//! `model::regmap`). Only motors with a register block (PMAC2: 1-8, Turbo: 1-32) get the
//! memory registers; every motor gets its `?` flags and its `P`/`V`/`F` report.

use crate::model::encode_fixed;
use crate::model::Addr;
use crate::model::CardModel;
use crate::model::CardState;
use crate::model::MotorFlags;
use crate::model::Space;
use crate::motion::motor::{Motor, TickOutput};
use crate::motion::params::MotorParams;

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
    take_latched(dst, src);
    dst.warning_fe = src.warning_fe;
    dst.in_position = src.in_position;
}

/// Copy the latched (event) `?` bits a host or PLC may have written since the last report
/// from the card's flags into `dst`, the motor's own flags, before the motor runs its cycle.
/// On a PMAC these bits are memory that the firmware changes only at their events (seed 004
/// 6833-6870): home complete (cleared at reset and at the start of a home search, set by a
/// successful home), stopped on position limit (set at the limit stop, cleared when the motor
/// moves again), trigger move (set at the start of a triggered move, cleared at the
/// trigger), and the kill causes amplifier fault, fatal and integrated following error (set
/// at the kill, cleared at the next enable). A write of 0 (`M145=0`) therefore sticks until
/// the next event; bits the servo evaluates every cycle (limits, in position, warning FE,
/// desired velocity zero, open loop, amplifier enabled) are the motor's and are not taken.
pub(super) fn take_latched(dst: &mut MotorFlags, src: &MotorFlags) {
    dst.stopped_on_limit = src.stopped_on_limit;
    dst.home_complete = src.home_complete;
    dst.trigger_move = src.trigger_move;
    dst.integrated_fe = src.integrated_fe;
    dst.amp_fault = src.amp_fault;
    dst.fatal_fe = src.fatal_fe;
}

/// [`take_latched`] for every motor: the card's flags (host and PLC writes) into the motors.
pub(super) fn take_host_writes(card: &CardModel, motors: &mut [Motor]) {
    for (m, f) in motors.iter_mut().zip(card.state.motors.iter()) {
        take_latched(&mut m.flags, f);
    }
}

/// Write a D: register (48-bit fixed point, X high) straight into raw memory.
fn write_d(st: &mut CardState, addr: Addr, v: f64) {
    let w = encode_fixed(v);
    st.memory
        .write(Space::X, addr, ((w >> 24) & 0xFF_FFFF) as u32);
    st.memory.write(Space::Y, addr, (w & 0xFF_FFFF) as u32);
}

/// Write motor `x`'s (1-based) registers (the profile's map: PMAC2 motors 1-8, Turbo 1-32).
pub(super) fn write_motor_registers(
    st: &mut CardState,
    x: u16,
    m: &Motor,
    p: &MotorParams,
    out: &TickOutput,
) {
    let Some(r) = st.map().motor_regs(x) else {
        return;
    };
    let k08 = p.gains.ix08 * 32.0;
    let k09 = p.gains.ix09 * 32.0;
    write_d(st, r.commanded, m.commanded() * k08);
    write_d(st, r.actual, m.actual() * k08);
    let vel = (m.velocity() * k09)
        .round()
        .clamp(-8_388_608.0, 8_388_607.0) as i32;
    st.memory
        .write(Space::X, r.velocity, vel as u32 & 0xFF_FFFF);
    st.memory.write(Space::X, r.filter, out.reg0);
    for a in st.map().following_regs(x) {
        write_d(st, a, m.following_error() * k08);
    }
    write_d(st, r.target, m.prejog * k08);
    write_d(st, r.bias, m.pos_bias * k08);
}

/// Motor `x`'s jog register Mx72 (L memory), counts.
pub(super) fn jog_register(st: &mut CardState, x: u16) -> f64 {
    match st.map().motor_regs(x) {
        Some(r) => crate::model::decode_float(crate::model::long(st, r.jog)),
        None => 0.0,
    }
}

/// Report every motor's position/velocity/following error and copy its `?` flags.
pub(super) fn report(card: &mut CardModel, motors: &[Motor]) {
    for (k, m) in motors.iter().enumerate() {
        let x = k as u16 + 1;
        card.set_motor_report(x, m.reported(), m.velocity(), m.following_error());
        if let Some(f) = card.state.motors.get_mut(k) {
            sync_flags(f, &m.flags);
        }
    }
}

/// Advance the servo cycle counter X:$0000 (and the card's own count of servo cycles).
pub(super) fn count_cycle(st: &mut CardState) {
    st.servo_cycles += 1;
    let a = crate::model::SERVO_COUNTER;
    let c = st.memory.read(Space::X, a);
    st.memory.write(Space::X, a, (c + 1) & 0xFF_FFFF);
}

/// Turbo user countdown timers Isx11/Isx12 of every C.S. (I5111, I5112, I5211 …): decremented
/// once per servo cycle, as 24-bit signed registers (wrapping past −2^23, as the register
/// does). PLCs set them and wait for them to pass zero (`WHILE(I5111>0)ENDWHILE`).
pub(super) fn count_timers(st: &mut CardState) {
    if st.profile() != crate::domain::Profile::Turbo {
        return;
    }
    for s in 1..=u32::from(st.limits().coords) {
        for nn in [11, 12] {
            let n = 5000 + 100 * s + nn;
            let v = st.vars.i(n).unwrap_or(0.0) as i64 - 1;
            let v = (v + 0x80_0000).rem_euclid(0x100_0000) - 0x80_0000;
            st.vars.force_i(n, v as f64);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;

    #[test]
    fn turbo_timers_count_down_and_wrap() {
        let mut st = CardState::new(Profile::Turbo);
        st.vars.set_i(5111, 3.0).unwrap();
        st.vars.set_i(6612, -8_388_608.0).unwrap();
        count_timers(&mut st);
        assert_eq!(st.vars.i(5111), Ok(2.0));
        assert_eq!(st.vars.i(5112), Ok(-1.0));
        assert_eq!(st.vars.i(6612), Ok(8_388_607.0), "24-bit wrap");
        let mut p2 = CardState::new(Profile::Pmac2);
        count_timers(&mut p2);
        assert_eq!(
            p2.vars.i(511),
            Ok(32_000.0),
            "PMAC2: I511 is motor 5's Ix11"
        );
    }
}
