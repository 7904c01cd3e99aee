//! Our own ring transport never loses a frame, even with the machine fully loaded: a
//! multi-process lockstep ring runs beside four busy threads, with one and with the most cycles
//! in flight (`ring.in_flight` 8: the most frames a link's queue must hold at once).
//!
//! In lockstep a lost frame stops the ring: the sync master waits for it until the frozen-member
//! wait runs out, then declares the ring down and latches a ring fault. The frozen-member wait
//! is set to 20 s here, longer than any scheduling delay on a loaded machine, so a stall that
//! long can only be a frame lost by the transport: the ring must keep cycling, never go down,
//! latch nothing, and count no error after lock.

use std::time::{Duration, Instant};

use mcc_tests::cluster::Cluster;
use mcc_tests::load::{ring_errors, Busy};
use mcc_tests::process::{mcc, ok, run_base, unique};

/// The default 2 + 2 lockstep cluster's config with `in_flight` cycles in flight and a 20 s
/// frozen-member wait, written to a file of its own.
fn config(in_flight: u64) -> String {
    let text = ok(
        mcc(
            &["up", "--print-config", "--clock", "lockstep"],
            Duration::from_secs(60),
        ),
        "mcc up --print-config",
    );
    // Whatever the default frozen wait is, this test sets its own.
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("member_timeout_ms = ") {
                "member_timeout_ms = 20000".to_string()
            } else if l.starts_with("in_flight = ") {
                format!("in_flight = {in_flight}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    assert!(text.contains("member_timeout_ms = 20000\n"), "{text}");
    assert!(
        text.contains(&format!("in_flight = {in_flight}\n")),
        "{text}"
    );
    std::fs::create_dir_all(run_base()).unwrap();
    let path = run_base().join(format!("{}.toml", unique("load-config")));
    std::fs::write(&path, text).unwrap();
    path.to_string_lossy().into_owned()
}

fn runs_loaded_without_losing_a_frame(in_flight: u64, cycles: u64) {
    let path = config(in_flight);
    let c = Cluster::up(&format!("load{in_flight}"), &["--config", &path]);
    let _busy = Busy::start(4);
    // Errors are counted from 500 cycles after lock: bring-up (the retried first cycles, the
    // first window of a pipelined ring, before the ring check is armed) may count some.
    let up = c.status()["ring"]["cycle"].as_u64().unwrap();
    let first = c.wait("500 cycles after lock", Duration::from_secs(120), |d| {
        d["ring"]["cycle"].as_u64().unwrap() >= up + 500
    });
    let from = first["ring"]["cycle"].as_u64().unwrap();
    let before: Vec<Vec<u64>> = first["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(ring_errors)
        .collect();
    let t0 = Instant::now();
    let last = c.wait(
        &format!("{cycles} loaded lockstep cycles"),
        Duration::from_secs(240),
        |d| d["ring"]["cycle"].as_u64().unwrap() >= from + cycles,
    );
    eprintln!(
        "in_flight {in_flight}: {cycles} cycles in {:?} under load",
        t0.elapsed()
    );
    let timing = &last["timing"];
    assert_eq!(timing["ring_down_count"], 0, "{last:#}");
    assert_eq!(timing["ring_down"], false, "{last:#}");
    assert_eq!(last["ring"]["faulted"], false, "{last:#}");
    assert_eq!(last["ring"]["locked"], true, "{last:#}");
    for (m, b) in last["members"].as_array().unwrap().iter().zip(&before) {
        assert_eq!(m["alive"], true, "{m:#}");
        assert_eq!(m["ring_fault_count"], 0, "{m:#}");
        assert_eq!(&ring_errors(m), b, "errors counted after lock: {m:#}");
    }
    let _ = std::fs::remove_file(&path);
}

#[test]
fn lockstep_rings_under_full_load_lose_no_frame() {
    runs_loaded_without_losing_a_frame(1, 3000);
    runs_loaded_without_losing_a_frame(8, 6000);
}
