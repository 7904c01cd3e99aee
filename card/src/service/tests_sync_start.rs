use super::*;
use crate::domain::Profile;

fn arm(id: u64, cycle: u64, line: &str) -> AtRequest {
    AtRequest::Arm {
        id,
        cycle,
        line: line.into(),
    }
}

use super::super::handle::{channel, Runner};
use crate::core::CardCore;
use crate::lang::Session;

/// A card with PROG 1 (a dwell), motor 1 in C.S. 1 with its loop closed: `&1B1R` starts it;
/// owned by its runner as on the servo thread.
struct T {
    runner: Runner,
    stall: Duration,
}

fn ready_card(stall: Duration) -> T {
    let mut c = Card::new(Profile::Pmac2);
    let mut s = Session::default();
    for line in [
        "I100=1",
        "&1#1->1000X",
        "#1J/",
        "OPEN PROG 1 CLEAR",
        "DWELL 10",
        "CLOSE",
    ] {
        let r = c.command_line(&mut s, line.as_bytes());
        assert!(
            !r.contains(&0x07),
            "{line}: {:?}",
            String::from_utf8_lossy(&r)
        );
    }
    let _ = c.take_actions();
    let (runner, _h) = channel(CardCore::new(c), None);
    T { runner, stall }
}

impl T {
    fn tick(&mut self, cycle: u64, drain: bool) {
        self.runner.sync_tick_start(cycle, self.stall);
        if drain {
            let _ = self.runner.core.card.take_actions();
        }
        self.runner.sync_tick_end();
    }

    fn handle(&mut self, req: &AtRequest) -> AtReply {
        if matches!(req, AtRequest::Info) {
            self.runner.sync_tick_end_info();
        }
        self.runner.sync.handle(req)
    }

    fn program_start(&self) -> (Option<u64>, Option<u64>) {
        self.runner.sync.lock().program_start()
    }

    fn payload(&mut self, p: &[u8]) -> AtReply {
        answer_payload(&self.runner.sync, p)
    }

    fn card(&mut self) -> &mut Card {
        &mut self.runner.core.card
    }
}

#[test]
fn armed_and_committed_line_runs_in_the_tick_of_its_cycle() {
    let mut t = ready_card(Duration::from_millis(50));
    t.tick(10, true);
    let r = t.handle(&arm(7, 13, "&1B1R"));
    assert!(r.ok, "{r:?}");
    assert_eq!(r.cycle, Some(10));
    assert!(t.handle(&AtRequest::Commit { id: 7 }).ok);
    t.tick(11, true);
    t.tick(12, true);
    let pending = t.handle(&AtRequest::Result { id: 7 });
    assert_eq!(pending.executed_cycle, None);
    assert_eq!(pending.message, "pending for cycle 13");
    t.tick(13, true);
    let done = t.handle(&AtRequest::Result { id: 7 });
    assert_eq!(done.executed_cycle, Some(13));
    let want = ready_card(Duration::from_millis(5))
        .card()
        .command_line(&mut Session::default(), b"&1B1R");
    assert!(!want.contains(&0x07));
    assert_eq!(done.reply.as_deref().map(str::as_bytes), Some(&want[..]));
    assert_eq!(t.program_start().0, Some(13));
    let info = t.handle(&AtRequest::Info);
    assert_eq!((info.program_start_cycle, info.cycle), (Some(13), Some(13)));
    assert_eq!(info.stalls, 0);
}

#[test]
fn an_arm_for_a_cycle_that_has_started_is_refused_as_late() {
    let mut t = ready_card(Duration::from_millis(50));
    let r = t.handle(&arm(1, 5, "&1B1R"));
    assert!(!r.ok && r.late, "no tick yet: {r:?}");
    t.tick(5, true);
    let r = t.handle(&arm(1, 5, "&1B1R"));
    assert!(!r.ok && r.late, "{r:?}");
    assert_eq!(r.message, "too late: cycle 5 has started (now 5)");
    let r = t.handle(&arm(1, 6, "&1B1R"));
    assert!(r.ok && !r.late);
}

