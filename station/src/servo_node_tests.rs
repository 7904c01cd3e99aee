//! Tests of one servo node against analytic models written here.

use super::*;
use crate::plant::amplifier::AmpMode;
use crate::plant::encoder::signed24;
use crate::plant::flags::{
    CMD_AMP_ENABLE, ST_AMP_ENABLED, ST_FAULT, ST_HOME, ST_MLIM, ST_PLIM, ST_USER,
};
use std::f64::consts::TAU;

const DT: f64 = 1.0 / 2258.7;

fn cfg() -> NodePlantConfig {
    NodePlantConfig {
        inertia: 1e-5,
        viscous: 0.0,
        coulomb: 0.0,
        ..Default::default()
    }
}

/// Command registers as a card writes them: DAC value << 8 in register 0, AENA in register 3.
fn cmd(dac: i32, enable: bool) -> NodeRegs {
    NodeRegs {
        r0: ((dac << 8) as u32) & 0xFF_FFFF,
        r1: 0,
        r2: 0,
        r3: if enable { CMD_AMP_ENABLE } else { 0 },
    }
}

/// One station tick: integrate, take the command, report.
fn tick(n: &mut ServoNode, c: NodeRegs, ring_fault: bool) -> NodeRegs {
    n.advance(DT);
    n.apply_command(c, ring_fault);
    n.feedback()
}

#[test]
fn constant_torque_accelerates_per_the_analytic_model() {
    // T = 8192/32768 · 4 N·m = 1 N·m, Tc = 0.1 N·m: a = 0.9/1e-5 rad/s² from the first tick.
    let c = NodePlantConfig {
        coulomb: 0.1,
        ..cfg()
    };
    let mut n = ServoNode::new(0, &c);
    n.apply_command(cmd(8192, true), false);
    let a_counts = 0.9 / 1e-5 / TAU * 131_072.0; // counts/s²
    let mut ext: i64 = 0;
    let mut last = n.feedback().r0;
    for k in 1..=60 {
        let fb = tick(&mut n, cmd(8192, true), false);
        ext += i64::from(signed24(fb.r0.wrapping_sub(last)));
        last = fb.r0;
        let t = k as f64 * DT;
        let expect = 0.5 * a_counts * t * t;
        // tolerance: the 1/32-count truncation of register 0, plus float noise
        assert!(
            (ext as f64 / 32.0 - expect).abs() <= 1.0 / 32.0 + 1e-6,
            "tick {k}: {} vs {expect}",
            ext as f64 / 32.0
        );
        assert!((n.snapshot().velocity - a_counts * t).abs() < 1e-6 * a_counts * t);
    }
    // 60 ticks in, the motor has crossed the 24-bit rollover of register 0 (2^19 counts)
    assert!(ext > 1 << 24, "{ext}");
    // the current reading in register 2: 1 N·m of 4 = 8192
    assert_eq!(n.feedback().r2, 8192);
}

#[test]
fn friction_brings_the_motor_to_rest() {
    // spin up, then disable: J·ω' = −b·ω − Tc stops at t = J/b·ln(1 + b·ω0/Tc)
    let (j, b, tc) = (1e-5, 2e-5, 2e-3);
    let c = NodePlantConfig {
        viscous: b,
        coulomb: tc,
        ..cfg()
    };
    let mut n = ServoNode::new(0, &c);
    n.apply_command(cmd(4096, true), false);
    for _ in 0..50 {
        tick(&mut n, cmd(4096, true), false);
    }
    let w0 = n.snapshot().velocity / 131_072.0 * TAU;
    let p0 = n.snapshot().position;
    assert!(w0 > 100.0);
    n.apply_command(cmd(4096, false), false);
    let t_stop = j / b * (1.0 + b * w0 / tc).ln();
    let dist = (w0 + tc / b) * j / b * (1.0 - (-b * t_stop / j).exp()) - tc / b * t_stop;
    let k_stop = (t_stop / DT).ceil() as usize;
    for _ in 0..k_stop - 1 {
        tick(&mut n, cmd(4096, false), false);
    }
    assert!(n.snapshot().velocity > 0.0);
    tick(&mut n, cmd(4096, false), false);
    let s = n.snapshot();
    assert_eq!(s.velocity, 0.0);
    let moved = (s.position - p0) / 131_072.0 * TAU;
    assert!((moved - dist).abs() < 1e-9 * dist, "{moved} vs {dist}");
    for _ in 0..500 {
        tick(&mut n, cmd(0, false), false);
    }
    assert_eq!(n.snapshot().position, s.position);
}

