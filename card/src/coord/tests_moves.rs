//! Move tests against independent models written here (issue 4 item 8): numerically
//! integrated PMAC velocity profiles, circle geometry, PVT boundary conditions.

use super::axes::{AxisTable, MotorAxisDef};
use super::cs::{CoordSystem, MoveWords};
use super::moves::{CsConfig, Mode, Modal, MotorLimits};
use super::CoordError;

const SERVO: f64 = 3_713_707.0 / 8_388_608.0; // ms per servo cycle at the default I10

enum It {
    Mv(MoveWords),
    Dwell(f64),
    Set(fn(&mut Modal)),
}

fn mv(v: &[(usize, f64)]) -> It {
    It::Mv(words(v))
}

fn words(v: &[(usize, f64)]) -> MoveWords {
    let mut w = MoveWords::default();
    for &(k, x) in v {
        w.pos[k] = Some(x);
    }
    w
}

/// C.S. 1 with motor k+1 defined as `scale`·axis k (k < 9).
fn cs(scales: &[(usize, f64)], cfg: CsConfig) -> CoordSystem {
    let mut t = AxisTable::new(8, 8);
    for (m, &(k, s)) in scales.iter().enumerate() {
        t.define(1, m as u16 + 1, MotorAxisDef::Linear { terms: vec![(k, s)], offset: 0.0 }).unwrap();
    }
    let n = scales.len();
    CoordSystem::new(cfg, t.cs_axes(1), &vec![0.0; n])
}

/// Feed the items as the look-ahead asks and record the motor positions of every cycle.
fn run(c: &mut CoordSystem, items: Vec<It>, max: usize) -> Vec<Vec<f64>> {
    let mut items = items.into_iter();
    let mut out = Vec::new();
    let mut done_feeding = false;
    for _ in 0..max {
        while !done_feeding && c.wants_moves() {
            match items.next() {
                None => done_feeding = true,
                Some(It::Mv(w)) => {
                    c.push_move(&w).unwrap();
                }
                Some(It::Dwell(t)) => {
                    c.dwell(t).unwrap();
                }
                Some(It::Set(f)) => f(&mut c.modal),
            }
        }
        out.push(c.tick().motors);
        if done_feeding && c.is_idle() {
            break;
        }
    }
    out
}

/// Independent model of a blended LINEAR sequence from rest (spec §5.3.2 / pmac-variables
/// §5.4): nominal constant velocities `v[i]` for `t[i]` ms, each velocity change spread over TA'
/// centred on the boundary, acceleration shaped by TS (linear rise TS, constant, linear fall),
/// integrated numerically. Returns the position at each servo cycle end 1..=n.
fn model(v: &[f64], t: &[f64], ta: f64, ts: f64, n: usize) -> Vec<f64> {
    let h = ta / 2.0;
    let s = ts / ta;
    let shape = |u: f64| {
        let ap = 1.0 / (1.0 - s);
        if !(0.0..=1.0).contains(&u) {
            0.0
        } else if u < s {
            ap * u / s
        } else if u > 1.0 - s {
            ap * (1.0 - u) / s
        } else {
            ap
        }
    };
    let mut steps = Vec::new();
    let mut c = h;
    let mut prev = 0.0;
    for (vi, ti) in v.iter().zip(t) {
        steps.push((c, vi - prev));
        prev = *vi;
        c += ti;
    }
    steps.push((c, -prev));
    let acc = |tt: f64| steps.iter().map(|&(c, dv)| dv * shape((tt - (c - h)) / ta) / ta).sum::<f64>();
    let dt: f64 = 0.01;
    let (mut p, mut vel, mut tt) = (0.0, 0.0, 0.0);
    let mut out = Vec::with_capacity(n);
    for k in 1..=n {
        let at = k as f64 * SERVO;
        while tt < at {
            let step = dt.min(at - tt);
            let (a0, am, a1) = (acc(tt), acc(tt + step / 2.0), acc(tt + step));
            let vm = vel + step / 2.0 * (a0 + am) / 2.0;
            let v1 = vel + step * (a0 + 4.0 * am + a1) / 6.0;
            p += step * (vel + 4.0 * vm + v1) / 6.0;
            vel = v1;
            tt += step;
        }
        out.push(p);
    }
    out
}

fn cfg() -> CsConfig {
    CsConfig { motors: vec![MotorLimits { ix16: 1e9, ix17: 1e9, ..MotorLimits::default() }; 8], ..CsConfig::default() }
}

fn arrival(trace: &[Vec<f64>], m: usize, target: f64) -> usize {
    trace.iter().position(|p| (p[m] - target).abs() < 1e-6).unwrap()
}

