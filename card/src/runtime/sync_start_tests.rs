use super::*;
use crate::domain::Profile;

fn arm(id: u64, cycle: u64, line: &str) -> AtRequest {
    AtRequest::Arm {
        id,
        cycle,
        line: line.into(),
    }
}

/// A card with PROG 1 (a dwell), motor 1 in C.S. 1 with its loop closed: `&1B1R` starts it.
fn ready_card() -> Mutex<Card> {
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
    Mutex::new(c)
}

fn tick(sync: &SyncStart, card: &Mutex<Card>, cycle: u64, drain: bool) {
    let mut c = card.lock().unwrap();
    sync.tick_start(&mut c, cycle);
    if drain {
        let _ = c.take_actions();
    }
    sync.tick_end(&c);
}

#[test]
fn armed_and_committed_line_runs_in_the_tick_of_its_cycle() {
    let card = ready_card();
    let sync = SyncStart::new(Duration::from_millis(50));
    tick(&sync, &card, 10, true);
    let r = sync.handle(&card, &arm(7, 13, "&1B1R"));
    assert!(r.ok, "{r:?}");
    assert_eq!(r.cycle, Some(10));
    assert!(sync.handle(&card, &AtRequest::Commit { id: 7 }).ok);
    tick(&sync, &card, 11, true);
    tick(&sync, &card, 12, true);
    let pending = sync.handle(&card, &AtRequest::Result { id: 7 });
    assert_eq!(pending.executed_cycle, None);
    assert_eq!(pending.message, "pending for cycle 13");
    tick(&sync, &card, 13, true);
    let done = sync.handle(&card, &AtRequest::Result { id: 7 });
    assert_eq!(done.executed_cycle, Some(13));
    let want = ready_card()
        .lock()
        .unwrap()
        .command_line(&mut Session::default(), b"&1B1R");
    assert!(!want.contains(&0x07));
    assert_eq!(done.reply.as_deref().map(str::as_bytes), Some(&want[..]));
    assert_eq!(sync.program_start().0, Some(13));
    let info = sync.handle(&card, &AtRequest::Info);
    assert_eq!((info.program_start_cycle, info.cycle), (Some(13), Some(13)));
    assert_eq!(info.stalls, 0);
}

#[test]
fn an_arm_for_a_cycle_that_has_started_is_refused_as_late() {
    let card = ready_card();
    let sync = SyncStart::new(Duration::from_millis(50));
    let r = sync.handle(&card, &arm(1, 5, "&1B1R"));
    assert!(!r.ok && r.late, "no tick yet: {r:?}");
    tick(&sync, &card, 5, true);
    let r = sync.handle(&card, &arm(1, 5, "&1B1R"));
    assert!(!r.ok && r.late, "{r:?}");
    assert_eq!(r.message, "too late: cycle 5 has started (now 5)");
    let r = sync.handle(&card, &arm(1, 6, "&1B1R"));
    assert!(r.ok && !r.late);
}

#[test]
fn aborted_or_uncommitted_lines_never_run() {
    let card = ready_card();
    let sync = SyncStart::new(Duration::from_millis(5));
    tick(&sync, &card, 1, true);
    assert!(sync.handle(&card, &arm(1, 3, "&1B1R")).ok);
    assert!(sync.handle(&card, &AtRequest::Abort { id: 1 }).ok);
    tick(&sync, &card, 3, true);
    assert_eq!(sync.program_start().0, None);
    // Never committed: the tick waits its stall limit, then abandons the line.
    assert!(sync.handle(&card, &arm(2, 4, "&1B1R")).ok);
    tick(&sync, &card, 4, true);
    let r = sync.handle(&card, &AtRequest::Result { id: 2 });
    assert!(r.abandoned && !r.ok, "{r:?}");
    assert_eq!(sync.program_start().0, None);
    assert!(!sync.handle(&card, &AtRequest::Commit { id: 2 }).ok);
    // Committed lines cannot be aborted.
    assert!(sync.handle(&card, &arm(3, 9, "&1B1R")).ok);
    assert!(sync.handle(&card, &AtRequest::Commit { id: 3 }).ok);
    assert!(!sync.handle(&card, &AtRequest::Abort { id: 3 }).ok);
}

