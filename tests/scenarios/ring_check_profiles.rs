//! Issue 23 item 1: every card profile starts with its ring check armed. A config that does
//! not set the check (here the default cluster's card with its ivars removed, as a user's
//! `profile = "turbo"` / `"power"` card without `ivars`) gets the PMAC2 default 16/2/4 in its
//! profile's own keys — PMAC2 I1001/I1004/I1005, Turbo I80/I81/I82, Power the
//! `Macro.TestPeriod/TestMaxErrors/TestReqdSynchs` the card keeps in its I80/I81/I82 (seed 000
//! 52275-52277). On each profile a cut of the ring is latched by the card (the synchronizing
//! master) within the README's bound (≤ 10 cycles), its motors are killed, and `$$$` recovers.
//! One card + one station on the deterministic lockstep ring; commands go in through the
//! card's PMAC interpreter (on a Power card the model the Power dialect shares; its Power
//! syntax on this path is `power_ring::power_sync_master_ring_faults_are_detected_localised_and_recovered`).
//! After the reset motor 1 closes again on every profile — on a Power card `#1j/` in Power
//! syntax: its `Motor[1]` is the model's second motor block (`Motor[0]` is no servo motor), so
//! the PMAC path's `#1J/` would address `Motor[0]`.

use mcc_card::Profile;
use mcc_contracts::config::ClusterConfig;
use mcc_ring::fault::{FaultKind, FaultSpec};
use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;

/// README "Detection bounds": a cut is latched by the sync master ≤ 10 cycles after the first
/// cycle the member downstream of the break did not get.
const CUT_BOUND: u64 = 10;

fn config(profile: &str) -> ClusterConfig {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    cfg.cards[0].profile = profile.into();
    cfg.cards[0].ivars.clear();
    cfg.resolve().expect("config")
}

/// The card's ring-fault latch (`???` word 1 bit 4 on PMAC2 and Turbo; the model's on Power).
fn ring_fault(rig: &mut Rig) -> bool {
    rig.card().state.global.ring_fault
}

/// Every motor on the card's nodes killed: open loop, amplifier off.
fn killed(rig: &mut Rig, n: usize) -> bool {
    rig.card().state.motors[..n]
        .iter()
        .all(|m| m.open_loop && !m.amp_enabled)
}

/// Close motors 1 and 2 in the card's own syntax (Power: `Motor[1]`, `Motor[2]` over the
/// gpascii dialect; PMAC2/Turbo: `#1J/ #2J/`).
fn close_motors(rig: &mut Rig, profile: Profile) {
    if profile == Profile::Power {
        assert_eq!(rig.power("#1j/ #2j/"), "", "Power jog-stop");
    } else {
        rig.cmd("#1J/ #2J/");
    }
}

fn cut_is_latched_killed_and_recovered(profile: Profile, name: &str, keys: [&str; 3]) {
    let cfg = config(name);
    let c = &cfg.cards[0];
    for (k, v) in keys.iter().zip([16.0, 2.0, 4.0]) {
        assert_eq!(c.ivar(k), Some(v), "{name}: config default {k}");
    }
    let mut rig = Rig::with_card(NodePlantConfig::default(), cfg, profile);
    rig.cmd("I3=2 I6=1");
    // The card's own check variables (Turbo and Power keep them in I80-I82).
    let (p, e, s) = if profile == Profile::Pmac2 {
        (1001, 1004, 1005)
    } else {
        (80, 81, 82)
    };
    let st = &rig.card().state;
    let vals: Vec<f64> = [p, e, s]
        .iter()
        .map(|&n| st.peek_ivar(n).unwrap())
        .collect();
    assert_eq!(vals, [16.0, 2.0, 4.0], "{name}: the card's check variables");
    rig.run(200);
    close_motors(&mut rig, profile);
    rig.run(100);
    assert!(!ring_fault(&mut rig), "{name}: healthy ring");
    assert!(!killed(&mut rig, 2), "{name}: motors 1 and 2 closed");
    assert!(rig.sim.member(0).status().ring_fault_cycle.is_none());
    // Cut the station's output link: from the next cycle on the card gets nothing back.
    let lost = rig.sim.cycle() + 1;
    rig.sim
        .inject(1, FaultSpec::always(FaultKind::Cut))
        .unwrap();
    rig.run(60);
    let at = rig.sim.member(0).status().ring_fault_cycle;
    let at = at.unwrap_or_else(|| panic!("{name}: the card latched no ring fault"));
    eprintln!("{name}: cut lost cycle {lost}, latched at {at}");
    assert!(
        at <= lost + CUT_BOUND,
        "{name}: latched at {at}, lost {lost}: beyond the README bound"
    );
    assert!(ring_fault(&mut rig), "{name}: the card's ring-fault bit");
    assert!(killed(&mut rig, 8), "{name}: every motor killed");
    if profile != Profile::Power {
        let g = u32::from_str_radix(&rig.cmd("???")[..6], 16).unwrap();
        assert_ne!(g & 0x10, 0, "{name}: ??? word 1 bit 4");
        let (w1, _) = rig.status(1);
        assert_ne!(w1 & (1 << 18), 0, "{name}: ? open loop");
    }
    // Recovery: the link back, `$$$` (PMAC2, Turbo; Power's `$$$` is the same reset, seed
    // 000), then the motors close again when commanded.
    rig.sim.clear_faults(1);
    rig.run(200);
    assert!(ring_fault(&mut rig), "{name}: latched until reset");
    rig.cmd("$$$");
    rig.cmd("I3=2 I6=1");
    rig.run(200);
    assert!(!ring_fault(&mut rig), "{name}: `$$$` clears the latch");
    // Motor 1 of the card (a Power card's `Motor[1]`: the model's second block, `Motor[0]`
    // is no servo motor) closes again when commanded, in the card's own syntax.
    close_motors(&mut rig, profile);
    rig.run(100);
    let m1 = usize::from(profile == Profile::Power);
    let m = &rig.card().state.motors[m1];
    assert!(
        !m.open_loop && m.amp_enabled,
        "{name}: motor 1 closes after the reset: {m:?}"
    );
    if profile == Profile::Power {
        // Motor[1].Status[0]: bit 13 closed loop, bit 12 amplifier enabled.
        let w = rig.power_value("Motor[1].Status[0]");
        assert_eq!(w & 0x3000, 0x3000, "{name}: Motor[1].Status[0] = ${w:X}");
    } else {
        let (w1, _) = rig.status(1);
        assert_eq!(
            w1 & (1 << 18),
            0,
            "{name}: ? word 1 bit 18 (open loop) clear"
        );
    }
    rig.run(100);
    assert!(!ring_fault(&mut rig), "{name}: and the ring stays healthy");
}

#[test]
fn pmac2_card_latches_a_cut_by_default() {
    cut_is_latched_killed_and_recovered(Profile::Pmac2, "pmac2", ["I1001", "I1004", "I1005"]);
}

#[test]
fn turbo_card_latches_a_cut_by_default() {
    cut_is_latched_killed_and_recovered(Profile::Turbo, "turbo", ["I80", "I81", "I82"]);
}

#[test]
fn power_card_latches_a_cut_by_default() {
    cut_is_latched_killed_and_recovered(Profile::Power, "power", ["I1001", "I1004", "I1005"]);
}
