//! Issue 14 items 5, 7, 8: homing and triggers on a PMAC2 ring card and a station plant
//! (lockstep `RingSim`; card and station meet only through ring registers). The station
//! latches the encoder count at the capture-flag edge (its MI912/MI913 choose flag and edge,
//! seed 5176-5219) and reports it in node register 1; the card homes on it.

use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;

/// `?` word 1 bit 10: home search in progress (seed 6811).
const W1_HOME_SEARCH: u32 = 1 << 10;
/// `?` word 2 bit 10 home complete, bit 7 trigger move (seed 6847), bit 0 in position.
const W2_HOME_COMPLETE: u32 = 1 << 10;
const W2_TRIGGER_MOVE: u32 = 1 << 7;
const W2_IN_POSITION: u32 = 1;

fn rig_with(plant: NodePlantConfig) -> Rig {
    let mut rig = Rig::new(plant);
    rig.cmd("I3=2 I6=1");
    rig.run(20);
    rig.cmd("#1J/");
    rig.run(50);
    rig
}

fn hex(rig: &mut Rig, var: &str) -> u32 {
    let r = rig.cmd(var);
    u32::from_str_radix(r.trim_start_matches('$'), 16).unwrap_or_else(|_| panic!("{var}: {r}"))
}

/// Run until motor 1 is in position with no move in progress (bounded), then settle.
fn settle(rig: &mut Rig, max: usize) {
    for _ in 0..max / 50 {
        rig.run(50);
        let (w1, w2) = rig.status(1);
        if w2 & W2_IN_POSITION != 0 && w1 & W1_HOME_SEARCH == 0 {
            rig.run(400);
            return;
        }
    }
    panic!(
        "motor 1 still moving after {max} cycles: {:?}",
        rig.status(1)
    );
}

/// Where the motor's zero is in plant counts: plant position − motor actual position.
fn zero_at(rig: &mut Rig) -> f64 {
    rig.node_position(0) - rig.num("#1P")
}

fn home(rig: &mut Rig) {
    assert_eq!(rig.cmd("#1HM"), "");
    rig.run(60);
    assert_ne!(rig.status(1).0 & W1_HOME_SEARCH, 0, "searching");
    settle(rig, 20_000);
    assert_ne!(rig.status(1).1 & W2_HOME_COMPLETE, 0, "home complete");
}

/// Seed 5176-5219 (I9n2 = 2: rising edge of the flag, I9n3 = 0: home) — here the station's
/// MI912/MI913 defaults — and spec §5.3: the motor zero is the count at which the home flag
/// rose (5000), not where the card first saw it a few ring cycles later.
#[test]
fn home_zero_is_the_count_at_the_flag_edge() {
    let mut rig = rig_with(NodePlantConfig::default());
    home(&mut rig);
    let z = zero_at(&mut rig);
    assert!((z - 5000.0).abs() < 0.2, "zero at {z}");
    // Ix26 offsets the zero from the capture (1/16 count): 1600 → 100 counts past it.
    rig.cmd("I126=1600 #1J=-2000");
    settle(&mut rig, 20_000);
    home(&mut rig);
    let z = zero_at(&mut rig);
    assert!((z - 5100.0).abs() < 0.2, "zero at {z}");
}

/// Software capture (Ix03 bit 16, seed 2681-2693) takes the position of the servo cycle that
/// saw the flag: the same search lands counts late (the motor is still accelerating at
/// 5000, a few counts per cycle, times the ring and flag-copy delay) — what hardware capture
/// avoids.
#[test]
fn software_capture_is_late_by_the_flag_latency() {
    let mut rig = rig_with(NodePlantConfig::default());
    let i103 = hex(&mut rig, "I103");
    rig.cmd(&format!("I103=${:X}", i103 | 1 << 16));
    home(&mut rig);
    let z = zero_at(&mut rig);
    assert!(z > 5003.0 && z < 5200.0, "software capture at {z}");
}

/// DLS retrace phases flip the capture edge (MSW{ms},I912): with MI912 = 10 (falling edge of
/// the flag, seed 5195) a search in − from inside the home window captures where the flag
/// drops: the switch's release point, its hysteresis (`switch_hysteresis`, default 100
/// counts) below the window 5000..=6000, so count 4899 (the first count below 4900).
#[test]
fn falling_edge_capture_from_inside_the_window() {
    let mut rig = rig_with(NodePlantConfig::default());
    rig.cmd("#1J=5500");
    settle(&mut rig, 20_000);
    let mut cfg = rig.station().node(0).unwrap().config().clone();
    cfg.capture_control = 10;
    rig.station().node_mut(0).unwrap().reconfigure(&cfg);
    rig.run(5);
    rig.cmd("I123=-32");
    home(&mut rig);
    let z = zero_at(&mut rig);
    let release = 5000.0 - cfg.switch_hysteresis;
    assert_eq!(release, 4900.0, "the default hysteresis");
    assert!((z - (release - 1.0)).abs() < 0.2, "zero at {z}");
}

