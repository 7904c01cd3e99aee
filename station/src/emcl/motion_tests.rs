use super::*;

fn plain(vmax: i64, a: i64) -> Ramp {
    Ramp {
        vmax,
        amax: a,
        ..Ramp::default()
    }
}

fn run_to_target(m: &mut Motion, r: &Ramp, limit: u32) -> (u32, Vec<i64>) {
    let mut v = Vec::new();
    let mut t = 0;
    while !m.at_target() && t < limit {
        m.step(r, Blocks::default());
        v.push(m.v);
        t += 1;
    }
    (t, v)
}

#[test]
fn triangle_move_is_exact_and_symmetric() {
    // 512000 µsteps at 512000 pps²: a 2 s triangle peaking at 512000 pps (seed L1707).
    let r = plain(512_000, 512_000);
    let mut m = Motion::default();
    m.move_to(512_000);
    let (t, v) = run_to_target(&mut m, &r, 10_000);
    assert_eq!(t, 2000);
    assert_eq!(m.pos, 512_000);
    assert_eq!(*v.iter().max().unwrap(), 512_000);
    // The velocity never changes by more than a/1000 (+1 for the carried remainder).
    for w in v.windows(2) {
        assert!((w[1] - w[0]).abs() <= 512, "{w:?}");
    }
    // Symmetric: the speed k ms before the end equals the speed k ms after the start.
    for k in 1..900 {
        assert!((v[k - 1] - v[v.len() - 1 - k]).abs() <= 512, "k {k}");
    }
}

#[test]
fn trapezoid_cruises_at_vmax() {
    let r = plain(1000, 10_000);
    let mut m = Motion::default();
    m.move_to(-3000);
    let (t, v) = run_to_target(&mut m, &r, 10_000);
    assert_eq!(m.pos, -3000);
    assert_eq!(*v.iter().min().unwrap(), -1000);
    assert!(v.iter().all(|x| *x <= 0));
    // 3000 µsteps: 0.1 s ramps (50 each), 2.9 s cruise: 3.1 s.
    assert!((3095..=3105).contains(&t), "{t} ms");
}

#[test]
fn retarget_behind_brakes_then_reverses() {
    let r = plain(5000, 20_000);
    let mut m = Motion::default();
    m.rotate(5000);
    for _ in 0..500 {
        m.step(&r, Blocks::default());
    }
    let p = m.pos;
    m.move_to(p - 100);
    let mut min_v = i64::MAX;
    let (_, v) = run_to_target(&mut m, &r, 10_000);
    for x in &v {
        min_v = min_v.min(*x);
    }
    assert!(min_v < 0, "came back");
    assert_eq!(m.pos, p - 100);
    // Braking from 5000 at 20000 pps² takes 250 ms: the first 240 ms still run positive.
    assert!(v[..240].iter().all(|x| *x > 0));
}

#[test]
fn velocity_mode_ramps_and_reverses_through_zero() {
    let r = plain(0, 1000);
    let mut m = Motion::default();
    m.rotate(100);
    for _ in 0..100 {
        m.step(&r, Blocks::default());
    }
    assert_eq!(m.v, 100);
    m.rotate(-100);
    let mut seen_zero = false;
    for _ in 0..200 {
        m.step(&r, Blocks::default());
        seen_zero |= m.v == 0;
    }
    assert!(seen_zero);
    assert_eq!(m.v, -100);
    // Position bookkeeping: 1 pps for 1000 ms is exactly one µstep.
    let mut m = Motion {
        v: 1,
        mode: Mode::Velocity,
        target_vel: 1,
        ..Motion::default()
    };
    for _ in 0..999 {
        m.step(&r, Blocks::default());
    }
    assert_eq!(m.pos, 0);
    m.step(&r, Blocks::default());
    assert_eq!(m.pos, 1);
}

#[test]
fn blocks_stop_hard_or_soft_and_keep_the_motor_from_starting() {
    let r = plain(10_000, 100_000);
    let mut m = Motion::default();
    m.rotate(10_000);
    for _ in 0..200 {
        m.step(&r, Blocks::default());
    }
    let hard = Blocks {
        plus: Some(StopKind::Hard),
        minus: None,
    };
    m.step(&r, hard);
    assert_eq!(m.v, 0);
    assert_eq!(m.mode, Mode::Velocity, "velocity mode keeps its target");
    for _ in 0..10 {
        m.step(&r, hard);
        assert_eq!(m.v, 0);
    }
    m.rotate(-10_000);
    m.step(&r, hard);
    assert!(m.v < 0, "away from the block is free");
    // Soft: decelerates at the given rate.
    let mut m = Motion::default();
    m.rotate(10_000);
    for _ in 0..200 {
        m.step(&r, Blocks::default());
    }
    let soft = Blocks {
        plus: Some(StopKind::Soft(1_000_000)),
        minus: None,
    };
    m.step(&r, soft);
    assert_eq!(m.v, 9000);
    for _ in 0..9 {
        m.step(&r, soft);
    }
    assert_eq!(m.v, 0);
    // A positioning move into a block is abandoned.
    let mut m = Motion::default();
    m.move_to(1000);
    m.step(&r, hard);
    assert_eq!(m.mode, Mode::Idle);
}

#[test]
fn stop_velocity_and_six_point_segments() {
    // Break velocity 2000: below it AP 16/19 (10000), above AP 5/17 (100000); stop at 500.
    let r = Ramp {
        vmax: 5000,
        amax: 100_000,
        vstart: 0,
        a1: 10_000,
        dmax: 100_000,
        v1: 2000,
        d1: 10_000,
        vstop: 500,
    };
    let mut m = Motion::default();
    m.move_to(20_000);
    let (_, v) = run_to_target(&mut m, &r, 20_000);
    assert_eq!(m.pos, 20_000);
    // 0 → 2000 at 10 pps/ms takes 200 ms; 2000 → 5000 at 100 pps/ms 30 ms more.
    assert_eq!(v[199], 2000);
    assert_eq!(v[229], 5000);
    // The last moving ms is at most the stop velocity.
    let last = v.iter().rev().find(|x| **x != 0).copied().unwrap();
    assert!(last <= 500, "{last}");
}
