//! A card motor driving an EMCL drive bound to a station's servo node (issue 12 item 5), on
//! the deterministic in-process lockstep ring: card 0 outputs motor 2's command as a pulse
//! frequency into node 1 register 2 (I202 = $C0A6), the drive integrates the pulses in ring
//! time and reports its shaft position in register 0 and its flags in register 3; the card
//! closes its loop on that feedback and moves the drive to the target. Meanwhile the drive
//! refuses direct-mode motion (status 6) and answers parameter reads on its bus.

use std::sync::{Arc, Mutex};

use mcc_card::{Card, CardRingApp, Profile, Session};
use mcc_contracts::config::{ClusterConfig, DriveConfig};
use mcc_ring::core::{RingApp, RingControl};
use mcc_ring::member::RingMember;
use mcc_ring::sim::RingSim;
use mcc_station::config::PlantConfig;
use mcc_station::emcl::codec::{Instr, Reply, Request};
use mcc_station::emcl::{Drive, DriveHost, HostedDrive};
use mcc_station::emcl_rt::app::DriveStationApp;
use mcc_station::emcl_rt::service::{HostState, Shared};
use mcc_station::emcl_rt::spec_from_config;
use mcc_station::station_app::StationApp;

enum App {
    Card(Box<CardRingApp>),
    Station(Box<DriveStationApp<StationApp>>),
}

impl RingApp for App {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        match self {
            App::Card(a) => a.tick(cycle, time_ns, regs, ring_fault),
            App::Station(a) => a.tick(cycle, time_ns, regs, ring_fault),
        }
    }
    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        if let App::Card(a) = self {
            a.sync_ring(ring);
        }
    }
}

struct Bench {
    sim: RingSim<App>,
    drives: Shared,
    session: Session,
}

impl Bench {
    /// Card 0 + station 0; drive0 (address 1) bound to node 1 of station 0.
    fn new() -> Bench {
        let mut cfg = ClusterConfig::default_cluster(1, 1);
        cfg.drives[0].node = Some(1);
        let cfg = cfg.resolve().unwrap();
        let dc: &DriveConfig = &cfg.drives[0];
        let drive = Drive::power_up(spec_from_config(dc).unwrap(), None, dc.node);
        let drives: Shared = Arc::new(Mutex::new(HostState {
            host: DriveHost::new(vec![HostedDrive {
                name: "drive0".into(),
                drive,
            }]),
            files: Vec::new(),
            errors: Vec::new(),
            member: "station0".into(),
        }));
        let bound = mcc_station::emcl_rt::app::bound_nodes(&cfg, "station0");
        assert_eq!(bound, [1]);
        let sim = mcc_tests::inproc::ring(
            &cfg,
            Card::new(Profile::Pmac2),
            |sc| {
                let nodes: Vec<u8> = sc
                    .nodes
                    .iter()
                    .copied()
                    .filter(|n| !bound.contains(n))
                    .collect();
                let st = StationApp::new(&nodes, &[], &PlantConfig::default()).unwrap();
                App::Station(Box::new(DriveStationApp::new(
                    st,
                    Arc::clone(&drives),
                    None,
                )))
            },
            |c| App::Card(Box::new(c)),
        );
        Bench {
            sim,
            drives,
            session: Session::default(),
        }
    }

    fn cmd(&mut self, line: &str) -> String {
        let mut s = self.session.clone();
        let card = match self.sim.app_mut(0) {
            App::Card(a) => &mut a.core().card,
            App::Station(_) => panic!("member 0 is the card"),
        };
        let r = mcc_tests::inproc::command(card, &mut s, line);
        self.session = s;
        r
    }

    fn run(&mut self, cycles: usize) {
        for _ in 0..cycles {
            self.sim.step();
        }
    }

    /// A frame on the drive's bus (as the station's queryable handles it).
    fn bus(&mut self, op: u8, typ: u8, value: i32) -> Reply {
        let frame = Request {
            addr: 1,
            instr: Instr::new(op, typ, 0, value),
        }
        .to_bytes();
        let mut st = self.drives.lock().unwrap();
        let a = st.host.frame(&frame);
        Reply::parse(&a[0].1.bytes.unwrap()).unwrap()
    }

    fn shaft(&mut self) -> i32 {
        self.bus(6, 209, 0).value
    }
}

#[test]
fn a_card_motor_moves_a_bound_drive_to_its_target() {
    let mut b = Bench::new();
    // Motor 2 outputs its command to node 1 register 2: a pulse-frequency output. A pulse
    // (velocity) plant wants a stiffer P term, no derivative and velocity feedforward
    // (measured: the default torque-plant gains leave ~450 counts of lag at speed).
    b.cmd("I202=$C0A6");
    b.cmd("I230=20000 I231=0 I232=2800");
    b.run(200);
    assert_eq!(b.cmd("#2$"), "");
    b.run(200);
    let start = b.shaft();
    assert_eq!(start, 0);
    b.cmd("#2J=20000");
    let mut max_fe = 0.0f64;
    for _ in 0..(4 * 2259) {
        b.run(1);
        let fe: f64 = b.cmd("#2F").parse().unwrap();
        max_fe = max_fe.max(fe.abs());
    }
    let p: f64 = b.cmd("#2P").parse().unwrap();
    let shaft = b.shaft();
    assert!((p - 20000.0).abs() <= 2.0, "card position {p}");
    assert!((i64::from(shaft) - 20000).abs() <= 2, "drive shaft {shaft}");
    // The drive's own counter followed the pulses; its status says bound.
    let st = b.drives.lock().unwrap().host.status(0, "station0").unwrap();
    assert_eq!((st.mode.as_str(), st.motion.as_str()), ("bound", "bound"));
    assert!((st.position - 20000).abs() <= 2, "{st:?}");
    assert!(max_fe < 50.0, "following error {max_fe}");
    // Direct motion refused while bound; reads and settings answer.
    assert_eq!(b.bus(1, 0, 1000).status, 6);
    assert_eq!(b.bus(4, 0, 0).status, 6);
    assert_eq!(b.bus(6, 254, 0).value, 1);
    assert_eq!(b.bus(5, 6, 100).status, 100);
    // Back and forth, and the motor holds.
    b.cmd("#2J=-5000");
    b.run(5 * 2259);
    let shaft = b.shaft();
    assert!((i64::from(shaft) + 5000).abs() <= 2, "drive shaft {shaft}");
    // Kill: the enable drops, the drive stops following.
    b.cmd("#2K");
    b.run(100);
    let s0 = b.shaft();
    b.run(1000);
    assert_eq!(b.shaft(), s0);
    let st = b.drives.lock().unwrap().host.status(0, "station0").unwrap();
    assert_eq!(st.velocity, 0);
}
