//! MACRO station commands on a real multi-process cluster (issue 11): a card's ASCII port
//! talks to station processes over the ring's node-15 channel. Command and reply forms,
//! ranges, copies, PLC `MSR`/`MSW`, node-15 broadcast, slave errors, timeouts with no station
//! or a frozen one, `MS CLRF` after a fault, and `MS SAVE` kept across a station restart.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use mcc_testing::{Cluster, FaultOptions};
use mcc_tests::process::bin_dir;

/// Longest wait for one reply (generous: the machine may be fully loaded; never asserted).
const REPLY_WAIT: Duration = Duration::from_secs(60);

/// A connection to card `n`'s ASCII port.
struct Port(TcpStream);

impl Port {
    fn open(c: &mut Cluster, n: u8) -> Port {
        let (port, _) = c.ports(n).unwrap_or_else(|e| panic!("card {n} ports: {e}"));
        let s = TcpStream::connect(("127.0.0.1", port)).expect("connect ascii port");
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .expect("read timeout");
        let mut p = Port(s);
        assert_eq!(p.send("I3=2 I6=1 I9=2"), "\x06");
        p
    }

    /// Send `line`; the whole reply (up to `<ACK>` or `<BEL>ERRnnn<CR>`).
    fn send(&mut self, line: &str) -> String {
        self.0
            .write_all(format!("{line}\r").as_bytes())
            .expect("write");
        let deadline = Instant::now() + REPLY_WAIT;
        let mut all = Vec::new();
        loop {
            let mut buf = [0u8; 4096];
            match self.0.read(&mut buf) {
                Ok(0) => panic!("{line}: connection closed"),
                Ok(k) => all.extend_from_slice(&buf[..k]),
                Err(_) => {}
            }
            let done = all.ends_with(b"\x06")
                || (all.contains(&0x07) && all.ends_with(b"\r") && {
                    let at = all.iter().rposition(|b| *b == 0x07).unwrap_or(0);
                    all[at..].starts_with(b"\x07ERR")
                });
            if done {
                return String::from_utf8_lossy(&all).into_owned();
            }
            assert!(Instant::now() < deadline, "{line}: no reply: {all:?}");
        }
    }

    /// Send `line` that has no reply (`$$$`).
    fn silent(&mut self, line: &str) {
        self.0
            .write_all(format!("{line}\r").as_bytes())
            .expect("write");
        let mut buf = [0u8; 256];
        let _ = self.0.read(&mut buf);
    }

    fn transcript(&mut self, items: &[(&str, &str)]) {
        for (line, want) in items {
            assert_eq!(self.send(line), *want, "{line}");
        }
    }
}

