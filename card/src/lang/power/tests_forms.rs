//! Issue 25 item 3, on-line command forms of seed 000: the long jog forms (`jog+`, `jog-`,
//! `jog/`, `jog=`; L565-624, L877-908, L20017-20019), a motor or C.S. list with no command
//! (error 20, L31649-31650, L31981), and grouped range queries (`P1..10:5`, L38087-38089).

use super::tests_programs::T;

#[test]
fn long_jog_forms_do_what_the_short_ones_do() {
    let mut t = T::new();
    t.ready_cs1();
    assert_eq!(t.send("#1jog+"), "");
    t.run(200);
    assert_eq!(
        t.send("Motor[1].DesVelZero"),
        "Motor[1].DesVelZero=0\r\n",
        "jogging"
    );
    assert_eq!(t.send("#1jog/"), "");
    t.run(800);
    assert_eq!(
        t.send("Motor[1].DesVelZero"),
        "Motor[1].DesVelZero=1\r\n",
        "stopped"
    );
    assert_eq!(t.send("#1jog=0"), "");
    t.run(3000);
    let r = t.send("#1p");
    let p: f64 = r.trim().parse().unwrap();
    assert!(p.abs() < 1.0, "jog=0 went back to 0: {r:?}");
    assert_eq!(t.send("#1jog-"), "");
    t.run(200);
    assert_eq!(t.send("Motor[1].DesVelZero"), "Motor[1].DesVelZero=0\r\n");
    assert_eq!(t.send("#1jog/"), "");
    // A word that only starts like a jog is no jog.
    assert!(t.send("#1jogx").contains("error #20"), "jogx");
}

#[test]
fn a_list_with_no_command_is_error_20() {
    let mut t = T::new();
    assert_eq!(
        t.send("#3..6"),
        "stdin:1:1: error #20: ILLEGAL CMD: #3..6\r\n"
    );
    assert_eq!(
        t.send("&3..6"),
        "stdin:2:1: error #20: ILLEGAL CMD: &3..6\r\n"
    );
    // One motor or C.S. alone is the modal address, as before; a list with a command works.
    assert_eq!(t.send("#3"), "");
    assert_eq!(t.send("&2"), "");
    assert_eq!(t.send("#3..4k"), "");
}

#[test]
fn range_queries_group_values_per_line() {
    let mut t = T::new();
    t.load(&["P1=7", "P2=3", "P3=5", "P4=2", "P5=11", "P6=8", "P7=33"]);
    assert_eq!(t.send("P1..10:5"), "P1=7,3,5,2,11\r\nP6=8,33,0,0,0\r\n");
    assert_eq!(t.send("P1..7:3"), "P1=7,3,5\r\nP4=2,11,8\r\nP7=33\r\n");
    assert_eq!(t.send("P1..3"), "P1=7\r\nP2=3\r\nP3=5\r\n");
    assert!(t.send("P1..3:0").contains("error #20"));
}

#[test]
fn axis_definition_reports_name_the_cs_when_it_changes() {
    // Seed L31680-31690, the example itself.
    let mut t = T::new();
    t.load(&[
        "&1 #1->500X",
        "&1 #2->500Y",
        "&1 #3->500Z",
        "&2 #4->500X",
        "&2 #5->500Y",
        "&2 #6->500Z",
        "&1",
    ]);
    assert_eq!(t.send("#1->"), "#1->500X\r\n");
    assert_eq!(t.send("#5->"), "&2#5->500Y\r\n");
    assert_eq!(
        t.send("#1..7->"),
        "#1->500X\r\n#2->500Y\r\n#3->500Z\r\n&2#4->500X\r\n#5->500Y\r\n#6->500Z\r\n&0#7->0\r\n"
    );
    // The addressed C.S. is still &1 afterwards.
    assert_eq!(t.send("#2->"), "#2->500Y\r\n");
}

