//! Motion programs and PLCs in-process (issue 4 items 5, 6, 8, 9 and "bad input"): a `Card`
//! and a `ProgramEngine` with eight `Motor`s whose feedback equals their setpoint (a perfect
//! plant), no ring. Trajectories are checked cycle by cycle against analytic models written
//! here from the spec's rules (pmac-commands §5.3, pmac-variables §5.4), not from the code.

use mcc_card::{
    ActionKind, Card, FlagInputs, Motor, MotorCommand, MotorParams, Profile, ProgramEngine,
    Session, Space, TickInput, TripScope,
};

/// Servo cycle at the default I10, ms.
const DT: f64 = 3_713_707.0 / 8_388_608.0;

struct Rig {
    card: Card,
    eng: ProgramEngine,
    motors: Vec<Motor>,
    s: Session,
    /// Setpoints of every tick (per motor).
    log: Vec<Vec<Option<f64>>>,
}

impl Rig {
    fn new() -> Rig {
        let mut r = Rig {
            card: Card::new(Profile::Pmac2),
            eng: ProgramEngine::new(),
            motors: (0..8).map(|_| Motor::new()).collect(),
            s: Session::default(),
            log: Vec::new(),
        };
        r.cmd("I100=1 I200=1 I300=1 I400=1 I500=1 I600=1 I700=1 I800=1");
        r.cmd("#1J/#2J/#3J/#4J/#5J/#6J/#7J/#8J/");
        r.tick();
        r
    }

    fn cmd(&mut self, line: &str) -> String {
        let r = self.card.command_line(&mut self.s, line.as_bytes());
        String::from_utf8_lossy(&r)
            .split(['\r', '\n', '\u{6}', '\u{7}'])
            .filter(|x| !x.is_empty())
            .collect::<Vec<_>>()
            .join(" ")
    }

    fn prog(&mut self, text: &str) {
        for l in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
            let r = self.cmd(l);
            assert!(!r.contains("ERR"), "{l}: {r}");
        }
    }

    fn tick(&mut self) -> Vec<Option<f64>> {
        for a in self.card.take_actions() {
            let _ = self
                .eng
                .handle_action(&mut self.card.model, &self.motors, &a);
            if let ActionKind::Jog { .. } = a.kind {
                let p = MotorParams::from_state(&self.card.state, a.motor.get());
                self.motors[a.motor.index()].command(MotorCommand::Enable, &p);
            }
        }
        let (model, mut cmds) = self.card.split();
        let sp = self.eng.servo_tick(model, &mut cmds, &self.motors, 0, DT);
        for (k, m) in self.motors.iter_mut().enumerate() {
            let p = MotorParams::from_state(&self.card.state, k as u16 + 1);
            let target = sp[k].unwrap_or(m.commanded());
            let fb = ((target * 32.0).round() as i64 as u32) & 0xFF_FFFF;
            m.tick(
                &p,
                &TickInput {
                    feedback: fb,
                    flags: FlagInputs::default(),
                    dt_ms: DT,
                    program: sp[k],
                    background: true,
                    capture: None,
                },
            );
        }
        let (model, mut cmds) = self.card.split();
        self.eng.background(model, &mut cmds, &self.motors);
        self.log.push(sp.clone());
        sp
    }

    /// Tick until C.S. 1 is idle; returns the setpoints of motor `m` per tick since `from`.
    fn run_out(&mut self, max: usize) {
        for _ in 0..max {
            self.tick();
            if !self.eng.coord(1).is_some_and(|c| c.busy()) {
                return;
            }
        }
        panic!("still busy after {max} cycles");
    }

    /// Motor `m`'s setpoints (1-based) from log index `from` on (None → previous value).
    fn trace(&self, m: usize, from: usize) -> Vec<f64> {
        let mut last = 0.0;
        self.log[from..]
            .iter()
            .map(|v| {
                if let Some(x) = v[m - 1] {
                    last = x;
                }
                last
            })
            .collect()
    }

    fn cs_word2(&mut self) -> u32 {
        let t = self.cmd("&1??");
        u32::from_str_radix(&t[6..12], 16).unwrap()
    }
}

/// ∫ of the normalised velocity ramp over u ∈ [0, x]: TS = 0 (linear ramp, s = 0) or a full
/// S-curve (TS = TA/2, s = 0.5).
fn ramp_integral(x: f64, s_curve: bool) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return x - 0.5;
    }
    if !s_curve {
        return x * x / 2.0;
    }
    if x <= 0.5 {
        2.0 * x * x * x / 3.0
    } else {
        1.0 / 12.0 + (x - 0.5) + (2.0 / 3.0) * ((1.0 - x).powi(3) - 0.125)
    }
}

