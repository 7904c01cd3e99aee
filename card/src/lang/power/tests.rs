//! Transcripts of the Power dialect (seed 000 examples where the seed gives them).

use super::Power;
use crate::domain::Profile;
use crate::lang::Card;

struct T {
    card: Card,
    p: Power,
}

impl T {
    fn new() -> Self {
        T {
            card: Card::new(Profile::Power),
            p: Power::new(),
        }
    }

    /// The reply text of `line` on connection 1 without the final ACK line.
    fn send(&mut self, line: &str) -> String {
        self.send_on(1, line)
    }

    fn send_on(&mut self, conn: u64, line: &str) -> String {
        let r = self.p.line(&mut self.card, conn, line.as_bytes());
        let s = String::from_utf8(r).unwrap();
        assert!(s.ends_with("\x06\r\n"), "no ACK: {s:?}");
        s[..s.len() - 3].to_string()
    }
}

#[test]
fn variables_echo_and_ivar_aliases() {
    let mut t = T::new();
    assert_eq!(t.send("echo0"), "");
    assert_eq!(t.send("I1=4"), "");
    assert_eq!(t.send("I1"), "I1=4\r\n");
    assert_eq!(t.send("P1=3"), "");
    assert_eq!(t.send("I(P1*100+22)=3"), "");
    assert_eq!(t.send("I322"), "I322=3\r\n");
    assert_eq!(t.send("Motor[3].JogSpeed"), "Motor[3].JogSpeed=3\r\n");
    assert_eq!(t.send("I122->"), "I122->Motor[1].JogSpeed\r\n");
    assert_eq!(t.send("echo4"), "");
    assert_eq!(t.send("I122->"), "Motor[1].JogSpeed\r\n");
    assert_eq!(t.send("echo2"), "");
    assert_eq!(t.send("I1"), "4\r\n");
    assert_eq!(t.send("P0..2"), "0\r\n3\r\n0\r\n");
    assert_eq!(t.send("echo 1"), "");
    assert_eq!(
        t.send("Motor[1].JogSpeed=2001 Motor[1].JogSpeed"),
        "2001\r\n"
    );
    // echo is per thread
    assert_eq!(
        t.send_on(2, "Motor[1].JogSpeed"),
        "Motor[1].JogSpeed=2001\r\n"
    );
}

#[test]
fn power_arithmetic() {
    let mut t = T::new();
    for (e, want) in [
        ("-11 % 4", "-3"),
        ("11 % -4", "3"),
        ("0.875 & 1.75", "0.75"),
        ("3 & -3", "1"),
        ("int(-2.5)", "-3"),
        ("1/0", "inf"),
        ("5 % 0", "nan"),
        ("rem(-11, 4)", "1"),
        ("1 << 4", "16"),
        ("2 + 3 * 4", "14"),
    ] {
        assert_eq!(
            t.send(&format!("P5={e} P5")),
            format!("P5={want}\r\n"),
            "{e}"
        );
    }
}

#[test]
fn addressing_and_identity() {
    let mut t = T::new();
    assert_eq!(t.send("#"), "#0\r\n");
    assert_eq!(t.send("&"), "&0\r\n");
    assert_eq!(t.send("#3 &2 # &"), "#3\r\n&2\r\n");
    // a list applies to the next command only
    assert_eq!(
        t.send("#1,2? #"),
        "0000000000000000 0000000000000000\r\n#3\r\n"
    );
    assert_eq!(t.send("cid"), "604020\r\n");
    assert_eq!(t.send("type"), "PWR PMAC UMAC\r\n");
    // Seed L33720-33721 (`cpu`), L34183-34199 (`date`: "Mmm dd yyyy").
    assert_eq!(t.send("cpu"), "Power PC, 460EX\r\n");
    assert_eq!(t.send("date"), "Jan 30 2008\r\n");
    assert_eq!(t.send("?"), "00000000\r\n");
    assert_eq!(t.send("Sys.MaxMotors"), "Sys.MaxMotors=32\r\n");
    assert_eq!(t.send("Ldata.Motor"), "Ldata.Motor=3\r\n");
    assert_eq!(t.send("&1p"), "No Motors\r\n");
}