#[test]
fn f_in_a_program_keeps_its_negative_in_coord_tm_and_tm_its_value() {
    // Seed L5133-5135: `tm{data}` sets Coord[x].Tm to data, `F{data}` to −data.
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["open prog 6", "linear abs ta10 ts0 F12.5", "X0.5", "close"]);
    assert_eq!(t.send("&1 b6 r"), "");
    t.run(400);
    assert_eq!(t.send("Coord[1].Tm"), "Coord[1].Tm=-12.5\r\n");
    t.load(&["open prog 7", "linear abs ta10 ts0 tm150", "X0", "close"]);
    assert_eq!(t.send("&1 b7 r"), "");
    t.run(400);
    assert_eq!(t.send("Coord[1].Tm"), "Coord[1].Tm=150\r\n");
}

/// Seed L37656-37661 and L37737-37744: `open plc n` only of a disabled PLC, `open prog n`
/// only of a program no C.S. runs or holds suspended (`a` ends it); another program may be
/// opened while one runs. Refusals are error 26 and change nothing.
#[test]
fn open_refuses_a_running_program_or_an_enabled_plc_only() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "open prog 1",
        "linear inc ta50 ts0 tm200",
        "while (1 < 2) {",
        "X1",
        "X-1",
        "}",
        "close",
        "open plc 3",
        "P30=P30+1",
        "close",
    ]);
    assert_eq!(t.send("&1 b1 r"), "");
    t.run(200);
    assert!(t.send("open prog 1").contains("error #26"), "running");
    assert!(
        t.send("list prog 1").contains("X-1"),
        "kept: {}",
        t.send("list prog 1")
    );
    // Another program: opened, written and closed while program 1 runs on.
    t.load(&["open prog 2", "X5", "close"]);
    assert!(t.send("list prog 2").contains("X5"));
    assert_eq!(t.send("Coord[1].ProgRunning"), "Coord[1].ProgRunning=1\r\n");
    // Held is still suspended; `a` ends it.
    assert_eq!(t.send("&1 h"), "");
    t.run(200);
    assert!(t.send("open prog 1").contains("error #26"), "held");
    assert_eq!(t.send("&1 a"), "");
    t.run(400);
    t.load(&["open prog 1", "X2", "close"]);
    assert!(t.send("list prog 1").contains("X2"));
    // A PLC: refused while enabled (it keeps running), accepted once disabled.
    assert_eq!(t.send("enable plc 3"), "");
    t.run(20);
    assert!(t.send("open plc 3").contains("error #26"), "enabled PLC");
    let before = t.send("P30");
    t.run(20);
    assert_ne!(t.send("P30"), before, "the PLC still runs");
    assert_eq!(t.send("disable plc 3"), "");
    t.load(&["open plc 3", "P31=1", "close"]);
    assert!(t.send("list plc 3").contains("P31=1"));
}

/// Seed L19985-20024: with `Sys.NoShortCmds = 1` the short action commands (`j+`, `k`, `r`,
/// `a`, `b`, `hm` …) are error 20 and do nothing, the long forms work, the commands before
/// the short one on the line still run; back at 0 both forms work.
#[test]
fn no_short_cmds_refuses_the_short_action_forms() {
    let mut t = T::new();
    t.ready_cs1();
    assert_eq!(t.send("Sys.NoShortCmds"), "Sys.NoShortCmds=0\r\n");
    assert_eq!(t.send("Sys.NoShortCmds=1"), "");
    for short in [
        "#1j+", "#1k", "&1r", "&1a", "&1b1", "#1hm", "#1j=100", "&1h",
    ] {
        let r = t.send(short);
        assert!(r.contains("error #20: ILLEGAL CMD"), "{short}: {r:?}");
    }
    t.run(100);
    assert_eq!(
        t.send("Motor[1].DesVelZero"),
        "Motor[1].DesVelZero=1\r\n",
        "the refused jog did nothing"
    );
    // What comes before the short form on the line runs.
    let r = t.send("P5=3 #1j+");
    assert!(r.contains("error #20"), "{r:?}");
    assert_eq!(t.send("P5"), "P5=3\r\n");
    // The long forms.
    assert_eq!(t.send("#1jog+"), "");
    t.run(100);
    assert_eq!(t.send("Motor[1].DesVelZero"), "Motor[1].DesVelZero=0\r\n");
    assert_eq!(t.send("#1jog/"), "");
    assert_eq!(t.send("#1kill"), "");
    assert_eq!(t.send("Sys.NoShortCmds=0"), "");
    assert_eq!(t.send("#1j/"), "", "short forms again");
}

