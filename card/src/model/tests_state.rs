//! CardState tests: I-variable replies, mirrors, M-variables on special registers, status
//! words bit by bit, reset and factory semantics, Turbo answers.

use super::error::StateError;
use super::persist::PersistError;
use super::status::{MotorFlags, MoveMode};
use super::*;
use crate::domain::ast::{MDef, MFormat, XySpace};
use crate::domain::ErrCode;
use crate::domain::Profile;

fn card() -> CardState {
    CardState::new(Profile::Pmac2)
}

fn bits(space: XySpace, addr: u32, offset: u8, width: u8, format: MFormat) -> MDef {
    MDef::Bits {
        space,
        addr,
        offset,
        width,
        format,
    }
}

#[test]
fn ivar_text_follows_i9() {
    let mut c = card();
    assert_eq!(c.ivar_text(125).unwrap(), "$40F70");
    assert_eq!(c.ivar_text(130).unwrap(), "2000");
    c.set_ivar(9, 3.0).unwrap();
    assert_eq!(c.ivar_text(125).unwrap(), "I125=$40F70");
    assert_eq!(c.ivar_text(115).unwrap(), "I115=0.25");
    c.set_ivar(9, 1.0).unwrap();
    assert_eq!(c.ivar_text(125).unwrap(), "I125=266096");
    c.set_ivar(9, 0.0).unwrap();
    assert_eq!(c.ivar_text(102).unwrap(), "49312");
    assert_eq!(c.ivar_text(1024), Err(StateError::NoSuchVariable(1024)));
}

#[test]
fn ivar_range_errors_are_err003() {
    let mut c = card();
    let e = c.set_ivar(6, 4.0).unwrap_err();
    assert_eq!(e.err_code(), ErrCode::Data);
    assert_eq!(c.read_ivar(6), Ok(3.0));
    c.set_ivar(6, 1.0).unwrap();
    assert_eq!(c.default_ivar(6), Ok(3.0));
}

#[test]
fn i995_mirror_and_clear_on_read() {
    let mut c = card();
    c.set_ivar(995, 0x30 as f64).unwrap();
    assert_eq!(c.read(Space::Y, 0xC08F), 0x30);
    c.latch_ring_status(0x4 | 0x40 | 0x100);
    // Issue 26 item 10: a synchronizing master shows no "sync node packet received" (bit 6):
    // it reads its set-up $30 plus error bits (seed 004 5495).
    assert_eq!(c.peek_ivar(995), Ok((0x30 | 0x4) as f64));
    assert_eq!(c.ivar_text(995).unwrap(), "$34");
    assert_eq!(c.read_ivar(995), Ok(0x30 as f64));
    // A non-synchronizing master with sync node phase lock ($90) latches it.
    c.set_ivar(995, 0x90 as f64).unwrap();
    c.latch_ring_status(0x40);
    assert_eq!(c.ivar_text(995).unwrap(), "$D0");
    assert_eq!(c.read_ivar(995), Ok(0x90 as f64));
    c.set_ivar(995, 0x30 as f64).unwrap();
    c.latch_ring_status(0x1);
    assert_eq!(c.read(Space::Y, 0xC08F), 0x31);
    assert_eq!(c.read(Space::Y, 0xC08F), 0x30);
    c.write(Space::Y, 0xC08E, 0xF00003);
    assert_eq!(c.ivar_text(996).unwrap(), "$F00003");
}

