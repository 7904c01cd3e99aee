//! Issue 26 item 10, manual cases on a PMAC2 ring card with the servo running (lockstep
//! ring, station plant): `??` word 2 carries the cutter-compensation bits (seed 004
//! 7006-7008), and the synchronizing master reads the I995 set-up the manual gives, `$30`
//! (seed 004 5495), not `$70`.

use crate::motion::Rig;
use crate::registers::rig;

/// `??` word 2 bit 2 cutter compensation on, bit 3 compensation to the left.
const CC_ON: u32 = 1 << 2;
const CC_LEFT: u32 = 1 << 3;

fn cs_word2(rig: &mut Rig) -> u32 {
    let r = rig.cmd("&1??");
    u32::from_str_radix(&r[6..12], 16).unwrap_or_else(|_| panic!("?? {r}"))
}

/// Run PROG 1 with `lines` to its end, return `??` word 2's cutter bits after it.
fn cutter_bits_after(rig: &mut Rig, lines: &[&str]) -> u32 {
    assert_eq!(rig.cmd("OPEN PROG 1 CLEAR"), "");
    for l in lines {
        assert_eq!(rig.cmd(l), "", "{l}");
    }
    assert_eq!(rig.cmd("CLOSE"), "");
    rig.cmd("&1B1R");
    rig.run(600);
    cs_word2(rig) & (CC_ON | CC_LEFT)
}

/// Seed 7006-7008: "Bit 3 Cutter Compensation Left: 1 if the coordinate system has cutter
/// compensation on, and the compensation is to the left …; Bit 2 Cutter Compensation On".
/// CC1 (left) sets both, CC2 (right) bit 2 only, CC0 clears them (seed 10481-10515).
#[test]
fn cs_status_shows_cutter_compensation() {
    let mut rig = rig();
    rig.cmd("&1 #1->X #2->Y I113=10");
    assert_eq!(cs_word2(&mut rig) & (CC_ON | CC_LEFT), 0, "off at power-up");
    let moves = ["LINEAR TA20 TS0 TM100", "X10 Y10"];
    let run = |rig: &mut Rig, cc: &str| {
        let lines: Vec<&str> = ["CCR0.5", cc].iter().chain(moves.iter()).copied().collect();
        cutter_bits_after(rig, &lines)
    };
    assert_eq!(run(&mut rig, "CC1"), CC_ON | CC_LEFT, "CC1: on, left");
    assert_eq!(run(&mut rig, "CC2"), CC_ON, "CC2: on, right");
    assert_eq!(run(&mut rig, "CC0"), 0, "CC0: off");
}

/// Seed 5495: "On this card, I995 should be set to $30" — the synchronizing master (the
/// default cluster's card 0) reads `$30` on a healthy ring, read after read. Bit 6 "sync node
/// packet received" belongs to a card that phase-locks to the sync packet (bit 7); the ring
/// check still sees every return of the master's own sync packet (the ring stays healthy and
/// a cut is still caught: `ring_check_profiles`).
#[test]
fn the_synchronizing_master_reads_its_i995_set_up() {
    let mut rig = rig();
    rig.run(100);
    assert_eq!(rig.cmd("I995"), "$30");
    rig.run(10);
    assert_eq!(rig.cmd("I995"), "$30");
    let g = u32::from_str_radix(&rig.cmd("???")[..6], 16).unwrap();
    assert_eq!(g & 0x10, 0, "no ring fault");
}