/// Seed L31838-31846: `%` reports the C.S.'s time-base override; a C.S. with no motor
/// assigned always reports 0.
#[test]
fn override_of_a_cs_without_motors_is_0() {
    let mut t = T::new();
    t.ready_cs1();
    assert_eq!(t.send("&2 %"), "0\r\n");
    assert_eq!(t.send("&2 %50"), "");
    assert_eq!(t.send("&2 %"), "0\r\n", "still no motor");
    assert_eq!(t.send("&1 %"), "100\r\n");
    assert_eq!(t.send("&1 %40"), "");
    assert_eq!(t.send("&1 %"), "40\r\n");
}

/// Seed L412-416: `&x disable` opens the loop and drops the amplifier of every motor
/// assigned to an axis of C.S. x, `&x enable` closes them again; other motors are left
/// alone, `enable plc` / `disable plc` keep their meaning.
#[test]
fn cs_enable_and_disable_act_on_the_cs_motors() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["Motor[2].ServoCtrl=1", "#2j/"]);
    t.run(20);
    let closed = |t: &mut T, x: u16| t.send(&format!("Motor[{x}].ClosedLoop"));
    assert_eq!(closed(&mut t, 1), "Motor[1].ClosedLoop=1\r\n");
    assert_eq!(closed(&mut t, 2), "Motor[2].ClosedLoop=1\r\n");
    assert_eq!(t.send("&1 disable"), "");
    t.run(5);
    assert_eq!(closed(&mut t, 1), "Motor[1].ClosedLoop=0\r\n");
    assert_eq!(t.send("Motor[1].AmpEna"), "Motor[1].AmpEna=0\r\n");
    assert_eq!(closed(&mut t, 2), "Motor[2].ClosedLoop=1\r\n", "not in &1");
    assert_eq!(t.send("&1 enable"), "");
    t.run(5);
    assert_eq!(closed(&mut t, 1), "Motor[1].ClosedLoop=1\r\n");
    assert_eq!(t.send("&2 disable"), "", "no motor in &2: nothing to do");
    assert_eq!(closed(&mut t, 2), "Motor[2].ClosedLoop=1\r\n");
    t.load(&["open plc 4", "P40=P40+1", "close", "enable plc 4"]);
    t.run(5);
    assert_ne!(t.send("P40"), "P40=0\r\n", "enable plc still enables a PLC");
}

