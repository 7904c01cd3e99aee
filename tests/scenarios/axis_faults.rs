//! Issue 23 item 2: axis faults injected at the station plant at run time, as the card sees
//! them. A PMAC2 (and for the amplifier fault and power loss a Turbo) ring card and a station
//! on the deterministic lockstep `RingSim`; each fault goes in through the station's
//! `RingApp::app_fault` with the JSON `mcc fault STATION axis NODE KIND` sends, and is taken
//! away by `clear_app_faults` (`mcc fault clear`). Asserted: the motor's `?` bits, the
//! FE kill (Ix11), what `#1P`/`#1F` read, the cycle the card reacts in, and the PMAC recovery.

use mcc_card::Profile;
use mcc_contracts::config::ClusterConfig;
use mcc_ring::core::RingApp;
use mcc_station::config::NodePlantConfig;
use serde_json::{json, Value};

use crate::motion::Rig;

const W1_NEG_LIMIT: u32 = 1 << 22;
const W1_POS_LIMIT: u32 = 1 << 21;
const W1_TURBO_AMP_ENABLED: u32 = 1 << 19;
const W1_OPEN_LOOP: u32 = 1 << 18;
const W1_HOME_SEARCH: u32 = 1 << 10;
const W2_AMP_ENABLED: u32 = 1 << 14;
const W2_STOPPED_ON_LIMIT: u32 = 1 << 11;
const W2_HOME_COMPLETE: u32 = 1 << 10;
const W2_AMP_FAULT: u32 = 1 << 3;
const W2_FATAL_FE: u32 = 1 << 2;

/// Ring cycles from the fault's first station tick to the card's `?` showing its effect:
/// the feedback written in tick C is read by the card in cycle C + 1 (ring latency), its
/// flag copy and servo act in that cycle; 4 cycles is the bound with margin.
pub(crate) const FLAG_BOUND: u64 = 4;

fn rig_with(plant: NodePlantConfig, profile: Profile) -> Rig {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    if profile == Profile::Turbo {
        cfg.cards[0].profile = "turbo".into();
        cfg.cards[0].ivars.clear();
        cfg = cfg.resolve().expect("config");
    }
    let mut rig = Rig::with_card(plant, cfg, profile);
    rig.cmd("I3=2");
    rig.run(20);
    rig.cmd("#1J/");
    rig.cmd("#2J/");
    rig.run(100);
    assert_eq!(rig.status(1).0 & W1_OPEN_LOOP, 0, "motor 1 closed loop");
    rig
}

fn rig() -> Rig {
    rig_with(NodePlantConfig::default(), Profile::Pmac2)
}

/// Inject on station 0 as `mcc fault station0 axis NODE KIND` does; the ring cycle of the
/// next station tick (the fault's `since_cycle`).
fn axis(rig: &mut Rig, node: u8, kind: &str, value: Option<f64>, cycles: Option<u64>) -> u64 {
    let mut req = json!({"op": "axis", "node": node, "kind": kind});
    if let Some(v) = value {
        req["value"] = json!(v);
    }
    if let Some(n) = cycles {
        req["cycles"] = json!(n);
    }
    send(rig, req).unwrap_or_else(|e| panic!("{kind}: {e}"));
    rig.sim.cycle() + 1
}

fn send(rig: &mut Rig, req: Value) -> Result<String, String> {
    rig.station().app_fault(&req)
}

fn clear(rig: &mut Rig) {
    rig.station().clear_app_faults();
}

/// The station's status entry for its injected faults.
fn shown(rig: &mut Rig) -> Vec<Value> {
    rig.station().status_extra()["axis_faults"]
        .as_array()
        .cloned()
        .unwrap()
}

/// Step until `pred` holds (at most `max` cycles); the cycle it first held in.
fn until(rig: &mut Rig, max: u64, what: &str, mut pred: impl FnMut(&mut Rig) -> bool) -> u64 {
    for _ in 0..max {
        rig.run(1);
        if pred(rig) {
            return rig.sim.cycle();
        }
    }
    panic!("{what}: not within {max} cycles: {:?}", rig.status(1));
}

fn killed_by(rig: &mut Rig, bit: u32) -> bool {
    let (w1, w2) = rig.status(1);
    w1 & W1_OPEN_LOOP != 0 && w2 & bit != 0
}

