//! Issue 14 items 14 and 15 with the servo loop running: a PMAC2 ring card and a station plant
//! on the lockstep `RingSim`. The `%` command register written by a PLC's M-variable, `LIST PE`
//! / `LIST PC` / `LIST PLC n,,` from the executing line, Ix89 after F/TM, `GATHER TRIGGER` on
//! MI2, "dwell in progress". Each test cites the seed (004) lines it checks.

use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;

/// `???` word 1 bit 19: data gathering on; bit 17: armed to start on MI2.
const G_GATHER_ON: u32 = 1 << 19;
const G_GATHER_ON_TRIGGER: u32 = 1 << 17;
/// `?` word 1 bit 15: dwell in progress.
const W1_DWELL: u32 = 1 << 15;

/// A PMAC2 ring card (I3=2 I6=1) with motors 1 and 2 closed at rest.
pub(crate) fn rig() -> Rig {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2 I6=1");
    rig.run(20);
    rig.cmd("#1J/ #2J/");
    rig.run(50);
    rig
}

/// Enter `lines` as program/PLC lines, one host line each (each becomes one stored line).
fn enter(rig: &mut Rig, open: &str, lines: &[&str]) {
    assert_eq!(rig.cmd(&format!("{open} CLEAR")), "");
    for l in lines {
        assert_eq!(rig.cmd(l), "", "line {l}");
    }
    assert_eq!(rig.cmd("CLOSE"), "");
}

/// A rig after `setup`, with `lines` entered into `open` and `start` sent.
fn started(setup: &str, open: &str, lines: &[&str], start: &str) -> Rig {
    let mut rig = rig();
    rig.cmd(setup);
    enter(&mut rig, open, lines);
    rig.cmd(start);
    rig
}

/// Motor 1's commanded position D:$0028, counts.
fn cmd_pos(rig: &mut Rig) -> f64 {
    rig.d_reg(1, 0x08)
}

fn global_word1(rig: &mut Rig) -> u32 {
    let s = rig.cmd("???");
    u32::from_str_radix(&s[..6], 16).unwrap()
}

/// Item 14, seed 6645-6650: "M197->X:$0806,24 … M197=P1*I10/100 ; Equivalent to &1%(P1)".
/// A PLC writing the M-variable changes C.S. 1's feedrate override: `%` reports it and the
/// program's motion freezes at 0 and goes on at 100.
#[test]
fn m_variable_on_the_percent_register_is_the_feedrate_override() {
    let mut rig = rig();
    // Ix94 = I10: the time base reaches a new % within one servo cycle.
    rig.cmd("I5=2 I194=3713707");
    rig.cmd("&1 #1->X M197->X:$0806,0,24,S P1=100");
    enter(
        &mut rig,
        "OPEN PLC 1",
        &["M197=P1*I10/100", "DISABLE PLC 1"],
    );
    enter(
        &mut rig,
        "OPEN PROG 1",
        &["LINEAR TA50 TS0 TM3000", "X3000"],
    );
    rig.cmd("&1B1R");
    rig.run(1000);
    let moving = cmd_pos(&mut rig);
    assert!(moving > 100.0, "the program moves: {moving}");
    rig.cmd("P1=0 ENABLE PLC 1");
    rig.run(20);
    assert_eq!(rig.cmd("&1%"), "0");
    assert_eq!(rig.cmd("M197"), "0");
    let frozen = cmd_pos(&mut rig);
    rig.run(300);
    assert!(
        (cmd_pos(&mut rig) - frozen).abs() < 1e-6,
        "% 0 from the PLC holds the trajectory: {frozen} then {}",
        cmd_pos(&mut rig)
    );
    rig.cmd("P1=50 ENABLE PLC 1");
    rig.run(20);
    // The register holds whole I10 units: 1856854 / 3713707 · 100 (the `%` reply reports it).
    assert!((rig.num("&1%") - 50.0).abs() < 1e-4);
    assert_eq!(rig.num("M197"), (50.0f64 * 3_713_707.0 / 100.0).round());
    let p0 = cmd_pos(&mut rig);
    rig.run(226); // 100 ms
    let d = cmd_pos(&mut rig) - p0;
    // TM3000 over 3000 counts: 1 count/ms at 100 %, so ≈ 50 counts in 100 ms at 50 %.
    assert!((d - 50.0).abs() < 2.0, "moved {d} counts in 100 ms at 50 %");
}

