//! Servo-loop unit tests: a card, its servo loop and the loopback plant, no ring.

use super::rig::{bench_card, LoopbackPlant, NODES};
use crate::lang::{Card, Session};
use crate::servo::Servo;

fn run(card: &mut Card, servo: &mut Servo, plant: &mut LoopbackPlant, n: u64) {
    for c in 0..n {
        plant.step(&mut card.model, &NODES);
        let (model, mut cmds) = card.split();
        servo.tick(model, &mut cmds, c);
    }
}

fn cmd(card: &mut Card, line: &str) -> String {
    let mut s = Session::default();
    String::from_utf8_lossy(&card.command_line(&mut s, line.as_bytes())).into_owned()
}

fn num(reply: &str) -> f64 {
    reply
        .trim_matches(|c: char| c.is_control() || c.is_whitespace())
        .parse()
        .unwrap_or(f64::NAN)
}

fn setup() -> (Card, Servo, LoopbackPlant) {
    let mut card = bench_card();
    cmd(&mut card, "I3=2");
    let servo = Servo::new(&card.model);
    (card, servo, LoopbackPlant::default())
}

#[test]
fn jog_goes_out_over_node_registers_and_reports() {
    let (mut card, mut servo, mut plant) = setup();
    run(&mut card, &mut servo, &mut plant, 5);
    assert_eq!(card.state.node_command(0)[3], 0, "killed: no enable");
    cmd(&mut card, "#1J=1000");
    run(&mut card, &mut servo, &mut plant, 3);
    // Enabled: Y:$0F70 bit 14 copied into node 0 register 3.
    assert_eq!(card.state.node_command(0)[3] & (1 << 14), 1 << 14);
    assert_ne!(cmd(&mut card, "?").get(..6), Some("812000"));
    run(&mut card, &mut servo, &mut plant, 3000);
    let p = num(&cmd(&mut card, "#1P"));
    assert!((p - 1000.0).abs() < 10.0, "P = {p}");
    assert!((plant.position(0) - p).abs() < 1.0);
    assert_eq!(num(&cmd(&mut card, "#1V")), 0.0);
    // In position, amp enabled, closed loop: word 1 $800000 + desired velocity zero.
    let q = cmd(&mut card, "#1?");
    assert!(q.starts_with("812000"), "{q:?}");
    assert_eq!(&q[11..12], "1", "in-position bit in {q:?}");
    // D:$002B (M162) actual position in 1/(Ix08·32) counts.
    cmd(&mut card, "M162->D:$002B");
    let m162 = num(&cmd(&mut card, "M162"));
    assert!((m162 / 3072.0 - p).abs() < 0.05, "M162 {m162}");
    // Other motors never moved.
    assert_eq!(plant.position(1), 0.0);
}

#[test]
fn kill_ctrl_k_and_reset_drop_enables() {
    let (mut card, mut servo, mut plant) = setup();
    cmd(&mut card, "#1J=100 #2J=100");
    run(&mut card, &mut servo, &mut plant, 400);
    assert_eq!(card.state.node_command(1)[3] & (1 << 14), 1 << 14);
    cmd(&mut card, "#2K");
    run(&mut card, &mut servo, &mut plant, 1);
    assert_eq!(card.state.node_command(1)[3] & (1 << 14), 0);
    assert_eq!(card.state.node_command(1)[0], 0, "killed output zero");
    assert_eq!(card.state.node_command(0)[3] & (1 << 14), 1 << 14);
    let mut s = Session::default();
    card.control_char(&mut s, 0x0B);
    run(&mut card, &mut servo, &mut plant, 1);
    assert_eq!(card.state.node_command(0)[3] & (1 << 14), 0);
    assert!(!servo.motors[0].closed_loop());
    cmd(&mut card, "#1J/");
    run(&mut card, &mut servo, &mut plant, 2);
    assert!(servo.motors[0].closed_loop());
    cmd(&mut card, "$$$");
    run(&mut card, &mut servo, &mut plant, 1);
    assert!(!servo.motors[0].closed_loop(), "$$$ kills");
}