/// Seed L33912-33975 and L34940-34962: `&x p|d|f|v` report each axis of the C.S. in user
/// units, `{letter}{value}` in the order X Y Z A B C U V W, solved from the motors' values
/// (`#1->1000X`: X = counts / 1000; `#2->-250Y+100`: Y = (counts - 100) / -250); a C.S.
/// without motors answers `No Motors`. A list reports each C.S. in turn.
#[test]
fn cs_reports_give_axis_letters_in_user_units() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["Motor[2].ServoCtrl=1", "&1 #2->-250Y+100", "#2j/"]);
    t.run(20);
    assert_eq!(t.send("#1j=2000"), "");
    t.run(3000);
    assert_eq!(t.send("#1p"), "2000\r\n");
    assert_eq!(t.send("&1p"), "X2 Y0.4\r\n");
    // Seed L33958-33962: the axis values stay in this thread's L(256 + Sys.MaxMotors + n),
    // n = 6 for X, 7 for Y (A 0, B 1, C 2, U 3, V 4, W 5, X 6 …).
    let max: u32 = t
        .send("Sys.MaxMotors")
        .trim_end()
        .rsplit('=')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(
        t.send(&format!("L({}) L({})", 256 + max + 6, 256 + max + 7)),
        format!("L{}=2\r\nL{}=0.4\r\n", 256 + max + 6, 256 + max + 7)
    );
    assert_eq!(t.send("&1d"), "X2 Y0.4\r\n");
    assert_eq!(t.send("&1f"), "X0 Y0\r\n");
    assert_eq!(t.send("&1v"), "X0 Y0\r\n");
    assert_eq!(t.send("&2p"), "No Motors\r\n");
    assert_eq!(t.send("&1..2d"), "X2 Y0.4 No Motors\r\n");
    // Moving: d - p = f per axis, v nonzero on X only.
    assert_eq!(t.send("#1j=0"), "");
    t.run(150);
    let axes = |t: &mut T, l: &str| -> Vec<f64> {
        t.send(l)
            .split_whitespace()
            .map(|w| w[1..].parse().unwrap())
            .collect()
    };
    let (p, d, f) = (
        axes(&mut t, "&1p"),
        axes(&mut t, "&1d"),
        axes(&mut t, "&1f"),
    );
    assert!((d[0] - p[0] - f[0]).abs() < 1e-3, "{d:?} - {p:?} = {f:?}");
    let v = axes(&mut t, "&1v");
    assert!(v[0] < 0.0 && v[1] == 0.0, "{v:?}");
}

/// Seed L23523 (`X25 Y15 F10 ta100 td200 ts50;`) and L40938 (`X100 F20;` "move out" at F20):
/// a move's own `F`/`tm` written after its axis words govern it; after a `;` they are the next
/// statement's. With the seed's default `Coord[x].Tm` = -1 (1 unit/s) the difference is
/// 20 to 1 in time.
#[test]
fn a_feedrate_on_the_move_statement_governs_that_move() {
    let mut t = T::new();
    t.ready_cs1();
    // No acceleration limit (the default 10 ms²/count would stretch the ramps to 200 ms).
    t.load(&["Motor[1].InvAmax=0"]);
    t.load(&["open prog 8", "linear abs ta10 ts0", "X1 F20", "close"]);
    assert_eq!(t.send("&1 b8 r"), "");
    // 1,000 counts at 20 units/s (20 counts/ms): about 60 ms, 140 cycles.
    t.run(400);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=1000\r\n");
    assert_eq!(t.send("Coord[1].Tm"), "Coord[1].Tm=-20\r\n");
    t.load(&["open prog 9", "linear abs ta10 ts0 F1", "X0; F20", "close"]);
    assert_eq!(t.send("&1 b9 r"), "");
    // At F1 the way back takes a second: still under way after 400 cycles (177 ms).
    t.run(400);
    let r = t.send("Motor[1].DesPos");
    let p: f64 = r.trim_end().rsplit('=').next().unwrap().parse().unwrap();
    assert!(p > 700.0 && p < 900.0, "{r:?}");
}

/// Seed L36069-36083: `jog` starts an indefinite jog at the motor's present velocity, taking a
/// motor moving in open loop (`out`) into closed loop without a jolt; a motor already jogging
/// is left alone.
#[test]
fn jog_alone_keeps_the_present_velocity_in_closed_loop() {
    let mut t = T::new();
    t.ready_cs1();
    let num = |t: &mut T, q: &str| -> f64 {
        let r = t.send(q);
        r.trim_end().rsplit('=').next().unwrap().parse().unwrap()
    };
    assert_eq!(t.send("#1out5"), "");
    t.run(400);
    let v_open = num(&mut t, "Motor[1].ActVel");
    assert!(v_open > 0.5, "moving in open loop: {v_open} counts/cycle");
    assert_eq!(num(&mut t, "Motor[1].ClosedLoop"), 0.0);
    assert_eq!(t.send("#1jog"), "");
    t.run(200);
    assert_eq!(num(&mut t, "Motor[1].ClosedLoop"), 1.0);
    let v = num(&mut t, "Motor[1].ActVel");
    assert!((v / v_open - 1.0).abs() < 0.05, "{v} vs {v_open}");
    // Still going (an indefinite jog), at the same commanded velocity.
    let p0 = num(&mut t, "Motor[1].DesPos");
    t.run(100);
    let p1 = num(&mut t, "Motor[1].DesPos");
    assert!(((p1 - p0) / 100.0 / v_open - 1.0).abs() < 0.05, "{p0} {p1}");
    // Already jogging: `jog` changes nothing (a `j+` would go to JogSpeed).
    assert_eq!(t.send("jog"), "");
    t.run(100);
    let p2 = num(&mut t, "Motor[1].DesPos");
    assert!(((p2 - p1) / (p1 - p0) - 1.0).abs() < 1e-6, "{p1} {p2}");
    assert_eq!(t.send("#1j/"), "");
}

