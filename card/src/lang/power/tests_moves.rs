//! Power `pvt`, `spline`, `td` and printf-style `send` in motion programs (seed L43340-43362,
//! L43937-43999, L44483-44520, L43796-43912) on the lockstep test card: motor 1 is X of
//! C.S. 1 at 1000 counts per unit; positions are its commanded positions, cycle by cycle.

use super::tests_programs::T;
use crate::servo::Servo;

/// Power motor 1's index among the servo's motors (Power numbers its motors from 0).
const MOTOR1: usize = 1;

/// Run `n` cycles, recording motor 1's commanded position relative to where it started.
fn trace(t: &mut T, n: usize) -> Vec<f64> {
    let p0 = t.servo.motors[MOTOR1].commanded();
    (0..n)
        .map(|_| {
            t.run(1);
            t.servo.motors[MOTOR1].commanded() - p0
        })
        .collect()
}

/// The time (ms, from the first sample) at which `tr` first rises through `level`, linearly
/// interpolated between samples.
fn crossing(tr: &[f64], level: f64, cyc: f64) -> f64 {
    for k in 1..tr.len() {
        if tr[k - 1] < level && tr[k] >= level {
            let f = (level - tr[k - 1]) / (tr[k] - tr[k - 1]);
            return ((k - 1) as f64 + f) * cyc;
        }
    }
    panic!("never reached {level}");
}

fn run_prog(t: &mut T, n: u32, lines: &[&str], cycles: usize) -> Vec<f64> {
    let open = format!("open prog {n}");
    let mut all = vec![open.as_str()];
    all.extend_from_slice(lines);
    all.push("close");
    t.load(&all);
    t.ready_cs1();
    assert_eq!(t.send(&format!("&1 b{n} r")), "");
    trace(t, cycles)
}

/// `pvt T` with `X{pos}:{vel}`: velocities in units per `Coord[x].FeedTime` ms (1000: units
/// per second). From rest, `X0:10` over 200 ms then `X0:0` are two Hermite cubics whose
/// extremes are ∓ T·v·4/27 = ∓0.2963 units (∓296.30 counts); `ta` does not change the
/// segment time in Power.
#[test]
fn pvt_moves_follow_position_velocity_time() {
    let mut t = T::new();
    let tr = run_prog(&mut t, 30, &["inc", "pvt200 ta50", "X0:10", "X0:0"], 1500);
    let min = tr.iter().copied().fold(f64::INFINITY, f64::min);
    let max = tr.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let peak = 200.0 * 0.01 * 4.0 / 27.0 * 1000.0;
    assert!((min + peak).abs() < 0.5, "min {min}");
    assert!((max - peak).abs() < 0.5, "max {max}");
    assert!(tr[tr.len() - 1].abs() < 1e-6, "end {}", tr[tr.len() - 1]);
    // The motion lasts the two segments: 400 ms.
    let cyc = Servo::cycle_ms(&t.card.model);
    let moving = tr.iter().filter(|p| p.abs() > 1e-9).count() as f64 * cyc;
    assert!((moving - 400.0).abs() < 1.5, "moving {moving} ms");
    // With `Coord[1].FeedTime=100` the same velocity is 1 unit per 100 ms.
    t.load(&[
        "Coord[1].FeedTime=100",
        "open prog 34",
        "inc pvt200",
        "X0:1",
        "X0:0",
        "close",
    ]);
    assert_eq!(t.send("&1 b34 r"), "");
    let tr = trace(&mut t, 1500);
    let min = tr.iter().copied().fold(f64::INFINITY, f64::min);
    assert!((min + peak).abs() < 0.5, "min {min} with FeedTime 100");
}

/// `spline T` sets SPLINE mode with its own segment time (not TA): one point from rest is a
/// uniform cubic B-spline of three 100 ms segments through 1/6 and 5/6 of the way at its
/// knots, 100 ms apart.
#[test]
fn spline_mode_uses_its_own_segment_time() {
    let mut t = T::new();
    let tr = run_prog(&mut t, 31, &["inc", "spline100 ta20", "X1"], 1200);
    let cyc = Servo::cycle_ms(&t.card.model);
    let k1 = crossing(&tr, 1000.0 / 6.0, cyc);
    let k2 = crossing(&tr, 5000.0 / 6.0, cyc);
    assert!((k2 - k1 - 100.0).abs() < 0.5, "knots {k1} {k2}");
    assert!((tr[tr.len() - 1] - 1000.0).abs() < 1e-6);
}

/// `td` sets the final deceleration apart from `ta`: a 400 ms move (2.5 counts/ms) from rest
/// with TA 100, TD 300, TS 0 passes its midpoint at 200 ms and is 93.75 counts short of the end
/// at its nominal end (v·TD/8), 200 ms later; `ta` makes the deceleration follow it again, and
/// `td0` with `ts0` stops with a step at the end point.
#[test]
fn td_sets_the_final_deceleration_time() {
    let mut t = T::new();
    let tr = run_prog(
        &mut t,
        32,
        &[
            "inc ts0 ta100 td300 tm400 X1",
            "dwell 10",
            "ta100 tm400 X1",
            "dwell 10",
            "td0 tm400 X1",
            "td7",
        ],
        5000,
    );
    let cyc = Servo::cycle_ms(&t.card.model);
    let mid = crossing(&tr, 500.0, cyc);
    let late = crossing(&tr, 906.25, cyc);
    assert!((late - mid - 200.0).abs() < 0.5, "td300: {mid} {late}");
    // With TD = TA = 100: 1000 − v·100/8 = 968.75 at the nominal end.
    let mid = crossing(&tr, 1500.0, cyc);
    let late = crossing(&tr, 1968.75, cyc);
    assert!((late - mid - 200.0).abs() < 0.5, "ta100: {mid} {late}");
    // TD 0: at full speed up to the end point.
    let mid = crossing(&tr, 2500.0, cyc);
    let late = crossing(&tr, 2999.0, cyc);
    assert!((late - mid - 199.6).abs() < 0.5, "td0: {mid} {late}");
    assert!((tr[tr.len() - 1] - 3000.0).abs() < 1e-6);
    // The elements follow: `ta` set both, `td` then Td alone.
    assert_eq!(
        t.send("Coord[1].Ta Coord[1].Td"),
        "Coord[1].Ta=100\r\nCoord[1].Td=7\r\n"
    );
}

