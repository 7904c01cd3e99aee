//! Closed-loop behaviour with a plant model written here, and the safety trips.
//!
//! Plant (units: counts, servo cycles): a double integrator driven by the DAC output with
//! viscous and Coulomb friction, `a = G·u − B·v − C·sign(v)`, sticking when |G·u| ≤ C at rest,
//! integrated with 8 semi-implicit Euler sub-steps per cycle. G = 0.02 counts/cycle² per DAC
//! bit, B = 0.002 /cycle, C = 0.02 counts/cycle² (1 DAC bit). Feedback is the plant position in
//! 1/32 counts, 24-bit wrapping, one cycle late (as it comes back over the ring).

use super::flags::FlagInputs;
use super::jog::JogCmd;
use super::motor::{Motor, MotorCommand, TickInput, TickOutput, TripKind, TripScope};
use super::params::MotorParams;

const DT: f64 = 3_713_707.0 / 8_388_608.0;
const G: f64 = 0.02;
const B: f64 = 0.002;
const C: f64 = 0.02;

struct Plant {
    x: f64,
    v: f64,
}

impl Plant {
    fn step(&mut self, dac: f64, enabled: bool) {
        let u = if enabled { dac } else { 0.0 };
        let h = 1.0 / 8.0;
        for _ in 0..8 {
            let drive = G * u - B * self.v;
            if self.v == 0.0 && drive.abs() <= C {
                continue;
            }
            let sgn = if self.v != 0.0 {
                self.v.signum()
            } else {
                drive.signum()
            };
            let nv = self.v + (drive - C * sgn) * h;
            // Coulomb friction never reverses the motion within a step.
            self.v = if self.v != 0.0 && nv.signum() != self.v.signum() {
                0.0
            } else {
                nv
            };
            self.x += self.v * h;
        }
    }
    fn feedback(&self) -> u32 {
        ((self.x * 32.0).round() as i64 as u32) & 0xFF_FFFF
    }
}

struct Rig {
    m: Motor,
    p: MotorParams,
    plant: Plant,
    flags: FlagInputs,
    stuck: Option<u32>,
}

impl Rig {
    fn new(p: MotorParams) -> Self {
        Rig {
            m: Motor::new(),
            p,
            plant: Plant { x: 0.0, v: 0.0 },
            flags: FlagInputs::default(),
            stuck: None,
        }
    }
    fn cmd(&mut self, c: MotorCommand) {
        self.m.command(c, &self.p);
    }
    fn jog(&mut self, c: JogCmd) {
        self.cmd(MotorCommand::Jog {
            cmd: c,
            trigger: None,
        });
    }
    fn tick(&mut self) -> TickOutput {
        let inp = TickInput {
            feedback: self.stuck.unwrap_or(self.plant.feedback()),
            flags: self.flags,
            dt_ms: DT,
            program: None,
            background: true,
        };
        let out = self.m.tick(&self.p, &inp);
        self.plant.step(out.dac, out.amp_enable);
        out
    }
}

#[test]
fn default_gains_10000_count_jog_following_error_bound() {
    let mut r = Rig::new(MotorParams::default());
    r.cmd(MotorCommand::Enable);
    r.jog(JogCmd::To(10_000.0));
    let mut max_fe: f64 = 0.0;
    let mut done_at = None;
    for k in 0..8000 {
        let out = r.tick();
        assert_eq!(out.trip, None);
        max_fe = max_fe.max(r.m.following_error().abs());
        if done_at.is_none() && r.m.flags.in_position {
            done_at = Some(k);
        }
    }
    // Default Ix19/Ix21 profile takes ~1.66 s (3,750 cycles); settled well before 8,000.
    let done = done_at.expect("in position");
    assert!(done > 3700 && done < 4200, "in position at cycle {done}");
    eprintln!("max |FE| {max_fe} counts, in position at cycle {done}");
    assert!(max_fe < 6.0, "max |FE| {max_fe} counts");
    assert!((r.m.actual() - 10_000.0).abs() * 16.0 < r.p.inpos_band);
    assert!((r.plant.x - 10_000.0).abs() < 10.0);
}