/// Seed L34166-34171, L36512-36518, L37461-37466: a variable selection takes one value
/// (computed once), an M-variable selection one definition; `first..last:n` is a query form
/// only; a selection past the family is refused and sets nothing.
#[test]
fn range_assignments_and_m_definition_ranges() {
    let mut t = T::new();
    t.load(&[
        "P1=2 P25=16",
        "P10..12=P1+5",
        "P30,3=-7",
        "P30,3,3=sqrt(P25)",
        "Q5..6=P1",
    ]);
    assert_eq!(t.send("P10..12"), "P10=7\r\nP11=7\r\nP12=7\r\n");
    assert_eq!(t.send("P30..36:7"), "P30=4,-7,-7,4,0,0,4\r\n");
    assert_eq!(t.send("Q5..6"), "Q5=2\r\nQ6=2\r\n");
    // The value is computed before the first variable is set: `P1..3=P1+1` sets all to 3.
    t.load(&["P1..3=P1+1"]);
    assert_eq!(t.send("P1..3"), "P1=3\r\nP2=3\r\nP3=3\r\n");
    assert!(t.send("P1..10:5=0").contains("error #20"));
    // Past the P-variables: refused before any is set.
    t.load(&["P65535=9"]);
    assert!(t.send("P65534..65536=1").contains("error #21"));
    assert_eq!(t.send("P65534..65535"), "P65534=0\r\nP65535=9\r\n");
    assert_eq!(t.send("P1"), "P1=3\r\n");
    t.load(&["M80..82->*s.16", "M80..82=-3"]);
    assert_eq!(
        t.send("M80..82->"),
        "M80->*s.16\r\nM81->*s.16\r\nM82->*s.16\r\n"
    );
    assert_eq!(t.send("M80,3"), "M80=-3\r\nM81=-3\r\nM82=-3\r\n");
    // The whole family at once (the seed's "clear all M-variable definitions").
    t.load(&["M0..16383->*"]);
    assert_eq!(t.send("M81->"), "M81->*\r\n");
}

/// Seed L34500-34506, L34905-34910, L38175-38178, L38716-38720: `enable|disable|pause|resume
/// plc` take lists (`2,4,6`, `7..10`, `11,13..16,20`), on-line and in programs; compiled C
/// PLCs (`enable bgcplc`) are not supported (27).
#[test]
fn plc_control_takes_lists_on_line_and_in_programs() {
    let mut t = T::new();
    for n in [2, 4, 7, 8, 9, 10] {
        t.load(&[
            &format!("open plc {n}"),
            &format!("P{} = P{} + 1", 100 + n, 100 + n),
            "close",
        ]);
    }
    t.load(&["enable plc 2,4", "enable plc 7..9"]);
    t.run(5);
    let active = |t: &mut T| -> Vec<bool> {
        [2, 4, 7, 8, 9, 10]
            .iter()
            .map(|n| {
                let r = t.send(&format!("Plc[{n}].Active"));
                r.trim_end().ends_with("=1")
            })
            .collect()
    };
    assert_eq!(active(&mut t), [true, true, true, true, true, false]);
    t.load(&["pause plc 2,7..8"]);
    let (p2, p4) = (t.send("P102"), t.send("P104"));
    t.run(5);
    assert_eq!(t.send("P102"), p2, "PLC 2 paused: P102 still");
    assert_ne!(t.send("P104"), p4, "PLC 4 runs on");
    let active_running = |t: &mut T, n: u32| {
        (
            t.send(&format!("Plc[{n}].Active")),
            t.send(&format!("Plc[{n}].Running")),
        )
    };
    assert_eq!(
        active_running(&mut t, 2),
        (
            "Plc[2].Active=1\r\n".to_string(),
            "Plc[2].Running=0\r\n".to_string()
        )
    );
    t.load(&["resume plc 2", "disable plc 4,7..9"]);
    assert_eq!(active(&mut t), [true, false, false, false, false, false]);
    assert!(t.send("enable plc 2..32").contains("error #21"));
    assert!(t.send("enable bgcplc 0").contains("error #27"));
    // A program does the same with a list.
    t.load(&[
        "open plc 20",
        "enable plc 4,7..9",
        "disable plc 20",
        "close",
        "enable plc 20",
    ]);
    t.run(5);
    assert_eq!(active(&mut t), [true, true, true, true, true, false]);
}