#[test]
fn linear_f_ta_ts_follows_model_and_arrives_on_time() {
    // 1000 counts/unit; TA100 TS20 F10: X5 takes T = 5/10 s = 500 ms, arrival at T + TA.
    let mut c = cs(&[(0, 1000.0)], cfg());
    let set: fn(&mut Modal) = |m| {
        m.set_ta(100.0).unwrap();
        m.set_ts(20.0).unwrap();
        m.set_f(10.0).unwrap();
    };
    let tr = run(&mut c, vec![It::Set(set), mv(&[(0, 5.0)])], 5000);
    let want = ((500.0 + 100.0) / SERVO).ceil() as usize;
    let k = arrival(&tr, 0, 5000.0);
    assert!((k + 1).abs_diff(want) <= 1, "arrived at cycle {} want {}", k + 1, want);
    let md = model(&[10.0], &[500.0], 100.0, 20.0, tr.len());
    for (i, (p, &m)) in tr.iter().zip(&md).enumerate() {
        assert!((p[0] - m).abs() < 1.0, "cycle {i}: {} vs model {m}", p[0]);
    }
}

#[test]
fn linear_corner_sequence_matches_blend_model() {
    // Two axes, X10 then Y5 then X0 (ABS) with F20 TA200 TS50: each corner is blended over TA.
    let mut c = cs(&[(0, 1000.0), (1, 1000.0)], cfg());
    let set: fn(&mut Modal) = |m| {
        m.set_ta(200.0).unwrap();
        m.set_ts(50.0).unwrap();
        m.set_f(20.0).unwrap();
    };
    let items = vec![It::Set(set), mv(&[(0, 10.0)]), mv(&[(1, 5.0)]), mv(&[(0, 0.0)])];
    let tr = run(&mut c, items, 20000);
    // X: +20 u/s for 500 ms, 0 for 250 ms, -20 u/s for 500 ms; Y: 0, +20, 0.
    let t = [500.0, 250.0, 500.0];
    let mxs = model(&[20.0, 0.0, -20.0], &t, 200.0, 50.0, tr.len());
    let mys = model(&[0.0, 20.0, 0.0], &t, 200.0, 50.0, tr.len());
    for (i, p) in tr.iter().enumerate() {
        let (mx, my) = (mxs[i], mys[i]);
        assert!((p[0] - mx).abs() < 1.0 && (p[1] - my).abs() < 1.0, "cycle {i}: {p:?} vs ({mx}, {my})");
    }
    let want = ((1250.0 + 200.0) / SERVO).ceil() as usize;
    let k = arrival(&tr, 0, 0.0).max(arrival(&tr, 1, 5000.0));
    let k = tr.iter().rposition(|p| (p[0]).abs() > 1e-6 || (p[1] - 5000.0).abs() > 1e-6).unwrap_or(k) + 1;
    assert!((k + 1).abs_diff(want) <= 1, "arrived at cycle {} want {want}", k + 1);
}

#[test]
fn tm_move_and_short_move_minimum_time() {
    // TM300 TA100 TS0: arrival at 400 ms whatever F says.
    let mut c = cs(&[(0, 1.0)], cfg());
    let set: fn(&mut Modal) = |m| {
        m.set_ta(100.0).unwrap();
        m.set_ts(0.0).unwrap();
        m.set_tm(300.0).unwrap();
    };
    let tr = run(&mut c, vec![It::Set(set), mv(&[(0, 3000.0)])], 5000);
    let k = arrival(&tr, 0, 3000.0) + 1;
    assert!(k.abs_diff((400.0 / SERVO).ceil() as usize) <= 1, "{k}");
    // Trapezoid: constant velocity 10 counts/ms in the middle.
    let mid = (200.0 / SERVO) as usize;
    assert!(((tr[mid + 1][0] - tr[mid][0]) / SERVO - 10.0).abs() < 1e-6);
    // F so fast the move would take 1 ms: slowed to TA (200), arrival at 2·TA.
    let mut c = cs(&[(0, 1.0)], cfg());
    let set: fn(&mut Modal) = |m| {
        m.set_ta(200.0).unwrap();
        m.set_ts(0.0).unwrap();
        m.set_f(1e6).unwrap();
    };
    let tr = run(&mut c, vec![It::Set(set), mv(&[(0, 100.0)])], 5000);
    let k = arrival(&tr, 0, 100.0) + 1;
    assert!(k.abs_diff((400.0 / SERVO).ceil() as usize) <= 1, "{k}");
}

