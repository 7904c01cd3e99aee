//! Single-stepping (130, issue 26 item 8): every accepted step is one instruction, however many
//! arrive within one drive tick; a WAIT holds its step until it ends; the step queue is bounded.

use super::codec::{status, Instr, Reply, Request};
use super::drive::Drive;
use super::program::{AppState, STEP_QUEUE};
use super::spec::DriveSpec;

fn i(op: u8, typ: u8, motor: u8, value: i32) -> Instr {
    Instr::new(op, typ, motor, value)
}

/// Send an instruction in direct mode; (status, value).
fn direct(d: &mut Drive, instr: Instr) -> (u8, i32) {
    let f = Request { addr: 1, instr }.to_bytes();
    let r = d.handle_frame(&f).unwrap().bytes.unwrap();
    let r = Reply::parse(&r).unwrap();
    (r.status, r.value)
}

/// A drive holding `prog` at 0 (download mode entered and left over the bus), stopped.
fn loaded(prog: &[Instr]) -> Drive {
    let mut d = Drive::new(DriveSpec::default());
    assert_eq!(direct(&mut d, i(132, 0, 0, 0)).0, status::OK);
    for p in prog {
        assert_eq!(direct(&mut d, *p), (status::STORED, p.value));
    }
    assert_eq!(direct(&mut d, i(133, 0, 0, 0)).0, status::OK);
    d
}

/// CALC ADD 1 forty times, then a jump back to 0.
fn counting_program() -> Drive {
    let mut prog = vec![i(19, 0, 0, 1); 40];
    prog.push(i(22, 0, 0, 0));
    loaded(&prog)
}

fn pc(d: &mut Drive) -> i32 {
    direct(d, i(10, 130, 0, 0)).1
}

#[test]
fn steps_arriving_within_one_tick_each_run_one_instruction() {
    for n in [1u16, 2, 7, 20] {
        let mut d = counting_program();
        // n steps (as from two hosts interleaved) before the drive ticks once.
        for _ in 0..n {
            assert_eq!(direct(&mut d, i(130, 0, 0, 0)), (status::OK, 0));
        }
        assert_eq!(direct(&mut d, i(135, 0, 0, 0)).1, AppState::Step as i32);
        d.run_ms(1);
        assert_eq!(pc(&mut d), 1, "one instruction per tick");
        d.run_ms(100);
        assert_eq!(pc(&mut d), i32::from(n), "{n} steps");
        assert_eq!(d.prog.accu, i32::from(n));
        assert_eq!(d.prog.executed, u64::from(n));
        // Nothing more runs until the next step.
        d.run_ms(100);
        assert_eq!(pc(&mut d), i32::from(n));
    }
}

#[test]
fn a_wait_is_one_step_and_holds_it_until_it_ends() {
    // WAIT TICKS 5 (50 ms), then CALC ADD 1 twice.
    let mut d = loaded(&[i(27, 0, 0, 5), i(19, 0, 0, 1), i(19, 0, 0, 1)]);
    direct(&mut d, i(130, 0, 0, 0));
    direct(&mut d, i(130, 0, 0, 0));
    d.run_ms(20);
    assert_eq!((pc(&mut d), d.prog.accu), (0, 0), "still waiting");
    d.run_ms(40);
    assert_eq!(
        (pc(&mut d), d.prog.accu),
        (2, 1),
        "the wait, then one instruction"
    );
    d.run_ms(50);
    assert_eq!(pc(&mut d), 2);
}

#[test]
fn the_step_queue_is_bounded_and_refuses_with_status_6() {
    let mut d = counting_program();
    for _ in 0..STEP_QUEUE {
        assert_eq!(direct(&mut d, i(130, 0, 0, 0)).0, status::OK);
    }
    assert_eq!(
        direct(&mut d, i(130, 0, 0, 0)),
        (status::NOT_AVAILABLE, 0),
        "one step over the queue"
    );
    // Stop drops the steps not taken; a new step is one instruction again.
    direct(&mut d, i(128, 0, 0, 0));
    d.run_ms(10);
    let at = pc(&mut d);
    assert_eq!(direct(&mut d, i(130, 0, 0, 0)).0, status::OK);
    d.run_ms(10);
    assert_eq!(pc(&mut d), at + 1);
}