#[test]
fn errors_in_gpascii_form() {
    let mut t = T::new();
    assert_eq!(
        t.send("P1=1 gooble"),
        "stdin:1:6: error #20: ILLEGAL CMD: P1=1 gooble\r\n"
    );
    // the commands before the error still ran
    assert_eq!(t.send("P1"), "P1=1\r\n");
    assert_eq!(
        t.send("Motor[1].ActPos=3"),
        "stdin:3:1: error #23: READ ONLY: Motor[1].ActPos=3\r\n"
    );
    assert_eq!(
        t.send("Motor[99].JogSpeed"),
        "stdin:4:1: error #21: ILLEGAL PARAMETER: Motor[99].JogSpeed\r\n"
    );
    assert_eq!(
        t.send("Motor[1].NoSuch"),
        "stdin:5:1: error #21: ILLEGAL PARAMETER: Motor[1].NoSuch\r\n"
    );
    assert_eq!(
        t.send("P70000=1"),
        "stdin:6:1: error #21: ILLEGAL PARAMETER: P70000=1\r\n"
    );
    assert!(t.send("P0..100000").contains("error #22"));
    assert!(t.send("P0..8191").ends_with("P8191=0\r\n"));
    assert!(t.send(&"P".repeat(2000)).contains("error #20"));
    assert_eq!(t.send(""), "");
}

#[test]
fn jog_reaches_the_model_as_an_action() {
    let mut t = T::new();
    t.send("#1j+");
    let a = t.card.model.take_actions();
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!(a[0].motor.get(), 2, "Power motor 1 is model motor 2");
}

impl T {
    /// `n` servo cycles of the card's servo loop (no plant).
    fn ticks(&mut self, servo: &mut crate::servo::Servo, n: u64) {
        for k in 0..n {
            let (model, mut cmds) = self.card.split();
            servo.tick(model, &mut cmds, k);
        }
    }
}

#[test]
fn a_plc_runs_every_control_construct() {
    let mut t = T::new();
    let mut servo = crate::servo::Servo::new(&t.card.model);
    for l in [
        "open plc 1",
        "P10=0 P11=0 P12=0 P13=0",
        "while (P10 < 5) {",
        "  P10 += 1",
        "  if (P10 == 3) {",
        "    continue",
        "  } else {",
        "    P11 = P11 + P10",
        "  }",
        "}",
        "do {",
        "  P12++",
        "  if (P12 >= 4 && !(P12 > 4)) break",
        "} while (1)",
        "switch (P12) {",
        "  case 3: P13 = 30",
        "  case 4: P13 = 40",
        "  break",
        "  default: P13 = -1",
        "}",
        "P14 = -11 % 4",
        "disable plc 1",
        "close",
    ] {
        assert_eq!(t.send(l), "", "{l}");
    }
    assert_eq!(t.send("enable plc 1"), "");
    t.ticks(&mut servo, 200);
    assert_eq!(
        t.send("P10..14"),
        "P10=5\r\nP11=12\r\nP12=4\r\nP13=40\r\nP14=-3\r\n"
    );
}

