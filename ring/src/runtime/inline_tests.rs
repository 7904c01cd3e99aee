//! Inline receive: rings over zenoh with followers forwarding on the receive thread keep the
//! lockstep contract cycle for cycle; the receive thread hands a frame over whenever it must.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::*;
use crate::control::{FaultRequest, MemberKind};
use crate::core::{CoreConfig, MemberCore};
use crate::runtime::driver::{DriverCmd, DriverConfig};
use crate::runtime::local::{LocalRing, LocalTransport};
use crate::runtime::tests::{ring, App};
use crate::settings::RingSettings;
use crate::transport::queue::frame_queue;
use crate::transport::{InlineSlot, LinkRx, LinkTx};

fn zenoh_ring(receive_thread_ticks: bool) {
    let cluster = format!("inline-test-{}-{receive_thread_ticks}", std::process::id());
    let mut members = ring(400);
    for m in &mut members[1..] {
        m.2.max_cycles = None;
    }
    let r = LocalRing::start(
        members,
        LocalTransport::ZenohInline {
            cluster,
            receive_thread_ticks,
        },
    )
    .unwrap();
    // The sync master stops at its cycle limit; the followers run on until stopped.
    let deadline = Instant::now() + Duration::from_secs(60);
    while !r.is_finished(0) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    let follower = r.status(1).expect("follower status");
    let hop = follower.extra.get("hop").cloned().expect("hop statistics");
    let out = r.stop();
    let App::M(m) = &out[0].app else { panic!() };
    assert_eq!(m.seen.len(), 400);
    // The loopback ring's relation (command of tick c, answer in frame c+2, latched at c+3)
    // holds for every cycle once the links are up: forwarding on another thread changes
    // nothing a member sees.
    for &(c, fb) in m.seen.iter().rev().take(100) {
        assert_eq!(u64::from(fb), c - 2, "cycle {c}");
    }
    for r in &out {
        let e = r.core.status().errors;
        assert_eq!(
            e.overrun + e.underrun + e.bad_frames,
            0,
            "{}: {e:?}",
            r.core.name()
        );
    }
    // Frames were forwarded on the receive thread.
    let inline = hop["inline"].as_u64().unwrap();
    assert!(inline > 100, "{hop}");
    assert!(hop["count"].as_u64().unwrap() >= inline, "{hop}");
}

#[test]
fn lockstep_over_zenoh_with_member_thread_ticks_keeps_the_cycle_relation() {
    zenoh_ring(false);
}

#[test]
fn lockstep_over_zenoh_with_receive_thread_ticks_keeps_the_cycle_relation() {
    zenoh_ring(true);
}

/// Captures what a member sends.
#[derive(Default, Clone)]
struct Capture(Arc<Mutex<Vec<Vec<u8>>>>);

impl LinkTx for Capture {
    fn send(&self, frame: Vec<u8>) -> Result<(), crate::transport::TransportError> {
        self.0.lock().unwrap().push(frame);
        Ok(())
    }
}

fn dcfg(name: &str, position: usize) -> DriverConfig {
    DriverConfig {
        max_cycles: None,
        ..ring(1).into_iter().nth(position).unwrap().2
    }
    .renamed(name)
}

trait Renamed {
    fn renamed(self, name: &str) -> Self;
}

impl Renamed for DriverConfig {
    fn renamed(mut self, name: &str) -> Self {
        self.name = name.into();
        self
    }
}

/// Frames of cycles 1.. from a sync master at position 0.
fn master_frames(n: u64) -> Vec<Vec<u8>> {
    let period = 1_000_000_000 / 2258;
    let mut m = MemberCore::new(CoreConfig::new(
        "card0",
        MemberKind::Card,
        0,
        RingSettings::new(0x30, 0x0F_0001),
        period,
    ));
    (1..=n)
        .map(|c| m.start_cycle(c, c * period).remove(0).frame_bytes)
        .collect()
}