#[test]
fn time_base_scales_move_time_but_not_dwell() {
    let mut cfg = cfg();
    cfg.ix94 = 1e9; // immediate % change
    let mut c = cs(&[(0, 1.0)], cfg);
    c.tb.set_percent(50.0);
    let set: fn(&mut Modal) = |m| {
        m.set_ta(100.0).unwrap();
        m.set_ts(0.0).unwrap();
        m.set_tm(300.0).unwrap();
    };
    let items = vec![It::Set(set), mv(&[(0, 1000.0)]), It::Dwell(250.0), mv(&[(0, 0.0)])];
    let tr = run(&mut c, items, 20000);
    let k1 = arrival(&tr, 0, 1000.0) + 1;
    assert!(k1.abs_diff((800.0 / SERVO).ceil() as usize) <= 1, "{k1}");
    // The dwell lasts 250 ms of real time, then the return move starts.
    let leave = tr.iter().skip(k1).position(|p| p[0] < 1000.0 - 1e-9).unwrap() + k1;
    assert!(((leave - k1) as f64 * SERVO - 250.0).abs() <= 2.0 * SERVO, "{}", (leave - k1) as f64 * SERVO);
    assert_eq!(c.tb.percent(), 50.0);
}

#[test]
fn circle_ends_on_point_with_small_radius_error() {
    let mut cfg = cfg();
    cfg.i13 = 10.0;
    for (mode, mid) in [(Mode::Circle1, (7.0710678, -7.0710678)), (Mode::Circle2, (-7.0710678, 7.0710678))] {
        let mut c = cs(&[(0, 1000.0), (1, 1000.0)], cfg.clone());
        c.push_move(&words(&[(0, 10.0)])).ok();
        while !c.is_idle() {
            c.tick();
        }
        c.modal.mode = mode;
        c.modal.set_ta(10.0).unwrap();
        c.modal.set_ts(0.0).unwrap();
        c.modal.set_f(10.0).unwrap();
        let mut w = words(&[(0, 0.0), (1, -10.0)]);
        w.ijk = [Some(-10.0), Some(0.0), None];
        c.push_move(&w).unwrap();
        let mut tr = Vec::new();
        while !c.is_idle() {
            tr.push(c.tick().motors);
        }
        let last = tr.last().unwrap();
        assert!((last[0]).abs() < 1e-6 && (last[1] + 10000.0).abs() < 1e-6, "{last:?}");
        for p in &tr {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            assert!((r - 10000.0).abs() <= 0.5, "radius error {} at {p:?}", r - 10000.0);
        }
        let has_mid = tr.iter().any(|p| (p[0] - mid.0 * 1000.0).abs() < 5.0 && (p[1] - mid.1 * 1000.0).abs() < 5.0);
        assert!(has_mid, "{mode:?} went the wrong way round");
    }
}

#[test]
fn circle_r_form_full_circle_and_refusals() {
    let mut cfg = cfg();
    cfg.i13 = 10.0;
    cfg.ix96 = 0.001;
    let mut c = cs(&[(0, 1000.0), (1, 1000.0)], cfg);
    c.modal.mode = Mode::Circle1;
    c.modal.set_ta(10.0).unwrap();
    c.modal.set_ts(0.0).unwrap();
    // Chord 10.003 > 2R = 10 by more than Ix96 → circle radius error; nothing queued.
    let mut w = words(&[(0, 7.072), (1, 7.072)]);
    w.r = Some(5.0);
    assert!(matches!(c.push_move(&w), Err(CoordError::CircleRadius(_))));
    assert!(c.is_idle());
    assert_eq!(c.program_position()[0], 0.0);
    // Centre on the start point → zero radius error.
    let mut w = words(&[(0, 1.0)]);
    w.ijk = [Some(0.0), Some(0.0), None];
    assert_eq!(c.push_move(&w), Err(CoordError::CircleZeroRadius));
    // Full circle: IJK form with end = start, duration 2πr/F.
    c.modal.set_f(10.0).unwrap();
    let mut w = words(&[]);
    w.ijk = [Some(1.0), Some(0.0), None];
    c.push_move(&w).unwrap();
    let mut n = 0;
    let mut far: f64 = 0.0;
    while !c.is_idle() {
        let p = c.tick().motors;
        far = far.max(p[0]);
        n += 1;
    }
    assert!((far - 2000.0).abs() < 1.0, "full circle reaches the far side: {far}");
    let want = (std::f64::consts::TAU * 1000.0 / 10.0 + 10.0) / SERVO;
    assert!((n as f64 - want).abs() <= 2.0, "{n} vs {want}");
    // R form, R>0 quarter arc from (0,0) to (1,1) CW about -Z: centre (1,0).
    let mut w = words(&[(0, 1.0), (1, 1.0)]);
    w.r = Some(1.0);
    c.push_move(&w).unwrap();
    while !c.is_idle() {
        let p = c.tick().motors;
        let r = ((p[0] - 1000.0).powi(2) + p[1] * p[1]).sqrt();
        assert!((r - 1000.0).abs() <= 0.5, "{p:?}");
    }
}

