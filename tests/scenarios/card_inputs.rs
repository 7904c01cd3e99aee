//! Issue 23 item 3: the card's hardware stop inputs, injected as `mcc fault CARD input KIND`
//! does (the card's `RingApp::app_fault` with its `input` request), on the deterministic
//! lockstep ring of one card and one station. What a host sees is read back in the card's
//! own syntax: `?`/`??` on PMAC2 and Turbo (motor word 1 bit 12 *Abort Deceleration*, bit 13
//! *Desired Velocity Zero*, bit 18 open loop; C.S. word 1 bit 0 program running, seed 004
//! L6795-6812), `Motor[x].Status[0]` on Power (bit 14 desired velocity zero, 13 closed loop,
//! 12 amplifier enabled).

use mcc_card::Profile;
use mcc_contracts::config::ClusterConfig;
use mcc_ring::core::RingApp;
use mcc_station::config::NodePlantConfig;

use crate::motion::{App, Rig};

const ABORT_DECEL: u32 = 1 << 12;
const DES_VEL_ZERO: u32 = 1 << 13;
const OPEN_LOOP: u32 = 1 << 18;

fn rig(profile: Profile) -> Rig {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    cfg.cards[0].profile = match profile {
        Profile::Pmac2 => "pmac2",
        Profile::Turbo => "turbo",
        Profile::Power => "power",
    }
    .into();
    let cfg = cfg.resolve().expect("config");
    Rig::with_card(NodePlantConfig::default(), cfg, profile)
}

/// `mcc fault card0 input KIND [...]` as the card receives it.
fn press(rig: &mut Rig, fault: serde_json::Value) -> Result<String, String> {
    match rig.sim.app_mut(0) {
        App::Card(a) => a.app_fault(&fault),
        App::Station(_) => panic!("member 0 is the card"),
    }
}

/// `mcc fault clear card0`.
fn clear(rig: &mut Rig) {
    match rig.sim.app_mut(0) {
        App::Card(a) => a.clear_app_faults(),
        App::Station(_) => panic!("member 0 is the card"),
    }
}

fn status_inputs(rig: &mut Rig) -> serde_json::Value {
    match rig.sim.app_mut(0) {
        App::Card(a) => a.status_extra()["inputs"].clone(),
        App::Station(_) => panic!("member 0 is the card"),
    }
}

/// Motor 1's actual position (`#1P`), counts.
fn pos(rig: &mut Rig) -> f64 {
    rig.num("#1P")
}

fn cs_running(rig: &mut Rig) -> bool {
    let r = rig.cmd("&1??");
    u32::from_str_radix(&r[..6], 16).unwrap() & 1 != 0
}

