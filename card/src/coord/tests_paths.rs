//! Path tests against independent models: circle geometry, PVT boundary conditions and
//! SPLINE1 knot values (issue 4 item 8).

use super::moves::Mode;
use super::tests_moves::{cfg, cs, words, SERVO};
use super::CoordError;

#[test]
fn circle_ends_on_point_with_small_radius_error() {
    let mut cfg = cfg();
    cfg.i13 = 10.0;
    for (mode, mid) in [
        (Mode::Circle1, (7.0710678, -7.0710678)),
        (Mode::Circle2, (-7.0710678, 7.0710678)),
    ] {
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
        assert!(
            (last[0]).abs() < 1e-6 && (last[1] + 10000.0).abs() < 1e-6,
            "{last:?}"
        );
        for p in &tr {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            assert!(
                (r - 10000.0).abs() <= 0.5,
                "radius error {} at {p:?}",
                r - 10000.0
            );
        }
        let has_mid = tr
            .iter()
            .any(|p| (p[0] - mid.0 * 1000.0).abs() < 5.0 && (p[1] - mid.1 * 1000.0).abs() < 5.0);
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
    assert!(
        (far - 2000.0).abs() < 1.0,
        "full circle reaches the far side: {far}"
    );
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
        (
            p0 + (p1 - p0) * (time - t0) / (t1 - t0),
            (p1 - p0) / (t1 - t0),
        )
    };
    for (k, &(p, v)) in segs.iter().enumerate() {
        let time = 100.0 * (k + 1) as f64;
        let (pp, _) = at(time);
        let vv = (at(time + 0.5).0 - at(time - 0.5).0) / 1.0;
        assert!((pp - p).abs() < 0.5, "segment {k}: {pp} vs {p}");
        assert!(
            (vv - v / 1000.0).abs() <= 0.01 * (v / 1000.0).abs() + 0.05,
            "segment {k}: v {vv}"
        );
    }
}

#[test]
fn spline1_b_spline_knots_and_rest_ends() {
    let mut c = cs(&[(0, 1.0)], cfg());
    c.modal.mode = Mode::Spline1;
    c.modal.set_ta(100.0).unwrap();
    let mut tr: Vec<f64> = Vec::new();
    let mut pts = vec![1000.0, 3000.0].into_iter();
    loop {
        while c.wants_moves() {
            match pts.next() {
                Some(p) => {
                    c.push_move(&words(&[(0, p)])).unwrap();
                }
                None => break,
            }
        }
        tr.push(c.tick().motors[0]);
        if c.is_idle() && tr.len() > 10 {
            break;
        }
    }
    // Uniform cubic B-spline with triple end points: knot values (Q[k-1] + 4Q[k] + Q[k+1])/6.
    let at = |ms: f64| tr[(ms / SERVO).round() as usize - 1];
    let knots = [
        (100.0, 1000.0 / 6.0),
        (200.0, 7000.0 / 6.0),
        (300.0, 16000.0 / 6.0),
        (400.0, 3000.0),
    ];
    for (t, want) in knots {
        assert!((at(t) - want).abs() < 2.0, "t {t}: {} vs {want}", at(t));
    }
    assert!((tr.last().unwrap() - 3000.0).abs() < 1e-9);
    assert!(
        ((tr.len() as f64) * SERVO - 400.0).abs() <= 2.0 * SERVO,
        "{}",
        tr.len()
    );
    // Continuous velocity: no per-cycle velocity step larger than a smooth profile gives.
    let v: Vec<f64> = tr.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(
        v.windows(2).all(|w| (w[1] - w[0]).abs() < 0.2),
        "velocity jump"
    );
}
