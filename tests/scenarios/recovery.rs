//! Issue 14 items 6, 9-12, 16: motion recovery and positions on a PMAC2 ring card with a
//! station plant (lockstep `RingSim`, commands and feedback over the ring only). Each test
//! cites the seed (004) lines it checks.

use mcc_card::Session;
use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;

/// 1/(Ix08·32) counts per count at the default Ix08 = 96.
const D_UNITS: f64 = 3072.0;
/// `?` word 1 bit 10: positive end limit set.
const W1_POS_LIMIT: u32 = 1 << 21;
/// `?` word 2 bit 11: stopped on position limit; bit 10 home complete.
const W2_STOPPED_ON_LIMIT: u32 = 1 << 11;
const W2_HOME_COMPLETE: u32 = 1 << 10;
/// `?` word 1 bit 18: open loop.
const W1_OPEN_LOOP: u32 = 1 << 18;
/// `??` word 2 bit 23: program hold.
const CS_W2_PROGRAM_HOLD: u32 = 1 << 23;

/// The in-position band Ix28 = 160 (1/16 count): the plant's Coulomb friction can hold the
/// motor a few counts off its commanded position at rest.
const BAND: f64 = 10.0;

/// Motor 1's commanded position D:$0028, counts.
fn cmd_pos(rig: &mut Rig) -> f64 {
    rig.d_reg(1, 0x08)
}

/// Reported position `P` is actual + bias: commanded + bias − following error (seed 8244).
fn assert_reported(rig: &mut Rig, expected: f64) {
    let (p, f) = (rig.num("#1P"), rig.num("#1F"));
    assert!(
        (p + f - expected).abs() < 0.25,
        "P {p} F {f}, expected {expected} − F"
    );
}

fn rig_with(plant: NodePlantConfig) -> Rig {
    let mut rig = Rig::new(plant);
    rig.cmd("I3=2 I6=1");
    rig.run(20);
    rig.cmd("#1J/ #2J/");
    rig.run(50);
    rig
}

fn rig() -> Rig {
    rig_with(NodePlantConfig::default())
}

fn cs_status(rig: &mut Rig) -> (u32, u32) {
    let s = rig.cmd("&1??");
    let w1 = u32::from_str_radix(&s[..6], 16).unwrap();
    let w2 = u32::from_str_radix(&s[6..12], 16).unwrap();
    (w1, w2)
}

/// Run until C.S. 1 runs no program and is in position (bounded by `max` cycles).
fn run_out(rig: &mut Rig, max: usize) {
    for _ in 0..max / 50 {
        rig.run(50);
        let (w1, w2) = cs_status(rig);
        if w1 & 1 == 0 && w2 & (1 << 17) != 0 {
            rig.run(600);
            return;
        }
    }
    panic!("C.S. 1 still busy after {max} cycles: {:?}", cs_status(rig));
}

/// Run until motor 1 is in position (bounded).
fn settle(rig: &mut Rig, max: usize) {
    for _ in 0..max / 50 {
        rig.run(50);
        if rig.status(1).1 & 1 != 0 {
            // In position is |FE| < Ix28 (10 counts): let the integrator finish.
            rig.run(600);
            return;
        }
    }
    panic!(
        "motor 1 not in position after {max} cycles: {:?}",
        rig.status(1)
    );
}

fn load(rig: &mut Rig, lines: &[&str]) {
    for l in lines {
        assert_eq!(rig.cmd(l), "", "{l}");
    }
}

fn three_moves(rig: &mut Rig) {
    load(
        rig,
        &[
            "&1 #1->X",
            "OPEN PROG 5 CLEAR",
            "LINEAR ABS TA50 TS0 TM300",
            "X4000",
            "X8000",
            "X12000",
            "CLOSE",
            "M163->D:$080B M164->D:$0813",
        ],
    );
}