#[test]
fn pvt_passes_points_with_programmed_velocity() {
    let mut c = cs(&[(0, 1.0)], cfg());
    c.modal.set_pvt(100.0).unwrap();
    // Segments of 100 ms: (p, v in counts/s).
    let segs = [(1000.0, 15000.0), (3000.0, 20000.0), (4000.0, 0.0)];
    let mut tr: Vec<(f64, f64)> = Vec::new(); // (time, pos)
    let mut fed = 0;
    let mut t = 0.0;
    loop {
        while fed < segs.len() && c.wants_moves() {
            let mut w = words(&[(0, segs[fed].0)]);
            w.vel[0] = Some(segs[fed].1);
            c.push_move(&w).unwrap();
            fed += 1;
        }
        let p = c.tick().motors[0];
        t += SERVO;
        tr.push((t, p));
        if fed == segs.len() && c.is_idle() && tr.len() > 1000 {
            break;
        }
    }
    // Evaluate by interpolation at the segment ends: pos within 0.5 count, velocity (central
    // difference) within 1 % of the programmed one.
    let at = |time: f64| {
        let i = tr.iter().position(|&(tt, _)| tt >= time).unwrap();
        let (t0, p0) = tr[i - 1];
        let (t1, p1) = tr[i];
        (p0 + (p1 - p0) * (time - t0) / (t1 - t0), (p1 - p0) / (t1 - t0))
    };
    for (k, &(p, v)) in segs.iter().enumerate() {
        let time = 100.0 * (k + 1) as f64;
        let (pp, _) = at(time);
        let vv = (at(time + 0.5).0 - at(time - 0.5).0) / 1.0;
        assert!((pp - p).abs() < 0.5, "segment {k}: {pp} vs {p}");
        assert!((vv - v / 1000.0).abs() <= 0.01 * (v / 1000.0).abs() + 0.05, "segment {k}: v {vv}");
    }
}

#[test]
fn two_axis_combination_moves_motors_by_the_matrix() {
    let mut t = AxisTable::new(8, 8);
    t.define(1, 1, MotorAxisDef::Linear { terms: vec![(0, 8660.0), (1, -5000.0)], offset: 0.0 }).unwrap();
    t.define(1, 2, MotorAxisDef::Linear { terms: vec![(0, 5000.0), (1, 8660.0)], offset: 0.0 }).unwrap();
    let mut c = CoordSystem::new(cfg(), t.cs_axes(1), &[0.0, 0.0]);
    let set: fn(&mut Modal) = |m| {
        m.set_ta(50.0).unwrap();
        m.set_f(2.0).unwrap();
    };
    let tr = run(&mut c, vec![It::Set(set), mv(&[(0, 1.0), (1, 0.5)])], 20000);
    let last = tr.last().unwrap();
    assert!((last[0] - (8660.0 - 2500.0)).abs() < 1e-6 && (last[1] - (5000.0 + 4330.0)).abs() < 1e-6, "{last:?}");
    // A straight axis move: the motors stay in the matrix ratio every cycle.
    for p in &tr {
        assert!((p[0] * 9330.0 - p[1] * 6160.0).abs() < 1e-6 * (1.0 + p[1].abs()) * 9330.0, "{p:?}");
    }
}

