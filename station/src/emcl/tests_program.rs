//! Stand-alone programs: the examples of spec emcl.md §12 running to their documented
//! result, the interpreter's flags, subroutines, WAIT forms and errors, download mode.

use super::codec::{status, Instr, Reply, Request, FRAME_LEN};
use super::drive::Drive;
use super::program::AppState;
use super::spec::DriveSpec;

fn i(op: u8, typ: u8, motor: u8, value: i32) -> Instr {
    Instr::new(op, typ, motor, value)
}

fn frame(instr: Instr) -> [u8; FRAME_LEN] {
    Request { addr: 1, instr }.to_bytes()
}

/// Send an instruction in direct mode; (status, value).
fn direct(d: &mut Drive, instr: Instr) -> (u8, i32) {
    let r = d.handle_frame(&frame(instr)).unwrap().bytes.unwrap();
    let r = Reply::parse(&r).unwrap();
    (r.status, r.value)
}

/// Download `prog` at 0 over the bus (every store answered 101), leave download mode.
fn load(d: &mut Drive, prog: &[Instr]) {
    assert_eq!(direct(d, i(132, 0, 0, 0)).0, status::OK);
    for p in prog {
        assert_eq!(direct(d, *p), (status::STORED, p.value));
    }
    assert_eq!(direct(d, i(133, 0, 0, 0)).0, status::OK);
}

fn run_at(d: &mut Drive, addr: i32) {
    assert_eq!(direct(d, i(129, 1, 0, addr)), (status::OK, addr));
}

const ABS: u8 = 0;

#[test]
fn closed_loop_setup_example_runs_forever_between_0_and_512000() {
    // §12 [L1683-1738], addresses 0..=25.
    let prog = [
        i(5, 6, 0, 150),
        i(5, 7, 0, 8),
        i(5, 202, 0, 200),
        i(5, 210, 0, 10000),
        i(5, 108, 0, 300000),
        i(5, 109, 0, 600000),
        i(5, 110, 0, 255),
        i(5, 111, 0, 256),
        i(5, 113, 0, 80),
        i(5, 114, 0, 150),
        i(5, 129, 0, 1),
        i(5, 4, 0, 512000),
        i(5, 5, 0, 512000),
        i(5, 16, 0, 512000),
        i(5, 17, 0, 512000),
        i(6, 133, 0, 0), // 15 CInit: GAP 133
        i(21, 0, 0, 15), // 16 JC ZE, CInit (no COMP: Z from the accumulator load)
        i(5, 1, 0, 0),   // 17
        i(9, 0, 2, 0),   // 18 LOOP1: SGP 0,2,0
        i(4, ABS, 0, 512000),
        i(27, 1, 0, 0),
        i(27, 0, 0, 50),
        i(4, ABS, 0, 0),
        i(27, 1, 0, 0),
        i(27, 0, 0, 50),
        i(22, 0, 0, 18),
    ];
    let mut d = Drive::new(DriveSpec::default());
    load(&mut d, &prog);
    run_at(&mut d, 0);
    // The init loop spins until AP 133 = 1 (500 ms after SAP 129).
    d.run_ms(400);
    assert_eq!(d.get_ap(133), Ok(0));
    assert!(
        (15..=16).contains(&d.prog.pc),
        "still in CInit: pc {}",
        d.prog.pc
    );
    // 512000 µsteps at 512000 pps and pps²: a 2 s triangle each way, 0.5 s pauses.
    let mut reached = Vec::new();
    let mut back = Vec::new();
    let mut last = d.get_ap(1).unwrap();
    for t in 0..12_000u64 {
        d.tick_ms();
        let p = d.get_ap(1).unwrap();
        assert!((0..=512000).contains(&p), "position {p} out of the stroke");
        if p == 512000 && last != 512000 {
            reached.push(t);
        }
        if p == 0 && last != 0 {
            back.push(t);
        }
        last = p;
    }
    assert!(reached.len() >= 2, "reached 512000 at {reached:?}");
    assert!(back.len() >= 2, "came back to 0 at {back:?}");
    let cycle = reached[1] - reached[0];
    // Two moves of ~2 s and two WAIT TICKS of 0.5 s (plus a few instruction ticks).
    assert!((4990..=5030).contains(&cycle), "cycle {cycle} ms");
    assert_eq!(d.get_ap(133), Ok(1));
    assert_eq!(d.prog.state, AppState::Run);
    // Encoder: 10000 lines per 51200 µsteps.
    d.run_ms(1);
    let p = i64::from(d.get_ap(1).unwrap());
    let e = i64::from(d.get_ap(209).unwrap());
    assert!(
        (e - p * 10000 / 51200).abs() <= 1,
        "encoder {e} vs position {p}"
    );
}