#[test]
fn the_receive_thread_hands_over_when_busy_behind_or_with_a_tick_pending() {
    let period = 1_000_000_000 / 2258;
    let core = MemberCore::new(CoreConfig::new(
        "station0",
        MemberKind::Station,
        1,
        RingSettings::new(0x8080, 0x0F_8001),
        period * 100,
    ));
    let (qtx, qrx) = frame_queue(16);
    let slot: InlineSlot = Arc::new(std::sync::OnceLock::new());
    let rx = LinkRx::new(qrx, Some(Arc::clone(&slot)));
    let sent = Capture::default();
    let (_ctx, crx) = crossbeam_channel::unbounded();
    let driver = Driver::new(
        dcfg("station0", 1),
        core,
        Parked,
        Box::new(sent.clone()),
        rx,
        crx,
        Arc::new(std::sync::atomic::AtomicBool::new(false)),
    );
    let shared: Shared<Parked> = Arc::new(Mutex::new(None));
    let handler = Handler {
        shared: Arc::clone(&shared),
        defer: true,
        waker: driver.rx.waker(),
        failed: Mutex::new(None),
    };
    *lock(&shared) = Some(Member {
        d: driver,
        st: None,
    });
    let f = master_frames(4);

    // Idle member: handled at once — forwarded, its tick left for the member's thread.
    assert!(handler.offer(&f[0], 1));
    assert_eq!(sent.0.lock().unwrap().len(), 1);
    assert!(lock(&shared).as_ref().unwrap().d.has_pending_tick());
    assert!(
        handler.waker.wait(Duration::ZERO),
        "the member's thread is woken"
    );
    // A tick pending: the next frame waits its turn.
    assert!(!handler.offer(&f[1], 2), "declined");
    qtx.push(f[1].clone(), 2);
    {
        let mut g = lock(&shared);
        g.as_mut().unwrap().d.take_pending_tick(Some(&mut Parked));
    }
    // A frame queued before this one: order is kept.
    assert!(!handler.offer(&f[2], 3), "declined");
    // The member's thread holds the lock: handed over, never waited for.
    {
        let _g = lock(&shared);
        assert!(!handler.offer(&f[3], 4), "declined");
    }
    assert_eq!(
        sent.0.lock().unwrap().len(),
        1,
        "nothing forwarded out of turn"
    );
    // Driver gone (the loop ended): everything is queued.
    lock(&shared).take();
    assert!(!handler.offer(&f[3], 4));
}

/// An application that counts its ticks and how often its status map is built, and keeps
/// the application faults it was given.
#[derive(Default)]
struct Counted {
    ticks: u64,
    built: std::cell::Cell<u64>,
    faults: Vec<serde_json::Value>,
}

impl crate::core::RingApp for Counted {
    fn tick(&mut self, _c: u64, _t: u64, _regs: &mut crate::member::RingMember, _f: bool) {
        self.ticks += 1;
    }

    fn status_extra(&self) -> serde_json::Map<String, serde_json::Value> {
        self.built.set(self.built.get() + 1);
        let mut m = serde_json::Map::new();
        m.insert("ticks".into(), self.ticks.into());
        m.insert("faults".into(), self.faults.len().into());
        m
    }

    fn app_fault(&mut self, fault: &serde_json::Value) -> Result<String, String> {
        if fault.get("bad").is_some() {
            return Err("bad fault".into());
        }
        self.faults.push(fault.clone());
        Ok(format!("fault {} applied", self.faults.len()))
    }

    fn clear_app_faults(&mut self) {
        self.faults.clear();
    }
}

