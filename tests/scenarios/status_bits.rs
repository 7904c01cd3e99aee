//! Issue 26 item 9: the latched `?` bits a host or PLC may write (suggested M-variables
//! Mx30, Mx42, Mx43, Mx45) behave as on the card: a write sticks until the bit's next event
//! (seed 004 6833-6870). pmac-motorhome's generated PLCs write `m145=0` at the start of a
//! group and test it at the end; the servo used to copy the motor's flag back every cycle.
//! PMAC2 and Turbo ring cards with a station plant on the lockstep ring.

use mcc_card::Profile;
use mcc_contracts::config::ClusterConfig;
use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;

fn rig(profile: Profile) -> Rig {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    if profile == Profile::Turbo {
        cfg.cards[0].profile = "turbo".into();
        cfg.cards[0].ivars.clear();
        cfg = cfg.resolve().expect("config");
    }
    let mut rig = Rig::with_card(NodePlantConfig::default(), cfg, profile);
    rig.cmd("I3=2 I6=1");
    rig.run(20);
    rig.cmd("#1J/");
    rig.run(50);
    rig
}

/// Seed 6839 ("Home Complete … set to 0 on power-up or reset, becomes 1 when the homing move
/// successfully locates the home trigger … set to 0 at the beginning of the move"): `M145=0`
/// after a home reads back 0 while the servo runs, until the next home sets it again; a
/// written 1 sticks as well; `$$$` clears it. Motor 1's status word 2 is Y:$0814 on PMAC2,
/// Y:$00C0 on Turbo (Turbo suggested M-variable Mxx45).
fn home_complete_write_sticks(profile: Profile, word2: &str) {
    let mut rig = rig(profile);
    rig.cmd(&format!("M145->{word2},10,1 M140->{word2},0,1"));
    rig.cmd("#1HMZ");
    rig.run(20);
    assert_eq!(rig.cmd("M145"), "1", "home zero sets home complete");
    rig.cmd("M145=0");
    rig.run(50);
    assert_eq!(rig.cmd("M145"), "0", "the host's 0 sticks");
    assert_eq!(rig.status(1).1 & (1 << 10), 0, "and `?` shows it");
    rig.cmd("#1HMZ");
    rig.run(20);
    assert_eq!(rig.cmd("M145"), "1", "the next home sets it again");
    // A bit the servo evaluates every cycle (in position) is the motor's: a write does not
    // stick.
    assert_eq!(rig.cmd("M140"), "1");
    rig.cmd("M140=0");
    rig.run(20);
    assert_eq!(rig.cmd("M140"), "1", "in position is evaluated each cycle");
    rig.cmd("M145=0");
    rig.run(5);
    rig.cmd("M145=1");
    rig.run(50);
    assert_eq!(rig.cmd("M145"), "1", "a written 1 sticks too");
    rig.cmd("$$$");
    rig.cmd("I3=2 I6=1");
    rig.run(20);
    assert_eq!(
        rig.cmd(&format!("M145->{word2},10,1 M145")),
        "0",
        "reset clears it"
    );
}

#[test]
fn pmac2_home_complete_written_by_a_host_sticks_until_the_next_home() {
    home_complete_write_sticks(Profile::Pmac2, "Y:$0814");
}

#[test]
fn turbo_home_complete_written_by_a_host_sticks_until_the_next_home() {
    home_complete_write_sticks(Profile::Turbo, "Y:$00C0");
}

/// The same from a PLC, as pmac-motorhome's groups do it: the PLC clears Mx45 at the start of
/// a group and tests it at the end; a group whose moves home nothing (here a plain jog) ends
/// with the bit still 0 — the "not homed" the generated PLC reports — and one that homes ends
/// with it 1.
#[test]
fn a_plc_clearing_m145_sees_it_set_only_by_a_home() {
    let mut rig = rig(Profile::Pmac2);
    rig.cmd("M145->Y:$0814,10,1 I5=2");
    rig.cmd("#1HMZ");
    rig.run(20);
    let plc = |rig: &mut Rig, n: u8, body: &[&str]| {
        assert_eq!(rig.cmd(&format!("OPEN PLC {n} CLEAR")), "");
        for l in body {
            assert_eq!(rig.cmd(l), "", "{l}");
        }
        assert_eq!(rig.cmd("CLOSE"), "");
    };
    plc(&mut rig, 1, &["M145=0", "CMD\"#1J:100\"", "DISABLE PLC 1"]);
    plc(&mut rig, 2, &["P1=M145", "DISABLE PLC 2"]);
    rig.cmd("ENABLE PLC 1");
    rig.run(1000);
    rig.cmd("ENABLE PLC 2");
    rig.run(20);
    assert_eq!(rig.cmd("P1"), "0", "no home in the group: still 0");
    plc(&mut rig, 1, &["M145=0", "CMD\"#1HM\"", "DISABLE PLC 1"]);
    rig.cmd("ENABLE PLC 1");
    for _ in 0..400 {
        rig.run(50);
        rig.cmd("ENABLE PLC 2");
        rig.run(5);
        if rig.cmd("P1") == "1" {
            return;
        }
    }
    panic!("the home never completed: {:?}", rig.status(1));
}