#[test]
fn jump_table_routines_func1_and_func3() {
    let mut d = Drive::new(DriveSpec::default());
    super::tests_vectors::download_session(&mut d);
    // Func1 (entry 0): to 1000 and back, STOP at 7.
    run_at(&mut d, 0);
    let mut max = 0;
    for _ in 0..5000 {
        d.tick_ms();
        max = max.max(d.get_ap(1).unwrap());
    }
    assert_eq!(max, 1000, "went exactly to 1000");
    assert_eq!(d.get_ap(1), Ok(0));
    assert_eq!(d.get_ap(8), Ok(1));
    assert_eq!(direct(&mut d, i(135, 0, 0, 0)).1, 0);
    assert_eq!(direct(&mut d, i(10, 130, 0, 0)).1, 7);
    // Func3 (entry 2): ROR 1000 for 7 s, MST, STOP at 15.
    run_at(&mut d, 2);
    d.run_ms(3000);
    assert_eq!(d.get_ap(3), Ok(1000));
    d.run_ms(6000);
    assert_eq!(d.get_ap(3), Ok(0));
    assert_eq!(direct(&mut d, i(10, 130, 0, 0)).1, 15);
    let p = d.get_ap(1).unwrap();
    // ~7 s at 1000 pps plus the ramps (1000 pps reached in ~20 ms at 51200 pps²).
    assert!((6990..=7030).contains(&p), "position {p}");
}