#[test]
fn aborted_or_uncommitted_lines_never_run() {
    let mut t = ready_card(Duration::from_millis(5));
    t.tick(1, true);
    assert!(t.handle(&arm(1, 3, "&1B1R")).ok);
    assert!(t.handle(&AtRequest::Abort { id: 1 }).ok);
    t.tick(3, true);
    assert_eq!(t.program_start().0, None);
    // Never committed: the tick waits its stall limit, then abandons the line.
    assert!(t.handle(&arm(2, 4, "&1B1R")).ok);
    t.tick(4, true);
    let r = t.handle(&AtRequest::Result { id: 2 });
    assert!(r.abandoned && !r.ok, "{r:?}");
    assert_eq!(t.program_start().0, None);
    assert!(!t.handle(&AtRequest::Commit { id: 2 }).ok);
    // Committed lines cannot be aborted.
    assert!(t.handle(&arm(3, 9, "&1B1R")).ok);
    assert!(t.handle(&AtRequest::Commit { id: 3 }).ok);
    assert!(!t.handle(&AtRequest::Abort { id: 3 }).ok);
}

#[test]
fn a_late_commit_stalls_the_tick_and_still_runs_at_its_cycle() {
    let mut t = ready_card(Duration::from_secs(5));
    t.tick(1, true);
    assert!(t.handle(&arm(9, 2, "&1B1R")).ok);
    let sync = Arc::clone(&t.runner.sync);
    let late = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(30));
        sync.handle(&AtRequest::Commit { id: 9 })
    });
    t.tick(2, true);
    assert!(late.join().unwrap().ok);
    let r = t.handle(&AtRequest::Result { id: 9 });
    assert_eq!(r.executed_cycle, Some(2));
    assert_eq!(r.stalls, 1);
    assert_eq!(t.program_start().0, Some(2));
}

#[test]
fn unscheduled_program_starts_are_recorded_at_the_tick_that_takes_them() {
    let mut t = ready_card(Duration::from_millis(5));
    t.tick(1, true);
    let r = t.card().command_line(&mut Session::default(), b"&1B1R");
    assert!(!r.contains(&0x07), "{r:?}");
    t.tick(2, true);
    assert_eq!(t.program_start().0, Some(2));
    t.tick(3, true);
    assert_eq!(t.program_start().0, Some(2));
    // Without a consumer the actions stay queued: an old R is not a new start.
    let _ = t.card().command_line(&mut Session::default(), b"&1R");
    t.tick(4, false);
    t.tick(5, false);
    assert_eq!(t.program_start().0, Some(4));
    // A refused R (ERR015: no program) records nothing.
    let r = t.card().command_line(&mut Session::default(), b"&1B7R");
    assert!(r.contains(&0x07));
    t.tick(6, false);
    assert_eq!(t.program_start().0, Some(4));
}

