//! StationApp through a real ring member: commands are routed in as packets and feedback
//! comes back one cycle later, as on the ring. Controllers here are written independently.

use super::*;
use crate::config::NodePlantConfig;
use crate::plant::amplifier::AmpMode;
use crate::plant::encoder::signed24;
use crate::plant::flags::{CMD_AMP_ENABLE, ST_AMP_ENABLED, ST_FAULT};
use mcc_ring::packet::Packet;
use mcc_ring::settings::RingSettings;

const PERIOD_NS: u64 = 442_733; // 2258.7 Hz

/// A slave member of master 0 with these nodes activated.
fn member(nodes: &[u8]) -> RingMember {
    let bits = nodes.iter().fold(0u32, |b, n| b | 1 << n);
    RingMember::new(RingSettings::new(0x80, 0x0F_0000 | bits))
}

/// The card's side of one cycle: its command packet passes the station, which substitutes its
/// last feedback (returned), then the station ticks.
fn cycle(
    app: &mut StationApp,
    m: &mut RingMember,
    k: u64,
    node: u8,
    c: NodeRegs,
    fault: bool,
) -> NodeRegs {
    let fwd = m
        .route(Packet::new(0, node, c))
        .forward
        .expect("slave forwards");
    app.tick(k, k * PERIOD_NS, m, fault);
    fwd.regs
}

fn cmd(dac: f64, enable: bool) -> NodeRegs {
    let d = dac.round().clamp(-32768.0, 32767.0) as i32;
    NodeRegs {
        r0: ((d << 8) as u32) & 0xFF_FFFF,
        r1: 0,
        r2: 0,
        r3: if enable { CMD_AMP_ENABLE } else { 0 },
    }
}

/// Card-side rollover extension of register 0 (1/32 count → counts).
struct Ext {
    last: Option<u32>,
    pos: i64,
}
impl Ext {
    fn update(&mut self, r0: u32) -> f64 {
        if let Some(l) = self.last {
            self.pos += i64::from(signed24(r0.wrapping_sub(l)));
        } else {
            self.pos = i64::from(signed24(r0));
        }
        self.last = Some(r0);
        self.pos as f64 / 32.0
    }
}

/// Triangular (accel-limited) move of `dist` counts at `acc` counts/s²: position at `t`.
fn triangle(dist: f64, acc: f64, t: f64) -> (f64, f64) {
    let th = (dist / acc).sqrt();
    if t <= th {
        (0.5 * acc * t * t, acc * t)
    } else if t <= 2.0 * th {
        let u = 2.0 * th - t;
        (dist - 0.5 * acc * u * u, acc * u)
    } else {
        (dist, 0.0)
    }
}

/// The PMAC PID with the seed's default gains (spec §4.1, Ix33 = 0):
/// DAC = 2^-19·Ix30·(Ix08·FE + Ix08·Ix32·CV/128 − Ix09·Ix31·AV/128), clipped to ±Ix69,
/// following a 10,000-count triangular move at the default Ix19 acceleration on the default
/// plant. `extra_delay` cycles are added between the card and the station (the test's
/// own path has one cycle: feedback of tick k−1 → command applied at tick k).
/// Returns (max |FE| during the run, final position).
fn default_gains_move(extra_delay: usize) -> (f64, f64) {
    let (ix30, ix31, ix32, ix08, ix69) = (2000.0, 1280.0, 1280.0, 96.0, 20480.0);
    let mut app = StationApp::new(&[0], &[], &PlantConfig::default()).unwrap();
    let mut m = member(&[0]);
    let mut ext = Ext { last: None, pos: 0 };
    let (mut prev_ap, mut max_fe, mut fb) = (0.0, 0.0f64, NodeRegs::default());
    let mut queue = std::collections::VecDeque::new();
    let dt = PERIOD_NS as f64 * 1e-9;
    let acc = 15_625.0; // Ix19 default 0.015625 counts/ms²
    for k in 0..6000u64 {
        let ap = ext.update(fb.r0);
        let t = k as f64 * dt;
        let (cp, cv_s) = triangle(10_000.0, acc, t);
        let (cv, av) = (cv_s * dt, ap - prev_ap);
        prev_ap = ap;
        let fe = cp - ap;
        max_fe = max_fe.max(fe.abs());
        let dac =
            ix30 / 524_288.0 * (ix08 * fe + ix08 * ix32 * cv / 128.0 - ix08 * ix31 * av / 128.0);
        queue.push_back(cmd(dac.clamp(-ix69, ix69), true));
        let c = if queue.len() > extra_delay {
            queue.pop_front().unwrap()
        } else {
            cmd(0.0, true)
        };
        fb = cycle(&mut app, &mut m, k, 0, c, false);
    }
    (max_fe, ext.update(fb.r0))
}