/// PMAC2 and Turbo: C.S. 1 runs moves on motors 1 and 2 in an endless loop, motor 3 jogs on its own. The
/// JPAN STOP/ input with FPD select 1 aborts C.S. 1 as `A` does; after the clear the program
/// runs again.
fn jpan_abort(profile: Profile) {
    let name = format!("{profile:?}");
    let mut rig = rig(profile);
    rig.cmd("I3=2 I6=1");
    rig.run(200);
    rig.cmd("#1J/ #2J/ #3J/ &1 #1->1000X #2->1000Y");
    for l in [
        "OPEN PROG 1 CLEAR",
        "LINEAR INC TA100 TS0 F10",
        "WHILE(1=1)",
        "X10 Y10",
        "ENDWHILE",
        "CLOSE",
    ] {
        let r = rig.cmd(l);
        assert!(!r.contains("ERR"), "{name}: {l}: {r}");
    }
    // A select of no C.S. (no FPD line low) and I2 = 1 (inputs as general-purpose I/O):
    // nothing happens.
    rig.cmd("&1B1R #3J+");
    rig.run(400);
    assert!(cs_running(&mut rig), "{name}: the program runs");
    let req =
        |select: u16| serde_json::json!({"family": "input", "kind": "abort", "select": select});
    let r = press(&mut rig, req(0)).unwrap();
    assert!(r.contains("FPD select 0"), "{r}");
    rig.run(20);
    assert!(cs_running(&mut rig), "{name}: select 0 aborts nothing");
    clear(&mut rig);
    rig.cmd("I2=1");
    press(&mut rig, req(1)).unwrap();
    rig.run(20);
    assert!(
        cs_running(&mut rig),
        "{name}: I2 = 1 disables the JPAN inputs"
    );
    clear(&mut rig);
    rig.cmd("I2=0");
    // The input, FPD select 1.
    press(&mut rig, req(1)).unwrap();
    let st = status_inputs(&mut rig);
    assert_eq!(st["held"][0]["kind"], "abort", "{st}");
    assert_eq!(st["held"][0]["select"], 1, "{st}");
    rig.run(1);
    assert!(
        !cs_running(&mut rig),
        "{name}: ?? word 1 bit 0: program aborted"
    );
    for x in [1, 2] {
        let (w1, _) = rig.status(x);
        assert_ne!(
            w1 & ABORT_DECEL,
            0,
            "{name}: #{x}? abort deceleration ${w1:06X}"
        );
        assert_eq!(w1 & OPEN_LOOP, 0, "{name}: #{x} stays closed");
    }
    let (w3, _) = rig.status(3);
    assert_eq!(
        w3 & (ABORT_DECEL | DES_VEL_ZERO),
        0,
        "{name}: #3 (no C.S.) jogs on"
    );
    // Ix15 deceleration (0.25 counts/ms² from 10 counts/ms: 40 ms, ~90 cycles) to a stop.
    let mut n = 0;
    while rig.status(1).0 & ABORT_DECEL != 0 {
        rig.run(1);
        n += 1;
        assert!(n < 2000, "{name}: motor 1 still decelerating");
    }
    eprintln!("{name}: abort deceleration over after {n} cycles");
    assert!(
        (60..=200).contains(&n),
        "{name}: {n} cycles of Ix15 deceleration"
    );
    let stop = pos(&mut rig);
    rig.run(200);
    for x in [1, 2] {
        let (w1, _) = rig.status(x);
        assert_eq!(w1 & (ABORT_DECEL | OPEN_LOOP), 0, "{name}: #{x} ${w1:06X}");
        assert_ne!(
            w1 & DES_VEL_ZERO,
            0,
            "{name}: #{x} holds position ${w1:06X}"
        );
    }
    let at = pos(&mut rig);
    assert!(
        (at - stop).abs() < 0.5,
        "{name}: motor 1 holds where it stopped: {at} vs {stop}"
    );
    assert_eq!(
        rig.status(3).0 & DES_VEL_ZERO,
        0,
        "{name}: #3 still jogging"
    );
    // Recovery: the input released, the program runs again.
    clear(&mut rig);
    assert_eq!(status_inputs(&mut rig)["held"], serde_json::json!([]));
    rig.cmd("&1B1R");
    rig.run(100);
    assert!(cs_running(&mut rig), "{name}: runs again after the clear");
    // Feed Hold (HOLD/) holds the program: time base to 0, still "running" as with `H`.
    press(
        &mut rig,
        serde_json::json!({"family": "input", "kind": "feed-hold", "select": 1, "cycles": 5}),
    )
    .unwrap();
    // The time base ramps to 0 at Ix95 (the default takes a few thousand cycles).
    let mut a = pos(&mut rig);
    let mut n = 0;
    loop {
        rig.run(50);
        n += 50;
        let b = pos(&mut rig);
        if (b - a).abs() < 0.01 {
            break;
        }
        a = b;
        assert!(n < 20_000, "{name}: feed hold never stopped the move");
    }
    eprintln!("{name}: feed hold stopped the path after {n} cycles");
    rig.run(200);
    let at = pos(&mut rig);
    assert!(
        (at - a).abs() < 0.5,
        "{name}: held: the move does not advance: {at} vs {a}"
    );
    let (w1, _) = rig.status(1);
    assert_eq!(w1 & OPEN_LOOP, 0, "{name}: held closed-loop");
    assert_eq!(
        status_inputs(&mut rig)["held"],
        serde_json::json!([]),
        "{name}: --cycles 5 released it"
    );
    rig.cmd("&1R");
    rig.run(300);
    assert!(pos(&mut rig) > a, "{name}: `R` resumes");
}

#[test]
fn pmac2_jpan_abort_input_aborts_the_selected_cs() {
    jpan_abort(Profile::Pmac2);
}

#[test]
fn turbo_jpan_abort_input_aborts_the_selected_cs() {
    jpan_abort(Profile::Turbo);
}