/// Seed 6745-6760 (the `/` example: stop, jog away, `J=`, `R`; ERR017 when not back) and
/// 8397-8403 (`J=` returns to the most recent programmed position, kept in the target
/// position register D:$080B).
#[test]
fn stop_jog_away_return_with_j_equals_and_resume() {
    let mut rig = rig();
    rig.cmd("I13=10");
    three_moves(&mut rig);
    assert_eq!(rig.cmd("&1B5R"), "");
    rig.run(300);
    // Move 1 is executing: the target register holds its end.
    assert_eq!(rig.num("M163"), 4000.0 * D_UNITS);
    assert_eq!(rig.cmd("&1/"), "");
    run_out(&mut rig, 5000);
    let stop = rig.num("#1P");
    assert!(
        (stop - 4000.0).abs() < BAND,
        "stopped at the end of move 1: {stop}"
    );
    assert_eq!(cmd_pos(&mut rig), 4000.0);
    rig.cmd("#1J+");
    rig.run(400);
    rig.cmd("#1J/");
    settle(&mut rig, 3000);
    assert!(rig.num("#1P") > stop + 100.0);
    assert_eq!(rig.cmd("&1R"), "ERR017");
    rig.cmd("#1J=");
    settle(&mut rig, 5000);
    assert_eq!(cmd_pos(&mut rig), 4000.0, "J= to the target register");
    assert!((rig.num("#1P") - 4000.0).abs() < BAND);
    assert_eq!(rig.cmd("&1R"), "");
    run_out(&mut rig, 10_000);
    assert!((rig.num("#1P") - 12_000.0).abs() < BAND);
    assert_eq!(rig.num("M163"), 12_000.0 * D_UNITS);
}

/// Seed 6749: "If resumption of this program from this point is not desired, the A (abort)
/// command should be issued before other programs are run" — one `A` clears the stop point
/// so `B..R` on the same line starts.
#[test]
fn abort_after_stop_lets_a_new_program_start() {
    let mut rig = rig();
    rig.cmd("I13=10");
    three_moves(&mut rig);
    rig.cmd("&1B5R");
    rig.run(300);
    rig.cmd("&1/");
    run_out(&mut rig, 5000);
    rig.cmd("#1J=1000");
    settle(&mut rig, 8000);
    assert_eq!(rig.cmd("&1R"), "ERR017");
    assert_eq!(rig.cmd("&1A"), "");
    rig.run(10);
    assert_eq!(rig.cmd("&1B5R"), "");
    run_out(&mut rig, 10_000);
    assert!((rig.num("#1P") - 12_000.0).abs() < BAND);
}

/// Seed 8401-8403 (`&1A` in the middle of a move, `#1J=`, `R`): `J=` goes to the end of the
/// move that was executing (I13 = 0) and `R` resumes with the next one.
#[test]
fn abort_mid_move_then_j_equals_and_resume() {
    let mut rig = rig();
    three_moves(&mut rig);
    rig.cmd("&1B5R");
    rig.run(1000); // inside move 2 (each move ≈ 680 cycles)
    assert_eq!(rig.num("M163"), 8000.0 * D_UNITS);
    rig.cmd("&1A");
    settle(&mut rig, 5000);
    let p = rig.num("#1P");
    assert!(p > 4000.0 && p < 7900.0, "stopped inside move 2: {p}");
    rig.cmd("#1J=");
    settle(&mut rig, 5000);
    assert_eq!(cmd_pos(&mut rig), 8000.0, "J= to the end of move 2");
    assert_eq!(rig.cmd("&1R"), "");
    rig.run(200);
    let q = rig.num("#1P");
    assert!(q > 8000.0 && q < 12_000.0, "resumed with move 3: {q}");
    run_out(&mut rig, 10_000);
    assert!((rig.num("#1P") - 12_000.0).abs() < BAND);
}

/// Item 16: `R` right after `#1J/` or `#1HMZ` on a motor at rest is not refused with ERR011
/// (no move in progress); `J==` sets the target register (seed 8397-8403).
#[test]
fn run_right_after_jog_stop_or_hmz_at_rest() {
    let mut rig = rig();
    three_moves(&mut rig);
    assert_eq!(rig.cmd("&1B5 #1J/ &1R"), "");
    run_out(&mut rig, 10_000);
    rig.cmd("#1J==100");
    assert_eq!(
        rig.num("M163"),
        12_000.0 * D_UNITS,
        "takes effect on the next servo cycle"
    );
    rig.run(2);
    assert_eq!(rig.num("M163"), 100.0 * D_UNITS);
    settle(&mut rig, 10_000);
    assert_eq!(rig.cmd("&1B5 #1HMZ &1R"), "");
    run_out(&mut rig, 10_000);
}