#[test]
fn a_status_request_waits_for_the_member_thread_and_gets_the_app_fields_of_that_moment() {
    // The application lives on the member's thread (inline receive, `run`); the driver holds
    // a stand-in. Wake-ups without a request never build the application's status map; a
    // request taken by the driver is answered by the member's thread with the fields the
    // application has then.
    let period = 1_000_000_000 / 2258;
    let core = MemberCore::new(CoreConfig::new(
        "station0",
        MemberKind::Station,
        1,
        RingSettings::new(0x8080, 0x0F_8001),
        period * 100,
    ));
    let (_qtx, qrx) = frame_queue(16);
    let (ctx, crx) = crossbeam_channel::unbounded();
    let mut d = Driver::new(
        dcfg("station0", 1),
        core,
        Parked,
        Box::new(Capture::default()),
        LinkRx::new(qrx, None),
        crx,
        Arc::new(std::sync::atomic::AtomicBool::new(false)),
    );
    d.app_elsewhere = true;
    let mut app = Counted::default();
    for _ in 0..100 {
        app.ticks += 1;
        answer_app(&mut d, &mut Some(&mut app as &mut dyn crate::core::RingApp));
    }
    assert_eq!(app.built.get(), 0, "a status map built with no request");
    // A request: taken by the driver's control pass, not answered there.
    let (tx, rx) = crossbeam_channel::bounded(1);
    ctx.send(DriverCmd::Status(tx)).unwrap();
    assert!(!d.service());
    assert!(d.app_wanted());
    assert!(rx.try_recv().is_err(), "answered without the application");
    // The application moves on, then the member's thread answers: the fields of now.
    app.ticks = 4242;
    answer_app(&mut d, &mut Some(&mut app as &mut dyn crate::core::RingApp));
    let s = rx.try_recv().expect("answered by the member's thread");
    assert_eq!(s.extra["ticks"], 4242);
    assert_eq!(s.name, "station0");
    assert_eq!(app.built.get(), 1);
    assert!(!d.app_wanted());
    answer_app(&mut d, &mut Some(&mut app as &mut dyn crate::core::RingApp));
    assert_eq!(app.built.get(), 1);
    // With the application in the driver (`run_send`, or no inline receive) the control pass
    // answers at once.
    d.app_elsewhere = false;
    let (tx, rx) = crossbeam_channel::bounded(1);
    ctx.send(DriverCmd::Status(tx)).unwrap();
    assert!(!d.service());
    let s = rx.try_recv().expect("answered in the control pass");
    assert!(s.extra.get("ticks").is_none(), "{s:?}");
}

#[test]
fn application_faults_reach_the_application_in_order_with_status_and_clear() {
    // `mcc fault MEMBER <app kind>`: the request goes to the application on the thread that
    // holds it, after what was asked before it; a refusal comes back as `ok: false`; `clear`
    // clears the application's faults too, before a status asked after it is answered.
    let period = 1_000_000_000 / 2258;
    let core = MemberCore::new(CoreConfig::new(
        "station0",
        MemberKind::Station,
        1,
        RingSettings::new(0x8080, 0x0F_8001),
        period * 100,
    ));
    let (_qtx, qrx) = frame_queue(16);
    let (ctx, crx) = crossbeam_channel::unbounded();
    let mut d = Driver::new(
        dcfg("station0", 1),
        core,
        Parked,
        Box::new(Capture::default()),
        LinkRx::new(qrx, None),
        crx,
        Arc::new(std::sync::atomic::AtomicBool::new(false)),
    );
    d.app_elsewhere = true;
    let mut app = Counted::default();
    let fault = |v: serde_json::Value| {
        let (tx, rx) = crossbeam_channel::bounded(1);
        ctx.send(DriverCmd::Fault(FaultRequest::App { fault: v }, tx))
            .unwrap();
        rx
    };
    let r1 = fault(serde_json::json!({"kind": "jam"}));
    let r2 = fault(serde_json::json!({"bad": 1}));
    let (stx, srx) = crossbeam_channel::bounded(1);
    ctx.send(DriverCmd::Status(stx)).unwrap();
    let (ctx2, crx2) = crossbeam_channel::bounded(1);
    ctx.send(DriverCmd::Fault(FaultRequest::Clear, ctx2))
        .unwrap();
    let (stx2, srx2) = crossbeam_channel::bounded(1);
    ctx.send(DriverCmd::Status(stx2)).unwrap();
    assert!(!d.service());
    assert!(r1.try_recv().is_err(), "answered without the application");
    assert!(
        crx2.try_recv().unwrap().ok,
        "the ring part of clear answers at once"
    );
    answer_app(&mut d, &mut Some(&mut app as &mut dyn crate::core::RingApp));
    let a1 = r1.try_recv().unwrap();
    assert_eq!((a1.ok, a1.message.as_str()), (true, "fault 1 applied"));
    let a2 = r2.try_recv().unwrap();
    assert_eq!((a2.ok, a2.message.as_str()), (false, "bad fault"));
    assert_eq!(srx.try_recv().unwrap().extra["faults"], 1);
    assert_eq!(
        srx2.try_recv().unwrap().extra["faults"],
        0,
        "clear ran before"
    );
    // With the application in the driver the control pass answers at once.
    d.app_elsewhere = false;
    let r3 = fault(serde_json::json!({"kind": "jam"}));
    assert!(!d.service());
    let a3 = r3.try_recv().unwrap();
    assert!(!a3.ok, "the stand-in takes no application faults: {a3:?}");
}
