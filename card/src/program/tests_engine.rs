//! Engine tests: run control, program logic, subroutines, synchronous M-variables, PLC scan
//! semantics, refusals. A "perfect motor" rig: each motor's feedback equals its setpoint.

use super::ProgramEngine;
use crate::domain::Profile;
use crate::lang::{Card, Session};
use crate::motion::flags::FlagInputs;
use crate::motion::motor::{Motor, MotorCommand, TickInput};
use crate::motion::params::MotorParams;

pub(super) struct Rig {
    pub card: Card,
    pub eng: ProgramEngine,
    pub motors: Vec<Motor>,
    pub s: Session,
    pub cycle: u64,
}

impl Rig {
    pub(super) fn new() -> Rig {
        let mut r = Rig {
            card: Card::new(Profile::Pmac2),
            eng: ProgramEngine::new(),
            motors: (0..8).map(|_| Motor::new()).collect(),
            s: Session::default(),
            cycle: 0,
        };
        r.cmd("I100=1 I200=1 I300=1 I400=1 I500=1 I600=1 I700=1 I800=1");
        r.cmd("#1J/#2J/#3J/#4J/#5J/#6J/#7J/#8J/");
        r.tick();
        r
    }

    /// Reply of a command line, without framing characters.
    pub(super) fn cmd(&mut self, line: &str) -> String {
        let r = self.card.command_line(&mut self.s, line.as_bytes());
        String::from_utf8_lossy(&r)
            .chars()
            .filter(|c| !c.is_control() || *c == '\r')
            .collect::<String>()
            .trim_end_matches('\r')
            .replace('\r', " ")
    }

    /// Enter program text lines.
    pub(super) fn prog(&mut self, text: &str) {
        for l in text.lines() {
            let l = l.trim();
            if !l.is_empty() {
                let r = self.cmd(l);
                assert!(!r.contains("ERR"), "{l}: {r}");
            }
        }
    }

    /// One servo tick; returns the setpoints.
    pub(super) fn tick(&mut self) -> Vec<Option<f64>> {
        for a in self.card.take_actions() {
            if !self
                .eng
                .handle_action(&mut self.card.model, &self.motors, &a)
            {
                if let crate::model::ActionKind::Jog { .. } = a.kind {
                    let p = MotorParams::from_state(&self.card.state, a.motor.get());
                    self.motors[a.motor.index()].command(MotorCommand::Enable, &p);
                }
            }
        }
        let (model, mut cmds) = self.card.split();
        let sp = self
            .eng
            .servo_tick(model, &mut cmds, &self.motors, self.cycle, 0.0);
        for (k, m) in self.motors.iter_mut().enumerate() {
            let p = MotorParams::from_state(&self.card.state, k as u16 + 1);
            let target = sp[k].unwrap_or(m.commanded());
            let fb = ((target * 32.0).round() as i64 as u32) & 0xFF_FFFF;
            m.tick(
                &p,
                &TickInput {
                    feedback: fb,
                    flags: FlagInputs::default(),
                    dt_ms: 3_713_707.0 / 8_388_608.0,
                    program: sp[k],
                    background: true,
                    capture: None,
                },
            );
        }
        let (model, mut cmds) = self.card.split();
        self.eng.background(model, &mut cmds, &self.motors);
        self.cycle += 1;
        sp
    }

    pub(super) fn ticks(&mut self, n: usize) {
        for _ in 0..n {
            self.tick();
        }
    }

    /// Tick until C.S. 1 is neither running nor moving (at most `max` cycles).
    pub(super) fn run_out(&mut self, max: usize) -> usize {
        for k in 0..max {
            self.tick();
            let busy = self.eng.coord(1).is_some_and(|c| c.busy());
            if !busy {
                return k + 1;
            }
        }
        max
    }

    pub(super) fn pos(&self, m: usize) -> f64 {
        self.motors[m - 1].commanded()
    }
}

#[test]
fn simple_program_runs_to_its_end_point() {
    let mut r = Rig::new();
    r.cmd("&1#1->1000X#2->1000Y");
    r.prog("OPEN PROG 1 CLEAR\nLINEAR ABS TA100 TS0 F10\nX1 Y2\nX3\nCLOSE");
    assert_eq!(r.cmd("&1B1R"), "");
    r.run_out(20_000);
    assert!((r.pos(1) - 3000.0).abs() < 1e-6, "{}", r.pos(1));
    assert!((r.pos(2) - 2000.0).abs() < 1e-6);
    assert!(!r.card.state.coords[0].running);
}

const DT: f64 = 3_713_707.0 / 8_388_608.0;