/// Item 11, seed 6590-6604: `$*` with Ix10 = 0 kills the motor, zeroes the actual position
/// and the position bias, and clears home complete.
#[test]
fn abs_read_with_ix10_zero_zeroes_the_actual_position() {
    let mut rig = rig();
    rig.cmd("#1J=3000");
    settle(&mut rig, 8000);
    rig.cmd("&1 #1->X+250 #1HMZ");
    rig.run(5);
    assert_ne!(rig.status(1).1 & W2_HOME_COMPLETE, 0);
    assert_reported(&mut rig, 250.0);
    assert_eq!(rig.cmd("I110=0 #1$*"), "");
    rig.run(5);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_OPEN_LOOP, 0, "killed");
    assert_eq!(w2 & W2_HOME_COMPLETE, 0);
    assert!(rig.num("#1P").abs() < 1.0, "actual position zeroed");
    assert_eq!(rig.cmd("M164->D:$0813 M164"), "0");
    // The plant has not moved: the zero is where the motor stood.
    assert!((rig.node_position(0) - 3000.0).abs() < 5.0);
}

/// Item 10: position bias — `Z` (seed 10187-10202), `{axis}=` (7250-7270), `PSET`
/// (11441-11452), HMZ with an axis offset (8244-8246) — shows in `P`, `<CTRL-P>` (6224) and
/// D:$0813; the motor does not move.
#[test]
fn position_bias_renames_reported_positions() {
    let mut rig = rig();
    load(&mut rig, &["&1 #1->X", "M164->D:$0813 M161->D:$0028"]);
    rig.cmd("#1J=2000");
    settle(&mut rig, 8000);
    let node = rig.node_position(0);
    assert_eq!(rig.cmd("&1Z"), "");
    rig.run(3);
    assert_reported(&mut rig, 0.0);
    assert_eq!(rig.num("M164"), -2000.0 * D_UNITS);
    assert_eq!(
        rig.num("M161"),
        2000.0 * D_UNITS,
        "motor commanded unchanged"
    );
    assert_eq!(rig.cmd("X=500"), "");
    rig.run(3);
    assert_reported(&mut rig, 500.0);
    let f = rig.num("#1F");
    let mut s = Session::default();
    let r = rig.card().control_char(&mut s, 0x10);
    let first: f64 = String::from_utf8_lossy(&r)
        .split(' ')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!((first + f - 500.0).abs() < 0.25, "CTRL-P {first}");
    assert!((rig.node_position(0) - node).abs() < 0.5, "no motion");
    // A program move to X600 goes 100 counts from here; PSET renames in the program.
    load(
        &mut rig,
        &[
            "OPEN PROG 6 CLEAR",
            "LINEAR ABS TA50 TS0 TM200",
            "X600",
            "PSET X0",
            "X50",
            "CLOSE",
        ],
    );
    rig.cmd("&1B6R");
    run_out(&mut rig, 10_000);
    assert_eq!(cmd_pos(&mut rig), 2150.0);
    assert_reported(&mut rig, 50.0);
    assert_eq!(
        rig.num("M164"),
        (-2100.0 * D_UNITS),
        "bias after PSET: 0 - 2100"
    );
    // HMZ with an axis offset: reported = offset − FE (seed 8244-8246).
    rig.cmd("#1->X+300 #1HMZ");
    rig.run(3);
    assert_reported(&mut rig, 300.0);
    assert_eq!(rig.num("M164"), 300.0 * D_UNITS);
    assert_eq!(rig.num("M161"), 0.0);
    // X0 is the home position now: motor commanded 0, reported 300.
    load(
        &mut rig,
        &[
            "OPEN PROG 7 CLEAR",
            "LINEAR ABS TA50 TS0 TM200",
            "X10",
            "CLOSE",
        ],
    );
    rig.cmd("&1B7R");
    run_out(&mut rig, 10_000);
    assert_reported(&mut rig, 310.0);
    assert_eq!(cmd_pos(&mut rig), 10.0);
}

