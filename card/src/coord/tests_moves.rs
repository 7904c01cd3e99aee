//! Move tests against independent models written here (issue 4 item 8): numerically
//! integrated PMAC velocity profiles, circle geometry, PVT boundary conditions.

use super::axes::{AxisTable, MotorAxisDef};
use super::cs::{CoordSystem, MoveWords};
use super::moves::{CsConfig, Modal, Mode, MotorLimits};
use super::CoordError;
use crate::domain::ErrCode;

pub(super) const SERVO: f64 = 3_713_707.0 / 8_388_608.0; // ms per servo cycle at the default I10

enum It {
    Mv(Box<MoveWords>),
    Dwell(f64),
    Set(fn(&mut Modal)),
}

fn mv(v: &[(usize, f64)]) -> It {
    It::Mv(Box::new(words(v)))
}

pub(super) fn words(v: &[(usize, f64)]) -> MoveWords {
    let mut w = MoveWords::default();
    for &(k, x) in v {
        w.pos[k] = Some(x);
    }
    w
}

/// C.S. 1 with motor k+1 defined as `scale`·axis k (k < 9).
pub(super) fn cs(scales: &[(usize, f64)], cfg: CsConfig) -> CoordSystem {
    let mut t = AxisTable::new(8, 8);
    for (m, &(k, s)) in scales.iter().enumerate() {
        t.define(
            1,
            m as u16 + 1,
            MotorAxisDef::Linear {
                terms: vec![(k, s)],
                offset: 0.0,
            },
        )
        .unwrap();
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
    let acc = |tt: f64| {
        steps
            .iter()
            .map(|&(c, dv)| dv * shape((tt - (c - h)) / ta) / ta)
            .sum::<f64>()
    };
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

pub(super) fn cfg() -> CsConfig {
    CsConfig {
        motors: vec![
            MotorLimits {
                ix16: 1e9,
                ix17: 1e9,
                ..MotorLimits::default()
            };
            8
        ],
        ..CsConfig::default()
    }
}

fn arrival(trace: &[Vec<f64>], m: usize, target: f64) -> usize {
    trace
        .iter()
        .position(|p| (p[m] - target).abs() < 1e-6)
        .unwrap()
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
    assert!(
        (k + 1).abs_diff(want) <= 1,
        "arrived at cycle {} want {}",
        k + 1,
        want
    );
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
    let items = vec![
        It::Set(set),
        mv(&[(0, 10.0)]),
        mv(&[(1, 5.0)]),
        mv(&[(0, 0.0)]),
    ];
    let tr = run(&mut c, items, 20000);
    // X: +20 u/s for 500 ms, 0 for 250 ms, -20 u/s for 500 ms; Y: 0, +20, 0.
    let t = [500.0, 250.0, 500.0];
    let mxs = model(&[20.0, 0.0, -20.0], &t, 200.0, 50.0, tr.len());
    let mys = model(&[0.0, 20.0, 0.0], &t, 200.0, 50.0, tr.len());
    for (i, p) in tr.iter().enumerate() {
        let (mx, my) = (mxs[i], mys[i]);
        assert!(
            (p[0] - mx).abs() < 1.0 && (p[1] - my).abs() < 1.0,
            "cycle {i}: {p:?} vs ({mx}, {my})"
        );
    }
    let want = ((1250.0 + 200.0) / SERVO).ceil() as usize;
    let k = arrival(&tr, 0, 0.0).max(arrival(&tr, 1, 5000.0));
    let k = tr
        .iter()
        .rposition(|p| (p[0]).abs() > 1e-6 || (p[1] - 5000.0).abs() > 1e-6)
        .unwrap_or(k)
        + 1;
    assert!(
        (k + 1).abs_diff(want) <= 1,
        "arrived at cycle {} want {want}",
        k + 1
    );
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
    let items = vec![
        It::Set(set),
        mv(&[(0, 1000.0)]),
        It::Dwell(250.0),
        mv(&[(0, 0.0)]),
    ];
    let tr = run(&mut c, items, 20000);
    let k1 = arrival(&tr, 0, 1000.0) + 1;
    assert!(k1.abs_diff((800.0 / SERVO).ceil() as usize) <= 1, "{k1}");
    // The dwell lasts 250 ms of real time, then the return move starts.
    let leave = tr
        .iter()
        .skip(k1)
        .position(|p| p[0] < 1000.0 - 1e-9)
        .unwrap()
        + k1;
    assert!(
        ((leave - k1) as f64 * SERVO - 250.0).abs() <= 2.0 * SERVO,
        "{}",
        (leave - k1) as f64 * SERVO
    );
    assert_eq!(c.tb.percent(), 50.0);
}

#[test]
fn two_axis_combination_moves_motors_by_the_matrix() {
    let mut t = AxisTable::new(8, 8);
    t.define(
        1,
        1,
        MotorAxisDef::Linear {
            terms: vec![(0, 8660.0), (1, -5000.0)],
            offset: 0.0,
        },
    )
    .unwrap();
    t.define(
        1,
        2,
        MotorAxisDef::Linear {
            terms: vec![(0, 5000.0), (1, 8660.0)],
            offset: 0.0,
        },
    )
    .unwrap();
    let mut c = CoordSystem::new(cfg(), t.cs_axes(1), &[0.0, 0.0]);
    let set: fn(&mut Modal) = |m| {
        m.set_ta(50.0).unwrap();
        m.set_f(2.0).unwrap();
    };
    let tr = run(&mut c, vec![It::Set(set), mv(&[(0, 1.0), (1, 0.5)])], 20000);
    let last = tr.last().unwrap();
    assert!(
        (last[0] - (8660.0 - 2500.0)).abs() < 1e-6 && (last[1] - (5000.0 + 4330.0)).abs() < 1e-6,
        "{last:?}"
    );
    // A straight axis move: the motors stay in the matrix ratio every cycle.
    for p in &tr {
        assert!(
            (p[0] * 9330.0 - p[1] * 6160.0).abs() < 1e-6 * (1.0 + p[1].abs()) * 9330.0,
            "{p:?}"
        );
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
    assert_eq!(
        c.push_move(&words(&[(0, 5.0)])),
        Err(CoordError::ZeroAccelTime)
    );
    c.modal.set_ta(10.0).unwrap();
    assert_eq!(
        c.push_move(&words(&[(0, f64::NAN)])),
        Err(CoordError::OutOfRange("axis position"))
    );
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
    assert_eq!(e.err_code(), Some(ErrCode::NoMotors));
}

#[test]
fn rapid_uses_jog_profile_of_limiting_motor() {
    // Motor 1 10000 counts, motor 2 2500 counts; Ix16 32, Ix19 0.25, Ix20 0, Ix21 50:
    // ramp = 50 + 32/0.25 = 178 ms, cruise 10000/32 − 178 = 134.5 ms → 490.5 ms total.
    let lim = MotorLimits {
        ix16: 32.0,
        ix19: 0.25,
        ix20: 0.0,
        ix21: 50.0,
        ..MotorLimits::default()
    };
    let cfg = CsConfig {
        motors: vec![lim; 2],
        ..CsConfig::default()
    };
    let mut c = cs(&[(0, 1.0), (1, 1.0)], cfg);
    c.modal.mode = Mode::Rapid;
    let tr = run(&mut c, vec![mv(&[(0, 10000.0), (1, 2500.0)])], 5000);
    let k0 = arrival(&tr, 0, 10000.0) + 1;
    let k1 = arrival(&tr, 1, 2500.0) + 1;
    assert_eq!(k0, k1, "all motors finish together");
    assert!(k0.abs_diff((490.5 / SERVO).ceil() as usize) <= 1, "{k0}");
    let mid = (245.0 / SERVO) as usize;
    assert!(((tr[mid + 1][0] - tr[mid][0]) / SERVO - 32.0).abs() < 1e-3);
    assert!(
        (tr[mid][0] - 4.0 * tr[mid][1]).abs() < 1e-6,
        "straight path"
    );
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
    assert!(
        !c.wants_moves(),
        "two moves beyond the executing one are enough"
    );
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
    assert!(
        v > 5.0 && vs.len() as f64 * SERVO > v / 0.25 - 2.0 * SERVO,
        "{v} {}",
        vs.len()
    );
    assert!(
        (vs[10] - vs[11] - 0.25 * SERVO).abs() < 1e-9,
        "decel at Ix15"
    );
    assert!(!c.wants_moves() || c.is_idle());
    assert!(c.executing().is_none() || c.executing() == Some(b));
}

#[test]
fn stop_at_end_of_current_move_and_sync_events() {
    let mut c = cs(&[(0, 1.0)], cfg());
    c.modal.set_ta(50.0).unwrap();
    c.modal.set_ts(0.0).unwrap();
    c.modal.set_tm(200.0).unwrap();
    let a = c.push_move(&words(&[(0, 1000.0)])).unwrap().unwrap();
    let b = c.push_move(&words(&[(0, 2000.0)])).unwrap().unwrap();
    let mut started = Vec::new();
    let mut finished = Vec::new();
    for _ in 0..50 {
        let o = c.tick();
        started.extend(o.started);
        finished.extend(o.finished);
    }
    assert_eq!(c.executing(), Some(a));
    c.stop_at_end();
    let mut last = 0.0;
    while !c.is_idle() {
        let o = c.tick();
        started.extend(o.started);
        finished.extend(o.finished);
        last = o.motors[0];
    }
    assert_eq!(last, 1000.0, "stopped on the end of the executing move");
    assert_eq!(started, [a]);
    assert_eq!(finished, [a]);
    let _ = b;
    // Resuming after `/`: a new move starts from rest at the stop point.
    c.push_move(&words(&[(0, 1500.0)])).unwrap();
    let mut p = Vec::new();
    while !c.is_idle() {
        p.push(c.tick().motors[0]);
    }
    assert!((p[0] - 1000.0).abs() < 1.0 && *p.last().unwrap() == 1500.0);
}

#[test]
fn delay_blends_and_adis_renames_without_moving() {
    let mut c = cs(&[(0, 1.0), (1, 1.0)], cfg());
    c.xf.define(1);
    c.tsel(1).unwrap();
    c.rename(|b| b.adis([100.0, 0.0, 0.0])).unwrap();
    assert_eq!(
        c.program_position()[0],
        100.0,
        "ADIS renames the present position"
    );
    c.modal.set_ta(100.0).unwrap();
    c.modal.set_ts(0.0).unwrap();
    c.modal.set_tm(200.0).unwrap();
    c.push_move(&words(&[(0, 150.0)])).unwrap();
    c.delay(300.0).unwrap();
    let mut tr = Vec::new();
    while !c.is_idle() {
        tr.push(c.tick().motors[0]);
    }
    assert!(
        tr.iter().all(|p| (-1e-9..=50.0 + 1e-9).contains(p)),
        "motor moves 50 counts"
    );
    assert_eq!(*tr.last().unwrap(), 50.0);
    // The delay is a blended zero move: total = 200 + 300 + TA.
    assert!(
        ((tr.len() as f64) * SERVO - 600.0).abs() <= 2.0 * SERVO,
        "{}",
        tr.len() as f64 * SERVO
    );
}