pub(super) fn xy() -> Rig {
    let mut r = Rig::new();
    r.cmd("&1#1->1000X#2->1000Y");
    r
}

#[test]
fn if_else_while_and_goto_steer_the_program() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 1 CLEAR
         P1=0 P2=0
         WHILE (P1<3)
         P1=P1+1
         IF (P1=2)
         P2=P2+10
         ELSE
         P2=P2+1
         ENDIF
         ENDWHILE
         IF (P2=12) P3=1 ELSE P3=2
         IF (P2!=12) P4=1
         ELSE P4=2
         GOTO5
         P5=99
         N5 P6=1
         CLOSE",
    );
    r.cmd("&1B1R");
    r.run_out(100);
    assert_eq!(r.cmd("P1 P2 P3 P4 P5 P6"), "3 12 1 2 0 1");
}

#[test]
fn call_gosub_read_and_gcodes_reach_their_targets() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 1000 CLEAR
         N1000 LINEAR RETURN
         N2000 P20=P20+1 RETURN
         CLOSE
         OPEN PROG 1011 CLEAR
         N15000 P21=1 RETURN
         CLOSE
         OPEN PROG 35 CLEAR
         N10000 READ(A,B,S) P30=Q101+Q102 P31=Q100 P32=Q119 RETURN
         CLOSE
         OPEN PROG 1 CLEAR
         TA10 TS0 F100
         G02 G01 X1 Y2
         M115
         CALL35.1 A3 B4 S5 C6
         GOSUB7
         P33=1
         RETURN
         N7 P34=P33 RETURN
         CLOSE",
    );
    r.cmd("&1B1R");
    r.run_out(20_000);
    assert_eq!(r.cmd("P20 P21 P30 P31 P32 P33 P34"), "1 1 7 262147 5 1 0");
    // Q100 mask: A (bit 0), B (bit 1), S (bit 18); C was not read.
    assert_eq!(262_147, 1 + 2 + (1 << 18));
    // G01 X1 Y2: the axis words after the code run after its RETURN as a move.
    assert!((r.pos(1) - 1000.0).abs() < 1e-6 && (r.pos(2) - 2000.0).abs() < 1e-6);
    // CALL of a missing program / label is ignored, GOTO to a missing label is not.
    assert_eq!(super::motion::call_target(35.1), (35, 10_000));
    assert_eq!(super::motion::call_target(500.12345), (500, 12_345));
    assert_eq!(
        super::motion::code_target(crate::domain::ast::CodeLetter::T, 115.0),
        (1012, 15_000)
    );
}

#[test]
fn synchronous_m_assignment_waits_for_the_next_move_start() {
    let mut r = xy();
    r.cmd("M1->*");
    r.prog(
        "OPEN PROG 2 CLEAR
         LINEAR INC TA100 TS0 TM1000
         X1
         M1==5 P1=1
         X1
         CLOSE",
    );
    r.cmd("&1B2R");
    r.tick();
    // P1=1 is processed during look-ahead, long before the second move starts.
    assert_eq!(r.cmd("P1 M1"), "1 0");
    // Move 2's blend window opens at 1050 - 50 = 1000 ms after the first move began.
    let k = (1000.0 / DT) as usize;
    r.ticks(k - 3);
    assert_eq!(r.cmd("M1"), "0");
    r.ticks(6);
    assert_eq!(r.cmd("M1"), "5");
    // MFLUSH / abort discard pending ones.
    r.run_out(10_000);
    r.prog("OPEN PROG 3 CLEAR\nLINEAR INC TA100 TS0 TM1000\nX1\nM1|=2\nX1\nCLOSE");
    r.cmd("&1B3R");
    r.ticks(10);
    r.cmd("&1A");
    r.run_out(10_000);
    assert_eq!(r.cmd("M1"), "5");
}

#[test]
fn step_quit_stop_and_resume_use_the_program_counter() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 4 CLEAR
         LINEAR INC TA10 TS0 TM10
         X1
         X1
         STOP
         X1
         CLOSE",
    );
    assert_eq!(r.cmd("&1B4PC"), "P4:0");
    r.cmd("&1S");
    r.run_out(1000);
    assert!(
        (r.pos(1) - 1000.0).abs() < 1e-6,
        "one move per S: {}",
        r.pos(1)
    );
    r.cmd("&1R");
    r.run_out(1000);
    assert!((r.pos(1) - 2000.0).abs() < 1e-6, "R runs to the STOP");
    assert!(!r.card.state.coords[0].running);
    r.cmd("&1R");
    r.run_out(1000);
    assert!((r.pos(1) - 3000.0).abs() < 1e-6);
    // The final RETURN resets the counter to the top of the program.
    assert_eq!(r.cmd("&1PC"), "P4:0");
}