#[test]
fn fatal_following_error_kills_in_the_same_cycle() {
    let mut r = Rig::new(MotorParams::default());
    r.cmd(MotorCommand::Enable);
    r.stuck = Some(0); // encoder disconnected
    r.jog(JogCmd::Plus);
    let mut tripped = None;
    for k in 0..10_000 {
        let out = r.tick();
        if let Some(t) = out.trip {
            assert_eq!((t.kind, t.scope), (TripKind::FatalFe, TripScope::Card));
            assert_eq!((out.reg0, out.dac, out.amp_enable), (0, 0.0, false));
            tripped = Some(k);
            break;
        }
        // Warning comes first (Ix12 = 1000 counts).
        assert_eq!(r.m.flags.warning_fe, r.m.following_error().abs() > 1000.0);
    }
    assert!(tripped.is_some());
    let f = &r.m.flags;
    assert!(f.fatal_fe && f.warning_fe && f.open_loop && !f.amp_enabled);
    // Nothing moves until commanded: killed output stays 0.
    assert_eq!(r.tick().reg0, 0);
    r.cmd(MotorCommand::Enable);
    assert!(!r.m.flags.fatal_fe, "cleared on re-enable");
}

#[test]
fn amp_fault_kills_with_ix25_scope_and_respects_ignore_bit() {
    let mut r = Rig::new(MotorParams {
        ix25: 0x40F70 | (1 << 22),
        ..MotorParams::default()
    });
    r.cmd(MotorCommand::Enable);
    r.jog(JogCmd::Plus);
    for _ in 0..200 {
        r.tick();
    }
    r.flags.amp_fault = true;
    let out = r.tick();
    let t = out.trip.unwrap();
    assert_eq!((t.kind, t.scope), (TripKind::AmpFault, TripScope::Motor));
    assert_eq!((out.reg0, out.amp_enable), (0, false));
    assert!(r.m.flags.amp_fault && r.m.flags.open_loop);
    // Ix25 bit 20 set: the fault input is ignored.
    let mut r = Rig::new(MotorParams {
        ix25: 0x40F70 | (1 << 20),
        ..MotorParams::default()
    });
    r.cmd(MotorCommand::Enable);
    r.flags.amp_fault = true;
    assert_eq!(r.tick().trip, None);
}

#[test]
fn hard_limit_decelerates_at_ix15_and_blocks_that_direction() {
    let p = MotorParams {
        ramp: super::profile::RampParams::new(1.0, 50.0, 0.0),
        ..MotorParams::default()
    };
    let mut r = Rig::new(p);
    r.cmd(MotorCommand::Enable);
    r.jog(JogCmd::Plus);
    for _ in 0..1000 {
        r.tick();
    }
    let v_ms = 32.0;
    r.flags.plus_limit = true;
    let out = r.tick();
    let t = out.trip.unwrap();
    assert_eq!(
        (t.kind, t.scope),
        (TripKind::PlusLimit, TripScope::ProgramOnly)
    );
    let f = &r.m.flags;
    assert!(f.pos_limit && f.stopped_on_limit && f.abort_decel && !f.open_loop);
    // Stops at Ix15 = 0.25 counts/ms²: 32/0.25 = 128 ms ≈ 289 cycles, loop stays closed.
    let start = r.m.commanded();
    let mut k = 0;
    while !r.m.flags.desired_velocity_zero && k < 1000 {
        r.tick();
        k += 1;
    }
    assert!((288..=291).contains(&k), "stopped after {k} cycles");
    let dist = r.m.commanded() - start;
    assert!(
        (dist - v_ms * v_ms / (2.0 * 0.25)).abs() < 32.0 * DT + 1.0,
        "{dist}"
    );
    assert!(r.m.closed_loop());
    // J+ refused while the limit is set; J- allowed.
    r.jog(JogCmd::Plus);
    let before = r.m.commanded();
    for _ in 0..100 {
        r.tick();
    }
    assert_eq!(r.m.commanded(), before);
    r.jog(JogCmd::Minus);
    for _ in 0..100 {
        r.tick();
    }
    assert!(r.m.commanded() < before);
}