#[test]
fn a_late_commit_stalls_the_tick_and_still_runs_at_its_cycle() {
    let card = Arc::new(ready_card());
    let sync = SyncStart::new(Duration::from_secs(5));
    tick(&sync, &card, 1, true);
    assert!(sync.handle(&card, &arm(9, 2, "&1B1R")).ok);
    let (s2, c2) = (sync.clone(), Arc::clone(&card));
    let late = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(30));
        s2.handle(&c2, &AtRequest::Commit { id: 9 })
    });
    tick(&sync, &card, 2, true);
    assert!(late.join().unwrap().ok);
    let r = sync.handle(&card, &AtRequest::Result { id: 9 });
    assert_eq!(r.executed_cycle, Some(2));
    assert_eq!(r.stalls, 1);
    assert_eq!(sync.program_start().0, Some(2));
}

#[test]
fn unscheduled_program_starts_are_recorded_at_the_tick_that_takes_them() {
    let card = ready_card();
    let sync = SyncStart::new(Duration::from_millis(5));
    tick(&sync, &card, 1, true);
    let r = card
        .lock()
        .unwrap()
        .command_line(&mut Session::default(), b"&1B1R");
    assert!(!r.contains(&0x07), "{r:?}");
    tick(&sync, &card, 2, true);
    assert_eq!(sync.program_start().0, Some(2));
    tick(&sync, &card, 3, true);
    assert_eq!(sync.program_start().0, Some(2));
    // Without a consumer the actions stay queued: an old R is not a new start.
    let _ = card
        .lock()
        .unwrap()
        .command_line(&mut Session::default(), b"&1R");
    tick(&sync, &card, 4, false);
    tick(&sync, &card, 5, false);
    assert_eq!(sync.program_start().0, Some(4));
    // A refused R (ERR015: no program) records nothing.
    let r = card
        .lock()
        .unwrap()
        .command_line(&mut Session::default(), b"&1B7R");
    assert!(r.contains(&0x07));
    tick(&sync, &card, 6, false);
    assert_eq!(sync.program_start().0, Some(4));
}

#[test]
fn bad_requests_are_refused_with_a_message() {
    let card = ready_card();
    let sync = SyncStart::new(Duration::from_millis(5));
    tick(&sync, &card, 1, true);
    let r = answer_payload(&sync, &card, b"{\"op\":\"launch\"}");
    assert!(!r.ok && r.message.starts_with("bad request"), "{r:?}");
    let r = answer_payload(&sync, &card, &[b' '; MAX_REQUEST + 1]);
    assert!(!r.ok && r.message.contains("longer"));
    assert!(!sync.handle(&card, &arm(1, 5, "&1B1R\r")).ok);
    assert!(!sync.handle(&card, &arm(1, 5, &"P".repeat(MAX_LINE + 1))).ok);
    assert!(!sync.handle(&card, &arm(1, 1 + MAX_LEAD_CYCLES + 1, "R")).ok);
    for id in 0..MAX_PENDING as u64 {
        assert!(sync.handle(&card, &arm(100 + id, 50, "P1=1")).ok);
    }
    assert!(!sync.handle(&card, &arm(999, 50, "P1=1")).ok);
    assert!(!sync.handle(&card, &AtRequest::Commit { id: 4242 }).ok);
    let r = answer_payload(
        &sync,
        &card,
        br#"{"op":"arm","id":100,"cycle":50,"line":"P1=2"}"#,
    );
    assert!(!r.ok && r.message.contains("differently"), "{r:?}");
}

#[test]
fn info_reports_ring_fault_and_killed_motors() {
    let card = ready_card();
    let sync = SyncStart::new(Duration::from_millis(5));
    let r = sync.handle(&card, &AtRequest::Info);
    assert!(!r.ring_fault && !r.motors_killed);
    assert!(r.killed_motors.is_empty(), "{r:?}");
    {
        let mut c = card.lock().unwrap();
        c.state.global.ring_fault = true;
        let _ = c.command_line(&mut Session::default(), b"#1K");
    }
    let r = sync.handle(&card, &AtRequest::Info);
    assert!(r.ring_fault && r.motors_killed, "{r:?}");
    assert_eq!(r.killed_motors, vec![1]);
}
