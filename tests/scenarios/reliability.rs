//! Reliability: the fault campaign (every fault kind at random members and times while programs
//! run, held to the ring-check rules) and card SAVE under SIGKILL at random moments, each a
//! bounded run of its benchmark (`mcc bench faults --campaign`, `mcc bench save-crash`).

use std::time::Duration;

use mcc_tests::process::{mcc, ok};
use serde_json::Value;

fn json(out: std::process::Output, what: &str) -> Value {
    let text = ok(out, what);
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{what}: {e}: {text}"))
}

/// 20 SIGKILLs at random moments of a card saving over and over: every restart finds the old
/// or the new state (never a mix, never a refused file) and no file but the state file.
#[test]
fn card_save_survives_sigkill_at_random_moments() {
    let r = json(
        mcc(
            &["bench", "save-crash", "--trials", "20", "--seed", "7", "--json"],
            Duration::from_secs(600),
        ),
        "mcc bench save-crash",
    );
    assert_eq!(r["trials"], 20, "{r}");
    assert_eq!(r["failures"].as_array().map(Vec::len), Some(0), "{r}");
    let old = r["found_old"].as_u64().unwrap();
    let new = r["found_new"].as_u64().unwrap();
    assert_eq!(old + new, 20, "every trial found old or new state: {r}");
    assert!(r["saves_acked"].as_u64().unwrap() > 0, "{r}");
}

/// A campaign of `n` faults on a lockstep or paced cluster of its own: every kind injected,
/// none against the rules (detected within its bound by exactly the members the rules name,
/// the broken link named, motors killed and amplifiers off in the latching cycle, programs
/// back at the same end position after recovery; faults below the thresholds quiet).
fn campaign(clock: &str, n: u64, seed: u64) {
    let (n_s, seed_s) = (n.to_string(), seed.to_string());
    let r = json(
        mcc(
            &[
                "bench", "faults", "--campaign", &n_s, "--seed", &seed_s, "--clock", clock,
                "--json",
            ],
            Duration::from_secs(60 * 40),
        ),
        "mcc bench faults --campaign",
    );
    assert_eq!(r["faults"], n, "{r}");
    assert_eq!(r["failed"], 0, "{:#}", r["violations"]);
    let kinds = r["kinds"].as_object().expect("kinds");
    assert_eq!(kinds.len(), 12, "every kind: {r}");
    let mut detected = 0;
    for (k, row) in kinds {
        assert!(row["injected"].as_u64().unwrap() >= n / 12, "{k}: {row}");
        let lat = &row["latency_cycles"];
        if row["sustained"].as_u64().unwrap() > 0 {
            assert!(lat["n"].as_u64().unwrap() > 0, "{k}: {row}");
            assert!(
                lat["max"].as_u64().unwrap() <= row["bound_cycles"].as_u64().unwrap(),
                "{k}: {row}"
            );
            detected += row["sustained"].as_u64().unwrap();
        }
    }
    assert!(detected > n / 3, "{r}");
}

#[test]
fn fault_campaign_lockstep() {
    campaign("lockstep", 60, 11);
}

#[test]
fn fault_campaign_paced() {
    campaign("paced", 48, 12);
}
