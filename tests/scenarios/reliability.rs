//! Reliability: card SAVE under SIGKILL at random moments, a bounded run of its benchmark
//! (`mcc bench save-crash`).

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
            &[
                "bench",
                "save-crash",
                "--trials",
                "20",
                "--seed",
                "7",
                "--json",
            ],
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
