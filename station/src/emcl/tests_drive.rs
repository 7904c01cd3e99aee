//! The drive in direct mode: parameters and their EEPROM copies, the lock, factory reset,
//! addresses, motion in the 1 kHz integer model (exact per ms), switches, reference search,
//! stall, POS_ERROR, heartbeat, I/O, coordinates, closed loop, MACRO-node binding.

use mcc_ring::packet::NodeRegs;

use super::codec::{status, Instr, Reply, Request, FRAME_LEN};
use super::drive::{Dirty, Drive, EepromLoad};
use super::io::InputError;
use super::spec::DriveSpec;

fn i(op: u8, typ: u8, motor: u8, value: i32) -> Instr {
    Instr::new(op, typ, motor, value)
}

fn send_to(d: &mut Drive, addr: u8, instr: Instr) -> Option<Reply> {
    let f = Request { addr, instr }.to_bytes();
    d.handle_frame(&f)
        .map(|a| Reply::parse(&a.bytes.expect("reply")).expect("checksum"))
}

fn direct(d: &mut Drive, instr: Instr) -> (u8, i32) {
    let r = send_to(d, 1, instr).expect("addressed");
    (r.status, r.value)
}

fn drive() -> Drive {
    Drive::new(DriveSpec::default())
}

#[test]
fn axis_parameters_ranges_access_and_unknown_numbers() {
    let mut d = drive();
    assert_eq!(direct(&mut d, i(5, 6, 0, 176)), (status::OK, 176));
    assert_eq!(direct(&mut d, i(6, 6, 0, 0)), (status::OK, 176));
    assert_eq!(direct(&mut d, i(5, 6, 0, 256)).0, status::INVALID_VALUE);
    assert_eq!(
        direct(&mut d, i(5, 6, 1, 10)).0,
        status::INVALID_VALUE,
        "motor 1"
    );
    assert_eq!(direct(&mut d, i(6, 6, 1, 0)).0, status::INVALID_VALUE);
    assert_eq!(
        direct(&mut d, i(5, 3, 0, 10)).0,
        status::WRONG_TYPE,
        "AP 3 (D16)"
    );
    assert_eq!(
        direct(&mut d, i(5, 180, 0, 1)).0,
        status::WRONG_TYPE,
        "AP 180 (D16)"
    );
    assert_eq!(direct(&mut d, i(5, 8, 0, 1)).0, status::WRONG_TYPE);
    for n in [9u8, 14, 130, 135, 140, 153, 154, 194, 204, 251] {
        assert_eq!(
            direct(&mut d, i(6, n, 0, 0)).0,
            status::WRONG_TYPE,
            "GAP {n}"
        );
        assert_eq!(
            direct(&mut d, i(5, n, 0, 0)).0,
            status::WRONG_TYPE,
            "SAP {n}"
        );
    }
    assert_eq!(direct(&mut d, i(5, 12, 0, 2)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(5, 12, 0, 3)).0, status::OK);
    assert_eq!(direct(&mut d, i(5, 167, 0, 1)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(5, 174, 0, -64)).0, status::OK);
    assert_eq!(direct(&mut d, i(6, 174, 0, 0)).1, -64);
    assert_eq!(direct(&mut d, i(5, 202, 0, 0)).0, status::INVALID_VALUE);
    // Nothing of the refused writes landed.
    assert_eq!(direct(&mut d, i(6, 6, 0, 0)).1, 176);
    assert_eq!(direct(&mut d, i(6, 12, 0, 0)).1, 3);
}