/// `#1J/` closes the loop again with no error bit left.
fn recovers(rig: &mut Rig) {
    rig.cmd("#1J/");
    rig.run(50);
    let (w1, w2) = rig.status(1);
    assert_eq!(w1 & W1_OPEN_LOOP, 0, "closed loop again");
    assert_eq!(w2 & (W2_AMP_FAULT | W2_FATAL_FE), 0, "no error bit left");
    let amp = rig.station().node(0).unwrap().snapshot().flags.amp_enabled;
    assert!(amp, "the station's amplifier is on");
}

fn amp_fault_kills_until_cleared(profile: Profile) {
    let mut rig = rig_with(NodePlantConfig::default(), profile);
    let enabled = |rig: &mut Rig| {
        let (w1, w2) = rig.status(1);
        match profile {
            Profile::Turbo => w1 & W1_TURBO_AMP_ENABLED != 0,
            _ => w2 & W2_AMP_ENABLED != 0,
        }
    };
    assert!(enabled(&mut rig));
    let c = axis(&mut rig, 0, "amp-fault", None, None);
    let seen = until(&mut rig, 20, "amp fault bit", |r| {
        killed_by(r, W2_AMP_FAULT)
    });
    assert!(seen - c <= FLAG_BOUND, "seen {} cycles after", seen - c);
    assert!(!enabled(&mut rig), "amplifier enable dropped");
    let f = shown(&mut rig);
    assert_eq!(f.len(), 1);
    assert_eq!(
        (f[0]["node"].clone(), f[0]["kind"].clone()),
        (json!(0), json!("amp-fault"))
    );
    assert_eq!(f[0]["since_cycle"], json!(c));
    // Still faulted: enabling again trips again.
    rig.cmd("#1J/");
    rig.run(20);
    assert!(killed_by(&mut rig, W2_AMP_FAULT), "re-faults while active");
    clear(&mut rig);
    rig.run(2);
    assert!(shown(&mut rig).is_empty());
    recovers(&mut rig);
    assert!(enabled(&mut rig));
}

#[test]
fn pmac2_amp_fault_kills_and_recovers_after_clear() {
    amp_fault_kills_until_cleared(Profile::Pmac2);
}

#[test]
fn turbo_amp_fault_kills_and_recovers_after_clear() {
    amp_fault_kills_until_cleared(Profile::Turbo);
}

/// `cycles = N`: the fault acts for N ticks and is gone; `#1J/` recovers without a clear.
#[test]
fn amp_fault_for_n_cycles_expires_by_itself() {
    let mut rig = rig();
    let c = axis(&mut rig, 0, "amp-fault", None, Some(10));
    rig.run(5);
    assert!(killed_by(&mut rig, W2_AMP_FAULT));
    assert_eq!(shown(&mut rig)[0]["until_cycle"], json!(c + 10));
    rig.run(10);
    assert!(shown(&mut rig).is_empty(), "expired at cycle {}", c + 10);
    assert!(!rig.station().node(0).unwrap().faults().amp_fault);
    recovers(&mut rig);
}

/// Encoder loss during a jog: `#1P` freezes exactly, `#1F` grows, the card kills on fatal FE
/// (here Ix11 = 8000/16 = 500 counts); after clear `#1P` reads where the motor really is.
#[test]
fn encoder_loss_freezes_position_and_trips_fatal_following_error() {
    let mut rig = rig();
    rig.cmd("I111=8000 I119=1 I122=16");
    rig.cmd("#1J+");
    rig.run(300);
    axis(&mut rig, 0, "encoder-loss", None, None);
    rig.run(3);
    let p0 = rig.num("#1P");
    let mut fe = Vec::new();
    let killed = until(&mut rig, 2000, "fatal FE", |r| {
        if !killed_by(r, W2_FATAL_FE) {
            fe.push(r.num("#1F"));
            assert_eq!(r.num("#1P"), p0, "position frozen");
            false
        } else {
            true
        }
    });
    assert!(fe.windows(2).all(|w| w[1] >= w[0]), "FE grows");
    let last = *fe.last().unwrap();
    assert!(
        last > 490.0 && last <= 500.0,
        "killed as FE passed 500: {last}"
    );
    assert!(killed > 0);
    clear(&mut rig);
    // The killed motor coasts to a stop.
    rig.run(5000);
    let truth = rig.node_position(0);
    assert!(
        (rig.num("#1P") - truth).abs() < 1.0,
        "reads the motor again"
    );
    assert!(
        truth > p0 + 100.0,
        "the motor went on moving: {p0} -> {truth}"
    );
    recovers(&mut rig);
}

