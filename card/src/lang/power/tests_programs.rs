//! Programs and PLCs of the Power dialect running on the card's engine (issue 13, seed
//! §2.10-2.11): every variable family and data-structure elements inside programs, `read()`
//! into D-variables (L43530-43563), G-codes through `Coord[x].Gprog` (L763-779), `call n.f`
//! labels × 1,000,000 (L39848-39866), the L/R stack across a call (L39880-39890), `cmd`
//! (L40193-40328), and `cx` (L33727-33800).

use super::{CmdQueue, Power};
use crate::core::rig::{LoopbackPlant, NODES};
use crate::domain::Profile;
use crate::lang::Card;
use crate::servo::Servo;

pub(super) struct T {
    pub(super) card: Card,
    p: Power,
    pub(super) servo: Servo,
    plant: LoopbackPlant,
    cycle: u64,
}

impl T {
    pub(super) fn new() -> Self {
        let mut card = Card::new(Profile::Power);
        Power::attach(&mut card);
        let servo = Servo::new(&card.model);
        T {
            card,
            p: Power::new(),
            servo,
            plant: LoopbackPlant::default(),
            cycle: 0,
        }
    }

    /// The reply text of `line` on connection 1 without the final ACK line.
    pub(super) fn send(&mut self, line: &str) -> String {
        let r = self.p.line(&mut self.card, 1, line.as_bytes());
        let s = String::from_utf8(r).unwrap();
        assert!(s.ends_with("\x06\r\n"), "no ACK: {s:?}");
        s[..s.len() - 3].to_string()
    }

    /// The whole output of `line` (any bytes).
    pub(super) fn raw(&mut self, line: &[u8]) -> Vec<u8> {
        self.p.line(&mut self.card, 1, line)
    }

    pub(super) fn load(&mut self, lines: &[&str]) {
        for l in lines {
            assert_eq!(self.send(l), "", "{l}");
        }
    }

    /// `n` servo cycles (plant, servo tick, then the programs' `cmd` lines), as the card
    /// core runs them.
    pub(super) fn run(&mut self, n: u64) {
        for _ in 0..n {
            self.plant.step(&mut self.card.model, &NODES);
            let mut q = CmdQueue::default();
            self.servo.tick(&mut self.card.model, &mut q, self.cycle);
            self.p.program_commands(&mut self.card, q);
            self.cycle += 1;
        }
    }

    /// Power motor 1 active, closed loop, the X axis of C.S. 1.
    pub(super) fn ready_cs1(&mut self) {
        // The auxiliary flag copy of the motors' nodes (what the ring start-up enables).
        let _ = self.card.model.state.set_ivar(70, 13_107.0);
        let _ = self.card.model.state.set_ivar(71, 13_107.0);
        self.load(&["Motor[1].ServoCtrl=1", "&1 #1->1000X"]);
        self.run(5);
        assert_eq!(self.send("#1j/"), "");
        self.run(20);
    }
}