#[test]
fn software_limit_stops_past_ix13() {
    let mut r = Rig::new(MotorParams {
        soft_plus: 500.0,
        ..MotorParams::default()
    });
    r.cmd(MotorCommand::Enable);
    r.jog(JogCmd::To(5000.0));
    let mut saw = false;
    for _ in 0..6000 {
        if let Some(t) = r.tick().trip {
            assert_eq!(t.kind, TripKind::PlusLimit);
            saw = true;
        }
    }
    assert!(saw && r.m.flags.pos_limit && r.m.flags.stopped_on_limit);
    assert!(
        r.m.commanded() > 500.0 && r.m.commanded() < 700.0,
        "{}",
        r.m.commanded()
    );
}

#[test]
fn integrated_fe_trip_with_negative_ix63() {
    let d = MotorParams::default();
    let p = MotorParams {
        gains: super::pid::PidGains {
            ki: 100_000.0,
            int_limit: -1600.0, // 100 counts
            ..d.gains
        },
        fatal_fe: 0.0,
        ..d
    };
    let mut r = Rig::new(p);
    r.cmd(MotorCommand::Enable);
    r.stuck = Some(((-50i32 * 32) as u32) & 0xFF_FFFF); // held 50 counts away
    let mut trip = None;
    for _ in 0..100_000 {
        if let Some(t) = r.tick().trip {
            trip = Some((t, r.m.flags.clone()));
            break;
        }
    }
    let (t, f) = trip.unwrap();
    assert_eq!(t.kind, TripKind::IntegratedFe);
    assert!(f.fatal_fe && f.integrated_fe && f.open_loop);
}

#[test]
fn kill_open_loop_and_abort() {
    let mut r = Rig::new(MotorParams::default());
    r.cmd(MotorCommand::OpenLoop(50.0));
    let out = r.tick();
    assert_eq!(
        (out.dac, out.reg0, out.amp_enable),
        (10_240.0, 10_240 << 8, true)
    );
    assert!(r.m.flags.open_loop && r.m.flags.amp_enabled);
    r.cmd(MotorCommand::OpenLoop(-300.0));
    assert_eq!(r.tick().dac, -20_480.0, "saturates at 100 % of Ix69");
    r.cmd(MotorCommand::Kill);
    let out = r.tick();
    assert_eq!((out.reg0, out.amp_enable), (0, false));
    // Ix29 offset is kept when killed.
    r.p.dac_offset = -3.0;
    assert_eq!(r.tick().reg0, (-3i32 * 256) as u32 & 0xFF_FFFF);
    r.p.dac_offset = 0.0;
    // Abort on a killed motor closes the loop where it stands.
    r.cmd(MotorCommand::Abort);
    assert!(r.m.closed_loop());
    assert_eq!(r.m.commanded(), r.m.actual());
}

#[test]
fn home_search_finds_flag_and_sets_zero_at_offset() {
    let p = MotorParams {
        home_offset: 160.0, // 10 counts
        ramp: super::profile::RampParams::new(1.0, 20.0, 10.0),
        ..MotorParams::default()
    };
    let mut r = Rig::new(p);
    r.cmd(MotorCommand::Home);
    assert!(r.m.flags.home_search && !r.m.flags.home_complete);
    let mut trigger_x = None;
    for _ in 0..20_000 {
        r.flags.home = r.plant.x >= 3000.0;
        r.tick();
        if trigger_x.is_none() && r.m.flags.home_complete {
            trigger_x = Some(r.plant.x);
        }
    }
    assert!(trigger_x.is_some());
    let f = &r.m.flags;
    assert!(f.home_complete && !f.home_search && f.in_position);
    assert!(
        r.m.actual().abs() < 2.0,
        "motor zero at the post-trigger end: {}",
        r.m.actual()
    );
    // Physical end point ≈ trigger + 10 counts; trigger seen one cycle after crossing 3000.
    assert!(
        (r.plant.x - 3010.0).abs() < 32.0 * DT + 2.0,
        "plant at {}",
        r.plant.x
    );
}

