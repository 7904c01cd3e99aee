//! Cycles in flight (`ring.in_flight`): more than one cycle around the ring at a time keeps the
//! lockstep contract — the same frames in the same order whatever the timing — with the servo
//! loop N-1 cycles longer.

use std::time::Duration;

use super::driver::DriverExit;
use super::local::{LocalRing, LocalTransport};
use super::tests::{ring, App};
use mcc_contracts::config::ClockMode;

/// Run the 3-member test ring with `in_flight` cycles in flight; the sync master's
/// (cycle, feedback) record.
fn run(in_flight: u64, clock: ClockMode, transport: LocalTransport) -> Vec<(u64, u32)> {
    let mut members = ring(600);
    for m in &mut members {
        // As member processes do: the ring check arms once locked (the first N ticks of the
        // sync master come before anything can be back).
        m.0.check_after_lock = true;
        m.2.in_flight = in_flight;
        m.2.clock = clock;
        m.2.rate_hz = 20_000.0;
        m.2.rtf = 1.0;
    }
    for m in &mut members[1..] {
        m.2.max_cycles = None;
    }
    let r = LocalRing::start(members, transport).unwrap();
    let out = r.join_member(0, Duration::from_secs(60));
    for r in &out {
        assert!(
            matches!(r.exit, DriverExit::Done | DriverExit::Stopped),
            "{:?}",
            r.exit
        );
        let e = r.core.status().errors;
        assert_eq!(
            e.overrun + e.underrun + e.bad_frames,
            0,
            "{}: {e:?}",
            r.core.name()
        );
    }
    let App::M(m) = &out[0].app else { panic!() };
    assert_eq!(m.seen.len(), 600);
    m.seen.clone()
}

/// The station answers command + 1; with N in flight the master's tick c sees the answer to
/// its own tick c-(N+2) (N = 1: c-3, see the loopback test of `tests`).
fn assert_delay(seen: &[(u64, u32)], in_flight: u64, from: usize) {
    for &(c, fb) in seen.iter().skip(from) {
        assert_eq!(
            u64::from(fb),
            c - (in_flight + 2) + 1,
            "cycle {c}, {in_flight} in flight"
        );
    }
}

#[test]
fn two_and_four_cycles_in_flight_lengthen_the_loop_by_one_and_three_cycles() {
    for n in [1, 2, 4] {
        let seen = run(n, ClockMode::Lockstep, LocalTransport::Loopback);
        assert_delay(&seen, n, 8);
    }
}

#[test]
fn paced_with_two_in_flight_is_cycle_for_cycle_the_same_as_lockstep() {
    let lockstep = run(2, ClockMode::Lockstep, LocalTransport::Loopback);
    let paced = run(2, ClockMode::Paced, LocalTransport::Loopback);
    assert_eq!(lockstep[8..], paced[8..]);
}

#[test]
fn two_in_flight_over_zenoh_with_inline_receive_keeps_the_relation() {
    for receive_thread_ticks in [false, true] {
        let cluster = format!("pipe-test-{}-{receive_thread_ticks}", std::process::id());
        let seen = run(
            2,
            ClockMode::Lockstep,
            LocalTransport::ZenohInline {
                cluster,
                receive_thread_ticks,
            },
        );
        // After the links are up (bring-up retries), every cycle.
        assert_delay(&seen[seen.len() - 200..], 2, 0);
    }
}
