//! Kinematic subroutines (seed §2.12, L37469-37610): `open forward|inverse`, `#n->I` motors
//! moved by the inverse routine every servo cycle, the forward routine at a program start.

use super::tests_programs::T;

/// Inverse: L1 = 2000·X, L2 = 1000·(X + Y); forward: its inverse.
const KIN: [&str; 9] = [
    "open inverse (1)",
    "L1 = C6 * 2000",
    "L2 = (C7 + C6) * 1000",
    "close",
    "&1",
    "open forward",
    "C6 = L1 / 2000",
    "C7 = L2 / 1000 - C6",
    "close",
];

fn pos(t: &mut T, m: u16) -> f64 {
    let r = t.send(&format!("#{m}p"));
    r.trim().parse().unwrap_or_else(|_| panic!("#{m}p: {r:?}"))
}

/// Power motors 1 and 2 closed loop, both `#n->I` in C.S. 1, with the routines above.
fn kin_card() -> T {
    let mut t = T::new();
    let _ = t.card.model.state.set_ivar(70, 13_107.0);
    let _ = t.card.model.state.set_ivar(71, 13_107.0);
    t.load(&KIN);
    t.load(&[
        "Motor[1].ServoCtrl=1",
        "Motor[2].ServoCtrl=1",
        "&1 #1->I #2->I",
    ]);
    t.run(5);
    assert_eq!(t.send("#1j/ #2j/"), "");
    t.run(20);
    t
}

#[test]
fn inverse_kinematics_moves_the_motors_along_the_transformed_path() {
    let mut t = kin_card();
    t.load(&["open prog 6", "linear abs X1 Y2 tm400", "close"]);
    assert_eq!(t.send("&1 b6 r"), "");
    // Mid-move every cycle is transformed: L2/L1 = 1000·3s / 2000·s = 1.5 all along.
    t.run(250);
    let (a, b) = (pos(&mut t, 1), pos(&mut t, 2));
    assert!(a > 200.0 && a < 1800.0, "{a}");
    assert!((b / a - 1.5).abs() < 0.05, "{a} {b}");
    t.run(2000);
    // Tolerance: the loopback plant's settling (the commanded positions are exact).
    let (a, b) = (pos(&mut t, 1), pos(&mut t, 2));
    assert!((a - 2000.0).abs() < 1.0, "{a}");
    assert!((b - 3000.0).abs() < 1.0, "{b}");
    // The move's target position (where `j=` returns): the end point transformed.
    let target = |t: &T, m: usize| t.servo.motors[m].prejog;
    assert!((target(&t, 1) - 2000.0).abs() < 1e-9 && (target(&t, 2) - 3000.0).abs() < 1e-9);
}

#[test]
fn forward_kinematics_gives_the_start_position_of_a_program() {
    let mut t = kin_card();
    // Motors jogged to L1 = 4000, L2 = 5000: forward gives X = 2, Y = 3.
    assert_eq!(t.send("#1j=4000 #2j=5000"), "");
    t.run(3000);
    t.load(&["open prog 7", "linear inc X1 tm300", "close"]);
    assert_eq!(t.send("&1 b7 r"), "");
    t.run(2000);
    // X = 3, Y = 3: L1 = 6000, L2 = 6000.
    let (a, b) = (pos(&mut t, 1), pos(&mut t, 2));
    assert!((a - 6000.0).abs() < 1.0, "{a}");
    assert!((b - 6000.0).abs() < 1.0, "{b}");
}

#[test]
fn a_runaway_or_failing_inverse_routine_stops_the_cs_with_a_run_time_error() {
    for body in ["while (1 > 0) { L3 = L3 + 1 }", "L1 = L(C6 + 9000)"] {
        let mut t = kin_card();
        t.load(&["open inverse (1)", body, "close"]);
        t.load(&["open prog 6", "linear abs X1 Y2 tm400", "close"]);
        assert_eq!(t.send("&1 b6 r"), "");
        t.run(100);
        let f = &t.card.model.state.coords[1];
        assert!(f.runtime_error && !f.running, "{body}");
        eprintln!(
            "ES {}",
            t.send("Coord[1].ErrorStatus Coord[1].RunTimeError")
        );
        // The motors stay where they were.
        assert!(pos(&mut t, 1).abs() < 1.0, "{body}");
    }
}

/// `Coord[x].Ldata.GoBack` (10): a loop may jump back 11 times in one call, not 12.
#[test]
fn an_iterating_routine_may_jump_back_go_back_plus_one_times() {
    for (n, ok) in [(11, true), (12, false)] {
        let mut t = kin_card();
        t.load(&[
            "open inverse (1)",
            "L1 = 0 L2 = 0",
            &format!("while (L2 < {n}) {{ L2 = L2 + 1 L1 = L1 + C6 * 2000 / {n} }}"),
            "L2 = (C7 + C6) * 1000",
            "close",
        ]);
        t.load(&["open prog 6", "linear abs X1 Y2 tm400", "close"]);
        assert_eq!(t.send("&1 b6 r"), "");
        t.run(2500);
        assert_eq!(t.card.model.state.coords[1].runtime_error, !ok, "{n}");
        if ok {
            assert!((pos(&mut t, 1) - 2000.0).abs() < 1.0);
        }
    }
}