/// Seed L38644-38646, L43085-43086: a program assigns a selection of variables
/// (`P10..12=P1+5`, `P30,3=-7`, `P30,3,3=sqrt(P25)`, `P20,5,10++`), each in turn; one past
/// the family refuses the line.
#[test]
fn programs_assign_variable_selections() {
    let mut t = T::new();
    t.load(&[
        "P1=2 P25=16",
        "open plc 3",
        "P10..12=P1+5",
        "P30,3=-7",
        "P30,3,3=sqrt(P25)",
        "P20,3,10++",
        "disable plc 3",
        "close",
        "enable plc 3",
    ]);
    t.run(5);
    assert_eq!(t.send("P10..12"), "P10=7\r\nP11=7\r\nP12=7\r\n");
    assert_eq!(t.send("P30..36:7"), "P30=5,-7,-7,4,0,0,4\r\n");
    assert_eq!(t.send("P20,3,10"), "P20=1\r\nP30=5\r\nP40=1\r\n");
    t.load(&["open plc 4"]);
    assert!(t.send("P65534..65536=1").contains("error #21"));
}

/// Seed L36030-36066: `j=*` goes to `Motor[x].ProgJogPos`, `^*` is `Motor[x].JogOffset`.
#[test]
fn star_jogs_take_prog_jog_pos() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["Motor[1].ProgJogPos=1500", "Motor[1].InvAmax=0"]);
    assert_eq!(t.send("#1j=*"), "");
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=1500\r\n");
    assert_eq!(t.send("#1j:*"), "");
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=3000\r\n");
    // `^*` parses and takes the jog offset (no trigger here: the move ends at its target).
    t.load(&["Motor[1].JogOffset=10", "Motor[1].ProgJogPos=-500"]);
    assert_eq!(t.send("#1j=*^*"), "");
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=-500\r\n");
}

/// Seed L37530-37537: `&n open forward|inverse[,stack[,labels]]` addresses C.S. n; the
/// label count and a stack offset in range are accepted (a routine calls no subroutine).
#[test]
fn kinematic_buffers_open_with_a_cs_prefix_and_arguments() {
    let mut t = T::new();
    t.load(&["&4open forward,,2048", "close"]);
    assert_eq!(t.send("&"), "&4\r\n");
    t.load(&["&2open inverse,256", "close"]);
    t.load(&[
        "&2open forward,64",
        "close",
        "&12open forward,512,256",
        "close",
    ]);
    assert_eq!(t.send("&"), "&12\r\n");
    assert!(t.send("&2open forward,0").contains("error #21"));
}

