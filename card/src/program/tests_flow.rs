//! Engine tests, continued: `/` and ERR017, PRELUDE, PC/PE, WAIT, I53, transformation
//! matrices, reset, SPLINE/RAPID/DELAY, PLC compound conditions.

use super::tests_engine::xy;

#[test]
fn stop_at_end_of_move_then_resume_needs_the_stop_point() {
    let mut r = xy();
    r.cmd("I13=10");
    r.prog("OPEN PROG 11 CLEAR\nLINEAR INC TA100 TS0 TM1000\nX10\nX10\nX10\nCLOSE");
    r.cmd("&1B11R");
    r.ticks(1000); // inside the first move (ends at 1050 ms ≈ 2372 cycles)
    r.cmd("&1/");
    r.run_out(10_000);
    let stop = r.pos(1);
    assert!(
        (stop - 10_000.0).abs() < 1e-6,
        "stopped at the end of move 1: {stop}"
    );
    // The motor reported away from the stop point: ERR017; back at it: accepted.
    r.card.set_motor_report(1, stop + 100.0, 0.0, 0.0);
    r.card.set_motor_report(2, 0.0, 0.0, 0.0);
    assert!(r.cmd("&1R").contains("ERR017"));
    r.card.set_motor_report(1, stop, 0.0, 0.0);
    assert_eq!(r.cmd("&1R"), "");
    r.run_out(20_000);
    assert!((r.pos(1) - 30_000.0).abs() < 1e-6, "{}", r.pos(1));
}

#[test]
fn prelude_calls_before_each_motion_line() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 50 CLEAR
         N1000 P70=P70+1 RETURN
         CLOSE
         OPEN PROG 12 CLEAR
         LINEAR INC TA10 TS0 TM10
         PRELUDE1 CALL50.01
         X1
         P71=1
         X1
         PRELUDE0
         X1
         CLOSE",
    );
    r.cmd("&1B12R");
    r.run_out(5000);
    assert_eq!(r.cmd("P70 P71"), "2 1");
    assert!((r.pos(1) - 3000.0).abs() < 1e-6);
}

#[test]
fn pc_runs_ahead_of_pe_and_shows_the_call_stack() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 13 CLEAR
         LINEAR INC TA100 TS0 TM1000
         X1
         X1
         GOSUB9
         X1
         RETURN
         N9 X1
         WAIT
         RETURN
         CLOSE",
    );
    r.cmd("&1B13R");
    r.ticks(10);
    let list = r.cmd("LIST PROG 13,");
    let second = list.split(' ').find(|w| w.ends_with(":X1")).unwrap();
    let off = second.trim_end_matches(":X1");
    let pc = r.cmd("&1PC");
    let pe = r.cmd("&1PE");
    assert_eq!(pe, format!("P13:{off}"), "executing the first X1 ({list})");
    assert_ne!(pc, pe, "calculation is ahead");
    assert!(pc.starts_with("P13:"), "{pc}");
}

#[test]
fn wait_loop_inside_a_subroutine_shows_in_pc_and_releases() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 14 CLEAR
         GOSUB9
         P81=1
         RETURN
         N9 WHILE (P80=0) WAIT
         RETURN
         CLOSE",
    );
    r.cmd("&1B14R");
    r.ticks(20);
    let pc = r.cmd("&1PC");
    assert!(
        pc.starts_with("P14:") && pc.contains(">P14:"),
        "call stack in PC: {pc}"
    );
    assert!(r.card.state.coords[0].running);
    assert_eq!(r.cmd("P81"), "0");
    r.cmd("P80=1");
    r.ticks(3);
    assert_eq!(r.cmd("P81"), "1");
    assert!(!r.card.state.coords[0].running);
}

