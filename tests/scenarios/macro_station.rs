//! MACRO station commands from the card (issue 11): the default cluster's card 0 (sync
//! master) and its stations on a deterministic in-process ring, wired as the processes are.
//! Host lines go in through the card's handle as a port's do (served at the card's ticks);
//! every `MS`/`MX` command travels the ring's node-15 channel to a real station and back.
//! Replies are compared byte for byte; waits are counted in ring cycles.

use std::sync::mpsc;

use mcc_card::{Card, CardHandle, CardRingApp, HostRequest, Profile, Request, Response};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::core::{CheckReport, RingApp, RingControl};
use mcc_ring::fault::{FaultKind, FaultSpec};
use mcc_ring::member::RingMember;
use mcc_ring::sim::RingSim;
use mcc_station::station_app::StationApp;

enum App {
    Card(Box<CardRingApp>),
    Station(Box<StationApp>),
}

impl RingApp for App {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        match self {
            App::Card(a) => a.tick(cycle, time_ns, regs, ring_fault),
            App::Station(a) => a.tick(cycle, time_ns, regs, ring_fault),
        }
    }
    fn take_ring_reset(&mut self) -> bool {
        match self {
            App::Card(a) => a.take_ring_reset(),
            App::Station(a) => a.take_ring_reset(),
        }
    }
    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        match self {
            App::Card(a) => a.sync_ring(ring),
            App::Station(a) => a.sync_ring(ring),
        }
    }
    fn on_check(&mut self, r: &CheckReport) {
        if let App::Station(s) = self {
            s.on_check(r);
        }
    }
}

/// Ring cycles a host line may take at most before the test fails (a range of 21 reads takes
/// a few hundred).
const LINE_LIMIT: u64 = 5_000;

struct Rig {
    sim: RingSim<App>,
    card: CardHandle,
    conn: u64,
}

impl Rig {
    /// Card 0 with `stations` stations of the default cluster (1: nodes 0,1,4,5,8,9,12,13;
    /// 2: station0 0,1,4,5 and station1 8,9,12,13), state files under `dir`.
    fn new(stations: usize, dir: Option<&std::path::Path>) -> Rig {
        Rig::with_profile(Profile::Pmac2, stations, dir)
    }

    /// [`Rig::new`] with a card of `profile`.
    fn with_profile(profile: Profile, stations: usize, dir: Option<&std::path::Path>) -> Rig {
        let mut cfg = ClusterConfig::default_cluster(1, stations);
        if profile != Profile::Pmac2 {
            // the PMAC2 ring-check numbers of the default are other variables on a Turbo card
            for c in &mut cfg.cards {
                c.ivars.clear();
            }
        }
        let (mut sim, card) = mcc_tests::inproc::ring_with_handle(
            &cfg,
            Card::new(profile),
            |sc| App::Station(Box::new(mcc_tests::inproc::station_app(sc, dir))),
            |c| App::Card(Box::new(c)),
        );
        sim.run(20);
        let conn = card.new_conn();
        let mut rig = Rig { sim, card, conn };
        // the framing host tools ask for: ACK after data, <BEL>ERRnnn<CR> errors
        assert_eq!(rig.send("I3=2 I6=1"), "\x06");
        rig
    }

    /// Send `line` on connection `conn` and run the ring until the card answers: the raw
    /// reply and the ring cycles it took.
    /// The reply to `line` on connection `conn` and the ring cycles it took. The request is
    /// queued with the card before the first step and its reply read in the step that served
    /// it (no thread in between: the count is the card's, not the scheduler's).
    fn send_on(&mut self, conn: u64, line: &str) -> (String, u64) {
        let rx = self
            .card
            .submit(Request::Host {
                conn,
                req: HostRequest::Line(line.as_bytes().to_vec()),
            })
            .expect("the card takes the request");
        let start = self.sim.cycle();
        loop {
            if let Ok(Response::Host(r)) = rx.try_recv() {
                let text = String::from_utf8_lossy(&r.bytes).into_owned();
                return (text, self.sim.cycle() - start);
            }
            assert!(
                self.sim.cycle() - start < LINE_LIMIT,
                "{line}: no reply within {LINE_LIMIT} ring cycles"
            );
            self.sim.step();
        }
    }