#[test]
fn potentiometer_follower_moves_with_the_analog_input() {
    // [L1362-1371]: GIO 0,1 / CALC MUL,4 / AAP 0,0 / JA Start.
    let mut d = Drive::new(DriveSpec {
        analog: 1000,
        ..DriveSpec::default()
    });
    load(
        &mut d,
        &[
            i(15, 0, 1, 0),
            i(19, 2, 0, 4),
            i(34, 0, 0, 0),
            i(22, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    d.run_ms(3000);
    assert_eq!(d.get_ap(0), Ok(4000));
    assert_eq!(d.get_ap(1), Ok(4000));
    d.set_input("analog", 250).unwrap();
    d.run_ms(3000);
    assert_eq!(d.get_ap(1), Ok(1000));
    // Direct GAP while the program runs: answered, the loop undisturbed.
    assert_eq!(direct(&mut d, i(6, 1, 0, 0)), (status::OK, 1000));
    assert_eq!(d.prog.state, AppState::Run);
}

#[test]
fn main_loop_example_ping_pongs_with_the_slow_ramp() {
    // §8.2 [L1884-1926]: SAP 4 500, SAP 5 100, loop MVP 5000 / WAIT POS / MVP 0 / WAIT POS.
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(5, 4, 0, 500),
            i(5, 5, 0, 100),
            i(4, ABS, 0, 5000),
            i(27, 1, 0, 0),
            i(4, ABS, 0, 0),
            i(27, 1, 0, 0),
            i(22, 0, 0, 2),
        ],
    );
    run_at(&mut d, 0);
    // v reaches 500 after 5 s (1250 µsteps), cruises 2500 in 5 s, brakes 5 s: 15 s a move.
    let mut t_at = None;
    for t in 0..40_000u64 {
        d.tick_ms();
        if t_at.is_none() && d.get_ap(1) == Ok(5000) {
            t_at = Some(t);
        }
        assert!(d.get_ap(3).unwrap().abs() <= 500);
    }
    let t = t_at.expect("reached 5000");
    assert!((14_900..=15_100).contains(&t), "reached 5000 after {t} ms");
    assert_eq!(d.prog.state, AppState::Run);
}

#[test]
fn subroutines_nest_eight_deep_and_rsub_on_empty_is_ignored() {
    let mut d = Drive::new(DriveSpec::default());
    // [L1019-1031] completed: 0 MVP 10000, 1 CSUB 5, 2 MVP 0, 3 CSUB 5, 4 STOP,
    // 5 SubW: WAIT POS, 6 WAIT TICKS 50, 7 RSUB.
    load(
        &mut d,
        &[
            i(4, ABS, 0, 10000),
            i(23, 0, 0, 5),
            i(4, ABS, 0, 0),
            i(23, 0, 0, 5),
            i(28, 0, 0, 0),
            i(27, 1, 0, 0),
            i(27, 0, 0, 50),
            i(24, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    let mut max = 0;
    for _ in 0..10_000 {
        d.tick_ms();
        max = max.max(d.get_ap(1).unwrap());
    }
    assert_eq!(max, 10000);
    assert_eq!(d.get_ap(1), Ok(0));
    assert_eq!((d.prog.state, d.prog.pc), (AppState::Stop, 4));

    // Recursion: CSUB 0 at address 0 nests until the stack is full, then is ignored and the
    // program falls through to RSUB ×9 (the 9th on an empty stack is ignored) and STOP.
    let mut d = Drive::new(DriveSpec::default());
    let mut prog = vec![i(19, 0, 0, 1), i(23, 0, 0, 0)];
    prog.extend(std::iter::repeat_n(i(24, 0, 0, 0), 1));
    prog.push(i(28, 0, 0, 0));
    load(&mut d, &prog);
    direct(&mut d, i(19, 9, 0, 0));
    run_at(&mut d, 0);
    d.run_ms(200);
    // CALC ADD 1 ran once per call level: 1 (top) + 8 nested calls = 9; then each RSUB
    // returns to address 2 (RSUB again) until the stack is empty, then STOP.
    assert_eq!(d.prog.accu, 9);
    assert_eq!((d.prog.state, d.prog.pc), (AppState::Stop, 3));
    assert!(d.prog.stack.is_empty());
}

#[test]
fn comp_and_every_jc_condition() {
    // accu := A; COMP B; JC cond, 5; CALC LOAD 0 (not taken) ; STOP; 5: CALC LOAD 1; STOP.
    let cases: &[(i32, i32, u8, bool)] = &[
        (5, 5, 2, true),
        (5, 6, 2, false),
        (5, 6, 3, true),
        (7, 6, 4, true),
        (6, 6, 4, false),
        (6, 6, 5, true),
        (5, 6, 5, false),
        (-1, 0, 6, true),
        (0, -1, 6, false),
        (0, 0, 7, true),
        (1, 0, 7, false),
        (3, 3, 0, true),  // ZE after COMP: equal
        (3, 4, 1, true),  // NZ
        (3, 4, 9, false), // type > 8: false
    ];
    for &(a, b, cond, taken) in cases {
        let mut d = Drive::new(DriveSpec::default());
        load(
            &mut d,
            &[
                i(19, 9, 0, a),
                i(20, 0, 0, b),
                i(21, cond, 0, 5),
                i(19, 9, 0, 100),
                i(28, 0, 0, 0),
                i(19, 9, 0, 200),
                i(28, 0, 0, 0),
            ],
        );
        run_at(&mut d, 0);
        d.run_ms(20);
        let want = if taken { 200 } else { 100 };
        assert_eq!(d.prog.accu, want, "accu {a} COMP {b} JC {cond}");
    }
}

#[test]
fn wait_timeouts_set_eto_and_cle_clears_it() {
    let mut d = Drive::new(DriveSpec::default());
    // ROR 100 (never reaches a target); WAIT POS with a 3-tick timeout; JC ETO 4; STOP;
    // 4: CLE ETO; JC ETO 7; CALC LOAD 42; 7: STOP.
    load(
        &mut d,
        &[
            i(1, 0, 0, 100),
            i(27, 1, 0, 3),
            i(21, 8, 0, 4),
            i(28, 0, 0, 0),
            i(36, 1, 0, 0),
            i(21, 8, 0, 7),
            i(19, 9, 0, 42),
            i(28, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    d.run_ms(25);
    assert_eq!(
        (d.prog.pc, d.prog.flags.eto),
        (1, false),
        "3 ticks = 30 ms not over"
    );
    d.run_ms(15);
    assert!(d.prog.flags.eto || d.prog.pc > 3);
    d.run_ms(100);
    assert_eq!(d.prog.accu, 42);
    assert!(!d.prog.flags.eto);
    assert_eq!((d.prog.state, d.prog.pc), (AppState::Stop, 7));
}

#[test]
fn wait_ticks_takes_ten_ms_per_tick() {
    let mut d = Drive::new(DriveSpec::default());
    load(&mut d, &[i(27, 0, 0, 50), i(28, 0, 0, 0)]);
    run_at(&mut d, 0);
    d.run_ms(500);
    assert_eq!(d.prog.state, AppState::Run, "still waiting after 500 ms");
    d.run_ms(2);
    assert_eq!((d.prog.state, d.prog.pc), (AppState::Stop, 1));
}

#[test]
fn calc_and_calcx_arithmetic() {
    let mut d = Drive::new(DriveSpec::default());
    let mut calc = |typ, v| {
        direct(&mut d, i(19, typ, 0, v));
    };
    calc(9, 100);
    calc(0, 5); // 105
    calc(1, 10); // 95
    calc(2, -3); // -285
    calc(3, 7); // -40 (toward zero)
    calc(4, 7); // -5
    calc(3, 0); // x/0: unchanged
    calc(4, 0);
    calc(5, 0xFF); // -5 & 0xFF = 0xFB
    calc(6, 0x100); // 0x1FB
    calc(7, 1); // 0x1FA
    calc(8, 0); // !0x1FA
    assert_eq!(d.prog.accu, !0x1FA);
    direct(&mut d, i(19, 9, 0, i32::MAX));
    direct(&mut d, i(19, 0, 0, 1));
    assert_eq!(d.prog.accu, i32::MIN, "wrapping");
    direct(&mut d, i(19, 9, 0, i32::MIN));
    direct(&mut d, i(19, 3, 0, -1));
    assert_eq!(d.prog.accu, i32::MIN, "MIN / -1 leaves the accumulator");
    // CALCX: LOAD X := accu, SWAP, arithmetic with X, NOT X.
    direct(&mut d, i(19, 9, 0, 6));
    direct(&mut d, i(33, 9, 0, 0)); // X = 6
    direct(&mut d, i(19, 9, 0, 20));
    direct(&mut d, i(33, 1, 0, 0)); // 14
    assert_eq!(d.prog.accu, 14);
    direct(&mut d, i(33, 2, 0, 0)); // 84
    direct(&mut d, i(33, 3, 0, 0)); // 14
    direct(&mut d, i(33, 4, 0, 0)); // 2
    assert_eq!(d.prog.accu, 2);
    direct(&mut d, i(33, 10, 0, 0)); // swap: accu 6, X 2
    assert_eq!((d.prog.accu, d.prog.x), (6, 2));
    direct(&mut d, i(33, 8, 0, 0));
    assert_eq!(d.prog.x, !2);
    assert_eq!(direct(&mut d, i(33, 11, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(19, 10, 0, 0)).0, status::WRONG_TYPE);
}

#[test]
fn variables_example_with_agp() {
    // §8.4 [L1974-1984] with erratum E10: SGP 42,2,1234; GGP 42,2; CALC MUL 2; AGP 42,2.
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(9, 42, 2, 1234),
            i(10, 42, 2, 0),
            i(19, 2, 0, 2),
            i(35, 42, 2, 0),
            i(28, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    d.run_ms(10);
    assert_eq!(direct(&mut d, i(10, 42, 2, 0)), (status::OK, 2468));
}

#[test]
fn host_and_program_talk_through_user_variables() {
    // The program waits for var 3 = 1 (polling), then writes 77 into var 4 and stops.
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(10, 3, 2, 0),
            i(20, 0, 0, 1),
            i(21, 3, 0, 0),
            i(19, 9, 0, 77),
            i(35, 4, 2, 0),
            i(28, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    d.run_ms(100);
    assert_eq!(d.prog.state, AppState::Run);
    assert_eq!(direct(&mut d, i(10, 4, 2, 0)).1, 0);
    assert_eq!(direct(&mut d, i(9, 3, 2, 1)).0, status::OK);
    d.run_ms(20);
    assert_eq!(direct(&mut d, i(10, 4, 2, 0)).1, 77);
    assert_eq!(d.prog.state, AppState::Stop);
}

#[test]
fn errors_inside_a_program_are_no_ops() {
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(5, 3, 0, 5),     // SAP 3: read-only
            i(5, 6, 0, 999),   // out of range
            i(99, 0, 0, 0),    // unknown instruction
            i(28, 0, 0, 0),    // (slot 3: replaced by a host-control instruction below)
            i(22, 0, 0, 5000), // jump outside memory
            i(9, 66, 7, 1),    // bank 7
            i(19, 9, 0, 9),    // reached: accu 9
            i(28, 0, 0, 0),
        ],
    );
    // A download cannot store 128..137 (they execute); an image could hold one.
    d.eeprom.set_slot(3, i(129, 1, 0, 0));
    run_at(&mut d, 0);
    d.run_ms(20);
    assert_eq!(
        (d.prog.accu, d.prog.state, d.prog.pc),
        (9, AppState::Stop, 7)
    );
    assert_eq!(d.get_ap(6), Ok(128), "AP 6 untouched");
    assert_eq!(d.address(), 1);
}

#[test]
fn stop_step_reset_continue_and_status() {
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(19, 0, 0, 1),
            i(19, 0, 0, 1),
            i(19, 0, 0, 1),
            i(22, 0, 0, 0),
        ],
    );
    direct(&mut d, i(19, 9, 0, 0));
    // Step: one instruction per 130.
    assert_eq!(direct(&mut d, i(130, 0, 0, 0)).0, status::OK);
    d.run_ms(5);
    assert_eq!((d.prog.accu, d.prog.pc), (1, 1));
    assert_eq!(direct(&mut d, i(135, 0, 0, 0)).1, 2);
    direct(&mut d, i(130, 0, 0, 0));
    d.run_ms(5);
    assert_eq!((d.prog.accu, d.prog.pc), (2, 2));
    // Continue (129 type 0) from the PC, then stop (128): the PC stays.
    direct(&mut d, i(129, 0, 0, 0));
    assert_eq!(direct(&mut d, i(135, 0, 0, 0)).1, 1);
    d.run_ms(7);
    direct(&mut d, i(128, 0, 0, 0));
    let (accu, pc) = (d.prog.accu, d.prog.pc);
    d.run_ms(10);
    assert_eq!((d.prog.accu, d.prog.pc), (accu, pc));
    assert_eq!(direct(&mut d, i(135, 0, 0, 0)).1, 0);
    assert_eq!(direct(&mut d, i(10, 128, 0, 0)).1, 0, "GP 128 = 135");
    // Reset: PC 0, status 3.
    direct(&mut d, i(131, 0, 0, 0));
    assert_eq!(direct(&mut d, i(135, 0, 0, 0)).1, 3);
    assert_eq!(direct(&mut d, i(10, 130, 0, 0)).1, 0);
    assert_eq!(direct(&mut d, i(129, 2, 0, 0)).0, status::WRONG_TYPE);
    assert_eq!(direct(&mut d, i(129, 1, 0, 2048)).0, status::INVALID_VALUE);
}

#[test]
fn download_mode_rules() {
    let mut d = Drive::new(DriveSpec::default());
    assert_eq!(direct(&mut d, i(10, 129, 0, 0)).1, 0);
    assert_eq!(direct(&mut d, i(132, 0, 0, 2046)).0, status::OK);
    assert_eq!(
        direct(&mut d, i(10, 129, 0, 0)).1,
        0,
        "GGP is stored, not run"
    );
    assert_eq!(d.eeprom().slot(2046), i(10, 129, 0, 0));
    assert_eq!(direct(&mut d, i(1, 0, 0, 5)), (status::STORED, 5));
    // Slot 2048 does not exist: status 4, nothing stored.
    assert_eq!(direct(&mut d, i(1, 0, 0, 6)), (status::INVALID_VALUE, 0));
    // Host-control instructions still execute.
    assert_eq!(direct(&mut d, i(135, 0, 0, 0)), (status::OK, 0));
    assert_eq!(direct(&mut d, i(133, 0, 0, 0)).0, status::OK);
    assert_eq!(d.get_ap(3), Ok(0), "stored ROR did not run");
    assert_eq!(direct(&mut d, i(132, 0, 0, 2048)).0, status::INVALID_VALUE);
    assert_eq!(direct(&mut d, i(132, 0, 0, -1)).0, status::INVALID_VALUE);
    // 134 reads memory: type<<24 | motor<<16 | value & 0xFFFF.
    assert_eq!(
        direct(&mut d, i(134, 0, 0, 2046)),
        (status::OK, (129u32 << 24) as i32)
    );
    assert_eq!(direct(&mut d, i(134, 0, 0, 2047)), (status::OK, 5));
    // Code protection: 1 refuses 134, 2 refuses 132; 1 → 0 erases the program.
    assert_eq!(direct(&mut d, i(9, 81, 0, 3)).0, status::OK);
    assert_eq!(direct(&mut d, i(134, 0, 0, 0)).0, status::NOT_AVAILABLE);
    assert_eq!(direct(&mut d, i(132, 0, 0, 0)).0, status::NOT_AVAILABLE);
    assert_eq!(d.eeprom().program.len(), 2048);
    assert_eq!(direct(&mut d, i(9, 81, 0, 0)).0, status::OK);
    assert!(
        d.eeprom().program.is_empty(),
        "protection off: program erased"
    );
}

#[test]
fn autostart_runs_the_stored_program_at_power_up() {
    let mut d = Drive::new(DriveSpec::default());
    load(&mut d, &[i(1, 0, 0, 2000), i(28, 0, 0, 0)]);
    assert_eq!(direct(&mut d, i(9, 77, 0, 1)).0, status::OK);
    let image = d.eeprom().encode();
    let mut d2 = Drive::power_up(DriveSpec::default(), Some(&image), None);
    assert_eq!(d2.prog.state, AppState::Run);
    d2.run_ms(500);
    assert_eq!(d2.get_ap(3), Ok(2000));
}

#[test]
fn wait_for_switches_and_the_reference_search() {
    // WAIT REFSW: the home window at 5000..6000 is reached while rotating.
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(1, 0, 0, 20000),
            i(27, 2, 0, 0),
            i(3, 0, 0, 0),
            i(28, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    let mut t = 0;
    while d.prog.state == AppState::Run && t < 5000 {
        d.tick_ms();
        t += 1;
    }
    assert_eq!(d.prog.pc, 3);
    let p = d.get_ap(1).unwrap();
    assert!(
        (5000..8000).contains(&p),
        "stopped after the home switch: {p}"
    );
    // WAIT LIMSW with a timeout: no switch within 5 ticks → ETO.
    let mut d = Drive::new(DriveSpec {
        right_limit: Some(1500),
        ..DriveSpec::default()
    });
    load(
        &mut d,
        &[
            i(27, 3, 0, 5),
            i(21, 8, 0, 4),
            i(28, 0, 0, 0),
            i(28, 0, 0, 0),
            i(1, 0, 0, 20000),
            i(27, 3, 0, 0),
            i(28, 0, 0, 0),
        ],
    );
    run_at(&mut d, 0);
    d.run_ms(3000);
    assert!(d.prog.flags.eto);
    assert_eq!((d.prog.pc, d.prog.state), (6, AppState::Stop));
    assert_eq!(d.get_ap(10), Ok(1), "stopped on the right limit");
    // WAIT RFS: the search finishes, then the program goes on.
    let mut d = Drive::new(DriveSpec::default());
    load(
        &mut d,
        &[
            i(13, 0, 0, 0),
            i(27, 4, 0, 0),
            i(19, 9, 0, 1),
            i(28, 0, 0, 0),
        ],
    );
    direct(&mut d, i(5, 1, 0, 123));
    run_at(&mut d, 0);
    d.run_ms(100);
    assert_eq!(d.prog.pc, 1, "waiting for the search");
    d.run_ms(20_000);
    assert_eq!((d.prog.accu, d.prog.state), (1, AppState::Stop));
    assert_eq!(d.get_ap(1), Ok(0));
}