/// A glitch of 500 counts (below Ix11): `#1P` jumps 500, the servo pulls the motor back by
/// 500 so `#1P` is where it was commanded; one of 5000 counts is a fatal FE at once.
#[test]
fn encoder_glitch_jumps_the_count() {
    let mut rig = rig();
    rig.run(200);
    let (p0, n0) = (rig.num("#1P"), rig.node_position(0));
    axis(&mut rig, 0, "encoder-glitch", Some(500.0), None);
    rig.run(3);
    assert!(
        (rig.num("#1P") - p0 - 500.0).abs() < 5.0,
        "jumped: {}",
        rig.num("#1P")
    );
    rig.run(1000);
    assert!((rig.num("#1P") - p0).abs() < 10.0, "servoed back");
    let n1 = rig.node_position(0);
    assert!(
        (n1 - (n0 - 500.0)).abs() < 10.0,
        "the motor moved: {n0} -> {n1}"
    );
    assert_eq!(rig.status(1).1 & W2_FATAL_FE, 0);
    clear(&mut rig);
    rig.run(1000);
    assert!(
        (rig.node_position(0) - n0).abs() < 10.0,
        "offset gone, back"
    );
    let c = axis(&mut rig, 0, "encoder-glitch", Some(5000.0), Some(1));
    let k = until(&mut rig, 20, "fatal FE", |r| killed_by(r, W2_FATAL_FE));
    assert!(k - c <= FLAG_BOUND, "{} cycles", k - c);
    // Once the count is back (the jump back reaches the card a few cycles later).
    rig.run(10);
    recovers(&mut rig);
}

/// A load torque gives a following error proportional to it while the motor holds (the
/// default PD loop, Ix33 = 0), in its direction; 0.3 N·m is beyond Ix11 and kills.
#[test]
fn load_torque_gives_a_chosen_following_error() {
    let mut rig = rig();
    rig.cmd("I133=0");
    rig.run(200);
    let mut fe = Vec::new();
    for v in [0.01, 0.02, -0.02] {
        axis(&mut rig, 0, "load", Some(v), None);
        rig.run(1500);
        fe.push(rig.num("#1F"));
    }
    assert!(fe[0] < -100.0, "a + load lags the motor ahead: {fe:?}");
    assert!((fe[1] / fe[0] - 2.0).abs() < 0.1, "proportional: {fe:?}");
    assert!((fe[2] + fe[1]).abs() < 0.05 * fe[1].abs(), "signed: {fe:?}");
    axis(&mut rig, 0, "load", Some(0.3), None);
    until(&mut rig, 2000, "fatal FE", |r| killed_by(r, W2_FATAL_FE));
    clear(&mut rig);
    rig.run(5000);
    recovers(&mut rig);
}

/// A jam during a jog holds the shaft exactly; FE grows to Ix11 and the card kills.
#[test]
fn jam_holds_the_shaft_and_trips_fatal_following_error() {
    let mut rig = rig();
    rig.cmd("I119=1 I122=16");
    rig.cmd("#1J+");
    rig.run(300);
    axis(&mut rig, 0, "jam", None, None);
    rig.run(2);
    let at = rig.node_position(0);
    until(&mut rig, 2000, "fatal FE", |r| killed_by(r, W2_FATAL_FE));
    assert_eq!(rig.node_position(0), at, "shaft held");
    rig.cmd("#1J/");
    rig.run(20);
    assert_eq!(rig.node_position(0), at, "still jammed while active");
    clear(&mut rig);
    recovers(&mut rig);
    rig.cmd("#1J:1000");
    rig.run(2000);
    assert!(rig.node_position(0) > at + 900.0, "moves again");
}