/// Blended LINEAR sequence from rest (spec: velocity v_i for T_i ms, each change spread over
/// TA centred on the move boundary; from rest the first window starts at 0): position at t.
fn linear_model(v: &[f64], t: &[f64], ta: f64, s_curve: bool, at: f64) -> f64 {
    let h = ta / 2.0;
    let mut c = h;
    let mut prev = 0.0;
    let mut p = 0.0;
    for (vi, ti) in v.iter().zip(t) {
        p += (vi - prev) * ta * ramp_integral((at - (c - h)) / ta, s_curve);
        prev = *vi;
        c += ti;
    }
    p + (-prev) * ta * ramp_integral((at - (c - h)) / ta, s_curve)
}

fn setup_xy(r: &mut Rig) {
    r.cmd("&1#1->1000X#2->1000Y");
}

#[test]
fn linear_f_ta_program_follows_the_spec_profile_and_reaches_points_on_time() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    r.prog(
        "OPEN PROG 1 CLEAR
         LINEAR ABS TA100 TS0 F10
         X10
         DWELL0
         F20
         X30
         F5
         X35
         CLOSE",
    );
    let start = r.log.len();
    assert_eq!(r.cmd("&1B1R"), "");
    r.run_out(40_000);
    let x = r.trace(1, start);
    // Part 1: 10 units at F10 → T = 1000 ms, stop: reaches X10 at T + TA = 1100 ms.
    let t1 = 1100.0;
    let n1 = (t1 / DT).ceil() as usize;
    for (k, &p) in x.iter().enumerate().take(n1) {
        let m = 1000.0 * linear_model(&[10.0 / 1000.0], &[1000.0], 100.0, false, k as f64 * DT);
        assert!((p - m).abs() < 0.01, "cycle {k}: {p} vs {m}");
    }
    let arrive = x.iter().position(|&p| p >= 10_000.0 - 1e-6).unwrap();
    assert!(
        (arrive as f64 - t1 / DT).abs() <= 1.0,
        "X10 at {arrive}, rule {}",
        t1 / DT
    );
    // Part 2 starts on the first cycle after the dwell: 20 units at F20 (1000 ms) blended into
    // 5 units at F5 (1000 ms), then the stop: X35 at T + TA after its start.
    let k2 = ((t1 + 1e-6) / DT).ceil() as usize;
    let v = [20.0 / 1000.0, 5.0 / 1000.0];
    for (k, &p) in x.iter().enumerate().skip(k2) {
        let m = 10_000.0
            + 1000.0 * linear_model(&v, &[1000.0, 1000.0], 100.0, false, (k - k2) as f64 * DT);
        assert!((p - m).abs() < 0.01, "cycle {k}: {p} vs {m}");
    }
    let end = x.iter().position(|&p| p >= 35_000.0 - 1e-6).unwrap();
    let rule = k2 as f64 + 2100.0 / DT;
    assert!(
        (end as f64 - rule).abs() <= 1.0,
        "X35 at {end}, rule {rule}"
    );
    assert!((x[x.len() - 1] - 35_000.0).abs() < 1e-6);
    assert_eq!(r.cmd("&1PC"), "P1:0");
}

#[test]
fn tm_move_with_full_s_curve_takes_tm_plus_ta() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    // TS50 with TA100: TA' = max(TA, 2·TS) = 100, pure S-curve; TM500: T = 500 ms whatever the
    // distance; the move lasts T + TA' = 600 ms.
    r.prog("OPEN PROG 2 CLEAR\nLINEAR INC TA100 TS50 TM500\nX4 Y-2\nCLOSE");
    let start = r.log.len();
    r.cmd("&1B2R");
    r.run_out(10_000);
    let (x, y) = (r.trace(1, start), r.trace(2, start));
    for k in 0..x.len() {
        let f = linear_model(&[1.0 / 500.0], &[500.0], 100.0, true, k as f64 * DT);
        assert!(
            (x[k] - 4000.0 * f).abs() < 0.01,
            "cycle {k}: {} vs {}",
            x[k],
            4000.0 * f
        );
        assert!((y[k] + 2000.0 * f).abs() < 0.01);
    }
    let end = x.iter().position(|&p| p >= 4000.0 - 1e-6).unwrap();
    assert!((end as f64 - 600.0 / DT).abs() <= 1.0, "{end}");
    // TA50 TS50: TS > TA/2 → the acceleration takes 2·TS = 100 ms: same profile.
    r.prog("OPEN PROG 3 CLEAR\nLINEAR INC TA50 TS50 TM500\nX4\nCLOSE");
    let start = r.log.len();
    r.cmd("&1B3R");
    r.run_out(10_000);
    let x2 = r.trace(1, start);
    let end2 = x2.iter().position(|&p| p >= 8000.0 - 1e-6).unwrap();
    assert!((end2 as f64 - 600.0 / DT).abs() <= 1.0, "{end2}");
}