#[test]
fn hold_freezes_the_trajectory_and_run_releases_it() {
    let mut r = xy();
    r.prog("OPEN PROG 5 CLEAR\nLINEAR INC TA100 TS0 TM2000\nX10\nX10\nX10\nX10\nCLOSE");
    r.cmd("&1B5R");
    r.ticks(1000);
    r.cmd("&1H");
    // Ix95 = 1644 per cycle: 100 % (I10) to 0 in 3,713,707 / 1644 ≈ 2259 cycles.
    r.ticks(2400);
    let p = r.pos(1);
    r.ticks(100);
    assert_eq!(r.pos(1), p, "held");
    assert!(p < 10_000.0);
    assert!(r.card.state.coords[0].running, "still calculating ahead");
    r.cmd("&1R");
    r.run_out(20_000);
    assert!((r.pos(1) - 40_000.0).abs() < 1e-6);
}

#[test]
fn program_commands_and_send_reach_the_host_output() {
    let mut r = xy();
    r.prog(
        "OPEN PROG 6 CLEAR
         SEND\"HELLO\"
         CMD\"P7=42\"
         CMD\"P7\"
         CLOSE",
    );
    r.cmd("&1B6R");
    r.run_out(100);
    let out = String::from_utf8(r.eng.take_output()).unwrap();
    assert_eq!(out, "HELLO\r42\r");
    assert_eq!(r.cmd("P7"), "42");
}

#[test]
fn plc_pause_resume_address_and_cmd() {
    let mut r = xy();
    r.prog(
        "OPEN PLC 3 CLEAR
         ADDRESS &2
         Q1=Q1+1
         P40=P40+1
         PAUSE PLC 3
         P41=P41+1
         CLOSE",
    );
    r.cmd("I5=2 ENABLE PLC 3");
    r.tick();
    assert_eq!(r.cmd("P40 P41 &2Q1 &1Q1"), "1 0 1 0");
    r.tick();
    assert_eq!(r.cmd("P40 P41"), "1 0", "paused");
    r.cmd("RESUME PLC 3");
    r.tick();
    assert_eq!(r.cmd("P40 P41"), "1 1", "resumed after the PAUSE");
    r.tick();
    assert_eq!(r.cmd("P40 P41"), "2 1");
    // A MACRO auxiliary statement whose preconditions fail (I1000 bit 0 clear for Type 0):
    // the ??? aux error bit, nothing copied, the PLC goes on.
    r.prog("OPEN PLC 4 CLEAR\nMXR0,1,P50\nCLOSE");
    r.cmd("P50=3 ENABLE PLC 4");
    r.tick();
    assert_eq!(r.cmd("P50"), "3");
    assert!(r.card.state.global.macro_aux_error);
}

#[test]
fn home_in_a_program_waits_for_the_motors() {
    let mut r = xy();
    r.prog("OPEN PROG 9 CLEAR\nHOME1\nP9=1\nCLOSE");
    r.cmd("&1B9R");
    r.tick();
    let homes: Vec<_> = r.card.take_actions();
    assert!(homes
        .iter()
        .any(|a| a.motor.get() == 1 && a.kind == crate::model::ActionKind::Home));
    assert_eq!(r.cmd("P9"), "0");
    // The (perfect) motors have no home search to run: the program continues after it.
    r.ticks(5);
    assert_eq!(r.cmd("P9"), "1");
}

#[test]
fn rotary_buffer_lines_execute_as_they_arrive() {
    let mut r = xy();
    r.cmd("&1DEFINE ROT 100");
    r.cmd("&1B0R");
    r.ticks(3);
    assert!(r.card.state.coords[0].running, "waits for lines");
    r.cmd("OPEN ROT");
    r.cmd("LINEAR INC TA10 TS0 TM10");
    r.cmd("X1");
    r.cmd("P60=5");
    r.cmd("CLOSE");
    // I13 = 0: Ix16 (32 counts/ms) stretches the move to 31 ms, Ix17 the TA to 64 ms.
    r.ticks(400);
    assert!((r.pos(1) - 1000.0).abs() < 1e-6, "{}", r.pos(1));
    assert_eq!(r.cmd("P60 PR"), "5 0");
}

#[test]
fn ctrl_a_aborts_every_program() {
    let mut r = xy();
    r.prog("OPEN PROG 10 CLEAR\nLINEAR INC TA100 TS0 F10\nX100\nCLOSE");
    r.cmd("&1B10R");
    r.ticks(500);
    r.card.control_char(&mut r.s, 0x01);
    r.run_out(1000);
    assert!(!r.card.state.coords[0].running);
    assert!(r.pos(1) < 100_000.0);
}
