//! Reliability: card SAVE under SIGKILL at random moments, a bounded run of its benchmark
//! (`mcc bench save-crash`); a bounded fault campaign (`mcc bench faults --campaign`).

use std::time::Duration;

use mcc_tests::process::{
    mcc, mcc_command, ok, pid_alive, run_base, send_signal, text, wait_until,
};
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

/// A campaign of 120 faults of every kind (drop-sync, drop-packets, corrupt, byte-violation,
/// overrun, underrun, delay, delay-us, cut, freeze, kill, restart, a card's abort input, an
/// amplifier fault at a station, a host-link fault on a card's port) at random members, the sync
/// master included, on a lockstep cluster of its own while programs run on every card: none
/// against the ring-check rules (every member the rules name latches within its bound in ring
/// cycles and nobody else, the broken link named, motors killed and station amplifiers off in
/// the latching cycle, programs back at the same end position after clear + restart + reset;
/// bursts below the thresholds latch nothing and kill no motor).
#[test]
fn fault_campaign_of_120_faults_keeps_the_ring_check_rules() {
    let n = 120u64;
    let out = mcc(
        &[
            "bench",
            "faults",
            "--campaign",
            "120",
            "--seed",
            "11",
            "--clock",
            "lockstep",
            "--json",
        ],
        Duration::from_secs(60 * 45),
    );
    let stdout = text(&out.stdout);
    let r: Value = serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!(
            "mcc bench faults --campaign: {e}: {stdout}\n{}",
            text(&out.stderr)
        )
    });
    assert_eq!(r["faults"], n, "the campaign ran to its end: {r}");
    assert_eq!(r["failed"], 0, "violations: {:#}", r["violations"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let kinds = r["kinds"].as_object().expect("kinds");
    // The twelve ring kinds and drills, a card's abort input, an amplifier fault and a
    // host-link fault.
    assert_eq!(kinds.len(), 15, "every kind: {r}");
    assert!(kinds.contains_key("link"), "the host-link fault: {r}");
    assert!(kinds.contains_key("input"), "the abort input: {r}");
    assert!(kinds.contains_key("axis"), "the amplifier fault: {r}");
    let mut detected = 0;
    let per_kind = n / kinds.len() as u64;
    let injected: u64 = kinds
        .values()
        .map(|r| r["injected"].as_u64().unwrap())
        .sum();
    assert_eq!(injected, n, "every fault injected: {r}");
    for (k, row) in kinds {
        let i = row["injected"].as_u64().unwrap();
        assert!(i == per_kind || i == per_kind + 1, "{k}: {row}");
        let sustained = row["sustained"].as_u64().unwrap();
        if sustained > 0 {
            let lat = &row["latency_cycles"];
            assert!(lat["n"].as_u64().unwrap() >= sustained, "{k}: {row}");
            assert!(
                lat["max"].as_u64().unwrap() <= row["bound_cycles"].as_u64().unwrap(),
                "{k}: {row}"
            );
            detected += sustained;
        }
    }
    for k in ["kill", "restart", "freeze"] {
        assert_eq!(
            kinds[k]["sustained"], kinds[k]["injected"],
            "{k} is always detected"
        );
    }
    // Never a ring error: delay-us, and the faults that are not the ring's (a card's input,
    // an amplifier fault, a host link), each judged by its own effect.
    let quiet = ["delay-us", "input", "axis", "link"];
    for k in quiet {
        assert_eq!(kinds[k]["sustained"], 0, "{k} is never a ring error");
        assert_eq!(kinds[k]["failed"], 0, "{k}");
    }
    let ring: u64 = n - quiet
        .iter()
        .map(|k| kinds[*k]["injected"].as_u64().unwrap())
        .sum::<u64>();
    // Of the ring's own faults, more than half are sustained (the rest are bursts below the
    // thresholds).
    assert!(
        detected > ring / 2,
        "{detected} of {ring} ring faults detected: {r}"
    );
}

/// A benchmark interrupted while its cluster runs (SIGINT, as Ctrl-C) leaves nothing behind:
/// its members exit within 3 s and its run directory is gone.
#[test]
fn an_interrupted_benchmark_leaves_no_process_and_no_file() {
    let mut child = mcc_command(&[
        "bench",
        "faults",
        "--campaign",
        "1000",
        "--clock",
        "lockstep",
    ])
    .stdout(std::process::Stdio::null())
    .stderr(std::process::Stdio::null())
    .spawn()
    .expect("mcc bench faults");
    let name = format!("bench-campaign-{}", child.id());
    let mut pids = Vec::new();
    let mut guard = scopeguard(&mut child);
    wait_until(
        "the benchmark's ring to lock",
        Duration::from_secs(120),
        || {
            let out = mcc(
                &["status", "--json", "--cluster", &name],
                Duration::from_secs(30),
            );
            let Ok(doc) = serde_json::from_slice::<Value>(&out.stdout) else {
                return false;
            };
            pids = doc["members"]
                .as_array()
                .map(|m| m.iter().filter_map(|m| m["pid"].as_u64()).collect())
                .unwrap_or_default();
            doc["ring"]["locked"] == true && pids.len() == 4
        },
    );
    send_signal(u64::from(guard.0.id()), "-INT");
    let mut exited = None;
    wait_until("mcc to exit on SIGINT", Duration::from_secs(30), || {
        exited = guard.0.try_wait().ok().flatten();
        exited.is_some()
    });
    assert_eq!(exited.and_then(|s| s.code()), Some(130));
    let t0 = std::time::Instant::now();
    wait_until("the members to exit", Duration::from_secs(20), || {
        pids.iter().all(|p| !pid_alive(*p))
    });
    assert!(t0.elapsed() < Duration::from_secs(3), "{:?}", t0.elapsed());
    assert!(
        !run_base().join(&name).exists(),
        "run directory left behind"
    );
    guard.1 = true;
}

/// Kills the child unless disarmed (a failing test leaves no benchmark running).
struct Guard<'a>(&'a mut std::process::Child, bool);

fn scopeguard(c: &mut std::process::Child) -> Guard<'_> {
    Guard(c, false)
}

impl Drop for Guard<'_> {
    fn drop(&mut self) {
        if !self.1 {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}