#[test]
fn circle_ends_on_the_point_and_stays_on_the_radius() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    r.cmd("I13=10");
    // Semicircle about (5,0) from (0,0) to (10,0): radius 5 units = 5000 counts.
    r.prog("OPEN PROG 4 CLEAR\nABS CIRCLE1 TA100 TS0 F5\nX10 Y0 I5 J0\nCLOSE");
    let start = r.log.len();
    r.cmd("&1B4R");
    r.run_out(20_000);
    let (x, y) = (r.trace(1, start), r.trace(2, start));
    let mut worst: f64 = 0.0;
    for k in 0..x.len() {
        let rad = ((x[k] - 5000.0).powi(2) + y[k].powi(2)).sqrt();
        worst = worst.max((rad - 5000.0).abs());
    }
    assert!(worst <= 0.5, "radius error {worst} counts");
    assert!((x[x.len() - 1] - 10_000.0).abs() < 1e-6 && y[y.len() - 1].abs() < 1e-6);
    // CIRCLE1 is clockwise about NORMAL K-1 (looking from +Z down: counter-clockwise in XY
    // as seen with Z towards the viewer): the path goes through y > 0 or y < 0 only.
    let ext = y
        .iter()
        .fold(0.0f64, |a, &v| if v.abs() > a.abs() { v } else { a });
    assert!((ext.abs() - 5000.0).abs() < 1.0, "apex {ext}");
    assert!(y.iter().all(|&v| v * ext >= -1e-6));
}

#[test]
fn pvt_passes_every_point_with_the_programmed_velocity() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    // PVT200: segments of 200 ms; velocities in units per Ix90 (1000) ms.
    r.prog("OPEN PROG 5 CLEAR\nINC PVT200\nX10:50\nX20:100\nX10:0\nCLOSE");
    let start = r.log.len();
    r.cmd("&1B5R");
    r.run_out(10_000);
    let x = r.trace(1, start);
    // Hermite segments (counts, ms): p(τ)=p0+v0τ+aτ²/2+jτ³/6, a=(6Δp−2T(2v0+v1))/T², j=(6T(v0+v1)−12Δp)/T³.
    let pts = [
        (0.0, 0.0),
        (10_000.0, 50.0),
        (30_000.0, 100.0),
        (40_000.0, 0.0),
    ];
    let t = 200.0;
    let model = |at: f64| -> (f64, f64) {
        let seg = ((at / t).floor() as usize).min(2);
        let tau = at - seg as f64 * t;
        let (p0, v0) = (pts[seg].0, pts[seg].1);
        let (p1, v1) = (pts[seg + 1].0, pts[seg + 1].1);
        let dp = p1 - p0;
        let a = (6.0 * dp - 2.0 * t * (2.0 * v0 + v1)) / (t * t);
        let j = (6.0 * t * (v0 + v1) - 12.0 * dp) / (t * t * t);
        if at >= 3.0 * t {
            return (40_000.0, 0.0);
        }
        (
            p0 + v0 * tau + a * tau * tau / 2.0 + j * tau.powi(3) / 6.0,
            v0 + a * tau + j * tau * tau / 2.0,
        )
    };
    for (k, &p) in x.iter().enumerate() {
        let (m, _) = model(k as f64 * DT);
        assert!((p - m).abs() < 0.01, "cycle {k}: {p} vs {m}");
    }
    // At each segment end the position is the point and the velocity the programmed one.
    for (seg, &(p, v)) in pts.iter().enumerate().skip(1) {
        let te = seg as f64 * t;
        let k = (te / DT).round() as usize;
        let (mp, mv) = model(te);
        assert!((mp - p).abs() < 1e-6 && (mv - v).abs() < 1e-9);
        let vel = (x[k + 1] - x[k - 1]) / (2.0 * DT);
        assert!(
            (vel - v).abs() < 0.5,
            "segment {seg}: {vel} counts/ms vs {v}"
        );
    }
}