#[test]
fn m_variables_through_card_state() {
    let mut c = card();
    assert_eq!(c.mdef_text(5).unwrap(), "*");
    c.write_m(5, 12.0).unwrap();
    assert_eq!(c.read_m(5), Ok(12.0));
    c.set_mdef(1, bits(XySpace::Y, 0xC0A0, 8, 16, MFormat::S))
        .unwrap();
    assert_eq!(c.mdef_text(1).unwrap(), "Y:$C0A0,8,16,S");
    c.set_ivar(9, 3.0).unwrap();
    assert_eq!(c.mdef_text(1).unwrap(), "M1->Y:$C0A0,8,16,S");
    c.write_m(1, -5.0).unwrap();
    assert_eq!(c.node_command(0), [0xFFFB00, 0, 0, 0]);
    assert_eq!(c.read_m(1), Ok(0.0));
    c.set_node_feedback(0, [0x000300, 0, 0, 0]);
    assert_eq!(c.read_m(1), Ok(3.0));
    assert!(c
        .set_mdef(2, bits(XySpace::X, 0, 2, 8, MFormat::U))
        .is_err());
    assert!(c.set_mdef(1024, MDef::SelfRef).is_err());
    // Suggested M140 (in position) and M145 (home complete) on motor 1's status word 2.
    c.set_mdef(140, bits(XySpace::Y, 0x0814, 0, 1, MFormat::U))
        .unwrap();
    c.set_mdef(145, bits(XySpace::Y, 0x0814, 10, 1, MFormat::U))
        .unwrap();
    c.motors[0].in_position = true;
    assert_eq!(c.read_m(140), Ok(1.0));
    c.write_m(145, 1.0).unwrap();
    assert!(c.motors[0].home_complete);
    // P1 through L:$1001.
    c.set_mdef(10, MDef::L(0x1001)).unwrap();
    c.vars.set_p(1, 25.0).unwrap();
    assert_eq!(c.read_m(10), Ok(25.0));
    c.write_m(10, -0.5).unwrap();
    assert_eq!(c.vars.p(1), Ok(-0.5));
}

#[test]
fn fresh_status_words() {
    let c = card();
    // Motor 1: activated, open loop (killed), integration mode.
    assert_eq!(c.motor_status_text(1), "850000000000");
    // Unused motor: open loop + integration mode (the CTRL-B example's 050000000000).
    assert_eq!(c.motor_status_text(2), "050000000000");
    assert_eq!(c.cs_status_text(1), "A80020020000");
    assert_eq!(c.global_status_text(), "000000000800");
    let t = CardState::new(Profile::Turbo);
    assert_eq!(t.cs_status_text(16), "A80020020000000000");
    assert_eq!(t.motor_status_text(32), "050000000000");
}

#[test]
fn seed_example_motor_word() {
    let mut c = card();
    let f = &mut c.motors[0];
    f.open_loop = false;
    f.desired_velocity_zero = true;
    f.coord = Some(1);
    f.amp_enabled = true;
    f.home_complete = true;
    f.in_position = true;
    assert_eq!(c.motor_status_text(1), "812000804401");
    assert_eq!(c.read(Space::X, 0x003D), 0x812000);
    assert_eq!(c.read(Space::Y, 0x0814), 0x804401);
    c.motors[1].coord = Some(8);
    assert_eq!(c.motor_status(2)[1], 0xF00000);
}

#[test]
fn motor_bits_one_by_one() {
    type Set = fn(&mut MotorFlags);
    let w1: [(Set, u32); 9] = [
        (|f| f.neg_limit = true, 22),
        (|f| f.pos_limit = true, 21),
        (|f| f.move_timer = true, 17),
        (|f| f.dwell = true, 15),
        (|f| f.data_block_error = true, 14),
        (|f| f.desired_velocity_zero = true, 13),
        (|f| f.abort_decel = true, 12),
        (|f| f.block_request = true, 11),
        (|f| f.home_search = true, 10),
    ];
    for (set, b) in w1 {
        let mut f = MotorFlags {
            open_loop: false,
            ..MotorFlags::default()
        };
        set(&mut f);
        assert_eq!(f.word1(Default::default()), 1 << b);
        let mut g = MotorFlags::default();
        g.set_word1(1 << b);
        g.open_loop = false;
        assert_eq!(g, f);
    }
    let w2: [(Set, u32); 12] = [
        (|f| f.amp_enabled = true, 14),
        (|f| f.stopped_on_limit = true, 11),
        (|f| f.home_complete = true, 10),
        (|f| f.phasing_error = true, 8),
        (|f| f.trigger_move = true, 7),
        (|f| f.integrated_fe = true, 6),
        (|f| f.i2t_fault = true, 5),
        (|f| f.backlash_dir = true, 4),
        (|f| f.amp_fault = true, 3),
        (|f| f.fatal_fe = true, 2),
        (|f| f.warning_fe = true, 1),
        (|f| f.in_position = true, 0),
    ];
    for (set, b) in w2 {
        let mut f = MotorFlags::default();
        set(&mut f);
        assert_eq!(f.word2(), 1 << b);
        let mut g = MotorFlags::default();
        g.set_word2(1 << b);
        assert_eq!(g, f);
    }
    // Desired-velocity-zero is shown only with the loop closed.
    let f = MotorFlags {
        desired_velocity_zero: true,
        ..MotorFlags::default()
    };
    assert_eq!(f.word1(Default::default()), 1 << 18);
}