#[test]
fn plc_compound_conditions_follow_the_spec_example() {
    let mut r = xy();
    r.prog(
        "OPEN PLC 5 CLEAR
         IF (P11=1)
         AND (P12=0)
         OR (P11=0)
         AND (P12=1)
         P1=P1+1
         ELSE
         P1=P1-1
         ENDIF
         CLOSE",
    );
    r.cmd("I5=2 ENABLE PLC 5");
    for (p11, p12, expect) in [(1, 0, "1"), (0, 1, "2"), (1, 1, "1"), (0, 0, "0")] {
        r.cmd(&format!("P11={p11} P12={p12}"));
        r.tick();
        assert_eq!(r.cmd("P1"), expect, "P11={p11} P12={p12}");
    }
}

#[test]
fn i53_steps_one_line_at_a_time() {
    let mut r = xy();
    r.prog("OPEN PROG 15 CLEAR\nP90=1\nP90=2 P91=1\nP90=3\nCLOSE");
    r.cmd("I53=1 &1B15");
    for expect in ["1 0", "2 1", "3 1"] {
        r.cmd("&1S");
        r.ticks(3);
        assert_eq!(r.cmd("P90 P91"), expect);
        assert!(!r.card.state.coords[0].running);
    }
}

#[test]
fn transformation_matrices_rename_and_rotate_programmed_positions() {
    let mut r = xy();
    assert_eq!(r.cmd("DEFINE TBUF 1"), "");
    // Q10..12 displacement (5,0,0); Q20..28 a 90° rotation about Z, row-major.
    r.cmd("&1Q10=5 Q11=0 Q12=0");
    r.cmd("&1Q20=0 Q21=-1 Q22=0 Q23=1 Q24=0 Q25=0 Q26=0 Q27=0 Q28=1");
    r.prog(
        "OPEN PROG 16 CLEAR
         LINEAR ABS TA10 TS0 TM100
         TSEL1 TINIT ADIS10 AROT20
         X1 Y0
         CLOSE",
    );
    r.cmd("&1B16R");
    r.run_out(5000);
    // programmed = R·base + D → base = Rᵀ·((1,0,0) − (5,0,0)) = (0, 4, 0).
    assert!(r.pos(1).abs() < 1e-6, "{}", r.pos(1));
    assert!((r.pos(2) - 4000.0).abs() < 1e-6, "{}", r.pos(2));
    // TSEL of a matrix that does not exist: run-time error.
    r.prog("OPEN PROG 17 CLEAR\nTSEL5\nCLOSE");
    r.cmd("&1B17R");
    r.ticks(3);
    assert!(r.card.state.coords[0].runtime_error);
}

#[test]
fn reset_drops_running_programs() {
    let mut r = xy();
    r.prog("OPEN PROG 18 CLEAR\nN1 P95=P95+1\nGOTO1\nCLOSE");
    r.cmd("&1B18R");
    r.ticks(2);
    assert_eq!(r.cmd("P95"), "4");
    r.cmd("$$$");
    r.cmd("P95=0");
    r.ticks(3);
    assert_eq!(r.cmd("P95"), "0");
    assert!(r.eng.coord(1).is_some_and(|c| !c.active));
}

#[test]
fn spline_rapid_and_delay_programs_end_on_their_points() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 19 CLEAR
         ABS SPLINE1 TA100
         X1
         X3
         X2
         RAPID X0 Y1
         LINEAR TA50 TS0 TM100 X1 DELAY200 X2
         CLOSE",
    );
    r.cmd("&1B19R");
    let mut max_x: f64 = 0.0;
    for _ in 0..20_000 {
        r.tick();
        max_x = max_x.max(r.pos(1));
        if !r.eng.coord(1).is_some_and(|c| c.busy()) {
            break;
        }
    }
    assert!(max_x > 2500.0, "the spline went towards X3: {max_x}");
    assert!((r.pos(1) - 2000.0).abs() < 1e-6, "{}", r.pos(1));
    assert!((r.pos(2) - 1000.0).abs() < 1e-6, "{}", r.pos(2));
    assert!(!r.card.state.coords[0].runtime_error);
}