#[test]
fn limit_home_and_user_flags_switch_at_configured_positions() {
    let c = NodePlantConfig {
        home_position: 5000.0,
        home_width: 1000.0,
        plus_limit: 20_000.0,
        minus_limit: -30_000.0,
        ..cfg()
    };
    let mut n = ServoNode::new(1, &c);
    let at = |n: &mut ServoNode, p: f64| {
        n.set_position(p);
        n.feedback().r3 & (ST_HOME | ST_PLIM | ST_MLIM)
    };
    assert_eq!(at(&mut n, 0.0), 0);
    assert_eq!(at(&mut n, 4999.9), 0);
    assert_eq!(at(&mut n, 5000.1), ST_HOME);
    assert_eq!(at(&mut n, 5999.9), ST_HOME);
    assert_eq!(at(&mut n, 6000.1), 0);
    assert_eq!(at(&mut n, 19_999.9), 0);
    assert_eq!(at(&mut n, 20_000.1), ST_PLIM);
    assert_eq!(at(&mut n, -29_999.9), 0);
    assert_eq!(at(&mut n, -30_000.1), ST_MLIM);
    assert_eq!(n.feedback().r3 & ST_USER, 0);
    n.set_user_flag(true);
    assert_eq!(n.feedback().r3 & ST_USER, ST_USER);
    // a limit switch is a sensor, not a stop: an enabled motor drives straight through it
    n.set_position(19_000.0);
    n.apply_command(cmd(8192, true), false);
    let mut saw = Vec::new();
    for _ in 0..20 {
        let fb = tick(&mut n, cmd(8192, true), false);
        saw.push(fb.r3 & ST_PLIM != 0);
    }
    let first = saw.iter().position(|&b| b).unwrap();
    assert!(first > 0 && saw[first..].iter().all(|&b| b));
}

#[test]
fn amp_fault_when_enabled_with_a_configured_fault() {
    let c = NodePlantConfig {
        amp_fault: true,
        ..cfg()
    };
    let mut n = ServoNode::new(0, &c);
    let fb = tick(&mut n, cmd(8192, false), false);
    assert_eq!(fb.r3 & (ST_FAULT | ST_AMP_ENABLED), ST_FAULT); // low-true line: healthy = 1
    let fb = tick(&mut n, cmd(8192, true), false);
    assert_eq!(fb.r3 & (ST_FAULT | ST_AMP_ENABLED), 0); // faulted in the same tick, no power
    assert_eq!(fb.r2, 0);
    for _ in 0..10 {
        tick(&mut n, cmd(8192, true), false);
    }
    assert_eq!(n.snapshot().position, 0.0);
    // disable clears the latch
    let fb = tick(&mut n, cmd(0, false), false);
    assert_eq!(fb.r3 & ST_FAULT, ST_FAULT);
    // high-true polarity reports 1 = fault
    let mut h = ServoNode::new(
        0,
        &NodePlantConfig {
            fault_high_true: true,
            ..c
        },
    );
    assert_eq!(tick(&mut h, cmd(0, true), false).r3 & ST_FAULT, ST_FAULT);
    assert_eq!(tick(&mut h, cmd(0, false), false).r3 & ST_FAULT, 0);
}

#[test]
fn injected_amp_fault_latches_until_cleared() {
    let mut n = ServoNode::new(0, &cfg());
    let fb = tick(&mut n, cmd(1000, true), false);
    assert_eq!(
        fb.r3 & (ST_FAULT | ST_AMP_ENABLED),
        ST_FAULT | ST_AMP_ENABLED
    );
    n.inject_amp_fault();
    for _ in 0..3 {
        let fb = tick(&mut n, cmd(1000, true), false);
        assert_eq!(fb.r3 & (ST_FAULT | ST_AMP_ENABLED), 0);
    }
    n.clear_amp_fault();
    let fb = tick(&mut n, cmd(1000, true), false);
    assert_eq!(
        fb.r3 & (ST_FAULT | ST_AMP_ENABLED),
        ST_FAULT | ST_AMP_ENABLED
    );
}