#[test]
fn buffer_rules() {
    let mut t = T::new();
    // only one buffer open at a time, across threads
    assert_eq!(t.send("open prog 5"), "");
    assert!(t.send_on(2, "open prog 6").contains("error #21"));
    assert_eq!(t.send("X10"), "");
    // a bad line erases and closes the buffer
    assert!(t.send("gooble").contains("error #20"));
    assert!(t
        .card
        .model
        .bufs
        .program(crate::model::BufId::Prog(5))
        .is_none());
    // the next line is an on-line command again
    assert_eq!(t.send("P1=2 P1"), "P1=2\r\n");
    // open then close deletes; unbalanced braces are refused at close
    assert_eq!(t.send("open prog 7"), "");
    assert_eq!(t.send("close"), "");
    assert!(t
        .card
        .model
        .bufs
        .program(crate::model::BufId::Prog(7))
        .is_none());
    assert_eq!(t.send("open prog 8"), "");
    assert_eq!(t.send("if (P1 > 1) {"), "");
    assert!(t.send("close").contains("error #20"));
    assert!(t
        .card
        .model
        .bufs
        .program(crate::model::BufId::Prog(8))
        .is_none());
    // `system` is not offered
    assert_eq!(t.send("open plc 2"), "");
    assert!(t.send("system\"ls\"").contains("error #27"));
    // Seed L37746-37752: `open prog n[,[stack]][,labels]`; a stack offset and a label count
    // in range are taken.
    for ok in [
        "open prog 2001,,2048",
        "open prog 5,256,256",
        "open subprog 3,256",
        "open prog 1",
    ] {
        assert_eq!(t.send(ok), "", "{ok}");
        assert_eq!(t.send("X1"), "");
        assert_eq!(t.send("close"), "");
    }
    // Stack offsets 1..8191 (seed L37748-37752 `open prog 100,64`, `open prog 5,512,256`).
    for ok in [
        "open prog 100,64",
        "open prog 5,512,256",
        "open subprog 5,8191",
    ] {
        assert_eq!(t.send(ok), "", "{ok}");
        assert_eq!(t.send("close"), "");
    }
    assert!(t.send("open prog 100,8192").contains("error #21"));
    assert!(t.send("open prog 100,0").contains("error #21"));
    assert!(t.send("open prog 5,256,0").contains("error #21"));
    assert!(t.send("open prog 5,x").contains("error #20"));
    assert!(
        t.send("open prog 5, 256").is_empty(),
        "white space between the arguments"
    );
    assert_eq!(t.send("close"), "");
    assert!(t.send("open prog 5,1,2,3").contains("error #20"));
}

/// Seed §2.7 (L36521-36754, L33567-33602): `list prog|subprog|plc n` without, with a trailing
/// comma, with a count and with a start and count; line numbers count the listed lines from
/// 0 (not `N` labels); `buffer` names each stored buffer with its offset and size.
#[test]
fn list_and_buffer_read_programs_back() {
    let mut t = T::new();
    for l in [
        "open prog 25",
        "  linear abs   // mode",
        "N10: X10 Y20",
        "",
        "dwell 50",
        "if (P1 > 0) {",
        "X0 Y0",
        "}",
        "close",
        "open subprog 7",
        "P2=P2+1",
        "return",
        "close",
        "open plc 3",
        "P3++",
        "close",
    ] {
        assert_eq!(t.send(l), "", "{l}");
    }
    let all = "linear abs\r\nN10: X10 Y20\r\ndwell 50\r\nif (P1 > 0) {\r\nX0 Y0\r\n}\r\n";
    assert_eq!(t.send("list prog 25"), all);
    assert_eq!(
        t.send("list prog 25,"),
        "0:linear abs\r\n1:N10: X10 Y20\r\n2:dwell 50\r\n3:if (P1 > 0) {\r\n4:X0 Y0\r\n5:}\r\n"
    );
    assert_eq!(
        t.send("list prog 25, 2"),
        "0:linear abs\r\n1:N10: X10 Y20\r\n"
    );
    assert_eq!(
        t.send("list prog 25, 2, 2"),
        "2:dwell 50\r\n3:if (P1 > 0) {\r\n"
    );
    assert_eq!(t.send("LIST PROG25,4,99"), "4:X0 Y0\r\n5:}\r\n");
    assert_eq!(t.send("list subprog 7"), "P2=P2+1\r\nreturn\r\n");
    assert_eq!(t.send("list plc 3,"), "0:P3++\r\n");
    // Sizes are the listed text's bytes (each line with its terminator), offsets running.
    assert_eq!(
        t.send("buffer"),
        "Prog25 offset 0, size 55\r\nSubProg7 offset 55, size 15\r\nPlc3 offset 70, size 5\r\n"
    );
    // Reopening clears; a bad line erases the buffer; absent buffers are an error.
    assert_eq!(t.send("open prog 25"), "");
    assert_eq!(t.send("X5"), "");
    assert_eq!(t.send("close"), "");
    assert_eq!(t.send("list prog 25"), "X5\r\n");
    assert_eq!(t.send("open plc 3"), "");
    assert!(t.send("P3 P3 +").contains("error #20"));
    assert!(t
        .send("list plc 3")
        .contains("error #21: ILLEGAL PARAMETER"));
    assert!(t.send("list prog 99").contains("error #21"));
    assert!(t.send("list prog 1,2,3,4").contains("error #20"));
    // No forward routine for the addressed C.S. (kinematics: tests_kin).
    assert!(t.send("list forward").contains("error #21"));
    assert_eq!(
        t.send("buffer"),
        "Prog25 offset 0, size 3\r\nSubProg7 offset 3, size 15\r\n"
    );
}