/// Item 15, seed 8738-8768: `LIST PE` lists from the line of the move executing, `LIST PC`
/// from the next line to be calculated, each first line `P{n}:{offset}:` as `PE` / `PC`
/// report; `LIST PE,` to the end of the program.
#[test]
fn list_pe_and_pc_list_from_the_executing_line() {
    let mut rig = rig();
    rig.cmd("&1 #1->X");
    enter(
        &mut rig,
        "OPEN PROG 5",
        &[
            "LINEAR TA50 TS0 TM400",
            "X100",
            "X200",
            "X300",
            "X400",
            "X500",
        ],
    );
    assert!(rig.cmd("&1B5 LIST PE").starts_with("P5:0:"));
    rig.cmd("&1R");
    rig.run(2000); // ≈ 885 ms: the third move (X300, 800-1200 ms) executes
    let pe = rig.cmd("&1PE");
    let pc = rig.cmd("&1PC");
    let list_pe = rig.cmd("&1LIST PE");
    let list_pc = rig.cmd("&1LIST PC");
    assert!(
        list_pe.starts_with(&format!("{pe}:")),
        "{list_pe} vs PE {pe}"
    );
    assert!(list_pe.ends_with("X300"), "executing: {list_pe}");
    assert!(
        list_pc.starts_with(&format!("{pc}:")),
        "{list_pc} vs PC {pc}"
    );
    assert!(!list_pe.contains('\r'), "LIST PE lists one line");
    let rest = rig.cmd("&1LIST PE,");
    let lines: Vec<&str> = rest.split('\r').collect();
    assert_eq!(lines[0], list_pe);
    assert!(
        lines[1].ends_with(":X400") && lines[2].ends_with(":X500"),
        "{rest}"
    );
    assert!(lines.last().unwrap().ends_with(":RET"), "{rest}");
    assert!(!rest.contains("X200"), "not from the top: {rest}");
}

/// Issue 26 item 10, seed 8759-8771: `LIST PE` starts at the line executing, not the line
/// calculated, wherever that line is: a move in a subroutine (`CALL`, the program number of
/// the subroutine's buffer), a `DWELL` (look-ahead stops at it), and the move after it.
#[test]
fn list_pe_follows_the_executing_line_into_subroutines_and_dwells() {
    let mut rig = rig();
    rig.cmd("&1 #1->X");
    enter(&mut rig, "OPEN PROG 8", &["X150", "RETURN"]);
    enter(
        &mut rig,
        "OPEN PROG 7",
        &[
            "LINEAR TA50 TS0 TM400",
            "X100",
            "CALL 8",
            "DWELL 1000",
            "P7=7",
            "X250",
            "X300",
        ],
    );
    rig.cmd("&1B7R");
    // 0-400 ms X100, 400-800 ms X150 (in PROG 8), then the dwell to 1800 ms.
    rig.run(1300); // ≈ 575 ms: the subroutine's move executes
    let list_pe = rig.cmd("&1LIST PE");
    assert!(
        list_pe.starts_with("P8:") && list_pe.ends_with(":X150"),
        "in the subroutine: {list_pe}"
    );
    assert!(
        list_pe.starts_with(&format!("{}:", rig.cmd("&1PE"))),
        "{list_pe}"
    );
    rig.run(1500); // ≈ 1240 ms: dwelling
    let list_pe = rig.cmd("&1LIST PE");
    assert!(
        list_pe.starts_with("P7:") && list_pe.ends_with(":DWE1000"),
        "dwelling: {list_pe}"
    );
    let pc = rig.cmd("&1LIST PC");
    // Look-ahead stops at the dwell (seed 004 L10735): the line after it is the next to
    // calculate, and nothing after it has run.
    assert!(pc.ends_with(":P7=7"), "look-ahead stops at the dwell: {pc}");
    assert_eq!(rig.cmd("P7"), "0", "calculated during the dwell");
    rig.run(1500); // ≈ 1900 ms: X250 executes
    let list_pe = rig.cmd("&1LIST PE");
    assert!(list_pe.ends_with(":X250"), "after the dwell: {list_pe}");
    assert_eq!(rig.cmd("P7"), "7");
    let rest = rig.cmd("&1LIST PE,");
    assert!(rest.ends_with(":RET") && rest.contains(":X300"), "{rest}");
    assert!(!rest.contains("X100") && !rest.contains("DWE"), "{rest}");
}