/// A +limit stuck on during a + jog stops the motor on the limit (loop closed); stuck off,
/// the jog runs through the real switch; chatter is seen as the limit.
#[test]
fn plus_limit_stuck_on_off_and_chattering() {
    let plant = NodePlantConfig {
        plus_limit: 20_000.0,
        ..NodePlantConfig::default()
    };
    let mut rig = rig_with(plant, Profile::Pmac2);
    rig.cmd("I119=1 I122=16");
    rig.cmd("#1J+");
    rig.run(300);
    let c = axis(&mut rig, 0, "plus-limit-on", None, None);
    let k = until(&mut rig, 20, "+limit bit", |r| {
        r.status(1).0 & W1_POS_LIMIT != 0
    });
    assert!(k - c <= FLAG_BOUND);
    rig.run(500);
    let (w1, w2) = rig.status(1);
    assert_ne!(w2 & W2_STOPPED_ON_LIMIT, 0);
    assert_eq!(
        w1 & W1_OPEN_LOOP,
        0,
        "limits decelerate, the loop stays closed"
    );
    let p = rig.num("#1P");
    assert!(p < 20_000.0, "stopped before the real switch: {p}");
    clear(&mut rig);
    rig.run(5);
    assert_eq!(rig.status(1).0 & W1_POS_LIMIT, 0);
    axis(&mut rig, 0, "plus-limit-off", None, None);
    rig.cmd("#1J+");
    rig.run(3000);
    assert!(
        rig.num("#1P") > 20_500.0,
        "ran through the switch: {}",
        rig.num("#1P")
    );
    assert_eq!(rig.status(1).0 & W1_POS_LIMIT, 0);
    assert!(rig.station().node(0).unwrap().snapshot().position > 20_000.0);
    clear(&mut rig);
    rig.cmd("#1J:-40000");
    rig.run(5000);
    axis(&mut rig, 0, "plus-limit-chatter", None, None);
    rig.cmd("#1J+");
    rig.run(500);
    assert_ne!(rig.status(1).1 & W2_STOPPED_ON_LIMIT, 0, "chatter stops it");
    clear(&mut rig);
}

/// The −limit stuck on blocks a − jog at once.
#[test]
fn minus_limit_stuck_on_blocks_negative_motion() {
    let mut rig = rig();
    rig.cmd("I119=1 I122=16");
    let p = rig.num("#1P");
    axis(&mut rig, 0, "minus-limit-on", None, None);
    rig.run(5);
    assert_ne!(rig.status(1).0 & W1_NEG_LIMIT, 0);
    rig.cmd("#1J-");
    rig.run(300);
    assert!((rig.num("#1P") - p).abs() < 5.0, "blocked");
    rig.cmd("#1J+");
    rig.run(300);
    assert!(rig.num("#1P") > p + 100.0, "the other way is free");
    clear(&mut rig);
    rig.run(5);
    assert_eq!(rig.status(1).0 & W1_NEG_LIMIT, 0);
}

/// The −limit chattering stops a − jog at once; stuck off, it lets the jog through the real
/// switch.
#[test]
fn minus_limit_stuck_off_and_chattering() {
    let plant = NodePlantConfig {
        minus_limit: -20_000.0,
        ..NodePlantConfig::default()
    };
    let mut rig = rig_with(plant, Profile::Pmac2);
    rig.cmd("I119=1 I122=16");
    axis(&mut rig, 0, "minus-limit-chatter", None, None);
    rig.cmd("#1J-");
    rig.run(500);
    let (w1, w2) = rig.status(1);
    assert_ne!(w2 & W2_STOPPED_ON_LIMIT, 0, "chatter stops it");
    assert_eq!(w1 & W1_OPEN_LOOP, 0);
    assert!(
        rig.num("#1P") > -5_000.0,
        "stopped at once: {}",
        rig.num("#1P")
    );
    axis(&mut rig, 0, "minus-limit-off", None, None);
    rig.run(5);
    rig.cmd("#1J-");
    rig.run(4000);
    assert!(
        rig.num("#1P") < -20_500.0,
        "ran through: {}",
        rig.num("#1P")
    );
    assert_eq!(rig.status(1).0 & W1_NEG_LIMIT, 0);
    clear(&mut rig);
    rig.run(5);
    assert_ne!(
        rig.status(1).0 & W1_NEG_LIMIT,
        0,
        "the real switch, once cleared"
    );
}