#[test]
fn ring_fault_shuts_the_amplifier_in_the_same_tick_and_needs_a_fresh_enable() {
    let mut n = ServoNode::new(0, &cfg());
    for _ in 0..5 {
        tick(&mut n, cmd(8192, true), false);
    }
    assert_eq!(n.feedback().r2, 8192);
    let fb = tick(&mut n, cmd(8192, true), true);
    assert_eq!((fb.r2, fb.r3 & ST_AMP_ENABLED), (0, 0));
    assert!(!n.amplifier().enable_requested());
    let v = n.snapshot().velocity;
    assert!(v > 0.0);
    // ring healthy again, card still asserting enable: stays off (no restart by itself)
    for _ in 0..5 {
        let fb = tick(&mut n, cmd(8192, true), false);
        assert_eq!((fb.r2, fb.r3 & ST_AMP_ENABLED), (0, 0));
    }
    assert_eq!(n.snapshot().velocity, v); // no friction configured: coasting
    tick(&mut n, cmd(0, false), false);
    let fb = tick(&mut n, cmd(8192, true), false);
    assert_eq!((fb.r2, fb.r3 & ST_AMP_ENABLED), (8192, ST_AMP_ENABLED));
}

#[test]
fn velocity_mode_settles_at_the_commanded_speed_less_friction_droop() {
    // ω_ss = (kv·ω_cmd − Tc)/(kv + b)
    let c = NodePlantConfig {
        mode: AmpMode::Velocity,
        viscous: 2e-5,
        coulomb: 2e-4,
        ..cfg()
    };
    let mut n = ServoNode::new(0, &c);
    for _ in 0..200 {
        tick(&mut n, cmd(3277, true), false);
    }
    let wcmd = f64::from(3277 << 8) / f64::from(1 << 23) * c.velocity_full_scale;
    let kv = c.velocity_gain;
    let wss = (kv * wcmd - 2e-4) / (kv + 2e-5);
    let w = n.snapshot().velocity / 131_072.0 * TAU;
    assert!((w - wss).abs() < 1e-9 * wss, "{w} vs {wss}");
}

#[test]
fn pulse_mode_moves_at_the_register_2_rate() {
    let c = NodePlantConfig {
        mode: AmpMode::Pulse,
        pulse_full_scale: 1_000_000.0,
        ..cfg()
    };
    let mut n = ServoNode::new(0, &c);
    let pfm = |r2: u16, en: bool| NodeRegs {
        r0: 0,
        r1: 0,
        r2,
        r3: if en { CMD_AMP_ENABLE } else { 0 },
    };
    n.apply_command(pfm(0x0800, true), false); // 2048/32768 · 1e6 = 62,500 counts/s
    for _ in 0..100 {
        tick(&mut n, pfm(0x0800, true), false);
    }
    let expect = 62_500.0 * 100.0 * DT;
    assert!(
        (n.snapshot().position - expect).abs() < 1e-6,
        "{}",
        n.snapshot().position
    );
}

#[test]
fn register0_rolls_over_at_2_pow_24_in_32nds() {
    let mut n = ServoNode::new(0, &cfg());
    n.set_position(524_287.5 + 1e-6);
    assert_eq!(n.feedback().r0, 0xFF_FFF0);
    n.set_position(524_288.25 + 1e-6);
    assert_eq!(n.feedback().r0, 8);
    n.set_position(-0.5 + 1e-6);
    assert_eq!(n.feedback().r0, 0xFF_FFF0);
}