/// Item 15, seed 8785-8817: `LIST PLC 5,,1` lists the line the next scan starts with (the
/// WHILE a scan ended at ENDWHILE goes back to), `LIST PLC 5,,` from there to the end,
/// `LIST PLC 5,0` from the top.
#[test]
fn list_plc_with_an_empty_start_lists_from_the_next_line_to_execute() {
    let mut rig = started(
        "I5=2",
        "OPEN PLC 5",
        &["P1=0", "WHILE (P1<100000)", "P1=P1+1", "ENDWHILE"],
        "ENABLE PLC 5",
    );
    rig.run(10);
    assert!(rig.num("P1") >= 2.0);
    let top = rig.cmd("LIST PLC 5,0");
    let lines: Vec<&str> = top.split('\r').collect();
    assert!(lines[0].starts_with("0:P1=0"), "{top}");
    let next = rig.cmd("LIST PLC 5,,1");
    assert!(next.contains("WHILE") && !next.contains('\r'), "{next}");
    assert_eq!(next, lines[1], "the WHILE line, with its offset");
    let rest = rig.cmd("LIST PLC 5,,");
    assert_eq!(rest, lines[1..].join("\r"));
}

/// Item 15, seed 4541-4543: polled, Ix89 reports the most recently executed F or TM.
#[test]
fn ix89_reports_the_last_f_or_tm() {
    let mut rig = rig();
    rig.cmd("&1 #1->X");
    assert_eq!(rig.cmd("I189"), "1000");
    for (n, feed, end, reply) in [(2, "TM150", "X10", "150"), (3, "F12.5", "X0", "12.5")] {
        let feed = format!("LINEAR TA20 TS0 {feed}");
        enter(&mut rig, &format!("OPEN PROG {n}"), &[&feed, end]);
        rig.cmd(&format!("&1B{n}R"));
        rig.run(2000);
        assert_eq!(rig.cmd("I189"), reply, "after PROG {n}");
    }
}

/// Item 15, seed 7062 and 8173: `GATHER TRIGGER` sets `???` bit 17 and gathers nothing until
/// machine input MI2 (Y:$FFC2 bit 1, suggested M12) rises; then bit 17 clears, bit 19 sets
/// and the first sample is the servo cycle of the edge.
#[test]
fn gather_trigger_waits_for_mi2() {
    let mut rig = rig();
    rig.cmd("M12->Y:$FFC2,1,1 M12=0 M100->X:$0000,0,24");
    rig.cmd("DEFINE GATHER 64 I19=1 I20=1 I21=$400000");
    rig.cmd("GATHER TRIGGER");
    let w = global_word1(&mut rig);
    assert_eq!(w & (G_GATHER_ON | G_GATHER_ON_TRIGGER), G_GATHER_ON_TRIGGER);
    rig.run(50);
    assert_eq!(rig.cmd("LIST GATHER"), "", "nothing before MI2");
    assert_eq!(global_word1(&mut rig) & G_GATHER_ON, 0);
    let edge = rig.num("M12=1 M100");
    rig.run(10);
    let w = global_word1(&mut rig);
    assert_eq!(w & (G_GATHER_ON | G_GATHER_ON_TRIGGER), G_GATHER_ON);
    let data = rig.cmd("ENDGATHER LIST GATHER");
    let first = i64::from_str_radix(data.split(' ').next().unwrap(), 16).unwrap();
    assert!(
        (first as f64 - edge - 1.0).abs() <= 1.0,
        "first sample at servo count {first}, MI2 raised at {edge}"
    );
    assert_eq!(global_word1(&mut rig) & G_GATHER_ON, 0);
    // ENDGATHER disarms a trigger that never came.
    rig.cmd("M12=0 GATHER TRIGGER ENDGATHER");
    rig.run(2);
    rig.cmd("M12=1");
    rig.run(5);
    assert_eq!(
        global_word1(&mut rig) & (G_GATHER_ON | G_GATHER_ON_TRIGGER),
        0
    );
}

/// Item 15, seed 6820-6822: `?` word 1 bit 15 is 1 while the motor's C.S. executes a DWELL,
/// 0 during its moves and after.
#[test]
fn dwell_in_progress_bit_follows_the_dwell() {
    let mut rig = started(
        "&1 #1->X",
        "OPEN PROG 4",
        &["LINEAR TA20 TS0 TM100", "X20", "DWELL 300", "X0"],
        "&1B4R",
    );
    let (mut seen_dwell, mut seen_move) = (false, false);
    for _ in 0..160 {
        rig.run(10);
        let w1 = rig.status(1).0;
        let p = cmd_pos(&mut rig);
        if w1 & W1_DWELL != 0 {
            seen_dwell = true;
            assert!((p - 20.0).abs() < 1e-3, "dwell bit while moving at {p}");
        } else if p > 0.5 && p < 19.5 {
            seen_move = true;
        }
    }
    assert!(seen_dwell && seen_move);
    assert_eq!(rig.status(1).0 & W1_DWELL, 0, "cleared after the DWELL");
    assert!(cmd_pos(&mut rig).abs() < 1e-3, "program finished");
}