#[test]
fn bad_kinematic_buffers_and_definitions_are_refused() {
    let mut t = T::new();
    assert!(t.send("open forward (128)").contains("error #21:"));
    assert!(t.send("open inverse (x)").contains("error #21:"));
    // A bad line erases the open routine, an unbalanced one is refused at `close`.
    assert_eq!(t.send("open inverse (2)"), "");
    assert!(t.send("L1 = ").contains("error #20:"));
    assert_eq!(t.send("open inverse (2)"), "");
    assert_eq!(t.send("if (C6 > 0) {"), "");
    assert!(t.send("close").contains("error #20:"));
    // `#n->I` for a motor of another C.S.
    assert_eq!(t.send("&2 #3->I"), "");
    assert!(t.send("&1 #3->I").contains("error #"));
    assert_eq!(t.send("&2 #3->"), "#3->I\r\n");
    assert_eq!(t.send("&1 #3->"), "&2#3->I\r\n");
}

#[test]
fn kinematic_routines_list_and_survive_a_save_and_load() {
    let mut t = kin_card();
    assert_eq!(
        t.send("list inverse (1)"),
        "L1 = C6 * 2000\r\nL2 = (C7 + C6) * 1000\r\n"
    );
    // `list forward` alone: the addressed C.S. (1 since `&1`).
    assert_eq!(
        t.send("list forward"),
        "C6 = L1 / 2000\r\nC7 = L2 / 1000 - C6\r\n"
    );
    assert!(t.send("list forward (5)").contains("error #21:"));
    let saved = super::saved::export(&t.card.model);
    assert!(saved.iter().any(|s| s.kind == "inverse" && s.n == 1));
    super::saved::restore(&mut t.card.model, Vec::new());
    assert!(t.send("list inverse (1)").contains("error #21:"));
    super::saved::restore(&mut t.card.model, saved);
    assert_eq!(
        t.send("list inverse 1"),
        "L1 = C6 * 2000\r\nL2 = (C7 + C6) * 1000\r\n"
    );
    // The rebuilt routine runs.
    t.load(&["open prog 6", "linear abs X1 Y2 tm400", "close"]);
    assert_eq!(t.send("&1 b6 r"), "");
    t.run(2500);
    assert!((pos(&mut t, 2) - 3000.0).abs() < 1.0);
}

/// On-line `pmatch`: the program position of the C.S. from the forward routine.
#[test]
fn pmatch_runs_the_forward_routine() {
    let mut t = kin_card();
    assert_eq!(t.send("#1j=4000 #2j=5000"), "");
    t.run(3000);
    assert_eq!(t.send("&1 pmatch"), "");
    t.run(2);
    let c = t.servo.engine.coord(2).and_then(|x| x.cs.as_ref()).unwrap();
    let p = c.program_position();
    assert!(
        (p[0] - 2.0).abs() < 1e-3 && (p[1] - 3.0).abs() < 1e-3,
        "{p:?}"
    );
}

/// A forward routine that never ends stops the program at its start.
#[test]
fn a_runaway_forward_routine_stops_the_program_at_its_start() {
    let mut t = kin_card();
    t.load(&["open forward (1)", "while (1 > 0) { C6 = C6 + 1 }", "close"]);
    t.load(&["open prog 6", "linear abs X1 Y2 tm400", "close"]);
    assert_eq!(t.send("&1 b6 r"), "");
    t.run(50);
    let f = &t.card.model.state.coords[1];
    assert!(f.runtime_error && !f.running);
    assert!(pos(&mut t, 1).abs() < 1.0 && pos(&mut t, 2).abs() < 1.0);
}

/// Seed L33955-33967: `&x p|d|f|v` of a C.S. with `#n->I` motors report the axes the forward
/// routine computes from the motors' positions; `No Solution` when it cannot.
#[test]
fn axis_reports_go_through_the_forward_routine() {
    let mut t = kin_card();
    assert_eq!(t.send("#1j=4000 #2j=5000"), "");
    t.run(3000);
    // X = L1/2000 = 2, Y = L2/1000 - X = 3.
    assert_eq!(t.send("&1p"), "X2 Y3\r\n");
    assert_eq!(t.send("&1d"), "X2 Y3\r\n");
    // At rest: velocities and following errors within the plant's 0.1-count noise.
    for q in ["&1v", "&1f"] {
        let r = t.send(q);
        let parts: Vec<&str> = r.trim_end().split(' ').collect();
        assert_eq!(parts.len(), 2, "{q}: {r}");
        assert!(
            parts[0].starts_with('X') && parts[1].starts_with('Y'),
            "{q}: {r}"
        );
        for p in parts {
            let v: f64 = p[1..].parse().unwrap();
            assert!(v.abs() < 1e-3, "{q}: {r}");
        }
    }
    // With `KinAxisUsed` (D0) the routine names its axes: only X.
    t.load(&[
        "&1",
        "open forward",
        "C6 = L1 / 2000",
        "C7 = L2 / 1000 - C6",
        "D0 = 64",
        "close",
    ]);
    assert_eq!(t.send("&1p"), "X2\r\n");
    // A routine that fails: No Solution (and the line goes on).
    t.load(&[
        "&1",
        "open forward",
        "C6 = L1 / 2000",
        "C7 = sqrt(-1) + P(1/0)",
        "close",
    ]);
    let r = t.send("&1p P1");
    assert!(r.starts_with("No Solution\r\n"), "{r}");
    // No forward routine at all.
    t.load(&["&1", "open forward", "close"]);
    assert_eq!(t.send("&1p"), "No Solution\r\n");
    // Text that looks like anything in a line's output is only text (a NUL from a `cmd`
    // escape, echoed in an error).
    for text in [
        &b"cx cmd\"\\0K\\0\""[..],
        b"cx cmd\"\\0K1p\\0\"",
        b"cx cmd\"\\0K65535p\\0\"",
    ] {
        let r = t.raw(text);
        assert!(r.ends_with(b"\x06\r\n"), "{r:?}");
    }
    t.load(&["P1=1"]);
}
