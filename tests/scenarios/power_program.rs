//! Issue 25: a Power card on a lockstep ring (one card, one station) runs a motion program
//! that moves two motors of a C.S., dwells and switches an output, while a PLC polls
//! `Coord[1].ProgRunning`, `Motor[x].DesVelZero` and `Sys.ServoCount`, as the seed describes:
//! the PLC sees the program start and end, a `dwell` stops look-ahead (the output switches only
//! after the moves have ended and the dwell has run, seed L41027-41029), and every time is a
//! number of ring cycles (`Sys.ServoCount` counts the card's servo cycles, one per ring cycle).

use mcc_card::Profile;
use mcc_contracts::config::ClusterConfig;
use mcc_station::config::NodePlantConfig;

use crate::motion::Rig;

fn value(rig: &mut Rig, q: &str) -> f64 {
    let r = rig.power(q);
    r.rsplit('=')
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{q}: {r:?}"))
}

#[test]
fn a_two_motor_program_with_dwell_and_output_runs_as_a_plc_sees_it_in_ring_cycles() {
    let mut cfg = ClusterConfig::default_cluster(1, 1);
    cfg.cards[0].profile = "power".into();
    let cfg = cfg.resolve().expect("config");
    let mut rig = Rig::with_card(NodePlantConfig::default(), cfg, Profile::Power);
    rig.run(20);
    for line in [
        "&1 #1->1000X #2->1000Y",
        "#1j/ #2j/",
        // The output: bit 8 of the card's general-purpose I/O (seed L36852-36866 form).
        "M1->Gate3[0].GpioData[0].8.1",
        "M1=0",
        "open plc 1",
        // The program's start, its first moves' end (once they have moved) and its end, in
        // servo cycles.
        "if (Coord[1].ProgRunning == 1 && P10 == 0) { P10 = Sys.ServoCount }",
        "if (P10 > 0 && Motor[1].DesVelZero == 0) { P13 = 1 }",
        "if (P13 == 1 && P12 == 0 && Motor[1].DesVelZero == 1 && Motor[2].DesVelZero == 1) {",
        "P12 = Sys.ServoCount",
        "}",
        "if (P10 > 0 && P11 == 0 && Coord[1].ProgRunning == 0) { P11 = Sys.ServoCount }",
        "close",
        "open prog 1",
        "linear abs ta50 ts0 tm300",
        "X2 Y-1",
        "dwell 100",
        "M1 = 1",
        "P20 = Sys.ServoCount",
        "X0 Y0",
        "close",
        "enable plc 1",
    ] {
        assert_eq!(rig.power(line), "", "{line}");
    }
    rig.run(50);
    let period_ms = value(&mut rig, "Sys.ServoPeriod");
    let cycles = |ms: f64| (ms / period_ms).round();
    let start_cycle = value(&mut rig, "Sys.ServoCount");
    assert_eq!(rig.power("&1 b1 r"), "");
    let mut seen_moving = false;
    for _ in 0..cycles(3000.0) as u64 {
        rig.run(1);
        // The output stays off until the first moves have ended and the dwell has run.
        let p12 = value(&mut rig, "P12");
        if value(&mut rig, "M1") == 1.0 {
            assert!(p12 > 0.0, "the output switched before the moves ended");
            let now = value(&mut rig, "Sys.ServoCount");
            assert!(
                now - p12 >= cycles(100.0) - 1.0,
                "output at cycle {now}, moves ended at {p12}: not after the dwell"
            );
        }
        if value(&mut rig, "Motor[2].DesVelZero") == 0.0 {
            seen_moving = true;
        }
        if value(&mut rig, "P11") > 0.0 {
            break;
        }
    }
    assert!(seen_moving, "motor 2 never moved");
    let (p10, p11, p12, p20) = (
        value(&mut rig, "P10"),
        value(&mut rig, "P11"),
        value(&mut rig, "P12"),
        value(&mut rig, "P20"),
    );
    assert!(p11 > 0.0, "the PLC never saw the program end");
    // The PLC saw the start within a few cycles of `r` (a PLC scan per servo cycle here).
    assert!(
        p10 - start_cycle >= 1.0 && p10 - start_cycle <= 5.0,
        "start seen at {p10}, `r` at {start_cycle}"
    );
    // The first moves (X2 Y-1: 2000 and 1000 counts, tm300, ta50) take TM + TA. Motor 1's
    // 6.67 counts/ms reached in 50 ms would be 0.13 counts/ms², past the seed's default
    // `Motor[x].InvAmax` 10 ms²/count (0.1 counts/ms²): the acceleration time grows to
    // 66.7 ms for both motors (seed L4976-4980: linear moves without segmentation).
    let ta = (2000.0 / 300.0 * 10.0_f64).max(50.0);
    let moves = p12 - p10;
    assert!(
        (moves - cycles(300.0 + ta)).abs() <= 3.0,
        "moves took {moves} cycles ({} ms), {} ms expected",
        moves * period_ms,
        300.0 + ta
    );
    // `dwell 100` stops look-ahead: the output line ran 100 ms after the moves ended (± a cycle).
    let dwell = p20 - p12;
    assert!(
        (dwell - cycles(100.0)).abs() <= 2.0,
        "dwell took {dwell} cycles, {} expected",
        cycles(100.0)
    );
    // The way back (the same TM + TA), then the program ends: ProgRunning falls.
    let back = p11 - p20;
    assert!(
        (back - cycles(300.0 + ta)).abs() <= 4.0,
        "the way back took {back} cycles"
    );
    for (q, want) in [("M1", 1.0), ("Coord[1].ProgRunning", 0.0)] {
        assert_eq!(value(&mut rig, q), want, "{q}");
    }
    for m in [1, 2] {
        let p = value(&mut rig, &format!("Motor[{m}].DesPos"));
        assert!(p.abs() < 0.5, "Motor[{m}] back at 0: {p}");
    }
}
