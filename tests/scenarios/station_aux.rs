//! The Type 1 auxiliary exchange across a real in-process ring (lockstep [`RingSim`]): masters
//! stream requests on their node-15 packets ([`AuxMaster`]), real [`StationApp`]s answer, and
//! the replies come back in ring packets cycles later. Also the station ring check (MI8-MI10,
//! break localisation, CLRF) and station SAVE.

use mcc_contracts::config::{ClusterConfig, MemberRef};
use mcc_ring::aux_channel::{
    slave_error, AuxMaster, AuxWord, Outcome, Reply, Request, StationCmd, ValueFormat, AUX_NODE,
};
use mcc_ring::builder;
use mcc_ring::core::{CheckReport, RingApp, RingControl};
use mcc_ring::fault::{FaultKind, FaultSpec};
use mcc_ring::member::RingMember;
use mcc_ring::sim::RingSim;
use mcc_station::station_app::StationApp;
use mcc_tests::inproc::station_app;

/// A master that runs one auxiliary transaction at a time and records how each ended.
#[derive(Default)]
struct AuxCard {
    aux: AuxMaster,
    queue: Vec<(u8, Request, u32)>,
    started: Option<u64>,
    done: Vec<(Outcome, u64)>,
}

impl AuxCard {
    fn tick(&mut self, cycle: u64, regs: &mut RingMember) {
        let me = regs.settings().master_number();
        let back = regs
            .latched_copy(me, AUX_NODE)
            .map_or(AuxWord::IDLE, |r| AuxWord::decode(r.r2, r.r3));
        if !self.aux.busy() && !self.queue.is_empty() {
            let (node, req, timeout) = self.queue.remove(0);
            self.aux.start(node, req, timeout);
            self.started = Some(cycle);
        }
        let (out, (r2, r3)) = self.aux.tick(back);
        if let Some(o) = out {
            self.done.push((o, cycle - self.started.unwrap_or(cycle)));
        }
        let w = regs.write_regs_mut(AUX_NODE);
        (w.r2, w.r3) = (r2, r3);
    }
}

enum App {
    Card(AuxCard),
    Station(Box<StationApp>),
}

impl RingApp for App {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        match self {
            App::Card(c) => c.tick(cycle, regs),
            App::Station(s) => s.tick(cycle, time_ns, regs, ring_fault),
        }
    }
    fn take_ring_reset(&mut self) -> bool {
        match self {
            App::Station(s) => s.take_ring_reset(),
            App::Card(_) => false,
        }
    }
    fn on_check(&mut self, r: &CheckReport) {
        if let App::Station(s) = self {
            s.on_check(r);
        }
    }
    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        match self {
            App::Station(s) => s.sync_ring(ring),
            App::Card(_) => {}
        }
    }
}

/// A ring from the embedded default cluster: `cards` cards, `stations` stations.
fn ring(cards: usize, stations: usize, state_dir: Option<&std::path::Path>) -> RingSim<App> {
    let cfg = ClusterConfig::default_cluster(cards, stations);
    // holdover after 1.5 periods: a member cut off from the ring keeps checking
    builder::sim(&cfg, cfg.period_ns() * 3 / 2, |_, member| match member {
        MemberRef::Card(_) => App::Card(AuxCard::default()),
        MemberRef::Station(sc) => App::Station(Box::new(station_app(sc, state_dir))),
    })
    .unwrap()
}

fn card(sim: &mut RingSim<App>, i: usize) -> &mut AuxCard {
    match sim.app_mut(i) {
        App::Card(c) => c,
        App::Station(_) => panic!("member {i} is a station"),
    }
}

fn station(sim: &RingSim<App>, i: usize) -> &StationApp {
    match sim.app(i) {
        App::Station(s) => s,
        App::Card(_) => panic!("member {i} is a card"),
    }
}

/// Queue requests on card `i`, run until all are answered (at most `limit` cycles).
fn ask(
    sim: &mut RingSim<App>,
    i: usize,
    reqs: &[(u8, Request)],
    limit: u64,
) -> Vec<(Outcome, u64)> {
    let c = card(sim, i);
    c.done.clear();
    c.queue = reqs.iter().map(|&(n, r)| (n, r, 32)).collect();
    let mut waited = std::time::Duration::ZERO;
    let mut cycles = 0;
    while cycles < limit {
        // A station's `MS SAVE` is written off its tick (a thread, in wall time): the
        // simulated ring waits for it (a generous wall bound) instead of counting cycles.
        let saving =
            (0..sim.len()).any(|k| matches!(sim.app(k), App::Station(s) if s.mi().saving()));
        if saving {
            assert!(
                waited < std::time::Duration::from_secs(60),
                "the save never ended"
            );
            std::thread::sleep(std::time::Duration::from_millis(1));
            waited += std::time::Duration::from_millis(1);
        } else {
            cycles += 1;
        }
        sim.step();
        if card(sim, i).done.len() == reqs.len() {
            break;
        }
    }
    std::mem::take(&mut card(sim, i).done)
}