/// Home stuck on: `#1HM` finds home where it starts (not at the switch at 5000); stuck off,
/// the search runs past the switch and goes on; chattering, it finds home at once.
#[test]
fn home_switch_stuck_on_and_off() {
    let mut rig = rig();
    axis(&mut rig, 0, "home-off", None, None);
    rig.cmd("I123=16 #1HM");
    rig.run(3000);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_HOME_SEARCH, 0, "still searching");
    assert_eq!(w2 & W2_HOME_COMPLETE, 0);
    assert!(rig.node_position(0) > 7_000.0, "past the switch");
    rig.cmd("#1K");
    clear(&mut rig);
    rig.cmd("#1J/");
    rig.run(50);
    rig.cmd("#1J=-20000");
    rig.run(6000);
    let start = rig.node_position(0);
    axis(&mut rig, 0, "home-on", None, None);
    rig.run(5);
    rig.cmd("#1HM");
    until(&mut rig, 3000, "home complete", |r| {
        r.status(1).1 & W2_HOME_COMPLETE != 0
    });
    assert!(
        (rig.node_position(0) - start).abs() < 2_000.0,
        "homed near {start}, not at 5000: {}",
        rig.node_position(0)
    );
    assert!(rig.num("#1P").abs() < 10.0, "position zeroed at home");
    clear(&mut rig);
    // Chattering: the first on-cycle is the edge the search triggers on.
    rig.cmd("#1J=-20000");
    rig.run(6000);
    let start = rig.node_position(0);
    axis(&mut rig, 0, "home-chatter", None, None);
    rig.cmd("#1HM");
    until(&mut rig, 3000, "home complete", |r| {
        r.status(1).1 & W2_HOME_COMPLETE != 0
    });
    assert!(
        (rig.node_position(0) - start).abs() < 2_000.0,
        "homed near {start}"
    );
    clear(&mut rig);
}

fn power_loss_kills_every_motor(profile: Profile) {
    let mut rig = rig_with(NodePlantConfig::default(), profile);
    rig.cmd("#3J/");
    rig.cmd("#8J/");
    rig.run(50);
    let c = rig.sim.cycle() + 1;
    send(&mut rig, json!({"op": "power-loss"})).unwrap();
    let k = until(&mut rig, 20, "amp fault", |r| killed_by(r, W2_AMP_FAULT));
    assert!(k - c <= FLAG_BOUND);
    rig.run(5);
    for x in [1u16, 2, 3, 8] {
        let (w1, w2) = rig.status(x);
        assert_ne!(w2 & W2_AMP_FAULT, 0, "motor {x} amp fault");
        assert_ne!(w1 & W1_OPEN_LOOP, 0, "motor {x} killed");
    }
    assert_eq!(rig.cmd("???")[..6].len(), 6);
    let ring_fault = u32::from_str_radix(&rig.cmd("???")[..6], 16).unwrap() & (1 << 4);
    assert_eq!(ring_fault, 0, "the ring stays healthy: the station answers");
    assert!(!rig.station().ring_fault());
    let st = rig.station().status_extra();
    assert_eq!(st["power_loss"], json!(true));
    assert_eq!(st["axis_faults"][0]["kind"], json!("power-loss"));
    assert_eq!(st["amps_enabled"], json!([]));
    clear(&mut rig);
    rig.run(2);
    recovers(&mut rig);
    for x in [2u16, 3, 8] {
        rig.cmd(&format!("#{x}J/"));
        rig.run(20);
        assert_eq!(rig.status(x).0 & W1_OPEN_LOOP, 0, "motor {x} back");
    }
}

#[test]
fn pmac2_power_loss_faults_every_amplifier_ring_stays_up() {
    power_loss_kills_every_motor(Profile::Pmac2);
}

#[test]
fn turbo_power_loss_faults_every_amplifier_ring_stays_up() {
    power_loss_kills_every_motor(Profile::Turbo);
}