/// Item 12, seed 6962-6964, 7164-7172: `\` in a segmented LINEAR move holds the program with
/// the program-hold bit, lets the motors jog, refuses `R` away from the hold point (ERR017),
/// and resumes after `J=`.
#[test]
fn program_hold_allows_jogging_and_resumes() {
    let mut rig = rig();
    // I52: stop (and restart) in I10·I13/I52 = 100 ms (seed 1964-1972).
    rig.cmd("I13=10 I52=371370");
    three_moves(&mut rig);
    rig.cmd("&1B5R");
    rig.run(300);
    assert_eq!(rig.cmd("&1\\"), "");
    rig.run(600);
    let (w1, w2) = cs_status(&mut rig);
    assert_ne!(w2 & CS_W2_PROGRAM_HOLD, 0, "program hold bit");
    assert_eq!(w1 & 1, 0, "not running");
    assert_eq!(rig.num("%"), 0.0);
    let hold = rig.num("#1P");
    assert!(hold > 100.0 && hold < 4000.0, "held inside move 1: {hold}");
    let held = cmd_pos(&mut rig);
    assert_eq!(
        rig.num("M163") / D_UNITS,
        held,
        "J= target is the hold point"
    );
    assert_eq!(rig.cmd("#1J:500"), "", "jogging in hold");
    settle(&mut rig, 8000);
    assert_eq!(cmd_pos(&mut rig), held + 500.0);
    assert_eq!(rig.cmd("&1R"), "ERR017");
    rig.cmd("#1J=");
    settle(&mut rig, 8000);
    assert_eq!(rig.cmd("&1R"), "");
    assert_eq!(cs_status(&mut rig).1 & CS_W2_PROGRAM_HOLD, 0);
    run_out(&mut rig, 10_000);
    assert!((rig.num("#1P") - 12_000.0).abs() < BAND);
    // With I13 = 0, `\` is `H` (Ix95 slew, 1 s from 100 %): a feed hold, no program-hold
    // bit, R resumes.
    rig.cmd("I13=0 &1B5R");
    rig.run(100);
    rig.cmd("&1\\");
    rig.run(2400);
    assert_eq!(cs_status(&mut rig).1 & CS_W2_PROGRAM_HOLD, 0);
    assert_eq!(rig.num("%"), 0.0);
    let p = cmd_pos(&mut rig);
    rig.run(100);
    assert_eq!(cmd_pos(&mut rig), p, "held");
    assert_eq!(rig.cmd("&1R"), "");
    run_out(&mut rig, 10_000);
    assert_eq!(cmd_pos(&mut rig), 12_000.0);
}

/// Item 6, seed 6837: "stopped on position limit" stays set while stopped, even after the
/// switch clears, and is 0 "even when into a limit but moving out of it".
#[test]
fn stopped_on_limit_clears_when_moving_out() {
    let plant = NodePlantConfig {
        plus_limit: 3_000.0,
        ..NodePlantConfig::default()
    };
    let mut rig = rig_with(plant);
    rig.cmd("I122=16");
    rig.cmd("#1J=10000");
    rig.run(4000);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_POS_LIMIT, 0);
    assert_ne!(w2 & W2_STOPPED_ON_LIMIT, 0);
    rig.cmd("#1J-");
    rig.run(30);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_POS_LIMIT, 0, "still on the switch");
    assert_eq!(w2 & W2_STOPPED_ON_LIMIT, 0, "moving out of it");
    rig.run(2000);
    assert_eq!(rig.status(1).0 & W1_POS_LIMIT, 0, "off the switch");
    rig.cmd("#1J/");
    settle(&mut rig, 5000);
    assert_eq!(rig.status(1).1 & W2_STOPPED_ON_LIMIT, 0);
}
