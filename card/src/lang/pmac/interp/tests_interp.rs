//! Facade tests: byte-exact replies through `Card::command_line` / `Card::control_char`.

use super::*;
use crate::domain::{CsNum, MotorNum};
use crate::model::ActionKind;

fn card() -> (Card, Session) {
    let mut c = Card::new(Profile::Pmac2);
    let mut s = Session::default();
    assert_eq!(c.command_line(&mut s, b"I3=2 I6=1"), b"\x06");
    (c, s)
}

fn send(c: &mut Card, s: &mut Session, line: &str) -> Vec<u8> {
    c.command_line(s, line.as_bytes())
}

#[test]
fn seed_default_framing() {
    let mut c = Card::new(Profile::Pmac2);
    let mut s = Session::default();
    assert_eq!(send(&mut c, &mut s, "P1=25"), b"\n");
    assert_eq!(send(&mut c, &mut s, "P1"), b"\n25\r\n");
    assert_eq!(send(&mut c, &mut s, "UUU"), b"\x07\r\nERR003\r");
    assert_eq!(send(&mut c, &mut s, "i6=1 i3=2 ver"), b"1.17\r\x06");
}

#[test]
fn error_mid_line_keeps_earlier_effects() {
    let (mut c, mut s) = card();
    assert_eq!(send(&mut c, &mut s, "P2=7 P2 UUU P2=8"), b"7\r\x07ERR003\r");
    assert_eq!(send(&mut c, &mut s, "P2"), b"7\r\x06");
}

#[test]
fn non_ascii_is_err004_and_long_line_err003() {
    let (mut c, mut s) = card();
    assert_eq!(c.command_line(&mut s, b"P1=\xC31"), b"\x07ERR004\r");
    let long = vec![b' '; MAX_LINE + 1];
    assert_eq!(c.command_line(&mut s, &long), b"\x07ERR003\r");
}

#[test]
fn addressing_is_per_session() {
    let (mut c, mut s1) = card();
    let mut s2 = Session::default();
    assert_eq!(send(&mut c, &mut s1, "#3&2"), b"\x06");
    assert_eq!(send(&mut c, &mut s1, "# &"), b"3\r2\r\x06");
    assert_eq!(send(&mut c, &mut s2, "# &"), b"1\r1\r\x06");
    assert_eq!(send(&mut c, &mut s1, "#9"), b"\x07ERR003\r");
    assert_eq!(send(&mut c, &mut s1, "#0"), b"\x07ERR003\r");
}

#[test]
fn program_round_trip_and_open_rules() {
    let (mut c, mut s) = card();
    let mut other = Session::default();
    assert_eq!(send(&mut c, &mut s, "OPEN PROG 1 CLEAR"), b"\x06");
    assert_eq!(send(&mut c, &mut other, "OPEN PLC 2"), b"\x07ERR007\r");
    // The other connection's lines execute normally.
    assert_eq!(send(&mut c, &mut other, "P7=1 P7"), b"1\r\x06");
    assert_eq!(send(&mut c, &mut s, "LINEAR"), b"\x06");
    assert_eq!(send(&mut c, &mut s, "SIZE"), b"-34815\r\x06");
    assert_eq!(send(&mut c, &mut s, "CLOSE"), b"\x06");
    assert_eq!(send(&mut c, &mut s, "SIZE"), b"34814\r\x06");
    assert_eq!(send(&mut c, &mut s, "LINEAR"), b"\x07ERR005\r");
    assert_eq!(send(&mut c, &mut s, "LIST"), b"\x07ERR005\r");
}

#[test]
fn control_chars_report_without_ack() {
    let (mut c, mut s) = card();
    assert_eq!(c.control_char(&mut s, 0x07), b"000000000800\r");
    assert_eq!(c.control_char(&mut s, 0x10), b"0 0 0 0 0 0 0 0\r");
    assert_eq!(c.control_char(&mut s, 0x0B), b"");
    assert_eq!(send(&mut c, &mut s, "P5=3"), b"\x06");
    assert_eq!(c.control_char(&mut s, 0x19), b"P5=3");
    assert_eq!(send(&mut c, &mut s, "P5"), b"3\r\x06");
    assert_eq!(c.control_char(&mut s, 0x09), b"3\r\x06");
    assert_eq!(c.control_char(&mut s, 0x18), b"");
    assert_eq!(send(&mut c, &mut s, "I63=1"), b"\x06");
    assert_eq!(c.control_char(&mut s, 0x18), b"\x18");
}

#[test]
fn motion_commands_are_queued_as_actions() {
    let (mut c, mut s) = card();
    assert_eq!(send(&mut c, &mut s, "#2J+#3K"), b"\x06");
    let a = c.take_actions();
    assert_eq!(a.len(), 2);
    assert_eq!(a[0].motor.get(), 2);
    assert!(matches!(a[1].kind, ActionKind::Kill));
    assert!(c.take_actions().is_empty());
}

