//! Jog accuracy against an independent analytic model of spec §5.2.
//!
//! The model below does not use the implementation's helpers: it derives the peak velocity and
//! ramp time from the rules of §5.2 in closed form, builds the acceleration profile a(t) and
//! integrates it numerically (fine midpoint steps) to get the position at every servo cycle.
//! The implementation is driven through `Motor` with an ideal follower as feedback.

use super::flags::FlagInputs;
use super::jog::JogCmd;
use super::motor::{Motor, MotorCommand, TickInput};
use super::params::MotorParams;
use super::profile::RampParams;

/// Servo period at the default I10 (3,713,707 / 2^23 ms).
const DT: f64 = 3_713_707.0 / 8_388_608.0;

/// A velocity ramp of the model: from `v0` to `v1` starting at `t0`, lasting `t`, S time `ts`.
#[derive(Clone, Copy)]
struct MRamp {
    t0: f64,
    v0: f64,
    v1: f64,
    t: f64,
    ts: f64,
}

/// Ramp duration per §5.2: max(Ix20, 2·Ix21), stretched to Ix21 + |Δv|/Ix19 when Ix19 binds.
fn model_ramp_time(ta: f64, ts: f64, amax: f64, dv: f64) -> f64 {
    let base = if ta == 0.0 && ts == 0.0 {
        1.0
    } else {
        ta.max(2.0 * ts)
    };
    base.max(ts + dv.abs() / amax)
}

fn accel(ramps: &[MRamp], t: f64) -> f64 {
    for r in ramps {
        let tau = t - r.t0;
        if tau < 0.0 || tau >= r.t {
            continue;
        }
        let ap = (r.v1 - r.v0) / (r.t - r.ts);
        return if tau < r.ts {
            ap * tau / r.ts
        } else if tau > r.t - r.ts {
            ap * (r.t - tau) / r.ts
        } else {
            ap
        };
    }
    0.0
}

/// Positions at t = k·DT − delay for k = 1..=n, integrating a(t) from p0 at rest.
fn integrate(ramps: &[MRamp], p0: f64, delay: f64, n: usize) -> Vec<f64> {
    let sub = 400;
    let h = DT / sub as f64;
    let (mut p, mut v) = (p0, 0.0);
    let mut out = Vec::with_capacity(n);
    let mut t = -delay;
    for _ in 0..n {
        for _ in 0..sub {
            let a = accel(ramps, t + h / 2.0);
            p += v * h + 0.5 * a * h * h;
            v += a * h;
            t += h;
        }
        out.push(p);
    }
    out
}

/// Rest-to-rest move of `d` counts: accel ramp, cruise, decel ramp.
fn model_move(ta: f64, ts: f64, amax: f64, vmax: f64, d: f64) -> Vec<MRamp> {
    let s = d.signum();
    let d = d.abs();
    let t_full = model_ramp_time(ta, ts, amax, vmax);
    let (vp, tr, tc) = if d >= vmax * t_full {
        (vmax, t_full, (d - vmax * t_full) / vmax)
    } else {
        let t0 = if ta == 0.0 && ts == 0.0 {
            1.0
        } else {
            ta.max(2.0 * ts)
        };
        let v = d / t0;
        if ts + v / amax <= t0 {
            (v, t0, 0.0)
        } else {
            // v·(ts + v/A) = d
            let v = (-ts + (ts * ts + 4.0 * d / amax).sqrt()) * amax / 2.0;
            (v, ts + v / amax, 0.0)
        }
    };
    vec![
        MRamp {
            t0: 0.0,
            v0: 0.0,
            v1: s * vp,
            t: tr,
            ts,
        },
        MRamp {
            t0: tr + tc,
            v0: s * vp,
            v1: 0.0,
            t: tr,
            ts,
        },
    ]
}

fn params(ix19: f64, ix20: f64, ix21: f64, ix22: f64) -> MotorParams {
    MotorParams {
        ramp: RampParams::new(ix19, ix20, ix21),
        jog_speed: ix22,
        fatal_fe: 0.0,
        ..MotorParams::default()
    }
}