#[test]
fn a_motion_program_reaches_every_variable_family_read_g_codes_and_calls() {
    let mut t = T::new();
    t.load(&[
        // G3 → `call Coord[1].Gprog` (subprogram 1000) at label 3000.
        "open subprog 1000",
        "N3000: read(A,B,DD) P20 = D1 + D2 P21 = D0 P22 = D54 P23 = D30",
        "return",
        "close",
        "open subprog 7",
        "P30 = L0",
        "return",
        "N500000: P31 = 1",
        "return",
        "close",
        "open prog 3",
        "L5 = 3 P10 = L5 * 2",
        "Motor[1].JogSpeed = 7 P11 = I122",
        "Motor[2].JogSpeed = P11 + 1 Sys.P[12] = 5",
        "C3 = 2 D7 = 6 P13 = C3 + D7",
        "G3 A2 B5 DD7",
        // The callee's L0 is the caller's R0 (StackOffset 256).
        "R0 = 42 call 7",
        "call 7.5",
        "cmd \"P40=P12+1\"",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b3 r"), "");
    t.run(200);
    assert_eq!(t.send("P10..13"), "P10=6\r\nP11=7\r\nP12=5\r\nP13=8\r\n");
    assert_eq!(t.send("Motor[2].JogSpeed"), "Motor[2].JogSpeed=8\r\n");
    // read(A,B,DD): D1 = 2, D2 = 5, D30 = 7 (DD: D(26+4)), bits 0, 1 and 29 in D0 and D54.
    assert_eq!(
        t.send("P20..23"),
        "P20=7\r\nP21=536870915\r\nP22=536870915\r\nP23=7\r\n"
    );
    assert_eq!(t.send("P30..31"), "P30=42\r\nP31=1\r\n");
    // `cmd` ran on the command thread after the tick.
    assert_eq!(t.send("P40"), "P40=6\r\n");
}

#[test]
fn g_codes_follow_coord_gprog() {
    let mut t = T::new();
    t.load(&[
        "open subprog 2000",
        "N1000: P50 = 11",
        "return",
        "close",
        "open prog 4",
        "G1",
        "close",
        "Coord[1].Gprog=2000",
    ]);
    assert_eq!(t.send("Coord[1].Gprog"), "Coord[1].Gprog=2000\r\n");
    t.ready_cs1();
    assert_eq!(t.send("&1 b4 r"), "");
    t.run(100);
    assert_eq!(t.send("P50"), "P50=11\r\n");
}

/// Seed §2.11: a PLC's locals persist from scan to scan; elements and I-variables in PLCs.
#[test]
fn a_plc_keeps_its_locals_and_writes_elements() {
    let mut t = T::new();
    t.load(&[
        "open plc 3",
        "L1 = L1 + 1 Sys.P[50] = L1 Motor[3].JogSpeed = 9 I422 = L1 * 10",
        "if (L1 >= 3) { disable plc 3 }",
        "close",
        "enable plc 3",
    ]);
    t.run(300);
    assert_eq!(t.send("P50"), "P50=3\r\n");
    assert_eq!(t.send("Motor[3].JogSpeed"), "Motor[3].JogSpeed=9\r\n");
    assert_eq!(t.send("Motor[4].JogSpeed"), "Motor[4].JogSpeed=30\r\n");
    // The on-line thread's L1 is its own.
    assert_eq!(t.send("L1"), "L1=0\r\n");
}

/// Bad program input is refused at entry in the seed's terms, the buffer erased (§2.9).
#[test]
fn bad_program_lines_are_refused_at_entry() {
    let mut t = T::new();
    for (line, code) in [
        ("Motor[1].Status[0] = 1", 23),
        ("Motor[1].ActPos = 1", 23),
        ("Motor[99].JogSpeed = 1", 21),
        ("Motor[1].NoSuchThing = 1", 21),
        ("L8192 = 1", 21),
        ("D55 = 1", 21),
        ("system \"ls\"", 27),
        ("send 9,\"x\"", 21),
    ] {
        assert_eq!(t.send("open prog 9"), "");
        let r = t.send(line);
        assert!(r.contains(&format!("error #{code}:")), "{line}: {r}");
        assert!(
            t.card
                .model
                .bufs
                .program(crate::model::BufId::Prog(9))
                .is_none(),
            "{line}"
        );
    }
    // A computed index out of range stops the program at run time, nothing else stored lost.
    t.load(&[
        "P1=5",
        "open prog 10",
        "P2 = 1 L(P1 * 10000) = 1 P3 = 1",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b10 r"), "");
    t.run(100);
    assert_eq!(t.send("P1..3"), "P1=5\r\nP2=1\r\nP3=0\r\n");
}

/// Seed L33727-33800 examples: `cx` runs a program line at once as a one-line PLC.
#[test]
fn cx_runs_one_line_at_once() {
    let mut t = T::new();
    assert_eq!(t.send("P100=30 P35=7"), "");
    assert_eq!(t.send("cx while (P100<40) P(P100)=0 P100++"), "");
    assert_eq!(t.send("P100 P35 P39"), "P100=40\r\nP35=0\r\nP39=0\r\n");
    assert_eq!(t.send("&1 Q10=-1"), "");
    assert_eq!(t.send("cx if (Q10<0) Q300=72"), "");
    assert_eq!(t.send("Q300"), "Q300=72\r\n");
    assert_eq!(t.send("Motor[4].ProgJogPos=100"), "");
    assert_eq!(t.send("cx Motor[4].ProgJogPos+=5000"), "");
    assert_eq!(
        t.send("Motor[4].ProgJogPos"),
        "Motor[4].ProgJogPos=5100\r\n"
    );
    // The thread's own locals; `cmd` runs on the command thread.
    assert_eq!(t.send("L3=4"), "");
    assert_eq!(t.send("cx L4 = L3 * 2 cmd\"P41=3\""), "");
    assert_eq!(t.send("L4 P41"), "L4=8\r\nP41=3\r\n");
    // Errors in the seed's terms.
    // A move in a C.S. that cannot run (no motors here).
    assert!(t.send("cx X10").contains("error #25:"));
    assert!(t.send("cx P1 = ").contains("error #20:"));
    assert!(t.send("cx Motor[1].Status[0]=1").contains("error #23:"));
    // The status word reads as `#1?` reports it.
    assert_eq!(
        t.send("echo 1 Motor[1].Status[0] Motor[1].Status[1] echo 0"),
        "$0\r\n$0\r\n"
    );
    // `cpx` moves need a C.S. that can run (none here: no motors).
    assert!(t.send("cpx linear X10 F5").contains("error #25:"));
    assert_eq!(t.send("cpx P42=1"), "");
    assert_eq!(t.send("P42"), "P42=1\r\n");
}

/// `cpx` with a move runs it as a motion program of the addressed C.S.
#[test]
fn cpx_moves_the_addressed_coordinate_system() {
    let mut t = T::new();
    t.ready_cs1();
    assert_eq!(t.send("&1"), "");
    assert_eq!(t.send("cpx linear abs X1 tm200 P43=1"), "");
    t.run(1500);
    assert_eq!(t.send("P43"), "P43=1\r\n");
    let p: f64 = t.send("#1p").trim().parse().unwrap();
    assert!((p - 1000.0).abs() < 20.0, "{p}");
}

/// Issue 13 item 5 / issue 10 item 5: a Power card's saved image holds its buffers' text; a
/// card loading it lists them again and runs them (elements and locals resolved anew).
#[test]
fn saved_buffers_list_and_run_after_a_load() {
    let mut t = T::new();
    let prog = [
        "open prog 12",
        "  L2 = 5   // a local",
        "Sys.P[60] = L2 * 2",
        "if (P61 == 0) {",
        "P61 = Motor[1].JogSpeed",
        "}",
        "close",
    ];
    t.load(&prog);
    t.load(&["open plc 4", "P62 = P62 + 1", "close"]);
    let listing = t.send("list prog 12");
    assert_eq!(
        listing,
        "L2 = 5\r\nSys.P[60] = L2 * 2\r\nif (P61 == 0) {\r\nP61 = Motor[1].JogSpeed\r\n}\r\n"
    );
    let image = t.card.save_image();

    let mut u = T::new();
    let loaded = u
        .card
        .apply_loaded(crate::lang::EffectResult::Loaded(Ok(Some(image))));
    assert_eq!(loaded, Ok(()));
    assert_eq!(u.send("list prog 12"), listing);
    assert_eq!(u.send("list plc 4"), "P62 = P62 + 1\r\n");
    assert_eq!(
        u.send("buffer"),
        "Prog12 offset 0, size 68\r\nPlc4 offset 68, size 14\r\n"
    );
    u.load(&["Motor[1].JogSpeed=3"]);
    u.ready_cs1();
    assert_eq!(u.send("&1 b12 r"), "");
    u.run(100);
    assert_eq!(u.send("P60..61"), "P60=10\r\nP61=3\r\n");
    // A reset without an image erases buffers and their text.
    let _ = u
        .card
        .apply_loaded(crate::lang::EffectResult::Loaded(Ok(None)));
    assert!(u.send("list prog 12").contains("error #21:"));
    assert_eq!(u.send("buffer"), "");
}

/// Seed L36521-36720: `list pc` from the program counter of the addressed C.S. (numbered with
/// a comma, headed by the program, ending in `end`), `list apc` where it was when aborted.
#[test]
fn list_pc_and_apc_follow_the_program_counter() {
    let mut t = T::new();
    t.load(&[
        "open prog 25",
        "P1 = 1",
        "dwell 2000",
        "P2 = 2",
        "dwell 50",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b25"), "");
    // Before the run the counter is at the top.
    assert_eq!(
        t.send("list pc"),
        "P1 = 1\r\ndwell 2000\r\nP2 = 2\r\ndwell 50\r\n"
    );
    assert_eq!(t.send("r"), "");
    t.run(100);
    // In the first dwell the counter points at the next line to calculate (seed L36690),
    // and a dwell stops look-ahead: `P2 = 2` is not calculated before the dwell has run
    // (L41027-41029).
    assert_eq!(t.send("P2"), "P2=0\r\n");
    assert_eq!(
        t.send("list pc,"),
        "prog 25\r\n2:P2 = 2\r\n3:dwell 50\r\n4:end\r\n"
    );
    assert_eq!(t.send("list pc,1"), "prog 25\r\n2:P2 = 2\r\n");
    assert_eq!(t.send("list pc"), "P2 = 2\r\ndwell 50\r\n");
    assert_eq!(t.send("a"), "");
    t.run(5);
    assert_eq!(
        t.send("list apc,"),
        "prog 25\r\n2:P2 = 2\r\n3:dwell 50\r\n4:end\r\n"
    );
    assert_eq!(
        t.send("P2"),
        "P2=0\r\n",
        "aborted in the dwell: never calculated"
    );
    assert!(t.send("list pc,x").contains("error #20:"));
}

/// Seed L39878-39880: a call of a missing subprogram stops the program with an error; a
/// missing label in an existing one calls its top.
#[test]
fn calls_of_missing_subprograms_stop_and_missing_labels_start_at_the_top() {
    let mut t = T::new();
    t.load(&[
        "open subprog 8",
        "P71 = P71 + 1",
        "return",
        "close",
        "open prog 13",
        "call 8.25 P72 = 1",
        "call 9 P73 = 1",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b13 r"), "");
    t.run(100);
    assert_eq!(t.send("P71..73"), "P71=1\r\nP72=1\r\nP73=0\r\n");
    // The C.S. is no longer running: `Coord[1].Status[1]` bit 27 (block active) clear.
    assert_eq!(t.send("echo1 Coord[1].Status[1]"), "$0\r\n");
}

/// Seed L39999-40160, L25130-25150: `cset`/`cclr` set and clear the C.S.'s conditional
/// flags (`Coord[x].Cflags` bit n), `cexe n`/`cskip n` run or skip the rest of the line.
#[test]
fn conditional_execution_flags() {
    let mut t = T::new();
    t.load(&[
        "open prog 14",
        "cset 3 cset5 cclr 5",
        "cexe 3 P80 = 1 P84 = 1",
        "cskip 3 P81 = 1",
        "cexec5 P82 = 1",
        "cskip 5 P83 = 1",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b14 r"), "");
    t.run(100);
    assert_eq!(
        t.send("P80..84"),
        "P80=1\r\nP81=0\r\nP82=0\r\nP83=1\r\nP84=1\r\n"
    );
    assert_eq!(t.send("Coord[1].Cflags"), "Coord[1].Cflags=$8\r\n");
    // On-line through `cx` (seed: `&x cx cclrn`), for the thread's C.S.
    assert_eq!(t.send("cx cset 2 cclr 3"), "");
    assert_eq!(t.send("Coord[1].Cflags"), "Coord[1].Cflags=$4\r\n");
    // Hosts cannot write it; a flag number beyond 31 is refused.
    assert!(t.send("Coord[1].Cflags=1").contains("error #23:"));
    assert!(t.send("cx cset 32").contains("error #21:"));
}

/// Seed L39868-39880: a PLC calls subroutines and subprograms (which run by PLC rules), with
/// `read` into the PLC's D-variables and its own L-stack; a missing subprogram stops the PLC.
#[test]
fn a_plc_calls_subroutines_and_subprograms() {
    let mut t = T::new();
    t.load(&[
        // M4 → `call Coord[x].Mprog` (subprogram 1001) at label 4000.
        "open subprog 1001",
        "N4000: read(Q) P91 = D17 + L0",
        "return",
        "close",
        "open subprog 20",
        "P92 = P92 + 1",
        "return",
        "close",
        "open plc 5",
        "R0 = 3 M4 Q10",
        "gosub 50 call 20 P94 = 1",
        "disable plc 5",
        "return",
        "N50: P93 = 6",
        "return",
        "close",
        "open plc 6",
        "call 21 P95 = 1",
        "close",
    ]);
    assert_eq!(t.send("enable plc 5 enable plc 6"), "");
    t.run(50);
    assert_eq!(
        t.send("P91..95"),
        "P91=13\r\nP92=1\r\nP93=6\r\nP94=1\r\nP95=0\r\n"
    );
    // PLC 6 stopped at its call of the missing subprogram 21.
    assert!(!t.card.model.run.plc[6].enabled);
    assert!(
        t.card.model.run.plc[4].enabled,
        "an untouched PLC stays as it was"
    );
}

/// Seed L39880-39890, L37686-37752: a program's stack offset (`open prog n,{offset}`) is
/// where its `R` variables start, the `L` of the subroutine it calls with `callsub` (or of a
/// subprogram it `call`s); `gosub` runs on the caller's locals. Kept by `save`.
#[test]
fn stack_offsets_place_the_callees_locals() {
    let mut t = T::new();
    t.load(&[
        "open subprog 9,32",
        "L0 = L0 + 1",
        "P44 = L0",
        "callsub 100",
        "P42 = R0",
        "return",
        "N100: P41 = L0 L0 = 7 return",
        "close",
        "open plc 3,64",
        "L0 = 5",
        "R0 = 10",
        "L64 = 11",
        "call 9",
        "gosub 200",
        "disable plc 3",
        "return",
        "N200: P43 = L0",
        "return",
        "close",
        "enable plc 3",
    ]);
    t.run(5);
    // The PLC's R0 is its L64 (offset 64): the subprogram's L0 = 11, +1 → 12 (with the
    // default 256 it would be the PLC's L256 = R0 = 10, → 11); the subprogram's R0 is its L32
    // (offset 32), the callsub's L0: 0.
    assert_eq!(t.send("P44"), "P44=12\r\n");
    assert_eq!(t.send("P41"), "P41=0\r\n");
    // The callsub set its L0 (the subprogram's R0) to 7.
    assert_eq!(t.send("P42"), "P42=7\r\n");
    // `gosub`: the PLC's own L0.
    assert_eq!(t.send("P43"), "P43=5\r\n");
    // A motion program: `open prog 12,16` makes its R0 its L16.
    t.ready_cs1();
    t.load(&[
        "open prog 12,16",
        "L16 = 3",
        "callsub 10",
        "P46 = R0",
        "return",
        "N10: P45 = L0 L0 = 8",
        "return",
        "close",
        "&1 b12 r",
    ]);
    t.run(20);
    assert_eq!(t.send("P45 P46"), "P45=3\r\nP46=8\r\n");
    // After a save and load the offsets hold: the same run gives the same values.
    let mut u = super::tests_units::reloaded(&mut t);
    u.load(&["P41=-1", "P42=-1", "P44=-1", "enable plc 3"]);
    u.run(5);
    assert_eq!(u.send("P41 P42 P44"), "P41=0\r\nP42=7\r\nP44=12\r\n");
}

/// Seed L33832-33835, L33907: `Plc[i].Ldata.…` and `Coord[x].Ldata.…` reach the local data of
/// that PLC or of that C.S.'s motion program from any thread.
#[test]
fn another_threads_local_data_is_reachable_by_its_owner() {
    let mut t = T::new();
    assert_eq!(t.send("Plc[5].Ldata.Motor=7"), "");
    assert_eq!(t.send("Plc[5].Ldata.Motor"), "Plc[5].Ldata.Motor=7\r\n");
    // A motion program's thread addresses its own C.S. until told otherwise.
    assert_eq!(t.send("Coord[3].Ldata.Coord"), "Coord[3].Ldata.Coord=3\r\n");
    t.load(&[
        "open plc 5",
        "P50 = Ldata.Motor",
        "L3 = 42",
        "P51 = Coord[3].Ldata.Coord",
        "disable plc 5",
        "close",
        "enable plc 5",
    ]);
    t.run(3);
    assert_eq!(t.send("P50 P51"), "P50=7\r\nP51=3\r\n");
    assert_eq!(t.send("Plc[5].Ldata.L[3]"), "Plc[5].Ldata.L[3]=42\r\n");
    assert!(t.send("Plc[32].Ldata.Motor").contains("error #21"));
    assert!(t.send("Motor[1].Ldata.Motor").contains("error #21"));
}