/// Seed L16417-16424: `Motor[x].pDac = Gate3[0].MacroOutA[n][0].a` points a motor at a MACRO
/// node's command register; the pointer reads back as that element's `.a`, and the motor's
/// output then reaches the new node.
#[test]
fn motor_pointers_take_macro_register_addresses() {
    let mut t = T::new();
    assert_eq!(t.send("echo0"), "");
    assert_eq!(
        t.send("Motor[3].pDac=Gate3[0].MacroOutA[4][0].a Motor[3].pDac"),
        "Motor[3].pDac=Gate3[0].MacroOutA[4][0].a\r\n"
    );
    assert_eq!(
        t.send("Motor[3].pEnc=Gate3[0].MacroInA[5][0].a Motor[3].pEnc"),
        "Motor[3].pEnc=Gate3[0].MacroInA[5][0].a\r\n"
    );
    // The address is the model's register address (what the Turbo-numbered I-variable holds).
    let a = t.send("Gate3[0].MacroOutA[4][0].a");
    assert_eq!(a, "Gate3[0].MacroOutA[4][0].a=$78428\r\n");
    assert_eq!(
        t.send("I302"),
        "I302=$78428\r\n".replace("$78428", "492584")
    );
    // Arithmetic on an address, and other elements' addresses, are plain values.
    assert_eq!(t.send("P1=Gate3[0].MacroOutA[1][0].a P1"), "P1=492580\r\n");
    assert_eq!(
        t.send("Motor[3].pDac=$1234 Motor[3].pDac"),
        "Motor[3].pDac=$1234\r\n"
    );
    assert!(t
        .send("Motor[3].pDac=Gate3[0].MacroOutA[16][0].a")
        .contains("error #21"));
    // The motor's command now goes to node 4's register.
    assert_eq!(t.send("Motor[3].pDac=Gate3[0].MacroOutA[4][0].a"), "");
    let ix02 = t.card.model.state.peek_ivar(402).unwrap() as u32;
    let map = *t.card.model.state.map();
    assert_eq!(map.node_of(crate::model::Space::Y, ix02), Some((4, 0)));
}

/// `&1b1r` (begin and run glued on), `$$$` (no reply at all) and `save` (its ACK).
#[test]
fn begin_run_glued_and_reset_commands() {
    let mut t = T::new();
    assert!(!t.send("&1b1r").contains("error #20"));
    let lim = t.card.model.state.limits();
    let p = super::parse::parse_line(b"&1b1r", lim.motors, lim.coords);
    assert!(p.error.is_none(), "{p:?}");
    assert_eq!(p.items.len(), 3);
    let r = t.p.line(&mut t.card, 1, b"$$$");
    assert!(r.is_empty(), "{r:?}");
    assert_eq!(t.card.take_detached_effects().len(), 1);
    assert_eq!(t.send("save"), "");
    assert_eq!(t.card.take_detached_effects().len(), 1);
}