#[test]
fn run_refusals_in_order() {
    let (mut c, mut s) = card();
    assert_eq!(send(&mut c, &mut s, "&3 B1 R"), b"\x07ERR014\r");
    assert_eq!(send(&mut c, &mut s, "&1 #1->1000X"), b"\x06");
    // Motor 1 starts killed (open loop).
    assert_eq!(send(&mut c, &mut s, "R"), b"\x07ERR012\r");
    assert_eq!(send(&mut c, &mut s, "#1J/"), b"\x06");
    assert_eq!(send(&mut c, &mut s, "R"), b"\x07ERR015\r");
    assert_eq!(send(&mut c, &mut s, "#2->Y"), b"\x06");
    assert_eq!(send(&mut c, &mut s, "R"), b"\x07ERR013\r");
    assert_eq!(send(&mut c, &mut s, "#2->0 #1J+ R"), b"\x07ERR011\r");
    assert_eq!(
        send(&mut c, &mut s, "#1J/ OPEN PROG 1 CLEAR X10 CLOSE B1 R"),
        b"\x06"
    );
    assert_eq!(send(&mut c, &mut s, "#1J+"), b"\x07ERR001\r");
    assert_eq!(send(&mut c, &mut s, "A #1J/"), b"\x06");
}

#[test]
fn program_commands_are_never_acknowledged() {
    let mut c = Card::new(Profile::Pmac2);
    // Seed defaults I6=3: errors are <BELL>ERRnnn<CR>; data lines end in CR; no ack.
    assert_eq!(c.program_command(1, 1, b"P3=4"), b"");
    assert_eq!(c.program_command(1, 1, b"P3"), b"4\r");
    assert_eq!(c.program_command(1, 1, b"UUU"), b"\x07ERR003\r");
    // CTRL-Y now returns the program's line.
    let mut s = Session::default();
    assert_eq!(c.control_char(&mut s, 0x19), b"UUU");
    assert_eq!(c.command_line(&mut s, b"I64=1"), b"\n");
    assert_eq!(c.program_command(1, 1, b"P3"), b"\x024\r");
    assert_eq!(c.program_command(1, 1, b"UUU"), b"\x02ERR003\r");
    assert_eq!(c.command_line(&mut s, b"I64=0 I62=1 I6=2"), b"\n");
    assert_eq!(c.program_command(1, 1, b"P3"), b"4");
    assert_eq!(c.program_command(1, 1, b"UUU"), b"");
    // Program addressing: Q-variables of the given C.S.
    assert_eq!(c.program_command(1, 2, b"Q1=9"), b"");
    assert_eq!(c.command_line(&mut s, b"&2Q1"), b"\n9\r\n");
}

#[test]
fn action_queue_is_bounded() {
    let (mut c, mut s) = card();
    for _ in 0..(crate::model::MAX_ACTIONS / 2 + 10) {
        assert_eq!(send(&mut c, &mut s, "#1J/J/"), b"\x06");
    }
    assert_eq!(c.take_actions().len(), crate::model::MAX_ACTIONS);
}

#[test]
fn any_connection_can_close_a_buffer_left_open() {
    let (mut c, mut a) = card();
    let mut b = Session::default();
    assert_eq!(send(&mut c, &mut a, "OPEN PROG 9 CLEAR"), b"\x06");
    // Lines from another connection are not stored; its OPEN is refused.
    assert_eq!(send(&mut c, &mut b, "I130"), b"2000\r\x06");
    assert_eq!(send(&mut c, &mut b, "OPEN PROG 10"), b"\x07ERR007\r");
    assert_eq!(send(&mut c, &mut b, "CLOSE"), b"\x06");
    assert_eq!(send(&mut c, &mut b, "OPEN PROG 10 CLOSE"), b"\x06");
    // end_session closes what a connection left open.
    assert_eq!(send(&mut c, &mut a, "OPEN PLC 3"), b"\x06");
    c.end_session(&a);
    assert_eq!(send(&mut c, &mut b, "OPEN PLC 4 CLOSE"), b"\x06");
}

#[test]
fn out_of_range_session_addressing_is_clamped_not_a_panic() {
    let (mut c, _) = card();
    let mut s = Session {
        motor: MotorNum::of(0),
        coord: CsNum::of(0),
        ..Session::with_id(999)
    };
    assert_eq!(
        send(&mut c, &mut s, "# & ?? P"),
        b"1\r1\rA80020020000\r0\r\x06"
    );
    let mut s = Session {
        motor: MotorNum::of(200),
        coord: CsNum::of(200),
        ..Session::with_id(998)
    };
    assert_eq!(send(&mut c, &mut s, "# &"), b"8\r8\r\x06");
    assert_eq!(
        c.control_char(
            &mut Session {
                motor: MotorNum::of(0),
                coord: CsNum::of(0),
                ..Session::with_id(1)
            },
            0x10
        ),
        b"0 0 0 0 0 0 0 0\r"
    );
}
