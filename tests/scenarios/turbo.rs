//! Issue 14, Turbo PMAC2 on a MACRO ring (items 1-4): a `profile = "turbo"` card and a station
//! on a deterministic lockstep `RingSim`, set up by the same start-up layer as the process
//! (`ring_startup`, Turbo numbering, every reply checked). Commands and feedback travel over
//! the ring only.

use mcc_contracts::config::{ClusterConfig, IVarValue};
use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;
use mcc_card::Profile;

/// 1/(Ixx08·32) counts per count at the default Ixx08 = 96.
const D_UNITS: f64 = 3072.0;

/// The default one-card cluster with a Turbo card whose ring check is set in Turbo numbers.
fn turbo_rig() -> Rig {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    let card = &mut cfg.cards[0];
    card.profile = "turbo".into();
    card.ivars = [("I80", 16), ("I81", 2), ("I82", 4)]
        .into_iter()
        .map(|(k, v)| (k.to_string(), IVarValue::Int(v)))
        .collect();
    let mut rig = Rig::with_card(NodePlantConfig::default(), cfg, Profile::Turbo);
    rig.cmd("I3=2");
    rig.run(20);
    rig
}

/// Item 1: the start-up speaks Turbo numbering (I6840/I6841 ring setup, I70/I71 auxiliary
/// flag copy and Type 1 protocol, Ixx00), the PMAC2 numbers (I995/I996, I1000/I1002 = motor
/// 10's Ixx00/Ixx02) are left alone, and the ring check runs from I80-I82.
#[test]
fn turbo_start_up_speaks_turbo_numbering() {
    let mut rig = turbo_rig();
    let i6840 = u32::from_str_radix(rig.cmd("I6840").trim_start_matches('$'), 16).unwrap();
    assert_eq!(i6840 & !0x4F, 0x30, "sync master (status bits aside)");
    let i6841 = u32::from_str_radix(rig.cmd("I6841").trim_start_matches('$'), 16).unwrap();
    assert_eq!(i6841 & 0xFFFF, 0x3333, "the card's nodes");
    assert_eq!(rig.cmd("I70 I71"), "$3333\r$3333");
    assert_eq!(
        rig.cmd("I100 I200 I300 I400 I500 I600 I700 I800 I900"),
        "1\r1\r1\r1\r1\r1\r1\r1\r0"
    );
    assert_eq!(rig.cmd("I995 I996 I1000 I1002"), "0\r0\r0\r$0");
    assert_eq!(rig.cmd("I80 I81 I82"), "16\r2\r4");
    assert_eq!(
        rig.cmd("I102 I103 I124 I125"),
        "$78420\r$3502\r$40001\r$3440"
    );
}

/// Items 1 and 4: every MACRO motor of a Turbo ring card runs (motor 1 on node 0, motor 8 on
/// node 13), the auxiliary flag copy keeps the amplifier fault clear, the positions come back
/// through the ECT (I8000-I8015) and the Turbo memory map (D:$00008B actual position of
/// motor 1, seed/Turbo suggested M-variable Mxx62), and `?` word 1 bit 19 shows the amplifier
/// enabled (Turbo layout; PMAC2 keeps it in word 2 bit 14).
#[test]
fn turbo_ring_card_runs_every_macro_motor() {
    let mut rig = turbo_rig();
    rig.cmd("I122=16 I822=16 M162->D:$00008B");
    assert_eq!(rig.cmd("M162->"), "D:$00008B");
    rig.cmd("#1J=1000 #8J=-2000");
    rig.run(3000);
    // Within the in-position band (Ixx28 = 160/16 = 10 counts) of the PD loop's rest point.
    let p1 = rig.node_position(0);
    assert!((p1 - 1000.0).abs() < 10.0, "node 0 at {p1}");
    assert!((rig.node_position(13) + 2000.0).abs() < 10.0, "node 13");
    assert!(
        (rig.num("#1P") - p1).abs() < 1.0,
        "#1P is the node's position"
    );
    assert!((rig.num("#8P") + 2000.0).abs() < 10.0);
    assert!((rig.num("M162") / D_UNITS - p1).abs() < 1.0, "D:$00008B");
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & (1 << 23), 0, "motor activated");
    assert_ne!(w1 & (1 << 19), 0, "amplifier enabled (Turbo word 1 bit 19)");
    assert_eq!(w1 & (1 << 18), 0, "closed loop");
    assert_eq!(w2 & (1 << 3), 0, "no amplifier fault");
    assert_ne!(w2 & 1, 0, "in position");
    rig.cmd("#1K");
    rig.run(5);
    let (w1, _) = rig.status(1);
    assert_eq!(w1 & (1 << 19), 0, "killed: amplifier disabled");
    assert_ne!(w1 & (1 << 18), 0, "open loop");
}

/// Item 3: a Turbo ring card reports MACRO IC 0's base address in I20 as a Turbo PMAC2
/// Ultralite does (dls-pmaclib counts 8 axes per IC that is not `$0`); I20-I23 are read-only,
/// and a `$$$` keeps the report (the start-up layer is the card's hardware).
#[test]
fn turbo_ring_card_reports_its_macro_ic() {
    let mut rig = turbo_rig();
    assert_eq!(rig.cmd("I20 I21 I22 I23"), "$78400\r$0\r$0\r$0");
    assert_eq!(rig.cmd("I20=0"), "ERR003");
    rig.cmd("$$$");
    rig.run(20);
    rig.cmd("I3=2");
    assert_eq!(rig.cmd("I20"), "$78400");
    assert_eq!(rig.cmd("I100 I70"), "1\r$3333");
}

/// Item 2: the Turbo user countdown timers Isx11/Isx12 count down once per servo cycle, so a
/// PLC waiting on one (as every pmac-motorhome PLC does) goes on.
#[test]
fn turbo_countdown_timers_count_servo_cycles() {
    let mut rig = turbo_rig();
    rig.cmd("I5111=1000 I5212=500 I6612=10");
    rig.run(100);
    assert_eq!(rig.num("I5111"), 900.0);
    assert_eq!(rig.num("I5212"), 400.0);
    assert_eq!(rig.num("I6612"), -90.0);
    rig.cmd("OPEN PLC 1 CLEAR");
    rig.cmd("P1=0 I5111=50 WHILE(I5111>0) ENDWHILE P1=1 DISABLE PLC 1");
    rig.cmd("CLOSE");
    rig.cmd("I5=2 ENABLE PLC 1");
    rig.run(30);
    assert_eq!(rig.num("P1"), 0.0, "the PLC is still waiting");
    rig.run(60);
    assert_eq!(rig.num("P1"), 1.0, "the timer ran out");
}