fn value(v: f64) -> Outcome {
    Outcome::Reply(Reply::Value(v, ValueFormat::Decimal))
}

#[test]
fn masters_read_and_write_station_mi_variables_over_node_15() {
    // card0 (sync master, master 0) → station0, card1 (master 1) → station1
    let mut sim = ring(2, 2, None);
    sim.run(20);
    let got = ask(
        &mut sim,
        0,
        &[
            (0, Request::ReadMi(8)),
            (1, Request::ReadMi(9)),
            (0, Request::ReadMi(0)),
            (4, Request::WriteMi(958, 2.5e-5)),
            (4, Request::ReadMi(958)),
            (0, Request::Command(StationCmd::Date)),
            (0, Request::ReadMi(996)),
        ],
        400,
    );
    let outcomes: Vec<_> = got.iter().map(|(o, _)| *o).collect();
    assert_eq!(
        outcomes,
        vec![
            value(8.0),
            value(4.0),
            Outcome::Reply(Reply::Value(1.104, ValueFormat::Version)),
            Outcome::Reply(Reply::Done),
            value(2.5e-5),
            Outcome::Reply(Reply::Value(19_990_812.0, ValueFormat::Date)),
            Outcome::Reply(Reply::Value(f64::from(0x0F_B333), ValueFormat::Hex)),
        ]
    );
    // Every exchange took ring cycles: a 2-word request and a 5-word reply need at least 5
    // cycles, and all finished well inside the 32-cycle timeout.
    for (o, cycles) in &got {
        assert!((5..32).contains(cycles), "{o:?} took {cycles} cycles");
    }
    assert_eq!(station(&sim, 1).mi().setup().nodes[&4].inertia, 2.5e-5);
    assert_eq!(station(&sim, 1).mi().setup().nodes[&5].inertia, 1.25e-5);
    // card1 talks to its own station over its own node-15 packet; the ring stays locked
    let got = ask(
        &mut sim,
        2,
        &[(5, Request::WriteMi(912, 10.0)), (5, Request::ReadMi(912))],
        200,
    );
    assert_eq!(got[0].0, Outcome::Reply(Reply::Done));
    assert_eq!(got[1].0, value(10.0));
    assert_eq!(station(&sim, 3).mi().setup().nodes[&5].capture_control, 10);
    assert_eq!(
        station(&sim, 1).mi().setup().nodes[&5].capture_control,
        2,
        "station0 untouched"
    );
    for i in 0..4 {
        assert!(!sim.member(i).ring_fault(), "member {i}");
    }
}

#[test]
fn slave_errors_timeouts_and_broadcasts() {
    // one card, two stations sharing its nodes: station0 0,1,4,5; station1 8,9,12,13
    let mut sim = ring(1, 2, None);
    sim.run(20);
    let before = station(&sim, 1).mi().setup().clone();
    let got = ask(
        &mut sim,
        0,
        &[
            (0, Request::WriteMi(958, -1.0)),
            (0, Request::WriteMi(0, 2.0)),
            (0, Request::ReadMi(7)),
            (0, Request::ReadParam(912)),
            (2, Request::ReadMi(8)), // no station serves node 2
            (15, Request::WriteMi(8, 12.0)),
            (15, Request::WriteMi(958, 3e-5)),
        ],
        600,
    );
    let outcomes: Vec<_> = got.iter().map(|(o, _)| *o).collect();
    assert_eq!(
        outcomes,
        vec![
            Outcome::Reply(Reply::Error(slave_error::OUT_OF_RANGE)),
            Outcome::Reply(Reply::Error(slave_error::READ_ONLY)),
            Outcome::Reply(Reply::Error(slave_error::UNKNOWN_VARIABLE)),
            value(2.0),
            Outcome::Timeout,
            Outcome::Reply(Reply::Done),
            Outcome::Reply(Reply::Done),
        ]
    );
    assert_eq!(got[4].1, 32, "the timeout is exactly 32 servo cycles");
    let after = station(&sim, 1).mi().setup();
    assert_eq!(after.nodes, {
        let mut n = before.nodes.clone();
        for c in n.values_mut() {
            c.inertia = 3e-5;
        }
        n
    });
    for s in [1, 2] {
        assert_eq!(
            station(&sim, s).mi().setup().globals.check_period,
            12,
            "station {s}"
        );
        assert!(station(&sim, s)
            .mi()
            .setup()
            .nodes
            .values()
            .all(|c| c.inertia == 3e-5));
    }
    // a cut link: the request never comes back
    sim.inject(1, FaultSpec::always(FaultKind::Cut)).unwrap();
    let got = ask(&mut sim, 0, &[(0, Request::ReadMi(8))], 100);
    assert_eq!(got[0].0, Outcome::Timeout);
}