#[test]
fn motor_setup_bits_follow_ivars() {
    let mut c = card();
    c.set_ivar(200, 1.0).unwrap();
    c.set_ivar(206, 1.0).unwrap();
    c.set_ivar(201, 1.0).unwrap();
    c.set_ivar(234, 0.0).unwrap();
    assert_eq!(
        c.motor_status(2)[0],
        (1 << 23) | (1 << 20) | (1 << 19) | (1 << 18)
    );
}

#[test]
fn cs_bits_and_modes() {
    let mut c = card();
    let f = &mut c.coords[0];
    f.move_by_time = true;
    f.single_step = true;
    f.mode = MoveMode::Pvt;
    assert_eq!(c.cs_status_text(1), "A8002A020012");
    for (mode, w) in [
        (MoveMode::Linear, 0),
        (MoveMode::Rapid, 2),
        (MoveMode::Circle1, 1),
        (MoveMode::Circle2, 3),
        (MoveMode::Pvt, 0x12),
        (MoveMode::Spline, 0x11),
    ] {
        let mut f = status::CsFlags {
            in_position: false,
            ..Default::default()
        };
        f.mode = mode;
        assert_eq!(f.word2(), w);
        let mut g = status::CsFlags::default();
        g.set_word2(w);
        assert_eq!(g.mode, mode);
    }
    let named = [23, 22, 21, 20, 19, 18, 17, 16, 14];
    for b in named {
        let mut g = status::CsFlags::default();
        g.set_word2(1 << b);
        assert_eq!(g.word2(), 1 << b, "bit {b}");
    }
    for b in 0..24 {
        let mut g = status::CsFlags::default();
        g.set_word1(1 << b);
        assert_eq!(g.word1(), 1 << b, "bit {b}");
    }
    c.write(Space::X, 0x08D8, 0x000001);
    assert!(c.coords[1].running);
}

#[test]
fn global_bits() {
    let mut c = card();
    c.global.ring_fault = true;
    c.global.macro_aux_error = true;
    assert_eq!(c.read(Space::X, 0x0003), 0x30);
    c.global.plc_open = true;
    assert_eq!(c.global_status()[1], 1 << 17);
    c.global.buffer_nearly_full = true;
    assert_eq!(c.global_status()[1], (1 << 17) | (1 << 11));
    c.global.plc_open = false;
    c.global.motion_buffer_open = true;
    c.global.rotary_open = true;
    c.global.buffer_nearly_full = false;
    assert_eq!(c.global_status()[1], (1 << 19) | (1 << 18) | (1 << 11));
    c.global.host_mode = true;
    c.global.from_cmd = true;
    c.global.binary_rotary = true;
    assert_eq!(c.global_status()[1] & 0x410040, 0x410040);
    c.write(Space::X, 0x0003, 0xA03000);
    assert_eq!(c.global_status()[0], 0x003000);
}