/// Power: the global abort input. Not wired (`Sys.pAbortAll = 0`, the default): nothing
/// happens. Wired, with `Sys.AbortAllLimit = 3`: the card acts on the 4th scan, per
/// `Coord[0].AbortAllMode` for motors in no C.S.
#[test]
fn power_global_abort_input_acts_per_abort_all_mode() {
    let mut rig = rig(Profile::Power);
    let st = |rig: &mut Rig, x: u16| rig.power_value(&format!("Motor[{x}].Status[0]")) as u32;
    let closed = 1 << 13 | 1 << 12;
    let jog = |rig: &mut Rig| {
        assert_eq!(rig.power("#1j+ #2j+"), "");
        rig.run(300);
    };
    rig.run(200);
    jog(&mut rig);
    let req = serde_json::json!({"family": "input", "kind": "abort"});
    assert!(press(
        &mut rig,
        serde_json::json!({"family": "input", "kind": "feed-hold"})
    )
    .unwrap_err()
    .contains("no feed-hold input"));
    press(&mut rig, req.clone()).unwrap();
    rig.run(50);
    assert_eq!(
        st(&mut rig, 1) & (1 << 14),
        0,
        "pAbortAll = 0: motor 1 jogs on"
    );
    clear(&mut rig);
    for l in [
        "Sys.pAbortAll=Gate3[0].GpioData[0].a",
        "Sys.AbortAllBit=31",
        "Sys.AbortAllLimit=3",
    ] {
        assert_eq!(rig.power(l), "", "{l}");
    }
    // Mode 0 (default): a closed-loop stop; the motors stay closed.
    press(&mut rig, req.clone()).unwrap();
    let start = rig.sim.cycle();
    rig.run(3);
    assert_eq!(status_inputs(&mut rig)["abort_all_count"], 3);
    assert!(
        !rig.card().state.motors[1].abort_decel,
        "3 scans: not yet (AbortAllLimit = 3)"
    );
    rig.run(1);
    assert!(
        rig.card().state.motors[1].abort_decel,
        "the 4th scan: abort deceleration"
    );
    let mut n = 0;
    while st(&mut rig, 1) & (1 << 14) == 0 {
        rig.run(1);
        n += 1;
        assert!(n < 2000, "motor 1 never stopped");
    }
    eprintln!("power: abort from cycle {start}, desired velocity 0 after {n} more");
    rig.run(100);
    for x in [1, 2] {
        assert_eq!(
            st(&mut rig, x) & closed,
            closed,
            "mode 0: Motor[{x}] closed"
        );
    }
    // Held, the card does not act again: a new jog moves.
    jog(&mut rig);
    assert_eq!(st(&mut rig, 1) & (1 << 14), 0, "acts once per activation");
    // Released (the count decays to 0), mode 1: killed at once.
    clear(&mut rig);
    rig.run(10);
    assert_eq!(status_inputs(&mut rig)["abort_all_count"], 0);
    assert_eq!(rig.power("Coord[0].AbortAllMode=1"), "");
    press(&mut rig, req.clone()).unwrap();
    rig.run(6);
    for x in [1, 2] {
        assert_eq!(st(&mut rig, x) & closed, 0, "mode 1: Motor[{x}] killed");
    }
    // Mode 2: stopped closed-loop, then killed.
    clear(&mut rig);
    rig.run(10);
    assert_eq!(rig.power("Coord[0].AbortAllMode=2"), "");
    jog(&mut rig);
    press(&mut rig, req.clone()).unwrap();
    rig.run(8);
    assert_eq!(
        st(&mut rig, 1) & closed,
        closed,
        "mode 2: decelerating closed-loop"
    );
    rig.run(400);
    assert_eq!(st(&mut rig, 1) & closed, 0, "mode 2: killed once stopped");
    // Mode 3: ignored.
    clear(&mut rig);
    rig.run(10);
    assert_eq!(rig.power("Coord[0].AbortAllMode=3"), "");
    jog(&mut rig);
    press(&mut rig, req).unwrap();
    rig.run(50);
    assert_eq!(
        st(&mut rig, 1) & (closed | 1 << 14),
        closed,
        "mode 3: jogs on"
    );
    // Recovery after the clear: the motors close and move on command.
    clear(&mut rig);
    rig.run(10);
    assert_eq!(rig.power("#1j/ #2j/"), "");
    rig.run(50);
    for x in [1, 2] {
        assert_eq!(st(&mut rig, x) & closed, closed, "Motor[{x}] re-closed");
    }
}