#[test]
fn a_break_upstream_latches_the_station_fault_until_clrf_on_a_healthy_ring() {
    let mut sim = ring(1, 2, None);
    sim.run(30);
    assert!(!station(&sim, 2).mi().faulted());
    // cut the fibre leaving station0: station1 (directly downstream) sees no light
    sim.inject(1, FaultSpec::always(FaultKind::Cut)).unwrap();
    sim.run(30);
    let s1 = station(&sim, 2);
    assert!(s1.mi().faulted());
    assert!(
        s1.mi().suspected_break(),
        "byte violations: the break is upstream"
    );
    assert!(s1.ring_fault());
    // the FAULT flag of every node reads faulted (low-true: bit clear) while latched
    for n in s1.servo_nodes() {
        assert!(n.flags().amp_fault);
    }
    sim.clear_faults(1);
    sim.run(30);
    assert!(
        station(&sim, 2).mi().faulted(),
        "latched after the ring heals"
    );
    // CLRF from the card, through node 15
    let got = ask(
        &mut sim,
        0,
        &[(8, Request::Command(StationCmd::ClearFault))],
        200,
    );
    assert_eq!(got[0].0, Outcome::Reply(Reply::Done));
    sim.run(2);
    let s1 = station(&sim, 2);
    assert!(!s1.mi().faulted());
    assert!(!s1.mi().suspected_break());
    assert!(!sim.member(2).ring_fault());
    assert!(s1.mi().live().errors > 0, "MI5 counted the errors");
}

#[test]
fn station_save_survives_a_restart_and_a_corrupt_file_is_reported() {
    let dir = std::env::temp_dir().join(format!("mcc-station-save-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut sim = ring(1, 1, Some(&dir));
    sim.run(20);
    let got = ask(
        &mut sim,
        0,
        &[
            (0, Request::ConfigWrite(37.0)),
            (1, Request::WriteMi(966, 50_000.0)),
            (0, Request::Command(StationCmd::Save)),
            (0, Request::WriteMi(2, 99.0)),
            (0, Request::Command(StationCmd::Reset)), // back to the saved setup
            (0, Request::Command(StationCmd::ConfigRead)),
        ],
        400,
    );
    assert_eq!(got[5].0, value(37.0));
    // a new station process on the same state file starts from the saved setup
    let mut sim = ring(1, 1, Some(&dir));
    sim.run(20);
    let got = ask(
        &mut sim,
        0,
        &[
            (0, Request::Command(StationCmd::ConfigRead)),
            (1, Request::ReadMi(966)),
        ],
        200,
    );
    assert_eq!(got[0].0, value(37.0));
    assert_eq!(got[1].0, value(50_000.0));
    assert!(station(&sim, 1).mi().config_error().is_none());
    // $$$*** goes back to the config values (without touching the file)
    let got = ask(
        &mut sim,
        0,
        &[
            (0, Request::Command(StationCmd::Reinit)),
            (0, Request::ReadMi(2)),
        ],
        200,
    );
    assert_eq!(got[1].0, value(0.0));
    // a corrupt file: config values, MI4 bit 2, and the reason
    let path = dir.join("station0.state");
    let mut bytes = std::fs::read(&path).unwrap();
    let k = bytes.len() - 5;
    bytes[k] ^= 0x20;
    std::fs::write(&path, bytes).unwrap();
    let mut sim = ring(1, 1, Some(&dir));
    sim.run(5);
    let st = station(&sim, 1);
    assert!(st.mi().config_error().unwrap().contains("checksum"));
    let got = ask(
        &mut sim,
        0,
        &[(0, Request::ReadMi(4)), (0, Request::ReadMi(2))],
        200,
    );
    assert_eq!(
        got[0].0,
        Outcome::Reply(Reply::Value(4.0, ValueFormat::Hex))
    );
    assert_eq!(got[1].0, value(0.0));
    std::fs::remove_dir_all(&dir).unwrap();
}
