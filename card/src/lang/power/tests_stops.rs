//! Issue 25 item 3, the stop and start forms of seed 000: `adisable` (L33233-33264),
//! `ddisable` (L34204, L40610-40659), `stop` (L445-446, L44192-44225), `start`/`begin` with
//! labels × 1,000,000 (L38930-38948, L39658-39702, L44040-44069), the look-ahead commands
//! `lh\` `lh<` `lh>` `lhpurge` (L966-971, L42511-42715), `step plc` (L38993-39025) and
//! `callsub`/`gosub` arguments (L39940-39964, L41477), `clear` of buffers (L33605-33656).

use super::tests_programs::T;

fn value(t: &mut T, q: &str) -> f64 {
    t.send(q)
        .trim_end()
        .rsplit('=')
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

/// Runs servo cycles until `q` reads `want` (at most `max`); the cycles it took.
fn until(t: &mut T, q: &str, want: f64, max: u64) -> u64 {
    for n in 0..max {
        if value(t, q) == want {
            return n;
        }
        t.run(1);
    }
    panic!("{q} never reached {want} in {max} cycles");
}

/// A program moving X from 0 to 3 (3000 counts) over 3 s (about 6,800 cycles).
fn long_move(t: &mut T) {
    t.load(&[
        "Motor[1].InvAmax=0",
        "open prog 14",
        "P20=P20+1",
        "linear abs ta10 ts0 tm3000",
        "X3",
        "dwell 10",
        "P21=P21+1",
        "close",
        "&1 b14 r",
    ]);
    t.run(200);
    assert_eq!(t.send("Coord[1].ProgRunning"), "Coord[1].ProgRunning=1\r\n");
}

#[test]
fn adisable_stops_under_control_then_disables_each_motor() {
    let mut t = T::new();
    t.ready_cs1();
    // A slow abort: 1/1000 count/ms² from 1 count/ms, about 1 s.
    t.load(&["Motor[1].AbortTa=-1000"]);
    long_move(&mut t);
    assert_eq!(t.send("&1 adisable"), "");
    t.run(2);
    // Decelerating in closed loop first (the abort).
    assert_eq!(value(&mut t, "Motor[1].ClosedLoop"), 1.0);
    assert_eq!(value(&mut t, "Motor[1].DesVelZero"), 0.0);
    let n = until(&mut t, "Motor[1].ClosedLoop", 0.0, 5000);
    assert_eq!(value(&mut t, "Coord[1].ProgRunning"), 0.0);
    assert_eq!(value(&mut t, "P21"), 0.0, "the program did not go on");
    assert!(n > 1000, "disabled only after its stop: {n} cycles");
    assert_eq!(value(&mut t, "Motor[1].AmpEna"), 0.0);
    // In a program: `adisable1` acts on C.S. 1 from a PLC addressing nothing else.
    t.load(&["#1j/"]);
    t.run(10);
    t.load(&[
        "open plc 5",
        "adisable1",
        "disable plc 5",
        "close",
        "enable plc 5",
    ]);
    t.run(50);
    assert_eq!(value(&mut t, "Motor[1].ClosedLoop"), 0.0);
}

#[test]
fn ddisable_disables_at_once_and_ends_the_program() {
    let mut t = T::new();
    t.ready_cs1();
    long_move(&mut t);
    assert_eq!(t.send("&1 ddisable"), "");
    t.run(2);
    assert_eq!(value(&mut t, "Motor[1].ClosedLoop"), 0.0);
    assert_eq!(value(&mut t, "Coord[1].ProgRunning"), 0.0);
    assert_eq!(value(&mut t, "P21"), 0.0, "the program did not go on");
    // A disabled C.S. is left as it is; `ddisable` of a list from a program.
    assert_eq!(t.send("&1 ddisable"), "");
    t.load(&["#1j/"]);
    t.run(10);
    t.load(&[
        "open plc 5",
        "ddisable1,2",
        "disable plc 5",
        "close",
        "enable plc 5",
    ]);
    t.run(5);
    assert_eq!(value(&mut t, "Motor[1].ClosedLoop"), 0.0);
}

#[test]
fn stop_ends_the_program_and_rewinds_it_to_its_top() {
    let mut t = T::new();
    t.ready_cs1();
    long_move(&mut t);
    assert_eq!(t.send("&1 stop"), "");
    // The move already calculated finishes; nothing after it runs.
    until(&mut t, "Coord[1].ProgRunning", 0.0, 20_000);
    let p = value(&mut t, "Motor[1].DesPos");
    assert!((p - 3000.0).abs() < 1.0, "{p}");
    assert_eq!(value(&mut t, "P21"), 0.0);
    // `r` starts at the top again (a `q` would resume after the move).
    t.load(&["&1 r"]);
    t.run(100);
    assert_eq!(value(&mut t, "P20"), 2.0);
    until(&mut t, "Coord[1].ProgRunning", 0.0, 20_000);
    assert_eq!(value(&mut t, "P21"), 1.0);
}

#[test]
fn start_and_begin_point_at_programs_and_labels() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "open prog 3",
        "P30=1",
        "N250000: P31=1",
        "close",
        "open prog 4",
        "P40=1",
        "close",
    ]);
    // `start3` = `b3r`; `&1 start` again runs the program the C.S. points at.
    assert_eq!(t.send("&1 start3"), "");
    t.run(20);
    assert_eq!((value(&mut t, "P30"), value(&mut t, "P31")), (1.0, 1.0));
    t.load(&["P30=0", "P31=0", "&1 start"]);
    t.run(20);
    assert_eq!(value(&mut t, "P30"), 1.0);
    // `b3.25`: label N250000 (fraction × 1,000,000).
    t.load(&["P30=0", "P31=0", "&1 b3.25 r"]);
    t.run(20);
    assert_eq!((value(&mut t, "P30"), value(&mut t, "P31")), (0.0, 1.0));
    // In a PLC: `start1:4`, `begin1:3.25` then `run1`.
    t.load(&[
        "open plc 6",
        "start1:4",
        "disable plc 6",
        "close",
        "enable plc 6",
    ]);
    t.run(20);
    assert_eq!(value(&mut t, "P40"), 1.0);
    t.load(&[
        "P31=0",
        "open plc 7",
        "begin1:(3+P50)",
        "run1",
        "disable plc 7",
        "close",
        "P50=0.25",
        "enable plc 7",
    ]);
    t.run(20);
    assert_eq!(value(&mut t, "P31"), 1.0);
    let r = t.send("&1 start9");
    assert!(
        r.ends_with(": error #25: NOT READY TO RUN: &1 start9\r\n"),
        "{r}"
    );
}