#[test]
fn reset_reloads_saved_and_loses_unsaved() {
    let mut c = card();
    c.set_ivar(130, 5000.0).unwrap();
    c.vars.set_p(3, 1.5).unwrap();
    c.set_mdef(1, MDef::D(0x2B)).unwrap();
    c.set_ivar(1004, 0.0).unwrap();
    c.set_ivar(1003, 32.0).unwrap();
    c.set_ivar(1000, 0xFFFF as f64).unwrap();
    c.password = "pw".into();
    c.memory.write(Space::Y, 0xC0A4, 7);
    let img = c.to_image(b"progs".to_vec());
    c.set_ivar(130, 1.0).unwrap();
    c.vars.set_p(3, 9.0).unwrap();
    let progs = c.reset(Some(&img)).unwrap();
    assert_eq!(progs, b"progs");
    assert_eq!(c.read_ivar(130), Ok(5000.0));
    assert_eq!(c.vars.p(3), Ok(1.5));
    assert_eq!(c.mdef(1), Ok(MDef::D(0x2B)));
    assert_eq!(c.read_ivar(1004), Ok(2.0));
    assert_eq!(c.read_ivar(1000), Ok(0x7FFF as f64));
    assert!(!c.password_matched);
    assert_eq!(c.node_command(1), [0; 4]);
    // No image: factory state.
    assert_eq!(c.reset(None).unwrap(), Vec::<u8>::new());
    assert_eq!(c.read_ivar(130), Ok(2000.0));
    assert_eq!(c.read_ivar(1005), Ok(4.0));
    let t = CardState::new(Profile::Turbo).to_image(Vec::new());
    assert!(matches!(c.reset(Some(&t)), Err(PersistError::Profile(_))));
}

#[test]
fn i58_forces_i3_at_reset() {
    let mut c = card();
    c.set_ivar(58, 1.0).unwrap();
    let img = c.to_image(Vec::new());
    c.reset(Some(&img)).unwrap();
    assert_eq!(c.read_ivar(3), Ok(0.0));
}

#[test]
fn factory_keeps_p_q_m_and_clears_password() {
    let mut c = card();
    c.set_ivar(130, 5000.0).unwrap();
    c.vars.set_p(1, 2.0).unwrap();
    c.vars.set_q(2, 1, 3.0).unwrap();
    c.set_mdef(7, MDef::L(0x082B)).unwrap();
    c.password = "x".into();
    c.password_matched = false;
    c.write(Space::Y, 0x0720, 0);
    c.factory();
    assert_eq!(c.read_ivar(130), Ok(2000.0));
    assert_eq!(c.vars.p(1), Ok(2.0));
    assert_eq!(c.vars.q(2, 1), Ok(3.0));
    assert_eq!(c.mdef(7), Ok(MDef::L(0x082B)));
    assert!(c.password.is_empty() && c.password_matched);
    assert_eq!(c.read(Space::Y, 0x0720), 0x28C0A0);
}

#[test]
fn ect_defaults() {
    let mut c = card();
    assert_eq!(c.read(Space::Y, 0x0720), 0x28C0A0);
    assert_eq!(c.read(Space::Y, 0x0721), 0xFFFFFF);
    assert_eq!(c.read(Space::Y, 0x072E), 0x28C0BC);
    assert_eq!(c.read(Space::Y, 0x0730), 0);
}

#[test]
fn long_words() {
    let mut c = card();
    c.write_long(0x0028, 3_072_000);
    assert_eq!(c.read_long(0x0028), 3_072_000);
    c.vars.set_p(0, 1.0).unwrap();
    assert_eq!(c.read_long(0x1000), 0x4000_0000_0801);
}

#[test]
fn turbo_answers() {
    let mut t = CardState::new(Profile::Turbo);
    assert_eq!(t.limits().cid, Some(602413));
    for n in 20..=23 {
        assert_eq!(t.ivar_text(n).unwrap(), "$0");
    }
    assert_eq!(t.ivar_text(68).unwrap(), "15");
    assert_eq!(t.ivar_text(124).unwrap(), "$40001");
    assert_eq!(t.ivar_text(8191).unwrap(), "$0", "an ECT word");
    assert_eq!(t.ivar_text(8000).unwrap(), "$2F8420");
    // The profile's address range: PMAC2 $FFFF, Turbo $7FFFF.
    let far = |a| bits(XySpace::X, a, 0, 1, MFormat::U);
    assert!(t.set_mdef(1, far(0x7_FFFF)).is_ok());
    assert!(t.set_mdef(1, far(0x8_0000)).is_err());
    assert!(card().set_mdef(1, far(0x1_0000)).is_err());
    assert!(card().set_mdef(1, far(0xFFFF)).is_ok());
    assert!(t.set_ivar(21, 5.0).is_err());
    t.vars.set_p(8000, 1.25).unwrap();
    assert_eq!(t.vars.p(8000), Ok(1.25));
    t.set_mdef(8191, MDef::SelfRef).unwrap();
}