/// Drive a motor with an ideal follower; returns commanded positions for cycles 1..=n.
fn run_motor(p: &MotorParams, cmds: &[(usize, JogCmd)], n: usize) -> Vec<f64> {
    let mut m = Motor::new();
    let mut fb = 0u32;
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        for (at, c) in cmds {
            if *at == k {
                m.command(
                    MotorCommand::Jog {
                        cmd: *c,
                        trigger: None,
                    },
                    p,
                );
            }
        }
        let inp = TickInput {
            feedback: fb,
            flags: FlagInputs::default(),
            dt_ms: DT,
            program: None,
            background: true,
            capture: None,
        };
        m.tick(p, &inp);
        out.push(m.commanded());
        fb = ((m.commanded() * 32.0).round() as i64 as u32) & 0xFF_FFFF;
    }
    out
}

fn check_move(ix19: f64, ix20: f64, ix21: f64, ix22: f64, d: f64) {
    let p = params(ix19, ix20, ix21, ix22);
    let model = model_move(ix20, ix21, ix19, ix22, d);
    let end = model[1].t0 + model[1].t;
    let n = ((end + p.i12) / DT) as usize + 50;
    let want = integrate(&model, 0.0, p.i12, n);
    let got = run_motor(&p, &[(0, JogCmd::To(d))], n);
    for k in 0..n {
        assert!(
            (got[k] - want[k]).abs() <= 1.0,
            "Ix19={ix19} Ix20={ix20} Ix21={ix21} Ix22={ix22} d={d}: cycle {}: got {} want {}",
            k + 1,
            got[k],
            want[k]
        );
    }
    assert_eq!(got[n - 1], d, "ends exactly on the target");
}

#[test]
fn jog_default_parameters_short_move_ix19_limited() {
    // Defaults: Ix19 = 0.015625, Ix20 = 0, Ix21 = 50, Ix22 = 32: never reaches speed in 10,000.
    check_move(0.015625, 0.0, 50.0, 32.0, 10_000.0);
}

#[test]
fn jog_trapezoid_reaches_speed() {
    check_move(10.0, 100.0, 0.0, 32.0, 10_000.0);
}

#[test]
fn jog_s_curve_with_constant_accel_section_negative() {
    check_move(10.0, 200.0, 50.0, 20.0, -20_000.0);
}

#[test]
fn jog_pure_s_curve_ix20_below_twice_ix21() {
    check_move(10.0, 60.0, 50.0, 25.0, 15_000.0);
}

#[test]
fn jog_short_move_reduced_peak_velocity() {
    check_move(10.0, 100.0, 30.0, 32.0, 500.0);
}

#[test]
fn jog_ix19_stretches_s_curve() {
    check_move(0.05, 100.0, 20.0, 40.0, 30_000.0);
}

#[test]
fn jog_plus_then_stop() {
    // J+ at cycle 0, J/ at cycle 2000: ramp up, cruise, ramp down (each after I12).
    let (ix19, ta, ts, v) = (10.0, 150.0, 40.0, 16.0);
    let p = params(ix19, ta, ts, v);
    let tr = model_ramp_time(ta, ts, ix19, v);
    let t_stop = 2000.0 * DT; // stop command time, relative to the first command
    let model = [
        MRamp {
            t0: 0.0,
            v0: 0.0,
            v1: v,
            t: tr,
            ts,
        },
        MRamp {
            t0: t_stop,
            v0: v,
            v1: 0.0,
            t: tr,
            ts,
        },
    ];
    let n = 2000 + ((tr + p.i12) / DT) as usize + 50;
    let want = integrate(&model, 0.0, p.i12, n);
    let got = run_motor(&p, &[(0, JogCmd::Plus), (2000, JogCmd::Stop)], n);
    for k in 0..n {
        assert!(
            (got[k] - want[k]).abs() <= 1.0,
            "cycle {}: {} vs {}",
            k + 1,
            got[k],
            want[k]
        );
    }
}
