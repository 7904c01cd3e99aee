//! Issue 23 item 2 end to end: `mcc fault STATION axis …` / `power-loss` on a real
//! (lockstep) cluster through `mcc_testing`: the card's `?` shows the fault, `mcc status`
//! (table and `--json`) shows it on the station, `mcc fault clear` takes it away and `#1J/`
//! brings the motor back; bad words are refused by the CLI naming the valid ones.

use std::time::Duration;

use mcc_testing::{Cluster, ErrorKind};
use mcc_tests::process::bin_dir;

const WAIT: Duration = Duration::from_secs(120);
const W1_OPEN_LOOP: u32 = 1 << 18;
const W2_AMP_FAULT: u32 = 1 << 3;
const W2_FATAL_FE: u32 = 1 << 2;

fn status_words(c: &Cluster, motor: u16) -> (u32, u32) {
    let r = c.send(&[&format!("#{motor}?")], Some(0)).unwrap().remove(0);
    let w = |s: &str| u32::from_str_radix(s, 16).unwrap();
    (w(&r[..6]), w(&r[6..12]))
}

/// Wait (ring cycles, generous wall time) until motor 1 is killed with `bit` set.
fn wait_killed(c: &mut Cluster, bit: u32) {
    for _ in 0..200 {
        let (w1, w2) = status_words(c, 1);
        if w1 & W1_OPEN_LOOP != 0 && w2 & bit != 0 {
            return;
        }
        c.wait_cycles(50, WAIT).unwrap();
    }
    panic!(
        "motor 1 not killed with bit {bit:#x}: {:?}",
        status_words(c, 1)
    );
}

fn recover(c: &mut Cluster, after: &str) {
    c.send(&["#1J/"], Some(0)).unwrap();
    c.wait_cycles(100, WAIT).unwrap();
    let (w1, w2) = status_words(c, 1);
    assert_eq!(
        w1 & W1_OPEN_LOOP,
        0,
        "closed loop again after {after}: {w2:06x}"
    );
    assert_eq!(
        w2 & (W2_AMP_FAULT | W2_FATAL_FE),
        0,
        "no error bit left after {after}"
    );
}

#[test]
fn axis_faults_from_the_cli_show_in_status_and_clear() {
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .clock("lockstep")
        .cards(1)
        .stations(1)
        .tag("axis")
        .start()
        .expect("cluster up");
    c.send(&["I3=2", "#1J/"], Some(0)).unwrap();
    c.wait_cycles(100, WAIT).unwrap();
    assert_eq!(status_words(&c, 1).0 & W1_OPEN_LOOP, 0);

    let msg = c
        .axis_fault("station0", 0, "amp-fault", None, None)
        .unwrap();
    assert!(msg.contains("node 0 amp-fault"), "{msg}");
    wait_killed(&mut c, W2_AMP_FAULT);
    let st = c.status().unwrap();
    let f = &st.0["stations"][0]["axis_faults"][0];
    assert_eq!(
        (f["node"].as_u64(), f["kind"].as_str()),
        (Some(0), Some("amp-fault"))
    );
    assert!(
        f["since_cycle"].as_u64().is_some() && f["until_cycle"].is_null(),
        "{f}"
    );
    let table = c.mcc(&["status"]);
    let table = String::from_utf8_lossy(&table.stdout);
    assert!(
        table.contains("station station0: axis faults: node 0 amp-fault (since"),
        "{table}"
    );
    c.clear(Some("station0")).unwrap();
    c.wait_cycles(5, WAIT).unwrap();
    assert_eq!(
        c.status().unwrap().0["stations"][0]["axis_faults"],
        serde_json::json!([])
    );
    recover(&mut c, "amp-fault");

    // A load of 0.3 N·m for 50 cycles: a fatal FE kill, then it expires by itself.
    c.axis_fault("station0", 0, "load", Some(0.3), Some(2000))
        .unwrap();
    wait_killed(&mut c, W2_FATAL_FE);
    c.wait_until(None, WAIT, |st| {
        st.0["stations"][0]["axis_faults"] == serde_json::json!([])
    })
    .unwrap();
    // The killed motor coasts to a stop (past the +limit: a runaway).
    c.wait_cycles(8000, WAIT).unwrap();
    recover(&mut c, "load");

    // Power loss: every amplifier of the station, the ring stays up.
    c.send(&["#2J/"], Some(0)).unwrap();
    c.power_loss("station0", None).unwrap();
    wait_killed(&mut c, W2_AMP_FAULT);
    assert_ne!(status_words(&c, 2).1 & W2_AMP_FAULT, 0, "motor 2 too");
    let st = c.status().unwrap();
    assert!(st.locked() && !st.faulted(), "the ring stays up");
    assert_eq!(st.0["stations"][0]["power_loss"], true);
    c.clear(None).unwrap();
    c.wait_cycles(5, WAIT).unwrap();
    recover(&mut c, "power-loss");

    // Refusals: the test API's own, then the CLI's (it checks the same words).
    let e = c.axis_fault("station0", 2, "jam", None, None).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::UnknownChoice { .. }), "{e}");
    let e = c.axis_fault("station0", 0, "melt", None, None).unwrap_err();
    assert!(e.message.contains("amp-fault"), "{e}");
    for (args, want) in [
        (
            &["fault", "station0", "axis", "2", "jam"][..],
            "servo nodes: 0, 1, 4, 5",
        ),
        (
            &["fault", "station0", "axis", "0", "melt"][..],
            "home-chatter",
        ),
        (&["fault", "card0", "axis", "0", "jam"][..], "not a station"),
        (
            &["fault", "station0", "axis", "0", "load"][..],
            "needs --value",
        ),
        (
            &["fault", "station0", "axis", "0", "jam", "--value", "3"][..],
            "takes no --value",
        ),
    ] {
        let out = c.mcc(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(want),
            "{args:?}: {err}"
        );
    }
    assert_eq!(
        c.status().unwrap().0["stations"][0]["axis_faults"],
        serde_json::json!([])
    );
}

/// The test API's kind list is the station's.
#[test]
fn the_test_api_knows_every_axis_kind() {
    assert_eq!(mcc_testing::AXIS_KINDS, mcc_station::faults::AXIS_KINDS);
    let takes: Vec<&str> = mcc_station::faults::VALUE_KINDS
        .iter()
        .map(|k| k.0)
        .collect();
    assert_eq!(mcc_testing::AXIS_VALUE_KINDS, takes);
}