#[test]
fn a_card_configures_and_diagnoses_its_stations_over_the_ring() {
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .tag("stations")
        .cards(1)
        .stations(2)
        .start()
        .unwrap_or_else(|e| panic!("mcc up: {e}"));
    let mut p = Port::open(&mut c, 0);
    p.transcript(&[
        ("MS0,MI8", "8\r\x06"),
        ("ms8,i9", "4\r\x06"),
        ("MS VER0", "1.104\r\x06"),
        ("MS DATE8", "08/12/1999\r\x06"),
        ("MS0,MI8..10", "8\r4\r4\r\x06"),
        ("MS4,MI964=6000", "\x06"),
        ("MS4,MI964", "6000\r\x06"),
        ("MS5,MI964", "5000\r\x06"),
        ("MSR0,MI9,P1", "\x06"),
        ("P1", "4\r\x06"),
        ("P2=5 MSW8,MI9,P2", "\x06"),
        ("MS8,MI9", "5\r\x06"),
        ("MX0,8", "8\r\x06"),
        // node 15: every station of the card
        ("MS15,MI958=0.00003", "\x06"),
        ("MS1,MI958", "0.00003\r\x06"),
        ("MS13,MI958", "0.00003\r\x06"),
        // slave errors and bad input
        ("MS0,MI9=300", "\x07ERR008\r"),
        ("RHX:$0798", "0002FE\r\x06"),
        ("MS0,MI7", "\x07ERR008\r"),
        ("RHX:$0798", "0001FE\r\x06"),
        ("MS16,MI8", "\x07ERR003\r"),
        ("MS0,MI8..", "\x07ERR003\r"),
        // no station serves node 2: the I1003 timeout
        ("MS2,MI8", "\x07ERR008\r"),
        ("RHX:$0798", "010000\r\x06"),
    ]);
    // The daisy chain (`@0 MS0,MI8`, the way from a terminal): the card's chain reply waits
    // for the ring as a port's does.
    let replies = c
        .send(&["MS0,MI8..9", "P1"], Some(0))
        .unwrap_or_else(|e| panic!("mcc send: {e}"));
    assert_eq!(replies, ["8\n4", "4"]);
    // A PLC copies a station variable and waits for the ring at the statement.
    p.transcript(&[
        ("OPEN PLC 1 CLEAR", "\x06"),
        ("MSR8,MI9,P10", "\x06"),
        ("P11=P10+1 MSW0,MI9,P11", "\x06"),
        ("P12=1", "\x06"),
        ("DISABLE PLC 1", "\x06"),
        ("CLOSE", "\x06"),
        ("P10=0 P12=0 I5=2 ENABLE PLC 1", "\x06"),
    ]);
    let deadline = Instant::now() + REPLY_WAIT;
    while p.send("P12") != "1\r\x06" {
        assert!(Instant::now() < deadline, "PLC 1 never finished");
        std::thread::sleep(Duration::from_millis(50));
    }
    p.transcript(&[("P10", "5\r\x06"), ("MS0,MI9", "6\r\x06")]);
    // SAVE, then the station process restarts: the saved setup comes back.
    p.transcript(&[("MS CONFIG0=37", "\x06"), ("MS SAVE0", "\x06")]);
    p.transcript(&[("MS CONFIG0=1", "\x06")]);
    drill(&mut c, "station0", "restart");
    recover(&mut c);
    let mut p = Port::open(&mut c, 0);
    p.transcript(&[("MS CONFIG0", "37\r\x06"), ("MS0,MI9", "6\r\x06")]);
    // A frozen station answers nothing: the card's access times out (ERR008, $010000).
    drill(&mut c, "station1", "freeze");
    p.transcript(&[("MS8,MI8", "\x07ERR008\r"), ("RHX:$0798", "010000\r\x06")]);
    drill(&mut c, "station1", "restart");
    recover(&mut c);
    // After a ring fault the station's latch holds until MS CLRF (on a healthy ring).
    let mut p = Port::open(&mut c, 0);
    drill(&mut c, "station0", "cut");
    wait(&mut c, "station1 faulted", |d| {
        d["stations"][1]["ring_fault"] == true
    });
    c.clear(None)
        .unwrap_or_else(|e| panic!("mcc fault clear: {e}"));
    let deadline = Instant::now() + REPLY_WAIT;
    loop {
        // the card's own latch first ($$$), then the station's through node 15
        p.silent("$$$");
        p = Port::open(&mut c, 0);
        if p.send("MS CLRF8") == "\x06" && p.send("MS8,MI4") == "$0\r\x06" {
            break;
        }
        assert!(Instant::now() < deadline, "station1 never cleared");
        std::thread::sleep(Duration::from_millis(200));
    }
    wait(&mut c, "station1 healthy", |d| {
        d["stations"][1]["ring_fault"] == false
    });
}

/// `mcc fault MEMBER KIND` (a ring fault or a process drill); the test fails if it does.
fn drill(c: &mut Cluster, member: &str, kind: &str) {
    if let Err(e) = c.fault(member, kind, FaultOptions::default()) {
        panic!("mcc fault {member} {kind}: {e}");
    }
}

/// Wait (bounded by [`REPLY_WAIT`]) until `f` holds on the status document.
fn wait(c: &mut Cluster, what: &str, mut f: impl FnMut(&serde_json::Value) -> bool) {
    if let Err(e) = c.wait_until(None, REPLY_WAIT, |st| f(&st.0)) {
        panic!("waiting for {what}: {e}");
    }
}

/// Members alive and locked again, then `$$$` on every card and the members' latches reset
/// until the ring is healthy (the test API's recovery, as a PMAC user does it).
fn recover(c: &mut Cluster) {
    if let Err(e) = c.reset(REPLY_WAIT) {
        panic!("recovery: {e}");
    }
}