#[test]
fn two_axis_combination_moves_the_motors_by_the_matrix() {
    let mut r = Rig::new();
    r.cmd("&1#1->8660X-5000Y#2->5000X+8660Y");
    r.prog("OPEN PROG 6 CLEAR\nLINEAR ABS TA100 TS0 F10\nX10 Y5\nCLOSE");
    let start = r.log.len();
    r.cmd("&1B6R");
    r.run_out(20_000);
    let (m1, m2) = (r.trace(1, start), r.trace(2, start));
    // T = vector length / F; with I13 = 0 no motor may exceed Ix16 (32 counts/ms default):
    // motor 2 moves 93,300 counts, so T = 93,300 / 32 ms, the path kept.
    let len = (125.0f64).sqrt();
    let tt = (len / 10.0 * 1000.0).max(93_300.0 / 32.0);
    for k in 0..m1.len() {
        let f = linear_model(&[1.0 / tt], &[tt], 100.0, false, k as f64 * DT);
        let (x, y) = (10.0 * f, 5.0 * f);
        assert!(
            (m1[k] - (8660.0 * x - 5000.0 * y)).abs() < 0.05,
            "cycle {k}"
        );
        assert!(
            (m2[k] - (5000.0 * x + 8660.0 * y)).abs() < 0.05,
            "cycle {k}"
        );
    }
    assert!((m1[m1.len() - 1] - 61_600.0).abs() < 1e-6);
    assert!((m2[m2.len() - 1] - 93_300.0).abs() < 1e-6);
}

#[test]
fn a_trip_aborts_the_program_and_nothing_moves_again() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    r.prog("OPEN PROG 7 CLEAR\nLINEAR INC TA100 TS0 F10\nX100\nX100\nCLOSE");
    r.cmd("&1B7R");
    for _ in 0..2000 {
        r.tick();
    }
    let before = r.log.len();
    r.eng.on_trip(&mut r.card, 1, TripScope::Motor);
    assert_eq!(
        r.cs_word2() & (1 << 22),
        0,
        "a trip is not a run-time error"
    );
    assert_eq!(
        r.cmd("&1??").as_bytes()[5] & 1,
        b'0' & 1,
        "program no longer running"
    );
    let mut stopped_at = None;
    for k in 0..5000 {
        let sp = r.tick();
        if sp[0].is_none() {
            stopped_at = Some(k);
            break;
        }
    }
    let x = r.trace(1, before - 1);
    // Deceleration at Ix15 = 0.25 counts/ms² from 10 counts/ms: 40 ms, each step slower.
    let stop = stopped_at.expect("C.S. stopped");
    assert!(stop as f64 <= 40.0 / DT + 3.0, "{stop}");
    for w in x.windows(3) {
        assert!(w[2] - w[1] <= w[1] - w[0] + 1e-9);
    }
    let rest = r.motors[0].commanded();
    for _ in 0..500 {
        let sp = r.tick();
        assert!(sp.iter().all(Option::is_none));
    }
    assert_eq!(r.motors[0].commanded(), rest);
}

#[test]
fn plc_scans_park_in_while_loops_and_follow_i5_and_enable() {
    let mut r = Rig::new();
    r.prog(
        "OPEN PLC 1 CLEAR
         P1=P1+1
         WHILE (P2<3)
         P2=P2+1
         ENDWHILE
         P3=P3+1
         CLOSE",
    );
    r.cmd("ENABLE PLC 1");
    r.cmd("I5=0");
    r.tick();
    assert_eq!(r.cmd("P1 P2 P3"), "0 0 0", "I5=0 blocks background PLCs");
    r.cmd("I5=2");
    let expect = ["1 1 0", "1 2 0", "1 3 0", "1 3 1", "2 3 2", "3 3 3"];
    for e in expect {
        r.tick();
        assert_eq!(r.cmd("P1 P2 P3"), e);
    }
    r.cmd("DISABLE PLC 1");
    r.tick();
    assert_eq!(r.cmd("P1 P2 P3"), "3 3 3");
    r.cmd("P2=0 ENABLE PLC 1");
    r.tick();
    assert_eq!(r.cmd("P1 P2 P3"), "4 1 3", "ENABLE restarts at the top");
    // PLC 0 runs every servo tick, with I5 bit 0 only.
    r.prog("OPEN PLC 0 CLEAR\nP10=P10+1\nCLOSE");
    r.cmd("ENABLE PLC 0");
    r.ticks(5);
    assert_eq!(r.cmd("P10"), "0");
    r.cmd("I5=1");
    r.ticks(5);
    assert_eq!(r.cmd("P10"), "5");
}