/// `send n,"fmt",expr…` formats with C printf rules when it runs; escapes are resolved.
#[test]
fn send_formats_printf_style() {
    let mut t = T::new();
    t.load(&[
        "open prog 33",
        "P1 = 42 P2 = -3.5",
        r#"send 1,"n=%d x=%6.2f h=%04X %g%%\t",P1,P2,P1*6+3,0.0001"#,
        r#"send2 "plain \"q\" 100%% \x41\101""#,
        "close",
    ]);
    t.ready_cs1();
    let _ = t.card.model.take_output();
    assert_eq!(t.send("&1 b33 r"), "");
    t.run(20);
    let out = String::from_utf8(t.card.model.take_output()).unwrap();
    assert_eq!(out, "n=42 x= -3.50 h=00FF 0.0001%\t\rplain \"q\" 100% AA\r");
}

/// Bad input is refused at entry in the seed's terms (the buffer erased), never a panic.
#[test]
fn bad_pvt_spline_td_and_send_lines_are_refused() {
    let mut t = T::new();
    let many = format!("send 1,\"{}\"{}", "%d".repeat(33), ",1".repeat(33));
    for (line, code) in [
        ("pvt0", 21),
        ("pvt -5", 21),
        ("pvt 1e12", 21),
        ("spline 0.2", 21),
        ("spline 100 spline 200", 21),
        ("spline 100,200", 21),
        ("td -1", 21),
        ("td 1e9", 21),
        ("send 1,\"%d %d\",P1", 20),
        ("send 1,\"%d\",P1,P2", 20),
        ("send 1,\"abc", 20),
        ("send 1,\"abc\\", 20),
        ("send 1,\"%s\",P1", 20),
        ("send 1,\"%*d\",P1,P2", 20),
        ("send 1,\"%200d\",P1", 20),
        ("send 1,\"\\q\"", 20),
        ("send 1,\"\\400\"", 20),
        ("send 1,\"%d\",", 20),
        ("send 5,\"x\"", 21),
        (many.as_str(), 20),
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
    // A computed PVT time of 0 stops the program at run time.
    t.load(&[
        "P5 = 0",
        "open prog 10",
        "P6 = 1 pvt(P5) X1:0 P7 = 1",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b10 r"), "");
    t.run(100);
    assert_eq!(t.send("P6..7"), "P6=1\r\nP7=0\r\n");
}

/// Seed L39640-39646, L40925-40942, L41743-41750, L42700-42716: a full circle from centre
/// words alone (`J10`), `do` with its `while` on the next line, and the synchronous `++=`.
#[test]
fn full_circles_split_do_while_and_sync_increments() {
    let mut t = super::tests_programs::T::new();
    let _ = t.card.model.state.set_ivar(71, 13_107.0);
    t.ready_cs1();
    t.load(&["Motor[2].ServoCtrl=1", "&1 #2->1000Y"]);
    t.run(5);
    assert_eq!(t.send("#2j/"), "");
    t.run(20);
    t.load(&[
        "Motor[1].InvAmax=0",
        "Motor[2].InvAmax=0",
        // Circles need segmentation (0 makes them linear, seed L39636-39637).
        "Coord[1].SegMoveTime=1",
        "open prog 21",
        "abs linear ta10 ts0 tm100 X0 Y0",
        "circle1 F10",
        "J1",
        "dwell 0",
        "P70 = 1",
        "P71++=",
        "X0.5",
        "do dwell 10",
        "while (P70 < 1)",
        "P72 = 3",
        "do {",
        "P72 = P72 - 1",
        "}",
        "while (P72 > 0)",
        "close",
        "&1 b21 r",
    ]);
    // Half way round: the far side of the circle (Y = 2 units).
    let mut top: f64 = 0.0;
    for _ in 0..2000 {
        t.run(1);
        let y: f64 = t
            .send("Motor[2].DesPos")
            .trim_end()
            .rsplit('=')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        top = top.max(y);
    }
    assert!((top - 2000.0).abs() < 5.0, "{top}");
    for _ in 0..10_000 {
        if t.send("Coord[1].ProgRunning") == "Coord[1].ProgRunning=0\r\n" {
            break;
        }
        t.run(1);
    }
    assert_eq!(t.send("P71 P72"), "P71=1\r\nP72=0\r\n");
    // A `do` body whose `while` never comes: the buffer does not close (#20).
    t.load(&["open prog 22", "do dwell 10"]);
    assert!(t.send("close").contains("error #20"));
    // Only `while` may follow a `}` that closes a `do` (a bad line drops the buffer).
    t.load(&["open prog 23", "do {", "P1=1", "}"]);
    assert!(t.send("X1").contains("error #20"));
    t.load(&[
        "open prog 24",
        "do {",
        "P1=1",
        "}",
        "while (P1 == 0)",
        "close",
    ]);
    let listed = "do {\r\nP1=1\r\n}\r\nwhile (P1 == 0)\r\n";
    assert_eq!(t.send("list prog 24"), listed);
    // Rebuilt from that text after a save and load.
    let mut u = super::tests_units::reloaded(&mut t);
    assert_eq!(u.send("list prog 24"), listed);
}