#[test]
fn look_ahead_quick_stop_holds_and_forward_resumes() {
    let mut t = T::new();
    t.ready_cs1();
    // The hold's ramp: 1 % of the time base per servo cycle (taken when the program starts).
    t.load(&["Coord[1].FeedHoldSlew=0.01"]);
    long_move(&mut t);
    assert_eq!(t.send("&1 lh\\"), "");
    until(&mut t, "Motor[1].DesVelZero", 1.0, 5000);
    let held = value(&mut t, "Motor[1].DesPos");
    t.run(500);
    assert_eq!(value(&mut t, "Motor[1].DesPos"), held, "stays stopped");
    assert!(held < 2900.0, "stopped on the path: {held}");
    assert_eq!(t.send("&1 lh>"), "");
    until(&mut t, "Coord[1].ProgRunning", 0.0, 20_000);
    let p = value(&mut t, "Motor[1].DesPos");
    assert!((p - 3000.0).abs() < 1.0, "{p}");
    assert_eq!(value(&mut t, "P21"), 1.0, "the program ran to its end");
    // `lh<` is accepted on-line and in programs (a hold on this card, see docs/power-pmac.md "Stop and start forms").
    assert_eq!(t.send("&1 lh<"), "");
    t.load(&[
        "open plc 3",
        "lh\\1",
        "lh<1",
        "lh>1",
        "disable plc 3",
        "close",
    ]);
}

#[test]
fn lhpurge_stops_blending_as_a_dwell_does() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "Motor[1].InvAmax=0",
        "open prog 15",
        "linear abs ta10 ts0 tm100",
        "X0.2",
        "lhpurge",
        "P22=Motor[1].DesPos",
        "close",
        "&1 b15 r",
    ]);
    until(&mut t, "Coord[1].ProgRunning", 0.0, 5000);
    // The assignment after `lhpurge` ran only once the move had ended.
    assert!((value(&mut t, "P22") - 200.0).abs() < 1.0);
}