    fn send(&mut self, line: &str) -> String {
        let conn = self.conn;
        self.send_on(conn, line).0
    }

    /// Host requests the card holds (accepted, not yet answered).
    fn pending(&mut self) -> usize {
        match self.sim.app_mut(0) {
            App::Card(a) => a.core().pending(),
            App::Station(_) => panic!("member 0 is the card"),
        }
    }

    /// `???` word 1 bit 5: the MACRO auxiliary error.
    fn aux_error(&mut self) -> bool {
        let r = self.send("???");
        u32::from_str_radix(&r[..6], 16).expect("??? reply") & 0x20 != 0
    }

    fn station(&self, i: usize) -> &StationApp {
        match self.sim.app(i) {
            App::Station(s) => s,
            App::Card(_) => panic!("member {i} is the card"),
        }
    }
}

/// Send each `(line, reply)` and compare the reply byte for byte.
fn transcript(rig: &mut Rig, items: &[(&str, &str)]) {
    for (line, want) in items {
        assert_eq!(rig.send(line), *want, "{line}");
    }
}

#[test]
fn every_ms_and_mx_form_is_answered_by_the_station_over_the_ring() {
    let mut rig = Rig::new(2, None);
    transcript(
        &mut rig,
        &[
            ("I9=2", "\x06"),
            // global MI-variables, both spellings real host tools send
            ("MS0,MI8", "8\r\x06"),
            ("ms0,i9", "4\r\x06"),
            ("MACROSLAVE8,MI10", "4\r\x06"),
            // station commands
            ("MS VER0", "1.104\r\x06"),
            ("MS DATE8", "08/12/1999\r\x06"),
            ("MS CONFIG0=37", "\x06"),
            ("MS CONFIG0", "37\r\x06"),
            ("MS CONFIG8", "0\r\x06"),
            ("MS0,MI4", "$0\r\x06"),
            // node variables: each node its own
            ("MS4,MI964=6000", "\x06"),
            ("MS4,MI964", "6000\r\x06"),
            ("MS5,MI964", "5000\r\x06"),
            ("MS12,MI913=1", "\x06"),
            ("MS12,MI913", "1\r\x06"),
            // a range
            ("MS0,MI8..10", "8\r4\r4\r\x06"),
            ("MS8,MI0..2", "1.104\r08/12/1999\r0\r\x06"),
            // copies into and out of PMAC variables
            ("MSR0,MI8,P1", "\x06"),
            ("P1", "8\r\x06"),
            ("P2=6 MSW8,MI9,P2", "\x06"),
            ("MS8,MI9", "6\r\x06"),
            ("MS0,MI9", "4\r\x06"),
            // Type 0 parameters (node n needs I1000 bit n: the motor nodes have it)
            ("MX0,8", "8\r\x06"),
            ("MX1,9=5", "\x06"),
            ("MX1,9", "5\r\x06"),
            ("P3=7 MXW0,9,P3", "\x06"),
            ("MXR0,9,P4", "\x06"),
            ("P4", "7\r\x06"),
            // node 15: every station of the master
            ("MS15,MI8=12", "\x06"),
            ("MS0,MI8", "12\r\x06"),
            ("MS8,MI8", "12\r\x06"),
            // C-commands: MS8,C2=0 resets the station at node 8 (its setup comes back)
            ("MS8,C2=0", "\x06"),
            ("MS8,MI9", "4\r\x06"),
            ("MS0,MI9", "7\r\x06"),
        ],
    );
    assert_eq!(rig.station(1).mi().setup().globals.check_period, 12);
    assert_eq!(rig.station(2).mi().setup().globals.check_period, 8);
}

#[test]
fn a_turbo_card_reaches_its_stations_with_i6840_i70_and_i78() {
    // The Turbo numbers of the Type 1 preconditions: master in I6840, I70 bit 15 clear, the
    // timeout I78 (32 at ring start-up, as on a PMAC2's I1003).
    let mut rig = Rig::with_profile(Profile::Turbo, 2, None);
    transcript(
        &mut rig,
        &[
            ("I78", "32\r\x06"),
            ("MS0,MI8", "8\r\x06"),
            ("ms4,i912=14", "\x06"),
            ("ms4,i912", "14\r\x06"),
            ("MS8,MI913", "0\r\x06"),
            ("I78=0", "\x06"),
            ("MS0,MI8", "\x07ERR008\r"),
            ("I78=32", "\x06"),
            ("MS0,MI8", "8\r\x06"),
        ],
    );
}