#[test]
fn runs_are_deterministic() {
    let run = || {
        let mut n = ServoNode::new(0, &NodePlantConfig::default());
        (0..3000)
            .map(|k| tick(&mut n, cmd(((k * 37) % 4001) - 2000, k % 700 < 650), false))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}

#[test]
fn arbitrary_command_registers_never_break_the_node() {
    // xorshift: deterministic "random" registers in every mode, with and without ring faults
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let documented = 0x1FF0u16; // bits 4-12 only (flags.rs table)
    for mode in [AmpMode::Torque, AmpMode::Velocity, AmpMode::Pulse] {
        let mut n = ServoNode::new(
            0,
            &NodePlantConfig {
                mode,
                ..Default::default()
            },
        );
        for _ in 0..2000 {
            let r = next();
            let c = NodeRegs {
                r0: r as u32,
                r1: (r >> 32) as u16,
                r2: (r >> 40) as u16,
                r3: (r >> 48) as u16,
            };
            let fb = tick(&mut n, c, r % 97 == 0);
            assert!(fb.r0 <= 0xFF_FFFF);
            assert_eq!(fb.r3 & !documented, 0);
            let s = n.snapshot();
            assert!(s.position.is_finite() && s.velocity.is_finite() && s.torque.abs() <= 4.0);
        }
    }
}

#[test]
fn capture_latches_the_count_at_the_flag_edge_and_end_stops_hold() {
    use crate::plant::flags::ST_CAPTURED;
    // Rising edge of the home flag at 5000 (window 5000..=6000), crossed at speed.
    let mut n = ServoNode::new(0, &NodePlantConfig::default());
    n.set_position(4990.3);
    assert_eq!(n.feedback().r3 & ST_CAPTURED, 0, "nothing latched yet");
    let mut m = n.clone();
    let omega = 20_000.0 / 131_072.0 * std::f64::consts::TAU; // 20,000 counts/s
    for _ in 0..3 {
        m.motor.set_state(m.motor.position(), omega);
        m.advance(0.000_442_7);
    }
    let fb = m.feedback();
    assert_ne!(fb.r3 & ST_CAPTURED, 0);
    assert_eq!(
        fb.r1, 5000,
        "the count at the edge, not where the tick ended"
    );
    // Falling edge (MI912 = 10) going down out of the window: the first count below it, the
    // switch's hysteresis (default 100 counts) below the window.
    let cfg = NodePlantConfig {
        capture_control: 10,
        ..NodePlantConfig::default()
    };
    let mut d = ServoNode::new(0, &cfg);
    d.set_position(4903.0);
    d.switch_states.home = true; // came from inside the window
    for _ in 0..3 {
        d.motor.set_state(d.motor.position(), -omega);
        d.advance(0.000_442_7);
    }
    assert_eq!(d.feedback().r1, 4899);
    // Without hysteresis the window's own edge.
    let mut d = ServoNode::new(
        0,
        &NodePlantConfig {
            switch_hysteresis: 0.0,
            ..cfg
        },
    );
    d.set_position(5003.0);
    for _ in 0..3 {
        d.motor.set_state(d.motor.position(), -omega);
        d.advance(0.000_442_7);
    }
    assert_eq!(d.feedback().r1, 4999);
    // End stop at 1000: full torque into it holds the shaft within the stiffness's reach.
    let stop = NodePlantConfig {
        hard_stops: true,
        plus_stop: 1_000.0,
        ..NodePlantConfig::default()
    };
    assert!(stop.validate().is_ok());
    let mut h = ServoNode::new(0, &stop);
    h.set_position(900.0);
    let full = NodeRegs {
        r0: 0x7F_FF00,
        r1: 0,
        r2: 0,
        r3: CMD_AMP_ENABLE,
    };
    let mut max = 0.0f64;
    for _ in 0..5000 {
        tick(&mut h, full, false);
        max = max.max(h.snapshot().position);
    }
    // Impact at speed overshoots the static 80-count penetration a little (damped).
    assert!(max > 1_000.0 && max < 1_000.0 + 150.0, "max {max}");
    let rest = h.snapshot();
    assert!(
        (rest.position - (1_000.0 + 4.0 / 0.05)).abs() < 2.0,
        "at rest {rest:?}"
    );
    let bad = NodePlantConfig {
        stop_stiffness: 100.0,
        ..stop
    };
    assert_eq!(
        bad.validate().unwrap_err().key_path(),
        Some("stop_stiffness")
    );
}

/// The pmac-motorhome `home_limit` path on one node: off the −limit (the release, captured
/// `switch_hysteresis` above the switch), back a little towards it (a servo's undershoot), and
/// then into it. The undershoot trips nothing; the −limit and the capture flag rise only at
/// the switch position itself, and the count latched there is the switch's.
#[test]
fn hysteresis_keeps_a_released_limit_off_until_the_switch_position() {
    use crate::plant::flags::ST_CAPTURED;
    let c = NodePlantConfig {
        minus_limit: -30_000.0,
        switch_hysteresis: 100.0,
        capture_flag: 2,
        capture_control: 10,
        ..NodePlantConfig::default()
    };
    let mut n = ServoNode::new(1, &c);
    n.set_position(-30_050.0);
    assert_ne!(n.feedback().r3 & ST_MLIM, 0, "on the limit");
    let speed = |cps: f64| cps / 131_072.0 * TAU;
    let run = |n: &mut ServoNode, cps: f64, to: f64| {
        for _ in 0..100_000 {
            let p = n.snapshot().position;
            if (cps > 0.0 && p >= to) || (cps < 0.0 && p <= to) {
                return;
            }
            n.motor.set_state(n.motor.position(), speed(cps));
            n.advance(50e-6);
        }
        panic!("never reached {to}");
    };
    // Up and off: still on the switch 50 counts above it, released past −29900.
    run(&mut n, 20_000.0, -29_950.0);
    assert_ne!(
        n.feedback().r3 & ST_MLIM,
        0,
        "inside the differential travel"
    );
    assert_eq!(n.feedback().r3 & ST_CAPTURED, 0);
    run(&mut n, 20_000.0, -29_850.0);
    let fb = n.feedback();
    assert_eq!(fb.r3 & ST_MLIM, 0, "released");
    assert_ne!(fb.r3 & ST_CAPTURED, 0);
    assert_eq!(fb.r1, (-29_900i64 & 0xFFFF) as u16, "the release count");
    // Back down 80 counts past the release point (an undershoot): still off.
    run(&mut n, -20_000.0, -29_980.0);
    assert_eq!(
        n.feedback().r3 & (ST_MLIM | ST_HOME),
        ST_HOME,
        "off; falling-edge flag 1"
    );
    // A rising-edge capture (MI912 = 2, as HM uses it) fires at the switch position.
    let rising = NodePlantConfig {
        capture_control: 2,
        ..c
    };
    n.reconfigure(&rising);
    assert_eq!(n.feedback().r3 & (ST_MLIM | ST_HOME), 0);
    run(&mut n, -20_000.0, -30_010.0);
    let fb = n.feedback();
    assert_eq!(fb.r3 & (ST_MLIM | ST_HOME), ST_MLIM | ST_HOME);
    assert_eq!(fb.r1, (-30_000i64 & 0xFFFF) as u16, "the switch position");
    // Deterministic: the same path twice gives the same registers.
    let again = {
        let mut m = ServoNode::new(1, &c);
        m.set_position(-30_050.0);
        run(&mut m, 20_000.0, -29_850.0);
        m.feedback()
    };
    let mut m = ServoNode::new(1, &c);
    m.set_position(-30_050.0);
    run(&mut m, 20_000.0, -29_850.0);
    assert_eq!(m.feedback(), again);
}

#[test]
fn injected_faults_change_the_feedback_registers_exactly() {
    use crate::faults::NodeFaults;
    let mut n = ServoNode::new(0, &cfg());
    n.apply_command(cmd(4096, true), false);
    for _ in 0..20 {
        tick(&mut n, cmd(4096, true), false);
    }
    // Encoder loss: register 0 and the A/B levels hold while the shaft moves on.
    n.set_faults(NodeFaults {
        encoder_frozen: true,
        ..Default::default()
    });
    let frozen = n.feedback();
    let before = n.snapshot().position;
    for _ in 0..20 {
        let fb = tick(&mut n, cmd(4096, true), false);
        assert_eq!(fb.r0, frozen.r0);
        assert_eq!(fb.r3 & 0x30, frozen.r3 & 0x30, "A/B held");
    }
    assert!(n.snapshot().position > before + 100.0, "the shaft moved on");
    // Glitch: register 0 is the true position + V counts, in 1/32 count.
    n.set_faults(NodeFaults {
        count_offset: 500.0,
        ..Default::default()
    });
    let truth = (n.snapshot().position * 32.0).floor() as i64;
    assert_eq!(
        i64::from(signed24(n.feedback().r0.wrapping_sub(wrap24(truth)))),
        500 * 32
    );
    // Jam: the shaft stands at the position it had, whatever the torque.
    n.set_faults(NodeFaults {
        jam: true,
        ..Default::default()
    });
    let at = n.snapshot().position;
    for _ in 0..20 {
        tick(&mut n, cmd(32767, true), false);
        n.set_faults(NodeFaults {
            jam: true,
            ..Default::default()
        });
    }
    assert_eq!(n.snapshot().position, at);
    // Switches forced, FAULT asserted (low-true line: bit 7 clear) and the output off.
    n.set_faults(NodeFaults {
        amp_fault: true,
        plus_limit: Some(true),
        minus_limit: Some(true),
        home: Some(true),
        ..Default::default()
    });
    let fb = tick(&mut n, cmd(8192, true), false);
    assert_eq!(
        fb.r3 & (ST_PLIM | ST_MLIM | ST_HOME),
        ST_PLIM | ST_MLIM | ST_HOME
    );
    assert_eq!(fb.r3 & (ST_FAULT | ST_AMP_ENABLED), 0);
    assert_eq!(fb.r2, 0, "no current");
    // Gone: everything back, the amplifier latch clears when enable drops.
    n.set_faults(NodeFaults::default());
    tick(&mut n, cmd(0, false), false);
    let fb = tick(&mut n, cmd(8192, true), false);
    assert_eq!(fb.r3 & (ST_PLIM | ST_MLIM | ST_HOME), 0);
    assert_ne!(fb.r3 & ST_FAULT, 0, "healthy line");
    assert_ne!(fb.r3 & ST_AMP_ENABLED, 0);
}