#[test]
fn store_restore_and_power_up_from_the_eeprom_image() {
    let mut d = drive();
    direct(&mut d, i(5, 4, 0, 12345));
    assert_eq!(d.take_dirty(), Dirty::Clean, "SAP is RAM only");
    assert_eq!(direct(&mut d, i(7, 4, 0, 0)).0, status::OK);
    assert_eq!(d.take_dirty(), Dirty::Now);
    direct(&mut d, i(5, 4, 0, 1));
    assert_eq!(direct(&mut d, i(8, 4, 0, 0)).0, status::OK);
    assert_eq!(direct(&mut d, i(6, 4, 0, 0)).1, 12345, "RSAP restored");
    direct(&mut d, i(5, 5, 0, 777));
    // User variables: 0..55 have an EEPROM copy, 56.. do not.
    direct(&mut d, i(9, 7, 2, -42));
    assert_eq!(direct(&mut d, i(11, 7, 2, 0)).0, status::OK);
    direct(&mut d, i(9, 60, 2, 5));
    assert_eq!(direct(&mut d, i(11, 60, 2, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(11, 128, 0, 0)).0, status::WRONG_TYPE);
    direct(&mut d, i(9, 7, 2, 1));
    assert_eq!(direct(&mut d, i(12, 7, 2, 0)).0, status::OK);
    assert_eq!(direct(&mut d, i(10, 7, 2, 0)).1, -42);
    // SGP on a bank-0 E parameter is stored at once.
    assert_eq!(direct(&mut d, i(9, 75, 0, 15)).0, status::OK);
    let image = d.eeprom().encode();
    let mut d2 = Drive::power_up(DriveSpec::default(), Some(&image), None);
    assert_eq!(*d2.eeprom_load(), EepromLoad::Loaded);
    assert_eq!(direct(&mut d2, i(6, 4, 0, 0)).1, 12345);
    assert_eq!(
        direct(&mut d2, i(6, 5, 0, 0)).1,
        51200,
        "AP 5 was never stored"
    );
    assert_eq!(direct(&mut d2, i(10, 7, 2, 0)).1, -42);
    assert_eq!(direct(&mut d2, i(10, 60, 2, 0)).1, 0);
    assert_eq!(direct(&mut d2, i(10, 75, 0, 0)).1, 15);
    // The telegram pause rides along with every reply.
    let f = Request {
        addr: 1,
        instr: i(6, 1, 0, 0),
    }
    .to_bytes();
    assert_eq!(d2.handle_frame(&f).unwrap().pause_ms, 15);
}

#[test]
fn eeprom_lock_refuses_every_eeprom_write_and_keeps_the_stored_data() {
    let mut d = drive();
    direct(&mut d, i(5, 4, 0, 999));
    direct(&mut d, i(7, 4, 0, 0));
    assert_eq!(direct(&mut d, i(9, 73, 0, 1234)).0, status::OK);
    assert_eq!(direct(&mut d, i(10, 73, 0, 0)).1, 1);
    let before = d.eeprom().clone();
    assert_eq!(before.global(73), Some(1), "the lock itself is stored");
    direct(&mut d, i(5, 4, 0, 5));
    assert_eq!(direct(&mut d, i(7, 4, 0, 0)).0, status::EEPROM_LOCKED);
    assert_eq!(direct(&mut d, i(11, 0, 2, 0)).0, status::EEPROM_LOCKED);
    assert_eq!(direct(&mut d, i(9, 66, 0, 9)).0, status::EEPROM_LOCKED);
    assert_eq!(direct(&mut d, i(30, 0, 255, 0)).0, status::EEPROM_LOCKED);
    assert_eq!(d.address(), 1);
    assert_eq!(*d.eeprom(), before, "nothing stored changed");
    // RAM writes still work; the value 1 is not a lock code.
    assert_eq!(direct(&mut d, i(9, 73, 0, 1)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(9, 73, 0, 4321)).0, status::OK);
    assert_eq!(direct(&mut d, i(10, 73, 0, 0)).1, 0);
    assert_eq!(direct(&mut d, i(7, 4, 0, 0)).0, status::OK);
}

#[test]
fn factory_reset_sends_no_reply_and_keeps_the_program() {
    let mut d = drive();
    direct(&mut d, i(9, 66, 0, 5));
    let f = Request {
        addr: 5,
        instr: i(5, 4, 0, 42),
    }
    .to_bytes();
    assert!(d.handle_frame(&f).is_some());
    let f = Request {
        addr: 5,
        instr: i(7, 4, 0, 0),
    }
    .to_bytes();
    d.handle_frame(&f);
    d.eeprom.set_slot(0, i(28, 0, 0, 0));
    // A wrong value is refused with a reply.
    let bad = Request {
        addr: 5,
        instr: i(137, 0, 0, 1),
    }
    .to_bytes();
    let r = Reply::parse(&d.handle_frame(&bad).unwrap().bytes.unwrap()).unwrap();
    assert_eq!(r.status, status::INVALID_VALUE);
    let reset = Request {
        addr: 5,
        instr: i(137, 0, 0, 1234),
    }
    .to_bytes();
    let a = d.handle_frame(&reset).expect("addressed");
    assert_eq!(a.bytes, None, "no reply (seed L1496)");
    assert_eq!(d.address(), 1, "back to the factory address");
    assert_eq!(direct(&mut d, i(6, 4, 0, 0)).1, 51200);
    assert_eq!(d.eeprom().program.len(), 1, "the program is not a setting");
    assert_eq!(d.take_dirty(), Dirty::Now);
}

#[test]
fn addresses_primary_secondary_and_silence() {
    let mut d = drive();
    assert!(
        send_to(&mut d, 2, i(6, 1, 0, 0)).is_none(),
        "other address: silent"
    );
    let bad = [2u8, 1, 0, 0, 0, 0, 0, 0, 0];
    assert!(
        d.handle_frame(&bad).is_none(),
        "bad checksum elsewhere: silent"
    );
    // SGP 66: the reply already carries the new address.
    let r = send_to(&mut d, 1, i(9, 66, 0, 3)).unwrap();
    assert_eq!((r.module, r.status), (3, status::OK));
    assert!(send_to(&mut d, 1, i(6, 1, 0, 0)).is_none());
    direct_at(&mut d, 3, i(9, 87, 0, 9));
    let r = send_to(&mut d, 9, i(10, 66, 0, 0)).unwrap();
    assert_eq!(
        (r.module, r.value),
        (3, 3),
        "secondary address: reply with GP 66"
    );
    // GP 76: the host address of replies.
    direct_at(&mut d, 3, i(9, 76, 0, 7));
    assert_eq!(send_to(&mut d, 3, i(6, 1, 0, 0)).unwrap().host, 7);
}

fn direct_at(d: &mut Drive, addr: u8, instr: Instr) {
    assert_eq!(send_to(d, addr, instr).unwrap().status, status::OK);
}

#[test]
fn instruction_and_type_errors() {
    let mut d = drive();
    for op in [
        0u8, 16, 17, 18, 25, 26, 29, 37, 38, 40, 64, 66, 71, 72, 127, 138, 139, 157, 255,
    ] {
        assert_eq!(
            direct(&mut d, i(op, 0, 0, 0)).0,
            status::INVALID_INSTRUCTION,
            "op {op}"
        );
    }
    for op in [20u8, 21, 22, 23, 24, 27, 28, 36] {
        assert_eq!(
            direct(&mut d, i(op, 0, 0, 0)).0,
            status::NOT_AVAILABLE,
            "op {op}"
        );
    }
    assert_eq!(
        direct(&mut d, i(1, 0, 0, 16_777_217)).0,
        status::INVALID_VALUE
    );
    assert_eq!(
        direct(&mut d, i(2, 0, 0, -16_777_217)).0,
        status::INVALID_VALUE
    );
    assert_eq!(direct(&mut d, i(1, 0, 0, 16_777_216)).0, status::OK);
    assert_eq!(
        direct(&mut d, i(6, 2, 0, 0)).1,
        16_777_216,
        "E4: stored in AP 2"
    );
    assert_eq!(direct(&mut d, i(4, 2, 0, 21)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(13, 3, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(
        direct(&mut d, i(9, 0, 1, 0)).0,
        status::WRONG_TYPE,
        "bank 1"
    );
    assert_eq!(
        direct(&mut d, i(10, 0, 3, 0)).0,
        status::WRONG_TYPE,
        "bank 3"
    );
    assert_eq!(
        direct(&mut d, i(10, 0, 4, 0)).0,
        status::INVALID_VALUE,
        "bank 4"
    );
    assert_eq!(direct(&mut d, i(10, 67, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(
        direct(&mut d, i(9, 128, 0, 1)).0,
        status::WRONG_TYPE,
        "read-only GP"
    );
    assert_eq!(direct(&mut d, i(9, 65, 0, 12)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(65, 2, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(65, 0, 0, 2)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(136, 2, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(30, 21, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(30, 1, 7, 0)).0, status::INVALID_VALUE);
    assert_eq!(d.counters().errors, d.counters().frames - 2);
}

#[test]
fn positioning_is_exact_per_ms_tick() {
    // AP 4 = 1000 pps, AP 5 = 10000 pps²: 10 pps per ms up to 1000 pps in 100 ms
    // (50 µsteps), cruise, brake; every ms the position is v/1000 µsteps further.
    let mut d = drive();
    direct(&mut d, i(5, 4, 0, 1000));
    direct(&mut d, i(5, 5, 0, 10000));
    direct(&mut d, i(4, 0, 0, 2000));
    let mut pos = Vec::new();
    let mut vel = Vec::new();
    for _ in 0..2200 {
        d.tick_ms();
        pos.push(d.get_ap(1).unwrap());
        vel.push(d.get_ap(3).unwrap());
    }
    assert_eq!(vel[0], 10);
    assert_eq!(vel[99], 1000);
    assert_eq!(
        pos[99], 50,
        "sum of 10+20+…+1000 over 1000 = 50.5 → 50 whole µsteps"
    );
    assert!(vel.iter().all(|v| (0..=1000).contains(v)));
    // Monotonic, never past the target, and exactly on it at rest.
    assert!(pos.windows(2).all(|w| w[1] >= w[0]));
    assert!(pos.iter().all(|p| *p <= 2000));
    let done = pos.iter().position(|p| *p == 2000).unwrap();
    assert!((2090..=2105).contains(&done), "arrived after {done} ms");
    assert_eq!(d.get_ap(8), Ok(1));
    assert_eq!(d.get_ap(3), Ok(0));
    // Deterministic: a second drive gives the same trajectory, ms for ms.
    let mut d2 = drive();
    direct(&mut d2, i(5, 4, 0, 1000));
    direct(&mut d2, i(5, 5, 0, 10000));
    direct(&mut d2, i(4, 0, 0, 2000));
    for p in &pos {
        d2.tick_ms();
        assert_eq!(d2.get_ap(1).unwrap(), *p);
    }
}

#[test]
fn relative_moves_reference_and_the_wrap_rule() {
    let mut d = drive();
    direct(&mut d, i(4, 0, 0, 1000));
    d.run_ms(2000);
    direct(&mut d, i(4, 1, 0, -300));
    d.run_ms(2000);
    assert_eq!(d.get_ap(1), Ok(700));
    // AP 127 = 1: relative to the actual position (here equal); 2: to the encoder.
    direct(&mut d, i(5, 209, 0, 0));
    direct(&mut d, i(5, 127, 0, 2));
    direct(&mut d, i(4, 1, 0, 100));
    assert_eq!(d.get_ap(0), Ok(100));
    d.run_ms(2000);
    // Wrap: from near i32::MAX to near i32::MIN is a short positive move.
    direct(&mut d, i(5, 1, 0, i32::MAX - 10));
    direct(&mut d, i(4, 0, 0, i32::MIN + 10));
    d.run_ms(5);
    assert!(d.get_ap(3).unwrap() > 0, "turned positive");
    d.run_ms(2000);
    assert_eq!(d.get_ap(1), Ok(i32::MIN + 10));
}

#[test]
fn rotate_stop_and_six_point_ramp() {
    let mut d = drive();
    direct(&mut d, i(2, 0, 0, 20000)); // ROL = ROR -v
    assert_eq!(direct(&mut d, i(6, 2, 0, 0)).1, -20000);
    d.run_ms(1000);
    assert_eq!(d.get_ap(3), Ok(-20000));
    direct(&mut d, i(3, 0, 0, 0));
    d.run_ms(391);
    assert_eq!(
        d.get_ap(3),
        Ok(0),
        "20000 pps at 51200 pps² stops in < 391 ms"
    );
    // Start velocity 1000 and a gentle first segment up to the break velocity 5000.
    direct(&mut d, i(5, 15, 0, 1000));
    direct(&mut d, i(5, 16, 0, 10000));
    direct(&mut d, i(5, 18, 0, 5000));
    direct(&mut d, i(1, 0, 0, 10000));
    d.tick_ms();
    assert_eq!(d.get_ap(3), Ok(1000), "jumps to the start velocity");
    d.run_ms(400);
    assert_eq!(d.get_ap(3), Ok(5000), "AP 16 below the break velocity");
    d.run_ms(98);
    assert_eq!(d.get_ap(3), Ok(10000), "AP 5 above it");
}

#[test]
fn limit_switches_stop_the_motor_and_report_their_state() {
    let spec = DriveSpec {
        right_limit: Some(3000),
        left_limit: Some(-3000),
        ..DriveSpec::default()
    };
    let mut d = Drive::new(spec.clone());
    direct(&mut d, i(1, 0, 0, 5000));
    d.run_ms(3000);
    let p = d.get_ap(1).unwrap();
    assert!((3000..3100).contains(&p), "hard stop at the switch: {p}");
    assert_eq!(d.get_ap(3), Ok(0));
    assert_eq!((d.get_ap(10), d.get_ap(11)), (Ok(1), Ok(0)));
    // Away from the switch works; into it does not.
    direct(&mut d, i(4, 0, 0, 0));
    d.run_ms(3000);
    assert_eq!(d.get_ap(1), Ok(0));
    assert_eq!(d.get_ap(10), Ok(0));
    // Disabled switch (AP 12 = 0): reported, not obeyed.
    direct(&mut d, i(5, 12, 0, 0));
    direct(&mut d, i(4, 0, 0, 4000));
    d.run_ms(3000);
    assert_eq!(d.get_ap(1), Ok(4000));
    // Pull-ups off: an open normally-open contact floats low and reads active.
    let mut d = Drive::new(spec);
    direct(&mut d, i(14, 0, 0, 0));
    assert_eq!(d.get_ap(11), Ok(1));
    assert_eq!(direct(&mut d, i(14, 1, 0, 0)).0, status::WRONG_TYPE);
    // With AP 21 the switch brakes on a linear ramp instead.
    let mut d = Drive::new(DriveSpec {
        right_limit: Some(3000),
        ..DriveSpec::default()
    });
    direct(&mut d, i(5, 21, 0, 100_000));
    direct(&mut d, i(1, 0, 0, 20000));
    d.run_ms(3000);
    let p = d.get_ap(1).unwrap();
    assert!(
        (3000..3000 + 2100).contains(&p),
        "braked past the switch: {p}"
    );
}

#[test]
fn virtual_stops() {
    let mut d = drive();
    direct(&mut d, i(5, 27, 0, 2000));
    direct(&mut d, i(5, 26, 0, -2000));
    direct(&mut d, i(5, 28, 0, 3));
    direct(&mut d, i(5, 29, 0, 1));
    direct(&mut d, i(1, 0, 0, 5000));
    d.run_ms(2000);
    let p = d.get_ap(1).unwrap();
    assert!((2000..2010).contains(&p), "hard virtual stop: {p}");
    direct(&mut d, i(2, 0, 0, 5000));
    d.run_ms(3000);
    let p = d.get_ap(1).unwrap();
    assert!((-2010..=-2000).contains(&p), "left virtual stop: {p}");
}

#[test]
fn reference_search_finds_the_index_and_zeroes_there() {
    let mut d = Drive::new(DriveSpec {
        index_offset: 10_000,
        ..DriveSpec::default()
    });
    direct(&mut d, i(5, 1, 0, 777));
    assert_eq!(direct(&mut d, i(13, 0, 0, 0)).0, status::OK);
    assert_eq!(direct(&mut d, i(13, 2, 0, 0)).1, 1, "running");
    d.run_ms(5000);
    assert_eq!(direct(&mut d, i(13, 2, 0, 0)).1, 0, "finished");
    assert_eq!((d.get_ap(1), d.get_ap(209)), (Ok(0), Ok(0)));
    assert_eq!(d.plant.shaft, 10_000, "at the index");
    assert_eq!(d.get_ap(8), Ok(1));
    // CCW search from there finds the index one revolution down; STOP aborts a search.
    direct(&mut d, i(5, 193, 0, 10));
    direct(&mut d, i(13, 0, 0, 0));
    d.run_ms(30);
    direct(&mut d, i(13, 1, 0, 0));
    d.run_ms(500);
    assert_eq!(direct(&mut d, i(13, 2, 0, 0)).1, 0);
    assert_eq!(d.get_ap(3), Ok(0));
}

#[test]
fn stall_detection_stops_at_a_hard_stop() {
    let spec = DriveSpec {
        hard_stop_plus: Some(10_000),
        ..DriveSpec::default()
    };
    // Without stall detection: the shaft stays at the stop, the counter runs on (lost steps).
    let mut d = Drive::new(spec.clone());
    direct(&mut d, i(1, 0, 0, 20000));
    d.run_ms(2000);
    assert_eq!(d.plant.shaft, 10_000);
    assert!(d.get_ap(1).unwrap() > 20_000);
    assert_eq!(d.get_ap(206), Ok(0));
    assert_eq!(d.get_ap(3), Ok(0), "actual velocity 0 at the stop");
    // AP 181: above 5000 pps a load of 0 stops the motor; AP 208 bit 0.
    let mut d = Drive::new(spec.clone());
    direct(&mut d, i(5, 181, 0, 5000));
    direct(&mut d, i(1, 0, 0, 20000));
    d.run_ms(2000);
    assert_eq!(direct(&mut d, i(6, 2, 0, 0)).1, 0);
    assert_eq!(d.get_ap(208).unwrap() & 1, 1);
    assert!(
        d.get_ap(1).unwrap() <= 10_000 + 20,
        "stopped within one ms of the stall"
    );
    // POS_ERROR: lost steps beyond AP 212 latch; motion commands are ignored until
    // RESET_IN; MST works; OUT_2 shows it.
    let mut d = Drive::new(spec);
    direct(&mut d, i(5, 212, 0, 1000));
    direct(&mut d, i(1, 0, 0, 20000));
    d.run_ms(2000);
    assert!(d.pos_error());
    assert_eq!(direct(&mut d, i(15, 2, 2, 0)).1, 1);
    assert_eq!(direct(&mut d, i(2, 0, 0, 1000)), (status::OK, 1000));
    d.run_ms(100);
    assert_eq!(d.get_ap(3), Ok(0), "ignored while POS_ERROR is latched");
    d.set_input("reset_in", 1).unwrap();
    d.set_input("reset_in", 0).unwrap();
    assert!(!d.pos_error());
    direct(&mut d, i(2, 0, 0, 1000));
    d.run_ms(100);
    assert_eq!(d.get_ap(3), Ok(-1000));
}

#[test]
fn serial_heartbeat_stops_a_forgotten_motor() {
    let mut d = drive();
    direct(&mut d, i(9, 68, 0, 200));
    direct(&mut d, i(1, 0, 0, 3000));
    d.run_ms(150);
    direct(&mut d, i(6, 1, 0, 0)); // any command feeds the heartbeat
    d.run_ms(150);
    assert_eq!(d.get_ap(3), Ok(3000));
    d.run_ms(300);
    assert_eq!(d.get_ap(3), Ok(0), "no command for 200 ms: stopped");
}

#[test]
fn digital_and_analog_io_with_dedicated_outputs() {
    let mut d = Drive::new(DriveSpec {
        inputs: [true, false, true],
        analog: 3210,
        ..DriveSpec::default()
    });
    assert_eq!(direct(&mut d, i(15, 0, 0, 0)).1, 1);
    assert_eq!(direct(&mut d, i(15, 1, 0, 0)).1, 0);
    assert_eq!(direct(&mut d, i(15, 2, 0, 0)).1, 1);
    assert_eq!(direct(&mut d, i(15, 0, 1, 0)).1, 3210);
    assert_eq!(direct(&mut d, i(15, 3, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(15, 1, 1, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(15, 0, 3, 0)).0, status::INVALID_VALUE);
    // GP 72 = 7: OUT_1 is POS_REACHED (at target at power-up), SIO has no effect there.
    assert_eq!(direct(&mut d, i(14, 1, 2, 0)).0, status::OK);
    assert_eq!(direct(&mut d, i(15, 1, 2, 0)).1, 1);
    direct(&mut d, i(4, 0, 0, 5000));
    d.tick_ms();
    assert_eq!(direct(&mut d, i(15, 1, 2, 0)).1, 0, "moving: not reached");
    // General-purpose outputs once GP 72 = 0.
    direct(&mut d, i(9, 72, 0, 0));
    assert_eq!(direct(&mut d, i(14, 2, 2, 1)), (status::OK, 1));
    assert_eq!(direct(&mut d, i(15, 2, 2, 0)).1, 1);
    assert_eq!(direct(&mut d, i(14, 2, 2, 2)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(14, 3, 2, 1)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(14, 0, 1, 1)).0, status::INVALID_VALUE);
    d.set_input("in1", 1).unwrap();
    assert_eq!(direct(&mut d, i(15, 1, 0, 0)).1, 1);
    assert_eq!(
        d.set_input("in3", 1),
        Err(InputError::Unknown("in3".into()))
    );
    assert_eq!(
        d.set_input("analog", 4096).unwrap_err().to_string(),
        "analog: 4096 is out of range 0-4095"
    );
    assert_eq!(
        d.set_input("in0", 2).unwrap_err().to_string(),
        "in0: 2 is not 0 or 1"
    );
    // Loopback plug: IN_k follows OUT_k.
    let mut d = Drive::new(DriveSpec {
        loopback: true,
        ..DriveSpec::default()
    });
    direct(&mut d, i(9, 72, 0, 0));
    direct(&mut d, i(14, 0, 2, 1));
    assert_eq!(direct(&mut d, i(15, 0, 0, 0)).1, 1);
    // ALARM_OUT (OUT_0 with GP 72 bit 0) on an injected driver error; the driver is off.
    direct(&mut d, i(9, 72, 0, 1));
    d.set_input("overtemp", 1).unwrap();
    assert_eq!(direct(&mut d, i(15, 0, 2, 0)).1, 1);
    assert_eq!(d.get_ap(208).unwrap() & 2, 2);
    assert!(!d.driver_on());
}

#[test]
fn drive_stage_power_and_enable_input() {
    let mut d = drive();
    assert_eq!(direct(&mut d, i(65, 0, 0, 0)).0, status::OK);
    assert_eq!(direct(&mut d, i(65, 1, 0, 0)).1, 0);
    direct(&mut d, i(1, 0, 0, 1000));
    d.run_ms(500);
    assert_eq!(d.plant.shaft, 0, "unpowered: the shaft does not turn");
    assert_eq!(d.get_ap(3), Ok(0));
    direct(&mut d, i(65, 0, 0, 1));
    direct(&mut d, i(9, 80, 0, 1)); // ENABLE_IN low-active; the line is high
    d.run_ms(100);
    assert!(!d.driver_on());
    d.set_input("enable_in", 0).unwrap();
    assert!(d.driver_on());
}

#[test]
fn coordinates_ram_eeprom_and_mvp_coord() {
    let mut d = drive();
    assert_eq!(direct(&mut d, i(30, 1, 0, 1000)).0, status::OK);
    assert_eq!(direct(&mut d, i(31, 1, 0, 0)).1, 1000);
    direct(&mut d, i(4, 2, 0, 1));
    d.run_ms(2000);
    assert_eq!(d.get_ap(1), Ok(1000));
    direct(&mut d, i(32, 3, 0, 0)); // CCO 3
    assert_eq!(direct(&mut d, i(31, 3, 0, 0)).1, 1000);
    direct(&mut d, i(19, 9, 0, -5));
    direct(&mut d, i(39, 4, 0, 0)); // ACO 4
    assert_eq!(direct(&mut d, i(31, 4, 0, 0)).1, -5);
    // RAM only until SCO n,255; GCO n,255 brings the EEPROM copy back.
    assert_eq!(direct(&mut d, i(30, 3, 255, 0)).0, status::OK);
    assert_eq!(d.take_dirty(), Dirty::Now);
    direct(&mut d, i(30, 3, 0, 7));
    assert_eq!(direct(&mut d, i(31, 3, 255, 0)).1, 1000);
    let img = d.eeprom().encode();
    let mut d2 = Drive::power_up(DriveSpec::default(), Some(&img), None);
    assert_eq!(
        direct(&mut d2, i(31, 3, 0, 0)).1,
        0,
        "GP 84 = 0: RAM only at power-up"
    );
    // GP 84 = 1: written through and loaded at power-up.
    direct(&mut d2, i(9, 84, 0, 1));
    direct(&mut d2, i(30, 5, 0, 55));
    let img = d2.eeprom().encode();
    let mut d3 = Drive::power_up(DriveSpec::default(), Some(&img), None);
    assert_eq!(direct(&mut d3, i(31, 5, 0, 0)).1, 55);
    assert_eq!(direct(&mut d3, i(31, 3, 0, 0)).1, 1000);
}

#[test]
fn closed_loop_defers_motion_until_initialised() {
    let mut d = drive();
    direct(&mut d, i(5, 129, 0, 1));
    assert_eq!(d.get_ap(133), Ok(0));
    direct(&mut d, i(1, 0, 0, 1000));
    d.run_ms(100);
    assert_eq!(d.get_ap(3), Ok(0), "deferred");
    d.run_ms(420);
    assert_eq!(d.get_ap(133), Ok(1));
    assert_eq!(d.get_ap(3), Ok(1000));
}

#[test]
fn corrupt_image_and_magic_give_factory_defaults_visibly() {
    let d = Drive::power_up(DriveSpec::default(), Some(b"garbage"), None);
    assert!(matches!(d.eeprom_load(), EepromLoad::Corrupt(_)));
    assert!(d.status("drive0", "station0").eeprom.starts_with("CORRUPT"));
    let mut d = drive();
    direct(&mut d, i(5, 4, 0, 1));
    direct(&mut d, i(7, 4, 0, 0));
    d.eeprom.set_slot(3, i(28, 0, 0, 0));
    assert_eq!(direct(&mut d, i(9, 64, 0, 0)).0, status::OK);
    let img = d.eeprom().encode();
    let mut d2 = Drive::power_up(DriveSpec::default(), Some(&img), None);
    assert_eq!(*d2.eeprom_load(), EepromLoad::MagicReset);
    assert_eq!(direct(&mut d2, i(6, 4, 0, 0)).1, 51200);
    assert_eq!(direct(&mut d2, i(10, 64, 0, 0)).1, 0xE4);
    assert_eq!(d2.eeprom().program.len(), 4, "program kept");
    assert_eq!(
        d2.take_dirty(),
        Dirty::Now,
        "the re-initialised image is written back"
    );
}

#[test]
fn tick_timer_random_and_version() {
    let mut d = drive();
    d.run_ms(25);
    assert_eq!(direct(&mut d, i(10, 132, 0, 0)).1, 25);
    direct(&mut d, i(9, 132, 0, -3));
    d.run_ms(5);
    assert_eq!(direct(&mut d, i(10, 132, 0, 0)).1, 2);
    direct(&mut d, i(9, 133, 0, 99));
    let a = direct(&mut d, i(10, 133, 0, 0)).1;
    let b = direct(&mut d, i(10, 133, 0, 0)).1;
    assert!(a >= 0 && b >= 0 && a != b);
    direct(&mut d, i(9, 133, 0, 99));
    assert_eq!(direct(&mut d, i(10, 133, 0, 0)).1, a, "seeded: repeatable");
}

#[test]
fn bound_drive_follows_its_node_and_refuses_direct_motion() {
    let mut spec = DriveSpec::default();
    spec.axis_defaults.insert(254, 1);
    spec.pulse_full_scale = 1_000_000;
    let mut d = Drive::power_up(spec, None, Some(4));
    assert!(d.is_bound());
    for m in [
        i(1, 0, 0, 1),
        i(2, 0, 0, 1),
        i(3, 0, 0, 0),
        i(4, 0, 0, 1),
        i(13, 0, 0, 0),
        i(5, 0, 0, 5),
        i(5, 2, 0, 5),
    ] {
        assert_eq!(direct(&mut d, m).0, status::NOT_AVAILABLE, "{m:?}");
    }
    assert_eq!(direct(&mut d, i(6, 1, 0, 0)), (status::OK, 0), "reads work");
    assert_eq!(
        direct(&mut d, i(5, 6, 0, 100)).0,
        status::OK,
        "settings work"
    );
    // r2 = 16384: half scale = 500000 pps; 1 ms = 500 µsteps, reported ×32 in register 0.
    let cmd = NodeRegs {
        r0: 0,
        r1: 0,
        r2: 16384,
        r3: 1 << 6,
    };
    let fb = d.bound_tick(cmd, 1_000_000, false);
    assert_eq!(fb.r0, 500 * 32);
    assert_ne!(fb.r3 & (1 << 6), 0, "amplifier enabled");
    assert_ne!(fb.r3 & (1 << 7), 0, "fault line high: healthy");
    assert_eq!(d.get_ap(3), Ok(500_000));
    // 442 733 ns at 2258.7 Hz: the remainder is carried exactly.
    let mut total = 500i64;
    for _ in 0..1000 {
        d.bound_tick(cmd, 442_733, false);
    }
    total += 500_000 * 442_733 * 1000 / 1_000_000_000;
    assert_eq!(d.plant.shaft, total);
    // No enable: no motion; ring fault: locked out until AENA drops.
    let off = NodeRegs { r3: 0, ..cmd };
    let s = d.plant.shaft;
    d.bound_tick(off, 1_000_000, false);
    assert_eq!(d.plant.shaft, s);
    d.bound_tick(cmd, 1_000_000, true);
    d.bound_tick(cmd, 1_000_000, false);
    assert_eq!(d.plant.shaft, s, "locked out after the ring fault");
    d.bound_tick(off, 1_000_000, false);
    d.bound_tick(cmd, 1_000_000, false);
    assert_eq!(d.plant.shaft, s + 500);
    // SAP 254,0,0 releases the motor to direct mode.
    assert_eq!(direct(&mut d, i(5, 254, 0, 0)).0, status::OK);
    assert!(!d.is_bound());
    assert_eq!(direct(&mut d, i(1, 0, 0, 100)).0, status::OK);
}

#[test]
fn every_frame_is_answered_or_silent_never_a_panic() {
    // A cheap exhaustive sweep: every instruction number with a spread of types, motors and
    // values, twice (direct and inside a download), on one drive.
    let mut d = drive();
    let values = [0, 1, -1, 255, 1234, 2047, 2048, i32::MAX, i32::MIN];
    for op in 0..=255u8 {
        if op == 137 {
            continue;
        }
        for typ in [
            0u8, 1, 2, 3, 8, 9, 10, 11, 20, 21, 64, 66, 73, 81, 129, 130, 254, 255,
        ] {
            for motor in [0u8, 1, 2, 3, 4, 255] {
                for v in values {
                    let f: [u8; FRAME_LEN] = Request {
                        addr: d.address(),
                        instr: i(op, typ, motor, v),
                    }
                    .to_bytes();
                    let _ = d.handle_frame(&f);
                    d.tick_ms();
                }
            }
        }
    }
    // Still answering normally.
    let a = d.address();
    let f = Request {
        addr: a,
        instr: i(136, 1, 0, 0),
    }
    .to_bytes();
    let r = Reply::parse(&d.handle_frame(&f).unwrap().bytes.unwrap()).unwrap();
    assert!(r.status == status::OK || r.status == status::STORED);
}
