//! The stepped sync master against a hand-driven rest of the ring.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::driver::{Driver, DriverConfig, DriverExit};
use crate::config::ClockMode;
use crate::control::MemberKind;
use crate::core::{CoreConfig, MemberCore, RingApp};
use crate::frame::Frame;
use crate::member::RingMember;
use crate::settings::RingSettings;
use crate::transport::loopback::LoopbackRing;
use crate::transport::LinkTx;

#[derive(Debug, Default)]
struct Cycles(Vec<u64>);

impl RingApp for Cycles {
    fn tick(&mut self, cycle: u64, _t: u64, _regs: &mut RingMember, _fault: bool) {
        self.0.push(cycle);
    }
}

#[test]
fn a_frame_numbered_beyond_the_cycle_in_flight_does_not_let_the_sync_master_run_ahead() {
    // A member that ran on its own clock (it judged its upstream frozen) numbers its dark
    // frames far ahead of the sync master. Main's loaded run: the master took such a number as
    // the return of cycles it had not started and started cycles without waiting, flooding
    // the ring. The number is only the return of the cycle in flight.
    let cycles = 120;
    let ring = LoopbackRing::new(2);
    let (tx0, rx0) = ring.member(0).unwrap();
    let (tx1, rx1) = ring.member(1).unwrap();
    let period = (1e9 / 2258.7) as u64;
    let mut cc = CoreConfig::new(
        "card0",
        MemberKind::Card,
        0,
        RingSettings::new(0x30, 0x0F_0001),
        period,
    );
    cc.upstream = Some(1);
    let d = DriverConfig {
        name: "card0".into(),
        clock: ClockMode::Lockstep,
        rate_hz: 2258.7,
        rtf: 1.0,
        member_timeout: Duration::from_secs(30),
        upstream_dead: None,
        upstream_probe: None,
        in_flight: 1,
        harden: false,
        max_cycles: Some(cycles),
        kind: MemberKind::Card,
        position: 0,
        extra: serde_json::Map::new(),
        record: 0,
        phase_delay_ns: 0,
    };
    let (_cmd_tx, cmd_rx) = crossbeam_channel::unbounded();
    let stop = Arc::new(AtomicBool::new(false));
    let master = std::thread::spawn(move || {
        let mut drv = Driver::new(
            d,
            MemberCore::new(cc),
            Cycles::default(),
            Box::new(tx0),
            rx0,
            cmd_rx,
            stop,
        );
        let exit = drv.run();
        (exit, drv.into_parts().1)
    });
    // The rest of the ring: every frame comes back dark; cycle 50's numbered 5000 ahead.
    let t0 = Instant::now();
    let mut seq = 0;
    let mut after_future = 0;
    while !master.is_finished() {
        assert!(t0.elapsed() < Duration::from_secs(60), "ring stuck");
        let Ok(Some(bytes)) = rx1.recv_timeout(Duration::from_millis(20)) else {
            continue;
        };
        let f = Frame::decode(&bytes).unwrap();
        if f.cycle > 50 && after_future < 5 {
            // Give a master that would run ahead every chance to: nothing may come before
            // this cycle has gone back.
            after_future += 1;
            std::thread::sleep(Duration::from_millis(100));
            assert_eq!(rx1.pending(), 0, "cycle {} not back yet", f.cycle);
        }
        let c = if f.cycle == 50 { 5050 } else { f.cycle };
        seq += 1;
        tx1.send(&Frame::dark(1, seq, 0, c, 0).encode()).unwrap();
    }
    let (exit, app) = master.join().unwrap();
    assert!(matches!(exit, DriverExit::Done), "{exit:?}");
    assert_eq!(after_future, 5);
    // The master's count is its own: consecutive, never from the far-ahead frame.
    assert_eq!(app.0, (0..cycles).collect::<Vec<_>>());
}