#[test]
fn bad_requests_are_refused_with_a_message() {
    let mut t = ready_card(Duration::from_millis(5));
    t.tick(1, true);
    let r = t.payload(b"{\"op\":\"launch\"}");
    assert!(!r.ok && r.message.starts_with("bad request"), "{r:?}");
    let r = t.payload(&[b' '; MAX_REQUEST + 1]);
    assert!(!r.ok && r.message.contains("longer"));
    assert!(!t.handle(&arm(1, 5, "&1B1R\r")).ok);
    assert!(!t.handle(&arm(1, 5, &"P".repeat(MAX_LINE + 1))).ok);
    assert!(!t.handle(&arm(1, 1 + MAX_LEAD_CYCLES + 1, "R")).ok);
    for id in 0..MAX_PENDING as u64 {
        assert!(t.handle(&arm(100 + id, 50, "P1=1")).ok);
    }
    assert!(!t.handle(&arm(999, 50, "P1=1")).ok);
    assert!(!t.handle(&AtRequest::Commit { id: 4242 }).ok);
    let r = t.payload(br#"{"op":"arm","id":100,"cycle":50,"line":"P1=2"}"#);
    assert!(!r.ok && r.message.contains("differently"), "{r:?}");
}

#[test]
fn info_reports_ring_fault_and_killed_motors() {
    let mut t = ready_card(Duration::from_millis(5));
    let r = t.handle(&AtRequest::Info);
    assert!(!r.ring_fault && !r.motors_killed);
    assert!(r.killed_motors.is_empty(), "{r:?}");
    {
        let c = t.card();
        c.state.global.ring_fault = true;
        let _ = c.command_line(&mut Session::default(), b"#1K");
    }
    let r = t.handle(&AtRequest::Info);
    assert!(r.ring_fault && r.motors_killed, "{r:?}");
    assert_eq!(r.killed_motors, vec![1]);
}

/// Issue 24 item 3: a synchronized start's line has one slice in the tick of its cycle: the
/// program starts in that cycle, and what is left of a long line (`P0..1023`) runs in the
/// pumps after it; its reply, the same as in one go, is reported executed in the cycle it
/// started in.
#[test]
fn a_long_started_line_starts_in_its_cycle_and_finishes_in_later_slices() {
    let mut t = ready_card(Duration::from_millis(50));
    t.tick(10, true);
    let line = "&1B1R P0..1023";
    assert!(t.handle(&arm(7, 12, line)).ok);
    assert!(t.handle(&AtRequest::Commit { id: 7 }).ok);
    t.tick(11, true);
    t.tick(12, false);
    assert_eq!(t.program_start().0, Some(12), "started in its cycle");
    let r = t.handle(&AtRequest::Result { id: 7 });
    assert_eq!(r.executed_cycle, None, "1024 values do not fit one slice");
    assert!(r.ok, "{r:?}");
    assert_eq!(r.message, "running since cycle 12");
    let mut pumps = 0;
    let done = loop {
        t.runner
            .pump(&mut crate::lang::Budget::new(crate::core::SLICE_UNITS));
        pumps += 1;
        let r = t.handle(&AtRequest::Result { id: 7 });
        if r.executed_cycle.is_some() {
            break r;
        }
        assert!(pumps < 1000, "never done");
    };
    assert!(pumps >= 2, "{pumps} pumps");
    assert_eq!(done.executed_cycle, Some(12));
    let want = ready_card(Duration::from_millis(5))
        .card()
        .command_line(&mut Session::default(), line.as_bytes());
    assert_eq!(done.reply.as_deref().map(str::as_bytes), Some(&want[..]));
}

#[test]
fn a_refused_line_reports_its_refusal_whatever_i6_prints() {
    let mut t = ready_card(Duration::from_millis(50));
    // I6 = 0: a refusal answers a bare <BELL>.
    let _ = t.card().command_line(&mut Session::default(), b"I6=0");
    t.tick(10, true);
    assert!(t.handle(&arm(3, 12, "UUU")).ok);
    assert!(t.handle(&AtRequest::Commit { id: 3 }).ok);
    t.tick(11, true);
    t.tick(12, true);
    let done = t.handle(&AtRequest::Result { id: 3 });
    assert_eq!(done.executed_cycle, Some(12));
    assert!(!done.reply.as_deref().unwrap_or_default().contains("ERR"));
    assert_eq!(
        done.refusal,
        Some(mcc_contracts::control::CardRefusal::Pmac(3))
    );
    // A good line: none.
    assert!(t.handle(&arm(4, 14, "P1")).ok);
    assert!(t.handle(&AtRequest::Commit { id: 4 }).ok);
    t.tick(13, true);
    t.tick(14, true);
    let done = t.handle(&AtRequest::Result { id: 4 });
    assert_eq!(done.executed_cycle, Some(14));
    assert_eq!(done.refusal, None);
}