/// MI913 = 1 (I9n3: capture on the +limit flag, seed 5211-5217) with the limit function off
/// (Ix25 bit 17, as the seed advises): home on the limit switch edge at 8000.
#[test]
fn capture_on_the_plus_limit_flag() {
    let plant = NodePlantConfig {
        plus_limit: 8_000.0,
        capture_flag: 1,
        ..NodePlantConfig::default()
    };
    let mut rig = rig_with(plant);
    let i125 = hex(&mut rig, "I125");
    rig.cmd(&format!("I125=${:X}", i125 | 1 << 17));
    home(&mut rig);
    let z = zero_at(&mut rig);
    assert!((z - 8000.0).abs() < 0.2, "zero at {z}");
}

/// Jog-until-trigger (seed 8515-8540): "home search in progress" while searching (6811), the
/// trigger-move bit set at the start and cleared when the trigger is found (6847), the end
/// point the captured position + the `^` distance; with no trigger the bit stays set.
#[test]
fn jog_until_trigger_bits_and_end_point() {
    let mut rig = rig_with(NodePlantConfig::default());
    assert_eq!(rig.cmd("#1J=20000^100"), "");
    rig.run(60);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_HOME_SEARCH, 0, "home search in progress");
    assert_ne!(w2 & W2_TRIGGER_MOVE, 0, "trigger move");
    settle(&mut rig, 20_000);
    let (w1, w2) = rig.status(1);
    assert_eq!((w1 & W1_HOME_SEARCH, w2 & W2_TRIGGER_MOVE), (0, 0));
    assert_eq!(rig.d_reg(1, 0x08), 5100.0, "capture 5000 + 100");
    assert_eq!(w2 & W2_HOME_COMPLETE, 0, "a jog does not home");
    // No trigger between 6500 and 9000: the move ends at 9000 and the bit stays set.
    rig.cmd("#1J=6500");
    settle(&mut rig, 20_000);
    rig.cmd("#1J=9000^50");
    settle(&mut rig, 20_000);
    assert_eq!(rig.d_reg(1, 0x08), 9000.0);
    let (w1, w2) = rig.status(1);
    assert_eq!(w1 & W1_HOME_SEARCH, 0);
    assert_ne!(w2 & W2_TRIGGER_MOVE, 0, "no trigger found: stays 1");
}

/// Program move-until-trigger `X{end}^{dist}` in RAPID mode (seed 10236-10262): the motor
/// stops `dist` past the capture, the trigger-move bit is cleared, and the program goes on
/// from there (next line after every motor finished, position re-matched).
#[test]
fn program_move_until_trigger() {
    let mut rig = rig_with(NodePlantConfig::default());
    for l in [
        "&1 #1->X",
        "OPEN PROG 8 CLEAR",
        "RAPID ABS X20000^100",
        "P10=M162/3072",
        "LINEAR INC TA50 TS0 TM100 X200",
        "CLOSE",
        "M162->D:$002B",
    ] {
        assert_eq!(rig.cmd(l), "", "{l}");
    }
    rig.cmd("&1B8R");
    rig.run(60);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_HOME_SEARCH, 0, "searching");
    assert_ne!(w2 & W2_TRIGGER_MOVE, 0, "trigger move");
    settle(&mut rig, 20_000);
    for _ in 0..40 {
        rig.run(100);
        if rig.cmd("&1??").as_bytes()[5] & 1 == 0 {
            break;
        }
    }
    settle(&mut rig, 20_000);
    let p10 = rig.num("P10");
    assert!((p10 - 5100.0).abs() < 10.0, "after the trigger move: {p10}");
    assert_eq!(rig.d_reg(1, 0x08), 5300.0, "5000 + 100, then INC 200");
    assert_eq!(rig.status(1).1 & W2_TRIGGER_MOVE, 0);
}

/// Item 7: optional plant end stops (position, stiffness). Hard-stop homing as DLS does it
/// (Ix03 bits 16-17: trigger on warning following error, software capture; seed 2691,
/// 3062): the jog into the stop raises the FE past Ix12, the trigger fires, and the motor
/// backs off by the `^` distance from where it stood.
#[test]
fn hard_stop_triggers_on_following_error() {
    let plant = NodePlantConfig {
        limits: false,
        hard_stops: true,
        plus_stop: 8_000.0,
        ..NodePlantConfig::default()
    };
    let mut rig = rig_with(plant);
    let i103 = hex(&mut rig, "I103");
    // Slow jog (4 counts/ms, Ix19 = 1 count/ms²) so the stop after the trigger is short.
    rig.cmd(&format!(
        "I103=${:X} I112=3200 I122=4 I119=1",
        i103 | 3 << 16
    ));
    rig.cmd("#1J=20000^-500");
    let mut max = f64::MIN;
    for _ in 0..200 {
        rig.run(50);
        max = max.max(rig.node_position(0));
        if rig.status(1).1 & W2_IN_POSITION != 0 && rig.status(1).0 & W1_HOME_SEARCH == 0 {
            break;
        }
    }
    settle(&mut rig, 20_000);
    assert!(
        max > 8_000.0 && max < 8_080.0,
        "stopped by the end stop: max {max}"
    );
    let end = rig.node_position(0);
    assert!(
        (end - (max - 500.0)).abs() < 30.0,
        "backed off 500 from the stop: {end}"
    );
    assert_eq!(rig.status(1).1 & W2_TRIGGER_MOVE, 0, "trigger found");
    // Without the stop the same jog would have run to 20000.
    assert!(rig.d_reg(1, 0x08) < 8_000.0);
}