#[test]
fn failures_answer_err008_with_x0798_and_bad_input_err003_and_nothing_changes() {
    let mut rig = Rig::new(2, None);
    let before = (
        rig.station(1).mi().setup().clone(),
        rig.station(2).mi().setup().clone(),
    );
    transcript(
        &mut rig,
        &[
            // slave errors: $xxxxFE with the station's code
            ("MS0,MI9=300", "\x07ERR008\r"),
            ("RHX:$0798", "0002FE\r\x06"),
        ],
    );
    assert!(rig.aux_error());
    transcript(
        &mut rig,
        &[
            ("MS0,MI7", "\x07ERR008\r"),
            ("RHX:$0798", "0001FE\r\x06"),
            ("MS0,MI0=2", "\x07ERR008\r"),
            ("RHX:$0798", "0003FE\r\x06"),
            // the error bit is cleared by the next auxiliary command
            ("MS0,MI8", "8\r\x06"),
        ],
    );
    assert!(!rig.aux_error());
    transcript(
        &mut rig,
        &[
            // a range stops at the first failure; what came before is sent
            ("MS0,MI8..11", "8\r4\r4\r\x07ERR008\r"),
            // malformed or out-of-range commands: ERR003, nothing sent
            ("MS16,MI8", "\x07ERR003\r"),
            ("MS0,MI2000", "\x07ERR003\r"),
            ("MS0,MI10..8", "\x07ERR003\r"),
            ("MS0,MI8..", "\x07ERR003\r"),
            ("MS0,MI", "\x07ERR003\r"),
            ("MS0", "\x07ERR003\r"),
            ("MS CONFIG", "\x07ERR003\r"),
            ("MX0,1=5", "\x07ERR003\r"),
            ("MX0,10=40000", "\x07ERR003\r"),
            ("MSR0,MI8,P99999", "\x07ERR003\r"),
        ],
    );
    assert_eq!(rig.station(1).mi().setup(), &before.0);
    assert_eq!(rig.station(2).mi().setup(), &before.1);
    // No station serves node 2: the timeout is I1003 = 32 servo cycles.
    let (r, cycles) = {
        let c = rig.conn;
        rig.send_on(c, "MS2,MI8")
    };
    assert_eq!(r, "\x07ERR008\r");
    assert!((32..LINE_LIMIT).contains(&cycles), "{cycles}");
    assert_eq!(rig.send("RHX:$0798"), "010000\r\x06");
    // Type 0 to a node without I1000 bit n: refused at once.
    transcript(&mut rig, &[("MX2,8", "\x07ERR008\r")]);
    // Type 1 disabled (I1003 = 0) or node 15 in aux-copy use: refused at once.
    transcript(
        &mut rig,
        &[
            ("I1003=0", "\x06"),
            ("MS0,MI8", "\x07ERR008\r"),
            ("RHX:$0798", "010000\r\x06"),
            ("I1003=32", "\x06"),
            ("MS0,MI8", "8\r\x06"),
        ],
    );
}

#[test]
fn a_station_cut_off_the_ring_times_out_and_clrf_clears_its_fault_once_healthy() {
    let mut rig = Rig::new(2, None);
    // cut the fibre from station0 into station1: it faults (loss of light), card0's requests for its
    // nodes do not come back
    rig.sim
        .inject(1, FaultSpec::always(FaultKind::Cut))
        .unwrap();
    rig.sim.run(40);
    assert!(rig.station(2).mi().faulted());
    let (r, cycles) = {
        let c = rig.conn;
        rig.send_on(c, "MS8,MI8")
    };
    assert_eq!(r, "\x07ERR008\r");
    assert!(cycles >= 32, "{cycles}");
    rig.sim.clear_faults(1);
    rig.sim.run(40);
    assert!(
        rig.station(2).mi().faulted(),
        "latched after the ring heals"
    );
    // the card's own latch is cleared by $$$ / CLRF of the card; the station's by MS CLRF
    transcript(&mut rig, &[("MS CLRF8", "\x06"), ("MS8,MI4", "$0\r\x06")]);
    assert!(!rig.station(2).mi().faulted());
}

