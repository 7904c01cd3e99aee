//! The preprocessor on the card (seed 000): `#define` (L45436-45449), the kinematic names in
//! the seed's own forward/inverse routines (L45482-45530), PLC identifiers (L45550-45572).

use super::tests_programs::T;

fn pos(t: &mut T, m: u16) -> f64 {
    let r = t.send(&format!("#{m}p"));
    r.trim().parse().unwrap_or_else(|_| panic!("#{m}p: {r:?}"))
}

#[test]
fn the_seeds_kinematic_routines_run_with_their_names() {
    let mut t = T::new();
    let _ = t.card.model.state.set_ivar(70, 13_107.0);
    let _ = t.card.model.state.set_ivar(71, 13_107.0);
    // Seed L45500-45530 for motors 1 and 2 of C.S. 1 (`#1->1000X`, `#2->1000Y` equivalent).
    t.load(&[
        "open forward (1)",
        "if (KinVelEna) callsub 100;  // For double-pass calculations",
        "KinAxisUsed = KinEnaAxisX + KinEnaAxisY;  // X and Y computed",
        "N100:",
        "KinPosAxisX = KinPosMotor1 / 1000;",
        "KinPosAxisY = KinPosMotor2 / 1000;",
        "close",
        "open inverse (1)",
        "KinPosMotor1 = 1000 * KinPosAxisX;",
        "KinPosMotor2 = 1000 * KinPosAxisY;",
        "if (KinVelEna) {",
        "KinVelMotor1 = 1000 * KinVelAxisX;",
        "KinVelMotor2 = 1000 * KinVelAxisY;",
        "}",
        "close",
    ]);
    // Stored as the variables they stand for.
    let l = t.send("list inverse (1)");
    assert!(l.contains("L1 = 1000 * C6;"), "{l}");
    assert!(l.contains("R2 = 1000 * C39;"), "{l}");
    t.load(&[
        "Motor[1].ServoCtrl=1",
        "Motor[2].ServoCtrl=1",
        "&1 #1->I #2->I",
    ]);
    t.run(5);
    assert_eq!(t.send("#1j=2000 #2j=-1000"), "");
    t.run(3000);
    t.load(&["open prog 7", "linear inc X1 Y1 tm300", "close"]);
    assert_eq!(t.send("&1 b7 r"), "");
    t.run(2000);
    // Forward: X 2, Y -1 at the start; inverse: motors at 3000 / 0 at the end.
    assert!((pos(&mut t, 1) - 3000.0).abs() < 1.0);
    assert!(pos(&mut t, 2).abs() < 1.0);
}

#[test]
fn defines_and_plc_identifiers_reach_every_command() {
    let mut t = T::new();
    t.load(&[
        "#define Counter P100",
        "#define Bump(v, n) v = v + (n)",
        "open plc 1",
        "Bump(Counter, 2)",
        "close",
        // PLC 1 holds a program: the identifier takes buffer 2.
        "open plc Coolant_Control // Auto-assigned to next available buffer",
    ]);
    assert_eq!(t.send("P101=1"), "");
    assert_eq!(t.send("close"), "");
    assert_eq!(t.send("list plc 2"), "P101=1\r\n");
    assert_eq!(t.send("enable plc Coolant_Control"), "");
    assert_eq!(t.send("Plc[Coolant_Control].Active"), "Plc[2].Active=1\r\n");
    assert_eq!(t.send("enable plc 1"), "");
    t.run(3);
    assert_eq!(t.send("Counter"), "P100=6\r\n");
    // Saved with the buffers: after a restart the identifier names the same PLC.
    let mut u = super::tests_units::reloaded(&mut t);
    assert_eq!(u.send("list plc Coolant_Control"), "P101=1\r\n");
    assert_eq!(u.send("Counter"), "P100=6\r\n");
    // A bad directive is error 20; what was defined stays.
    let r = t.send("#define 9x 1");
    assert!(
        r.ends_with(": error #20: ILLEGAL CMD: #define 9x 1\r\n"),
        "{r}"
    );
    assert_eq!(t.send("Counter=0 Counter"), "P100=0\r\n");
    // `#undef`; `$$$***` forgets every definition.
    assert_eq!(t.send("#undef Counter"), "");
    assert!(t.send("Counter").contains("error #20"));
    assert_eq!(t.raw(b"$$$***"), b"", "no reply (seed §2.7)");
    assert!(t.send("enable plc Coolant_Control").contains("error"));
}