#[test]
fn ring_fault_keeps_motors_killed_until_reset() {
    let (mut card, mut servo, mut plant) = setup();
    cmd(&mut card, "#1J=100");
    run(&mut card, &mut servo, &mut plant, 100);
    card.state.global.ring_fault = true;
    run(&mut card, &mut servo, &mut plant, 1);
    assert!(!servo.motors[0].closed_loop());
    cmd(&mut card, "#1J=0");
    run(&mut card, &mut servo, &mut plant, 10);
    assert!(!servo.motors[0].closed_loop(), "no command closes a loop");
    assert_eq!(card.state.node_command(0)[3] & (1 << 14), 0);
    card.state.global.ring_fault = false;
    cmd(&mut card, "#1J=0");
    run(&mut card, &mut servo, &mut plant, 2);
    assert!(servo.motors[0].closed_loop());
}

#[test]
fn gather_samples_the_cycle_counter() {
    let (mut card, mut servo, mut plant) = setup();
    cmd(&mut card, "I19=2 I20=1 I21=$400000 DEFINE GATHER 4");
    run(&mut card, &mut servo, &mut plant, 3);
    cmd(&mut card, "GATHER");
    run(&mut card, &mut servo, &mut plant, 20);
    // X:$0000 counts servo cycles: 3 before GATHER, sampled (before counting) every 2 cycles.
    let l = cmd(&mut card, "LIST GATHER");
    assert_eq!(
        l, "000000000003 000000000005 000000000007 000000000009\r\u{6}",
        "{l:?}"
    );
    assert!(!card.gathering(), "full buffer stops gathering");
    assert_eq!(
        cmd(&mut card, "LIST GATHER 1,2"),
        "000000000005 000000000007\r\u{6}"
    );
    cmd(&mut card, "GATHER");
    assert!(cmd(&mut card, "DELETE GATHER").contains("ERR003"));
    cmd(&mut card, "ENDGATHER DELETE GATHER");
    assert_eq!(cmd(&mut card, "LIST GATHER"), "\u{6}");
}

/// `cargo test --release -p mcc-card --lib core::tests_servo::servo_bench -- --ignored --nocapture`
#[test]
#[ignore = "timing benchmark; run in release"]
fn servo_bench() {
    let r = crate::runtime::bench_servo::run_servo_bench();
    println!("{r}");
    assert!(r.per_motor_p50_ns > 0.0);
}

#[test]
fn bench_loop_runs_and_reports_sane_numbers() {
    let (mut card, mut servo, mut plant) = setup();
    cmd(&mut card, "#1J=10000 #8J=-10000");
    run(&mut card, &mut servo, &mut plant, 6000);
    assert!((plant.position(0) - 10_000.0).abs() < 10.0);
    assert!((plant.position(13) + 10_000.0).abs() < 10.0);
    let text = crate::runtime::bench_servo::ServoBenchReport {
        ticks: 10,
        per_motor_p50_ns: 500.0,
        per_motor_p99_ns: 900.0,
        core_share_p50_pct: 0.9,
        core_share_p99_pct: 1.63,
    }
    .to_string();
    assert!(text.contains("p50 500 ns, p99 900 ns"), "{text}");
    assert!(
        text.contains("0.90 % of one core (p50), 1.63 % (p99)"),
        "{text}"
    );
}

#[test]
fn a_plc_send_becomes_unsolicited_output_of_the_card() {
    let (mut card, mut servo, mut plant) = setup();
    // One connection: the open buffer belongs to the session that opened it.
    let mut session = Session::default();
    for line in [
        "OPEN PLC 3 CLEAR",
        "SEND\"HELLO\"",
        "DISABLE PLC 3",
        "CLOSE",
        "I5=3",
        "ENABLE PLC 3",
    ] {
        let r =
            String::from_utf8_lossy(&card.command_line(&mut session, line.as_bytes())).into_owned();
        assert!(!r.contains('\x07'), "{line}: {r:?}");
    }
    run(&mut card, &mut servo, &mut plant, 5);
    let out = card.model.take_output();
    let text = String::from_utf8_lossy(&out).into_owned();
    // One scan: the PLC sends once, then disables itself.
    assert_eq!(text.matches("HELLO").count(), 1, "{text:?}");
}