#[test]
fn other_connections_are_served_while_a_line_waits_for_the_ring() {
    let mut rig = Rig::new(1, None);
    let (tx, rx) = mpsc::channel();
    let h = rig.card.clone();
    let a = h.new_conn();
    std::thread::spawn(move || {
        let r = h.host(a, HostRequest::Line(b"MS0,MI950..970".to_vec()));
        let _ = tx.send(r);
    });
    // until connection a's line is with the card (its request crosses a thread: wall time,
    // bounded)
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while rig.pending() == 0 {
        assert!(std::time::Instant::now() < deadline);
        rig.sim.step();
        std::thread::yield_now();
    }
    rig.sim.run(2);
    assert!(rx.try_recv().is_err(), "a's range is still on the ring");
    // connection b is answered while a's line is still waiting (no ring cycle ran)
    let b = rig.card.new_conn();
    let (r, cycles) = rig.send_on(b, "P7=3 P7");
    assert_eq!(r, "3\r\x06");
    assert!(cycles <= 2, "{cycles}");
    let mut n = 0;
    let reply = loop {
        if let Ok(r) = rx.try_recv() {
            break r;
        }
        rig.sim.step();
        n += 1;
        assert!(n < LINE_LIMIT);
    };
    let text = String::from_utf8_lossy(&reply.bytes).into_owned();
    assert_eq!(text.matches('\r').count(), 21, "{text:?}");
    assert!(text.ends_with('\x06'), "{text:?}");
    assert!(n > 21 * 5, "21 exchanges take ring cycles: {n}");
}

#[test]
fn a_flood_of_ms_commands_from_many_connections_is_answered_in_full() {
    let mut rig = Rig::new(1, None);
    let (tx, rx) = mpsc::channel();
    for i in 0..40u32 {
        let h = rig.card.clone();
        let tx = tx.clone();
        std::thread::spawn(move || {
            let c = h.new_conn();
            let line = format!("MS0,MI2={i} MS0,MI2");
            let r = h.host(c, HostRequest::Line(line.into_bytes()));
            let _ = tx.send((i, String::from_utf8_lossy(&r.bytes).into_owned()));
        });
    }
    drop(tx);
    let mut got = Vec::new();
    let mut n = 0;
    while got.len() < 40 {
        while let Ok(x) = rx.try_recv() {
            got.push(x);
        }
        rig.sim.step();
        n += 1;
        assert!(n < 40 * LINE_LIMIT, "{} of 40 answered", got.len());
    }
    // One transaction at a time; a line waits its turn for each of its accesses, so another
    // line's write may come between its write and its read: every reply is a value some line
    // wrote, ACK-terminated.
    for (i, r) in &got {
        let v: u32 = r
            .trim_end_matches('\x06')
            .trim_end_matches('\r')
            .parse()
            .unwrap_or_else(|_| panic!("line {i}: {r:?}"));
        assert!(v < 40, "line {i}: {r:?}");
    }
}

#[test]
fn plc_msr_and_msw_wait_at_the_statement_for_the_ring() {
    let mut rig = Rig::new(2, None);
    transcript(
        &mut rig,
        &[
            ("OPEN PLC 1 CLEAR", "\x06"),
            ("P20=P20+1", "\x06"),
            ("MSR0,MI8,P10", "\x06"),
            ("P21=P21+1", "\x06"),
            ("P11=P10+3 MSW8,MI9,P11", "\x06"),
            ("MSR2,MI8,P12", "\x06"),
            ("P22=P22+1", "\x06"),
            ("DISABLE PLC 1", "\x06"),
            ("CLOSE", "\x06"),
            ("P12=-1 I5=2 ENABLE PLC 1", "\x06"),
        ],
    );
    let mut n = 0;
    while rig.send("P22") != "1\r\x06" {
        rig.sim.run(5);
        n += 1;
        assert!(n < 200);
    }
    transcript(
        &mut rig,
        &[
            // the PLC waited at each statement: the first line ran once
            ("P20 P21 P22", "1\r1\r1\r\x06"),
            ("P10", "8\r\x06"),
            ("MS8,MI9", "11\r\x06"),
            // node 2 has no station: a timeout, flagged, the variable untouched
            ("P12", "-1\r\x06"),
            ("RHX:$0798", "010000\r\x06"),
        ],
    );
}
