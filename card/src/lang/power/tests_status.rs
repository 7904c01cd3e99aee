//! Issue 25 items 2 and 3: status elements fed by the motion core every servo cycle
//! (`Sys.ServoCount`, `Sys.Time`, motor status bits and positions, C.S. program state and time
//! base), and a `dwell` that stops look-ahead while a `delay` does not (seed 000
//! L41027-41029, L41031-41034).

use super::tests_programs::T;

/// The number a query of `name` answers (`name=value`).
pub(super) fn value(t: &mut T, name: &str) -> f64 {
    let r = t.send(name);
    let v = r
        .trim_end()
        .rsplit('=')
        .next()
        .unwrap_or_else(|| panic!("{name}: {r:?}"));
    match v.strip_prefix('$') {
        Some(h) => u32::from_str_radix(h, 16).map(f64::from).ok(),
        None => v.parse().ok(),
    }
    .unwrap_or_else(|| panic!("{name} answered {r:?}, not a number"))
}

#[test]
fn servo_count_and_time_advance_every_servo_cycle() {
    let mut t = T::new();
    assert_eq!(value(&mut t, "Sys.ServoCount"), 0.0);
    t.run(250);
    assert_eq!(value(&mut t, "Sys.ServoCount"), 250.0);
    let period_ms = value(&mut t, "Sys.ServoPeriod");
    let time = value(&mut t, "Sys.Time");
    assert!(
        (time - 250.0 * period_ms / 1000.0).abs() < 1e-6,
        "Sys.Time {time} s after 250 cycles of {period_ms} ms"
    );
    // The seed's own timing idiom in a PLC: wait until ServoCount passes a mark.
    t.load(&[
        "open plc 4",
        "P40 = Sys.ServoCount + 100",
        "while (Sys.ServoCount < P40) {}",
        "P41 = P41 + 1",
        "disable plc 4",
        "close",
        "enable plc 4",
    ]);
    t.run(60);
    assert_eq!(value(&mut t, "P41"), 0.0, "the PLC waits for its mark");
    t.run(80);
    assert_eq!(value(&mut t, "P41"), 1.0, "the mark passed");
}

#[test]
fn motor_and_coord_status_elements_follow_a_move() {
    let mut t = T::new();
    t.ready_cs1();
    for (e, want) in [
        ("Motor[1].ClosedLoop", 1.0),
        ("Motor[1].AmpEna", 1.0),
        ("Motor[1].DesVelZero", 1.0),
        ("Motor[1].AmpFault", 0.0),
        ("Motor[1].FeFatal", 0.0),
        ("Coord[1].ProgRunning", 0.0),
        ("Coord[1].ProgActive", 0.0),
        ("Coord[1].ClosedLoop", 1.0),
        ("Motor[2].ClosedLoop", 0.0),
    ] {
        assert_eq!(value(&mut t, e), want, "{e} at rest");
    }
    // The bits are the same as the status words' bits.
    let w = value(&mut t, "Motor[1].Status[0]") as u32;
    assert_eq!(w >> 13 & 1, 1);
    assert_eq!(w >> 12 & 1, 1);
    t.load(&["open prog 3", "linear abs ta100 ts0 tm500", "X2", "close"]);
    assert_eq!(t.send("&1 b3 r"), "");
    t.run(300);
    assert_eq!(value(&mut t, "Coord[1].ProgRunning"), 1.0);
    assert_eq!(value(&mut t, "Coord[1].ProgActive"), 1.0);
    assert_eq!(value(&mut t, "Motor[1].DesVelZero"), 0.0, "moving");
    let act = value(&mut t, "Motor[1].ActPos");
    let des = value(&mut t, "Motor[1].DesPos");
    assert!(act > 10.0 && act < 2000.0, "mid-move ActPos {act}");
    assert!((des - act).abs() < 50.0, "DesPos {des} near ActPos {act}");
    // `#1d` (seed L33912-33970) is the desired position, `#1f` desired − actual: d − p = f.
    let num = |t: &mut T, l: &str| -> f64 { t.send(l).trim().parse().unwrap() };
    let (d, p, f) = (num(&mut t, "#1d"), num(&mut t, "#1p"), num(&mut t, "#1f"));
    assert!((d - p - f).abs() < 0.2, "d {d} - p {p} = f {f}");
    assert!((d - des).abs() < 0.2, "#1d {d} is Motor[1].DesPos {des}");
    t.run(1500);
    assert_eq!(
        value(&mut t, "Coord[1].ProgRunning"),
        0.0,
        "the program ended"
    );
    assert_eq!(value(&mut t, "Motor[1].DesVelZero"), 1.0);
    let des = value(&mut t, "Motor[1].DesPos");
    assert!(
        (des - 2000.0).abs() < 0.5,
        "DesPos {des} at the end (X2 = 2000 counts)"
    );
    let act = value(&mut t, "Motor[1].ActPos");
    assert!((act - 2000.0).abs() < 5.0, "ActPos {act} at the end");
    // %50: the desired time base is half the servo period.
    let period_ms = value(&mut t, "Sys.ServoPeriod");
    assert_eq!(t.send("&1 %50"), "");
    let tb = value(&mut t, "Coord[1].TimeBase");
    assert!((tb - period_ms / 2.0).abs() < 1e-9, "TimeBase {tb} at %50");
}

#[test]
fn a_dwell_stops_look_ahead_and_a_delay_does_not() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "open prog 5",
        "P50 = 1",
        "dwell 400",
        "P50 = 2",
        "P51 = 1",
        "delay 400",
        "P51 = 2",
        "dwell 10",
        "close",
    ]);
    let period_ms = value(&mut t, "Sys.ServoPeriod");
    let cycles = |ms: f64| (ms / period_ms).round() as u64;
    assert_eq!(t.send("&1 b5 r"), "");
    // Wait, then switch an output: P50 = 2 only once the dwell has run.
    t.run(cycles(200.0));
    assert_eq!(value(&mut t, "P50"), 1.0, "200 ms into the 400 ms dwell");
    t.run(cycles(150.0));
    assert_eq!(value(&mut t, "P50"), 1.0, "350 ms into the dwell");
    t.run(cycles(100.0));
    assert_eq!(value(&mut t, "P50"), 2.0, "after the dwell");
    // A delay does not stop look-ahead: the line after it is calculated at once.
    assert_eq!(value(&mut t, "P51"), 2.0, "the delay was looked past");
}