#[test]
fn step_plc_runs_one_line_then_pauses() {
    let mut t = T::new();
    t.load(&["open plc 3", "P10=P10+1", "P11=P11+1", "P12=P12+1", "close"]);
    assert_eq!(t.send("step plc 3"), "");
    t.run(5);
    assert_eq!((value(&mut t, "P10"), value(&mut t, "P11")), (1.0, 0.0));
    assert_eq!(value(&mut t, "Plc[3].Active"), 1.0);
    assert_eq!(value(&mut t, "Plc[3].Running"), 0.0);
    assert_eq!(t.send("step plc 3"), "");
    t.run(5);
    assert_eq!((value(&mut t, "P11"), value(&mut t, "P12")), (1.0, 0.0));
    // `resume plc` goes on from there: line 3, then whole scans.
    assert_eq!(t.send("resume plc 3"), "");
    t.run(3);
    assert_eq!(value(&mut t, "P12"), 3.0);
    assert_eq!(value(&mut t, "P10"), 3.0);
    // A PLC that does not exist is passed over; a running PLC stops continuous execution.
    assert_eq!(t.send("step plc 3,9"), "");
    t.run(5);
    let p = value(&mut t, "P10");
    t.run(5);
    assert_eq!(value(&mut t, "P10"), p, "paused after its step");
    // From a program.
    t.load(&[
        "open plc 4",
        "step plc 3",
        "disable plc 4",
        "close",
        "enable plc 4",
    ]);
    t.run(5);
    assert_eq!(value(&mut t, "P11"), 4.0);
}

#[test]
fn callsub_and_gosub_pass_letter_arguments_to_read() {
    let mut t = T::new();
    t.load(&[
        "open plc 2",
        "callsub 5000 E5",
        "P8=P7",
        "gosub 5000 E(P9+1)",
        "disable plc 2",
        "return",
        "N5000: read(E)",
        "P7=D5",
        "return",
        "close",
        "P9=6",
        "enable plc 2",
    ]);
    t.run(10);
    assert_eq!(value(&mut t, "P8"), 5.0);
    assert_eq!(value(&mut t, "P7"), 7.0);
}

/// Seed L33605-33656: `clear prog|plc|subprog n` is `open … close` (the buffer deleted), refused
/// as `open` is; `clear all buffers` deletes every program, PLC and kinematic routine once
/// nothing runs.
#[test]
fn clear_deletes_buffers_and_clear_all_buffers_every_one() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "open prog 3",
        "X1",
        "close",
        "open prog 4",
        "X2",
        "close",
        "open subprog 5",
        "P1=1",
        "close",
        "open plc 6",
        "P2=1",
        "close",
        "open forward (1)",
        "C6=L1/1000",
        "close",
    ]);
    assert_eq!(t.send("clear prog 3"), "");
    assert!(t.send("list prog 3").contains("error #21"), "deleted");
    assert_eq!(t.send("list prog 4"), "X2\r\n");
    assert_eq!(
        t.send("clear prog 99"),
        "",
        "an absent buffer: nothing to clear"
    );
    // An enabled PLC, a running program: #26, and the buffer stays.
    t.load(&["enable plc 6"]);
    let r = t.send("clear plc 6");
    assert!(
        r.ends_with(": error #26: PROGRAM RUNNING: clear plc 6\r\n"),
        "{r}"
    );
    let r = t.send("clear all buffers");
    assert!(
        r.ends_with(": error #26: PROGRAM RUNNING: clear all buffers\r\n"),
        "{r}"
    );
    t.load(&["disable plc 6", "clear plc 6"]);
    assert!(t.send("list plc 6").contains("error #21"));
    assert_eq!(t.send("clear all buffers"), "");
    for q in ["list prog 4", "list subprog 5", "list forward (1)"] {
        assert!(t.send(q).contains("error #21"), "{q}");
    }
    assert_eq!(t.send("buffer"), "");
}

/// Seed L545, L704-705, L33797: `pmatch` and `pclr` in programs and after `cx`.
#[test]
fn pmatch_and_pclr_in_programs_and_cx() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&["Motor[1].InvAmax=0", "#1j=700"]);
    t.run(3000);
    t.load(&[
        "open prog 16",
        "linear abs ta10 ts0 tm100",
        "pclr",
        "dwell 0",
        "P59 = Motor[1].DesPos",
        "X0.5",
        "dwell 0",
        "P60 = Motor[1].DesPos",
        "close",
        "&1 b16 r",
    ]);
    until(&mut t, "Coord[1].ProgRunning", 0.0, 5000);
    // `pclr` made the present position (700 counts) X0, the motor's zero there too (Power's
    // `pset` moves the motor zero, L43197-43199): it reads 0, then 500 at X0.5.
    let (p59, p60) = (value(&mut t, "P59"), value(&mut t, "P60"));
    assert!(p59.abs() < 1.0, "{p59}");
    assert!((p60 - 500.0).abs() < 1.0, "{p60}");
    // The motor jogged away: `pmatch` takes the program's axes to where the motor is.
    t.load(&["#1j=2000"]);
    t.run(3000);
    let at = value(&mut t, "Motor[1].DesPos");
    assert!(
        (at - 1300.0).abs() < 1.0,
        "jog targets are raw counts, reports biased: {at}"
    );
    t.load(&[
        "open prog 17",
        "linear inc ta10 ts0 tm100",
        "pmatch",
        "X1",
        "close",
        "&1 b17 r",
    ]);
    until(&mut t, "Coord[1].ProgRunning", 0.0, 5000);
    let p = value(&mut t, "Motor[1].DesPos");
    assert!((p - (at + 1000.0)).abs() < 1.0, "{p}");
    // `cx pmatch X1`: a rapid move from the matched position (`inc` is still the mode: 1 on
    // from where the motor is); `abs` then X1 is 1000.
    t.load(&["#1j=500"]);
    t.run(3000);
    let at = value(&mut t, "Motor[1].DesPos");
    assert_eq!(t.send("cx pmatch X1"), "");
    t.run(5000);
    let p = value(&mut t, "Motor[1].DesPos");
    assert!((p - (at + 1000.0)).abs() < 1.0, "{p}");
    assert_eq!(t.send("cx abs X1"), "");
    t.run(5000);
    let p = value(&mut t, "Motor[1].DesPos");
    assert!((p - 1000.0).abs() < 1.0, "{p}");
}