/// Seed L39311-39346, L41864-41866, L42969-42975, L43310-43311: `abs(X,Y)`/`inc(X)` switch
/// only the axes named, `pset X…` redefines the present axis position, `normal K-1` sets the
/// plane; double-letter axes are not modelled (21).
#[test]
fn axis_lists_pset_and_normal_in_programs() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["Motor[1].InvAmax=0"]);
    t.load(&[
        "open prog 11",
        "normal K-1",
        "linear abs ta10 ts0 tm100",
        "inc(X)",
        "X0.5",
        "X0.5",
        "abs(X,Y)",
        "X0.25",
        "close",
    ]);
    assert_eq!(t.send("&1 b11 r"), "");
    t.run(1500);
    // inc: 0.5 + 0.5 = 1 (1000 counts); then abs again: 0.25.
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=250\r\n");
    t.load(&["open prog 12", "pset X2", "close"]);
    assert_eq!(t.send("&1 b12 r"), "");
    t.run(20);
    assert_eq!(t.send("&1p"), "X2\r\n");
    t.load(&["open prog 13"]);
    assert!(t.send("inc(I..KK)").contains("error #21"));
    t.load(&["open prog 13"]);
    assert!(t.send("normal KK-1").contains("error #21"));
}

/// Direct program commands (seed L40897-40900, L41910-42387, L42440-42441, L39280-39282):
/// a PLC jogs its addressed motor (`Ldata.Motor`) to a computed position, then kills a motor
/// by its list; each runs as the on-line command after the PLC's pass.
#[test]
fn direct_commands_in_a_plc_act_on_listed_or_addressed_motors() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "Motor[1].InvAmax=0",
        "P7=1500",
        "open plc 6",
        "Ldata.Motor = 1",
        "jog=(P7)",
        "disable plc 6",
        "close",
        "enable plc 6",
    ]);
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=1500\r\n");
    assert_eq!(t.send("Motor[1].ClosedLoop"), "Motor[1].ClosedLoop=1\r\n");
    t.load(&[
        "open plc 7",
        "kill1",
        "disable plc 7",
        "close",
        "enable plc 7",
    ]);
    t.run(5);
    assert_eq!(t.send("Motor[1].ClosedLoop"), "Motor[1].ClosedLoop=0\r\n");
    // `abort` of a C.S. list, `run` of a C.S.: the on-line forms.
    t.load(&["#1j/"]);
    t.run(5);
    t.load(&[
        "open prog 14",
        "linear abs ta10 ts0 tm3000",
        "X3",
        "close",
        "&1 b14",
        "open plc 8",
        "run1",
        "disable plc 8",
        "close",
        "enable plc 8",
    ]);
    t.run(300);
    assert_eq!(t.send("Coord[1].ProgRunning"), "Coord[1].ProgRunning=1\r\n");
    t.load(&[
        "open plc 9",
        "abort1",
        "disable plc 9",
        "close",
        "enable plc 9",
    ]);
    t.run(2000);
    assert_eq!(t.send("Coord[1].ProgRunning"), "Coord[1].ProgRunning=0\r\n");
    let p: f64 = t
        .send("Motor[1].DesPos")
        .trim_end()
        .rsplit('=')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(p < 2900.0, "aborted before X3: {p}");
}

/// Seed L912-917: `jogret={data}` jogs to the position and makes it the pre-jog position,
/// `jogret` returns there.
#[test]
fn jogret_returns_to_the_pre_jog_position() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["Motor[1].InvAmax=0", "#1jogret=800"]);
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=800\r\n");
    t.load(&["#1j=2000"]);
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=2000\r\n");
    t.load(&["#1jogret"]);
    t.run(3000);
    assert_eq!(t.send("Motor[1].DesPos"), "Motor[1].DesPos=800\r\n");
}

/// Seed L40935: `do {statement} while ({condition})` on one line.
#[test]
fn a_do_while_on_one_line_repeats_its_body() {
    let mut t = T::new();
    t.load(&[
        "open plc 10",
        "do P60++ while (P60 < 5)",
        "P61 = P60",
        "disable plc 10",
        "close",
        "enable plc 10",
    ]);
    // (A jump back ends a PLC scan, as for the block form: one pass a scan.)
    t.run(10);
    assert_eq!(t.send("P60..61"), "P60=5\r\nP61=5\r\n");
    t.load(&["open plc 11"]);
    assert!(t.send("do while (P1 < 2)").contains("error #20"));
}