#[test]
fn refusals_and_absurd_inputs_do_not_panic() {
    let mut m = Modal::new(&CsConfig::default());
    assert_eq!(m.set_tm(0.0), Err(CoordError::BadTime("TM")));
    assert!(m.set_tm(-5.0).is_err() && m.set_f(f64::NAN).is_err() && m.set_f(0.0).is_err());
    assert!(m.set_ta(-1.0).is_err() && m.set_ts(f64::INFINITY).is_err() && m.set_pvt(0.0).is_err());
    m.set_ta(0.0).unwrap();
    m.set_ts(0.0).unwrap();
    assert_eq!(m.accel(), Err(CoordError::ZeroAccelTime));
    let mut c = cs(&[(0, 1.0)], cfg());
    c.modal = m;
    assert_eq!(c.push_move(&words(&[(0, 5.0)])), Err(CoordError::ZeroAccelTime));
    c.modal.set_ta(10.0).unwrap();
    assert_eq!(c.push_move(&words(&[(0, f64::NAN)])), Err(CoordError::OutOfRange("axis position")));
    assert!(c.push_move(&words(&[(0, 1e300)])).is_err());
    assert!(c.dwell(-1.0).is_err() && c.delay(f64::NAN).is_err());
    // Huge but legal: runs (clamped to 2^23 ms) without panicking.
    c.modal.set_f(1e-300).unwrap();
    c.push_move(&words(&[(0, 1e9)])).unwrap();
    for _ in 0..10 {
        assert!(c.tick().motors[0].is_finite());
    }
    // No motors: ERR014.
    let t = AxisTable::new(8, 8);
    let mut c = CoordSystem::new(cfg(), t.cs_axes(1), &[]);
    let e = c.push_move(&words(&[(0, 1.0)])).unwrap_err();
    assert_eq!(e.err_code(), Some(14));
}

#[test]
fn rapid_uses_jog_profile_of_limiting_motor() {
    // Motor 1 10000 counts, motor 2 2500 counts; Ix16 32, Ix19 0.25, Ix20 0, Ix21 50:
    // ramp = 50 + 32/0.25 = 178 ms, cruise 10000/32 − 178 = 134.5 ms → 490.5 ms total.
    let lim = MotorLimits { ix16: 32.0, ix19: 0.25, ix20: 0.0, ix21: 50.0, ..MotorLimits::default() };
    let cfg = CsConfig { motors: vec![lim; 2], ..CsConfig::default() };
    let mut c = cs(&[(0, 1.0), (1, 1.0)], cfg);
    c.modal.mode = Mode::Rapid;
    let tr = run(&mut c, vec![mv(&[(0, 10000.0), (1, 2500.0)])], 5000);
    let k0 = arrival(&tr, 0, 10000.0) + 1;
    let k1 = arrival(&tr, 1, 2500.0) + 1;
    assert_eq!(k0, k1, "all motors finish together");
    assert!(k0.abs_diff((490.5 / SERVO).ceil() as usize) <= 1, "{k0}");
    let mid = (245.0 / SERVO) as usize;
    assert!(((tr[mid + 1][0] - tr[mid][0]) / SERVO - 32.0).abs() < 1e-3);
    assert!((tr[mid][0] - 4.0 * tr[mid][1]).abs() < 1e-6, "straight path");
}

#[test]
fn lookahead_hold_and_abort() {
    let mut c = cs(&[(0, 1.0)], cfg());
    c.modal.set_ta(100.0).unwrap();
    c.modal.set_ts(0.0).unwrap();
    c.modal.set_tm(500.0).unwrap();
    assert!(c.wants_moves());
    let a = c.push_move(&words(&[(0, 5000.0)])).unwrap().unwrap();
    assert!(c.wants_moves(), "the first move executes at once");
    let b = c.push_move(&words(&[(0, 10000.0)])).unwrap().unwrap();
    assert!(c.wants_moves());
    c.push_move(&words(&[(0, 12000.0)])).unwrap();
    assert!(!c.wants_moves(), "two moves beyond the executing one are enough");
    let out = c.tick();
    assert_eq!(out.started, [a]);
    // Feed hold: the time base ramps to 0 (1 s at Ix95 default), motion freezes.
    for _ in 0..200 {
        c.tick();
    }
    c.hold();
    let mut last = 0.0;
    for _ in 0..2400 {
        last = c.tick().motors[0];
    }
    assert_eq!(c.tick().motors[0], last);
    assert_eq!(c.tb.percent(), 0.0);
    c.release();
    // Abort: decelerate at Ix15 = 0.25 counts/ms².
    for _ in 0..2000 {
        c.tick();
    }
    let v0 = (c.tick().motors[0] - last) * 0.0;
    let _ = v0;
    let p1 = c.tick().motors[0];
    let p2 = c.tick().motors[0];
    let v = (p2 - p1) / SERVO;
    c.abort();
    let mut prev = p2;
    let mut vs = Vec::new();
    while !c.is_idle() {
        let p = c.tick().motors[0];
        vs.push((p - prev) / SERVO);
        prev = p;
    }
    assert!(v > 5.0 && vs.len() as f64 * SERVO > v / 0.25 - 2.0 * SERVO, "{v} {}", vs.len());
    assert!((vs[10] - vs[11] - 0.25 * SERVO).abs() < 1e-9, "decel at Ix15");
    assert!(!c.wants_moves() || c.is_idle());
    assert!(c.executing().is_none() || c.executing() == Some(b));
}