/// Seed L34990-35026: `&x g` gives each axis's distance to go in the move executing, after
/// `N{Nsync}` with `Coord[x].Ndisplay` = 1, and `No targets defined` while `TPSize` is 0.
#[test]
fn g_reports_the_distance_to_go() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "Motor[1].InvAmax=0",
        "open prog 18",
        "linear abs ta10 ts0 tm3000",
        "N430 X3",
        "close",
    ]);
    assert_eq!(t.send("&1g"), "No targets defined\r\n");
    t.load(&["Coord[1].TPSize=8", "&1 b18 r"]);
    t.run(1000);
    let r = t.send("&1g");
    let d: f64 = r.trim_end().strip_prefix('X').unwrap().parse().unwrap();
    let des = value(&mut t, "Motor[1].DesPos") / 1000.0;
    assert!((d - (3.0 - des)).abs() < 1e-3, "{r} at {des}");
    assert!(d > 1.0 && d < 2.9, "{d}");
    // The value is in the thread's D6 (X's axis index), as `dtogread` puts it.
    let d6 = value(&mut t, "D6");
    assert!((d6 - d).abs() < 1e-9);
    t.load(&["Coord[1].Ndisplay=1"]);
    assert!(t.send("&1g").starts_with("N430 X"));
    assert_eq!(t.send("Coord[1].Nsync"), "Coord[1].Nsync=430\r\n");
    until(&mut t, "Coord[1].ProgRunning", 0.0, 20_000);
    assert_eq!(t.send("&1g"), "N430 X0\r\n");
}

/// Seed L43188-43203, L43316-43330: `pstore` keeps the motors' `pset` offsets, `pload` puts
/// them back (before any `pstore`: the offsets from before the first `pset`).
#[test]
fn pload_restores_what_pstore_kept() {
    let mut t = T::new();
    t.ready_cs1();
    let p0 = value(&mut t, "Motor[1].ActPos");
    t.load(&[
        "open prog 19",
        "pset X5",
        "dwell 0",
        "P61 = Motor[1].ActPos",
        "pload",
        "dwell 0",
        "P62 = Motor[1].ActPos",
        "pset X7",
        "pstore",
        "pset X2",
        "pload",
        "dwell 0",
        "P63 = Motor[1].ActPos",
        "close",
        "&1 b19 r",
    ]);
    until(&mut t, "Coord[1].ProgRunning", 0.0, 5000);
    t.run(5);
    // X = counts / 1000: pset X5 puts the motor at 5000 in its new frame; the first pload
    // takes it back to where it was; after pstore at X7, pload undoes pset X2.
    let (p61, p62, p63) = (
        value(&mut t, "P61"),
        value(&mut t, "P62"),
        value(&mut t, "P63"),
    );
    assert!((p61 - 5000.0).abs() < 1.0, "{p61}");
    assert!((p62 - p0).abs() < 1.0, "{p62} {p0}");
    assert!((p63 - 7000.0).abs() < 1.0, "{p63}");
    // The axes follow: a move to X7.5 goes 500 counts on.
    t.load(&["open prog 20", "linear abs tm100 X7.5", "close", "&1 b20 r"]);
    until(&mut t, "Coord[1].ProgRunning", 0.0, 5000);
    let p = value(&mut t, "Motor[1].DesPos");
    assert!((p - 7500.0).abs() < 1.0, "{p}");
}