impl Rig {
    fn ticks(&mut self, n: usize) {
        for _ in 0..n {
            self.tick();
        }
    }
}

#[test]
fn runaway_programs_and_plcs_stay_within_their_budgets() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    // A motion program looping without moves: two backward jumps per calculation pass.
    r.prog("OPEN PROG 8 CLEAR\nN1 P1=P1+1\nGOTO1\nCLOSE");
    r.cmd("&1B8R");
    r.ticks(9); // the R action is taken on the first of these ticks: 9 passes
    assert_eq!(r.cmd("P1"), "18");
    r.cmd("&1A");
    r.ticks(2);
    assert_eq!(r.cmd("P1"), "18");
    // A PLC longer than the per-scan budget (2000 instructions) runs in slices.
    let mut text = String::from("OPEN PLC 2 CLEAR\n");
    for _ in 0..2500 {
        text.push_str("P5=P5+1\n");
    }
    text.push_str("CLOSE");
    r.prog(&text);
    r.cmd("I5=2 ENABLE PLC 2");
    r.tick();
    assert_eq!(r.cmd("P5"), "2000");
    r.tick();
    assert_eq!(r.cmd("P5"), "2500");
    r.tick();
    assert_eq!(r.cmd("P5"), "4500");
}

fn runtime_error(r: &mut Rig) -> u32 {
    r.card.state.memory.read(Space::X, 0x0799)
}

#[test]
fn bad_programs_give_the_spec_errors_without_panicking() {
    let mut r = Rig::new();
    setup_xy(&mut r);
    // Structural error: CLOSE ERR003, R ERR016.
    r.cmd("OPEN PROG 20 CLEAR");
    r.cmd("IF (P1=0)");
    r.cmd("X1");
    assert!(r.cmd("CLOSE").contains("ERR003"));
    assert!(r.cmd("&1B20R").contains("ERR016"));
    r.cmd("OPEN PROG 20 CLEAR CLOSE");
    // No motors in the C.S.: ERR014.
    r.prog("OPEN PROG 21 CLEAR\nX1\nCLOSE");
    assert!(r.cmd("&2B21R").contains("ERR014"));
    // Impossible circle: chord 10 > 2R = 4 by more than I196 → run-time error + bit 21.
    r.cmd("I13=10 I196=0.1");
    r.prog("OPEN PROG 22 CLEAR\nCIRCLE1 F5 TA100\nX10 Y0 R2\nCLOSE");
    r.cmd("&1B22R");
    r.ticks(3);
    let w2 = r.cs_word2();
    assert_ne!(w2 & (1 << 22), 0, "run-time error bit");
    assert_ne!(w2 & (1 << 21), 0, "circle radius error bit");
    assert_eq!(runtime_error(&mut r), 8);
    // Zero TA and TS; negative TM; zero PVT time; missing GOTO label.
    for (n, body, code) in [
        (23, "TA0 TS0 X1", 8),
        (24, "TM-5 X1", 8),
        (25, "PVT0 X1:0", 8),
        (26, "GOTO77", 6),
        (27, "P(5000)=1", 7),
    ] {
        r.prog(&format!("OPEN PROG {n} CLEAR\nLINEAR\n{body}\nCLOSE"));
        assert_eq!(r.cmd(&format!("&1B{n}R")), "", "{body}");
        r.ticks(3);
        assert_ne!(r.cs_word2() & (1 << 22), 0, "{body}");
        assert_eq!(runtime_error(&mut r), code, "{body}");
        assert!(r
            .log
            .last()
            .unwrap()
            .iter()
            .all(|v| v.is_none_or(|p| p.abs() < 1e-9)));
    }
    // A later good run clears the bit.
    r.prog("OPEN PROG 28 CLEAR\nLINEAR TA10 TS0 TM10\nX0\nCLOSE");
    r.cmd("&1B28R");
    r.run_out(1000);
    assert_eq!(r.cs_word2() & (1 << 22), 0);
}