#[test]
fn pmac_default_gains_track_a_10000_count_move_on_the_default_plant() {
    // Bound for the default plant + default gains: the Coulomb deadband (≈ 4.5 counts) plus the
    // lag of the delayed feedback; measured 5.2 counts (1 cycle) and 6.2 counts (3 cycles, as a
    // sync-master card sees it on the ring).
    for (delay, bound) in [(0, 6.0), (2, 7.0)] {
        let (max_fe, end) = default_gains_move(delay);
        assert!(
            max_fe < bound,
            "delay {delay}: max following error {max_fe}"
        );
        assert!(
            (end - 10_000.0).abs() < 10.0,
            "delay {delay}: settled at {end}"
        ); // Ix28
    }
}

#[test]
fn simple_p_controller_drives_a_velocity_mode_plant_to_target() {
    let plant = PlantConfig {
        defaults: NodePlantConfig {
            mode: AmpMode::Velocity,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut app = StationApp::new(&[5], &[], &plant).unwrap();
    let mut m = member(&[5]);
    let mut ext = Ext { last: None, pos: 0 };
    let mut fb = NodeRegs::default();
    let target = 10_000.0;
    let mut peak: f64 = 0.0;
    for k in 0..1200u64 {
        let ap = ext.update(fb.r0);
        peak = peak.max(ap);
        fb = cycle(
            &mut app,
            &mut m,
            k,
            5,
            cmd(1.0 * (target - ap), true),
            false,
        );
    }
    let end = ext.update(fb.r0);
    assert!((end - target).abs() < 10.0, "settled at {end}");
    assert!(peak < target * 1.02, "overshoot to {peak}");
}

#[test]
fn ring_fault_zeroes_outputs_and_drops_enables_in_the_same_tick() {
    let mut app = StationApp::new(&[0, 1], &[2], &PlantConfig::default()).unwrap();
    let mut m = member(&[0, 1, 2]);
    let io = NodeRegs {
        r0: 0x123456,
        r1: 7,
        r2: 8,
        r3: 9,
    };
    for k in 0..20 {
        m.route(Packet::new(0, 0, cmd(4000.0, true)));
        m.route(Packet::new(0, 1, cmd(-4000.0, true)));
        m.route(Packet::new(0, 2, io));
        app.tick(k, k * PERIOD_NS, &mut m, false);
    }
    assert_eq!(m.write_regs(2), io);
    for n in [0, 1] {
        let w = m.write_regs(n);
        assert_ne!(w.r2, 0);
        assert_eq!(
            w.r3 & (ST_AMP_ENABLED | ST_FAULT),
            ST_AMP_ENABLED | ST_FAULT
        );
    }
    let extra = app.status_extra();
    assert_eq!(extra["ring_shutdown_cycle"], serde_json::Value::Null);
    assert_eq!(extra["amps_enabled"], serde_json::json!([0, 1]));
    app.tick(20, 20 * PERIOD_NS, &mut m, true);
    assert!(app.ring_fault());
    app.tick(21, 21 * PERIOD_NS, &mut m, true);
    // The status names the tick that shut the amplifiers down, while the fault lasts.
    let extra = app.status_extra();
    assert_eq!(extra["ring_shutdown_cycle"], 20);
    assert_eq!(extra["amps_enabled"], serde_json::json!([]));
    assert_eq!(m.write_regs(2), NodeRegs::default());
    for n in [0, 1] {
        let w = m.write_regs(n);
        assert_eq!((w.r2, w.r3 & ST_AMP_ENABLED), (0, 0), "node {n}");
        assert!(!app.node(n).unwrap().amplifier().enable_requested());
        assert_ne!(w.r0, 0, "position keeps being reported");
    }
    app.tick(22, 22 * PERIOD_NS, &mut m, false);
    assert_eq!(app.shutdown_cycle(), None);
}

#[test]
fn time_steps_come_from_the_tick_time() {
    let mut app = StationApp::new(&[0], &[], &PlantConfig::default()).unwrap();
    let mut m = member(&[0]);
    m.route(Packet::new(0, 0, cmd(8192.0, true)));
    app.tick(100, 100 * PERIOD_NS, &mut m, false); // first tick: no step
    assert_eq!(app.node(0).unwrap().snapshot().position, 0.0);
    app.tick(101, 100 * PERIOD_NS, &mut m, false); // time did not advance: no step
    assert_eq!(app.node(0).unwrap().snapshot().position, 0.0);
    app.tick(102, 99 * PERIOD_NS, &mut m, false); // backwards: no step
    assert_eq!(app.node(0).unwrap().snapshot().position, 0.0);
    app.tick(103, 101 * PERIOD_NS, &mut m, false);
    assert!(app.node(0).unwrap().snapshot().position > 0.0);
    assert_eq!(app.ticks(), 4);
}

/// A restarted sync master renumbers the ring from a lower cycle: the plant goes on stepping
/// one period per cycle from the new count (it does not stand still until the ring's count
/// passes the old one).
#[test]
fn a_renumbered_ring_keeps_the_plant_stepping() {
    let run = |renumber: bool| {
        let mut app = StationApp::new(&[0], &[], &PlantConfig::default()).unwrap();
        let mut m = member(&[0]);
        m.route(Packet::new(0, 0, cmd(2000.0, true)));
        for c in 50_000..50_010u64 {
            app.tick(c, c * PERIOD_NS, &mut m, false);
        }
        let base = if renumber { 0 } else { 50_010 };
        for c in base..base + 10 {
            app.tick(c, c * PERIOD_NS, &mut m, false);
        }
        app.node(0).unwrap().snapshot()
    };
    let (renumbered, steady) = (run(true), run(false));
    assert!(renumbered.velocity > 0.0, "{renumbered:?}");
    // One tick (the renumbering itself) without a step; otherwise the same motion.
    assert!(renumbered.position > 0.0 && renumbered.position < steady.position);
    assert!(
        renumbered.velocity > steady.velocity * 0.8,
        "{renumbered:?} {steady:?}"
    );
}

#[test]
fn bad_node_lists_are_refused_with_a_message() {
    let p = PlantConfig::default();
    let refused = |servo: &[u8], io: &[u8], plant: &PlantConfig| {
        let e = StationApp::new(servo, io, plant).unwrap_err();
        (e, e.to_string())
    };
    assert_eq!(
        refused(&[16], &[], &p),
        (
            NodeListError::OutOfRange(16),
            "node 16: must be 0-15".into()
        )
    );
    assert_eq!(
        refused(&[1], &[1], &p),
        (NodeListError::Duplicate(1), "node 1: listed twice".into())
    );
    let q = PlantConfig::from_toml_str("[nodes.3]\namp_fault = true").unwrap();
    assert_eq!(
        refused(&[0, 1], &[], &q),
        (
            NodeListError::NotServo(3),
            "plant.nodes.3: node 3 is not a servo node of this station".into()
        )
    );
    assert!(StationApp::new(&[0, 1, 3], &[], &q)
        .unwrap()
        .node(3)
        .is_some());
}

/// `MS SAVE` through the whole station: the tick hands the write to the save thread and the
/// reply comes back (through the master, which keeps waiting) once the file is written.
#[allow(clippy::disallowed_methods)] // waits for the save thread in wall-clock time
fn save_through_the_app(path: &std::path::Path) -> mcc_ring::aux_channel::Outcome {
    use mcc_ring::aux_channel::{AuxMaster, AuxWord, Request, StationCmd, AUX_NODE};
    let mut app = StationApp::new(&[0], &[], &PlantConfig::default())
        .unwrap()
        .with_setup(Globals::from_check(8, 4, 4), Some(path.to_path_buf()));
    let mut m = member(&[0]);
    let mut master = AuxMaster::default();
    assert!(master.start(0, Request::Command(StationCmd::Save), 32));
    let mut back = AuxWord::IDLE;
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    for k in 0.. {
        let (out, (r2, r3)) = master.tick(back);
        if let Some(o) = out {
            return o;
        }
        let regs = NodeRegs {
            r2,
            r3,
            ..NodeRegs::default()
        };
        let fwd = m.route(Packet::new(0, AUX_NODE, regs)).forward.unwrap();
        back = AuxWord::decode(fwd.regs.r2, fwd.regs.r3);
        app.tick(k, k * PERIOD_NS, &mut m, false);
        assert!(std::time::Instant::now() < deadline, "no reply");
        std::thread::sleep(std::time::Duration::from_micros(100));
    }
    unreachable!()
}

#[test]
#[allow(clippy::disallowed_methods)] // reads the state file back
fn ms_save_is_written_by_the_save_thread_and_then_answered() {
    use crate::mi::persist::{self, Loaded};
    use mcc_ring::aux_channel::{slave_error, Outcome, Reply};
    let dir = std::env::temp_dir().join(format!("mcc-station-app-save-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let path = dir.join("state").join("station0.state");
    assert_eq!(save_through_the_app(&path), Outcome::Reply(Reply::Done));
    assert!(matches!(persist::load(&path), Loaded::Setup(_)));
    // a state file below a regular file cannot be written: SAVE_FAILED
    let bad = path.join("station0.state");
    assert_eq!(
        save_through_the_app(&bad),
        Outcome::Reply(Reply::Error(slave_error::SAVE_FAILED))
    );
    assert!(matches!(persist::load(&path), Loaded::Setup(_)), "intact");
    std::fs::remove_dir_all(&dir).unwrap();
}