/// A Power card on the same plant: its `Motor[1]` sits on servo node 0. The amplifier fault
/// kills it (`Motor[1].Status[0]` bit 24 `AmpFault` set, bits 13 `ClosedLoop` and 12 `AmpEna`
/// clear; `Motor[1].AmpFault` reads 1), the ring stays healthy, and after the clear `#1j/`
/// closes the loop again with no fault bit left. Power loss does the same to every motor.
#[test]
fn power_card_amp_fault_and_power_loss_kill_and_recover_after_clear() {
    const AMP_FAULT: u64 = 1 << 24;
    const CLOSED: u64 = (1 << 13) | (1 << 12);
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    cfg.cards[0].profile = "power".into();
    cfg.cards[0].ivars.clear();
    let cfg = cfg.resolve().expect("config");
    let mut rig = Rig::with_card(NodePlantConfig::default(), cfg, Profile::Power);
    rig.run(20);
    assert_eq!(rig.power("#1j/ #2j/"), "");
    rig.run(100);
    let st = |rig: &mut Rig, x: u16| rig.power_value(&format!("Motor[{x}].Status[0]"));
    assert_eq!(
        st(&mut rig, 1) & (CLOSED | AMP_FAULT),
        CLOSED,
        "Motor[1] closed"
    );
    // A load holds Motor[1] off its commanded position: `#1d` is the desired position,
    // `#1p` the actual, `#1f` their difference (seed 000 L33912-33970).
    send(
        &mut rig,
        json!({"op": "axis", "node": 0, "kind": "load", "value": 0.03}),
    )
    .unwrap();
    rig.run(400);
    let num = |rig: &mut Rig, l: &str| -> f64 { rig.power(l).parse().unwrap() };
    let (d, p, f) = (
        num(&mut rig, "#1d"),
        num(&mut rig, "#1p"),
        num(&mut rig, "#1f"),
    );
    assert!(f.abs() > 300.0, "the load's following error: {f}");
    assert!((d - p - f).abs() < 0.5, "d {d} - p {p} = f {f}");
    assert!(d.abs() < 1.0, "the desired position stays at 0: {d}");
    clear(&mut rig);
    rig.run(400);
    for (inject, motors) in [
        (
            json!({"op": "axis", "node": 0, "kind": "amp-fault"}),
            &[1u16][..],
        ),
        (json!({"op": "power-loss"}), &[1u16, 2][..]),
    ] {
        let c = rig.sim.cycle() + 1;
        send(&mut rig, inject.clone()).unwrap();
        let seen = until(&mut rig, 20, "Motor[1].AmpFault", |r| {
            st(r, 1) & (CLOSED | AMP_FAULT) == AMP_FAULT
        });
        assert!(
            seen - c <= FLAG_BOUND,
            "{inject}: seen {} cycles after",
            seen - c
        );
        rig.run(5);
        for &x in motors {
            assert_eq!(
                st(&mut rig, x) & (CLOSED | AMP_FAULT),
                AMP_FAULT,
                "{inject}: Motor[{x}] killed by its amplifier fault"
            );
            assert_eq!(
                rig.power_value(&format!("Motor[{x}].AmpFault")),
                1,
                "{inject}"
            );
        }
        assert!(
            !rig.station().ring_fault(),
            "{inject}: the ring stays healthy"
        );
        clear(&mut rig);
        rig.run(2);
        assert_eq!(rig.power("#1j/ #2j/"), "");
        rig.run(50);
        for &x in motors {
            assert_eq!(
                st(&mut rig, x) & (CLOSED | AMP_FAULT),
                CLOSED,
                "{inject}: Motor[{x}] closed again, no fault bit"
            );
        }
    }
}

/// No input panics the station: bad requests are refused naming the choices, nothing changes.
#[test]
fn bad_requests_are_refused_and_change_nothing() {
    let mut rig = rig();
    for (req, want) in [
        (
            json!({"op": "axis", "node": 2, "kind": "jam"}),
            "servo nodes: 0, 1, 4, 5",
        ),
        (
            json!({"op": "axis", "node": 0, "kind": "melt"}),
            "amp-fault",
        ),
        (
            json!({"op": "axis", "node": 0, "kind": "load"}),
            "needs --value",
        ),
        (
            json!({"op": "axis", "node": 0, "kind": "jam", "value": 1}),
            "takes no --value",
        ),
        (
            json!({"op": "axis", "node": 0, "kind": "load", "value": 1e300}),
            "out of range",
        ),
        (json!({"op": "boil"}), "power-loss"),
        (json!([1, 2]), "power-loss"),
        (json!({"op": "power-loss", "cycles": 0}), "at least 1"),
    ] {
        let e = send(&mut rig, req.clone()).unwrap_err();
        assert!(e.contains(want), "{req}: {e}");
    }
    assert!(shown(&mut rig).is_empty());
    rig.run(50);
    assert_eq!(rig.status(1).0 & W1_OPEN_LOOP, 0);
}
