//! Our own ring transport never loses a frame, even with the machine fully loaded: a
//! multi-process lockstep ring runs beside four busy threads, with one and with the most cycles
//! in flight (`ring.in_flight` 8: the most frames a link's queue must hold at once).
//!
//! In lockstep a lost frame stops the ring: the sync master waits for it until the frozen-member
//! wait runs out, then declares the ring down and latches a ring fault. The frozen-member wait
//! is set to 20 s here, longer than any scheduling delay on a loaded machine, so a stall that
//! long can only be a frame lost by the transport: the ring must keep cycling, never go down,
//! latch nothing, and count no error after lock.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mcc_testing::{Cluster, Status};
use mcc_tests::process::bin_dir;
use serde_json::Value;

/// Threads spinning on the CPU until dropped.
struct Busy {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Busy {
    fn start(n: usize) -> Busy {
        let stop = Arc::new(AtomicBool::new(false));
        let threads = (0..n)
            .map(|_| {
                let stop = Arc::clone(&stop);
                std::thread::spawn(move || {
                    let mut x = 0u64;
                    while !stop.load(Ordering::Relaxed) {
                        x = std::hint::black_box(
                            x.wrapping_mul(6364136223846793005).wrapping_add(1),
                        );
                    }
                })
            })
            .collect();
        Busy { stop, threads }
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn errors(m: &Value) -> Vec<u64> {
    [
        "byte_violation",
        "checksum",
        "overrun",
        "underrun",
        "bad_frames",
    ]
    .iter()
    .map(|k| m["errors"][k].as_u64().unwrap())
    .collect()
}

/// Wait (bounded by `timeout`) until the ring has run to cycle `cycle`, for a status every
/// member answered (on a loaded machine one may answer too late for a given status round:
/// its fields, and the sync master's timing, are then missing from that document); that
/// status.
fn wait_cycle(c: &mut Cluster, what: &str, timeout: Duration, cycle: u64) -> Value {
    c.wait_until(None, timeout, |st: &Status| {
        let members = st.0["members"].as_array().cloned().unwrap_or_default();
        st.cycle() >= cycle && members.iter().all(|m| m["alive"] == true)
    })
    .unwrap_or_else(|e| panic!("waiting for {what}: {e}"))
    .0
}

fn runs_loaded_without_losing_a_frame(in_flight: u64, cycles: u64) {
    // The default 2 + 2 cluster in lockstep, `in_flight` cycles in flight, and a 20 s
    // frozen-member wait whatever the default is.
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .tag(&format!("load{in_flight}"))
        .clock("lockstep")
        .extra("member_timeout_ms", 20_000.into())
        .extra("ring.in_flight", (in_flight as i64).into())
        .start()
        .unwrap_or_else(|e| panic!("mcc up: {e}"));
    let up = c.initial_status().clone();
    assert_eq!(up.0["clock"], "lockstep", "{:#}", up.0);
    let _busy = Busy::start(4);
    // Errors are counted from 500 cycles after lock: bring-up (the retried first cycles, the
    // first window of a pipelined ring, before the ring check is armed) may count some.
    let first = wait_cycle(
        &mut c,
        "500 cycles after lock",
        Duration::from_secs(120),
        up.cycle() + 500,
    );
    let from = first["ring"]["cycle"].as_u64().unwrap();
    let before: Vec<Vec<u64>> = first["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(errors)
        .collect();
    let t0 = Instant::now();
    let last = wait_cycle(
        &mut c,
        &format!("{cycles} loaded lockstep cycles"),
        Duration::from_secs(240),
        from + cycles,
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
        assert_eq!(&errors(m), b, "errors counted after lock: {m:#}");
    }
}

#[test]
fn lockstep_rings_under_full_load_lose_no_frame() {
    runs_loaded_without_losing_a_frame(1, 3000);
    runs_loaded_without_losing_a_frame(8, 6000);
}