/// Servo tick cost: `cargo test -p mcc-card --release --lib motion::tests_loop::bench -- --ignored --nocapture`.
#[test]
#[ignore]
#[allow(clippy::disallowed_methods)] // a timing probe, not a test
fn bench_servo_tick_cost() {
    let mut rigs: Vec<Rig> = (0..8).map(|_| Rig::new(MotorParams::default())).collect();
    for r in &mut rigs {
        r.cmd(MotorCommand::Enable);
        r.jog(JogCmd::To(10_000.0));
    }
    let mut ns = Vec::with_capacity(8 * 20_000);
    for _ in 0..20_000 {
        for r in &mut rigs {
            let inp = TickInput {
                feedback: r.plant.feedback(),
                flags: r.flags,
                dt_ms: DT,
                program: None,
                background: true,
            };
            let t0 = std::time::Instant::now();
            let out = r.m.tick(&r.p, &inp);
            ns.push(t0.elapsed().as_nanos() as u64);
            r.plant.step(out.dac, out.amp_enable);
        }
    }
    ns.sort_unstable();
    let (p50, p99) = (ns[ns.len() / 2], ns[ns.len() * 99 / 100]);
    let share = 8.0 * p50 as f64 * 2258.7 / 1e9 * 100.0;
    eprintln!("servo tick per motor: p50 {p50} ns, p99 {p99} ns; 8 motors at 2258.7 Hz: {share:.3} % of a core");
}

#[test]
fn jog_until_trigger_stops_past_the_flag_and_resolve_forms() {
    use crate::domain::ast::JogKind;
    let p = MotorParams {
        ramp: super::profile::RampParams::new(1.0, 20.0, 0.0),
        ..MotorParams::default()
    };
    let mut r = Rig::new(p);
    r.cmd(MotorCommand::Enable);
    let c = r.m.resolve_jog(JogKind::To(8000.0), 0.0).unwrap();
    r.cmd(MotorCommand::Jog {
        cmd: c,
        trigger: Some(100.0),
    });
    assert!(r.m.flags.trigger_move);
    let mut cap = None;
    for _ in 0..10_000 {
        r.flags.home = r.plant.x >= 2000.0;
        r.tick();
        if cap.is_none() && !r.m.flags.trigger_move {
            cap = Some(r.m.actual());
        }
    }
    let cap = cap.unwrap();
    assert!((2000.0..2020.0).contains(&cap), "captured at {cap}");
    assert_eq!(r.m.commanded(), cap + 100.0, "ends d past the capture");
    assert!(!r.m.flags.home_complete, "not a home move");
    // Resolution of the relative and pre-jog forms.
    let (cmd, act) = (r.m.commanded(), r.m.actual());
    assert_eq!(
        r.m.resolve_jog(JogKind::RelCommanded(5.0), 0.0),
        Some(JogCmd::To(cmd + 5.0))
    );
    assert_eq!(
        r.m.resolve_jog(JogKind::VarRelActual, -7.0),
        Some(JogCmd::To(act - 7.0))
    );
    assert_eq!(
        r.m.resolve_jog(JogKind::ToAndSetPreJog(42.0), 0.0),
        Some(JogCmd::To(42.0))
    );
    assert_eq!(
        r.m.resolve_jog(JogKind::PreJog, 0.0),
        Some(JogCmd::To(42.0))
    );
    assert_eq!(r.m.resolve_jog(JogKind::To(f64::NAN), 0.0), None);
}

#[test]
fn inactive_motor_does_nothing() {
    let mut r = Rig::new(MotorParams {
        active: false,
        ..MotorParams::default()
    });
    r.cmd(MotorCommand::OpenLoop(50.0));
    let out = r.tick();
    assert_eq!((out.reg0, out.amp_enable, out.trip), (0, false, None));
}
