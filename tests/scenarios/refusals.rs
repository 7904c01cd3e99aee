//! How a full host port refuses a new host (issue 26 item 4): a binary port (the EMCL bus)
//! closes without writing a byte, so a TMCL client never reads text as a reply frame; the
//! daisy chain, a terminal, keeps its text line.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use mcc_station::emcl::codec::{Instr, Reply, Request, FRAME_LEN};
use mcc_testing::Cluster;
use mcc_tests::process::bin_dir;

fn connect(addr: &str) -> TcpStream {
    let s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    s
}

/// Everything readable within `t` and whether the stream then ended (EOF or reset).
fn read_to_end_within(s: &mut TcpStream, t: Duration) -> (Vec<u8>, bool) {
    read_until(s, t, |_| false)
}

/// What is read within `t` or until `enough`, and whether the stream ended (EOF or reset).
fn read_until(s: &mut TcpStream, t: Duration, enough: impl Fn(&[u8]) -> bool) -> (Vec<u8>, bool) {
    let deadline = Instant::now() + t;
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while Instant::now() < deadline && !enough(&got) {
        match s.read(&mut buf) {
            Ok(0) => return (got, true),
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => return (got, true),
            Err(_) => {}
        }
    }
    (got, false)
}

/// One EMCL round trip (GAP 1 of drive 1): the reply's status.
fn emcl_round_trip(s: &mut TcpStream) -> u8 {
    let f = Request {
        addr: 1,
        instr: Instr::new(6, 1, 0, 0),
    }
    .to_bytes();
    s.write_all(&f).unwrap();
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut buf = [0u8; FRAME_LEN];
    while got.len() < FRAME_LEN && Instant::now() < deadline {
        if let Ok(k) = s.read(&mut buf[..FRAME_LEN - got.len()]) {
            got.extend_from_slice(&buf[..k]);
        }
    }
    let r: [u8; FRAME_LEN] = got.try_into().expect("one reply frame");
    Reply::parse(&r).expect("reply checksum").status
}

#[test]
fn a_full_emcl_bus_refuses_by_closing_and_the_chain_with_a_line() {
    let host: toml::Value =
        toml::Value::Table(toml::from_str("max_connections = 2").expect("host table"));
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .clock("lockstep")
        .cards(1)
        .stations(1)
        .extra("host", host)
        .tag("refusals")
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"));
    let doc = c.status().expect("status").0;
    let bus = doc["emcl_bus"].as_str().expect("emcl_bus").to_string();
    // Two active hosts fill the bus (eviction needs 5 s of silence).
    let mut a = connect(&bus);
    let mut b = connect(&bus);
    assert_eq!(emcl_round_trip(&mut a), 100);
    assert_eq!(emcl_round_trip(&mut b), 100);
    let mut refused = connect(&bus);
    let (got, ended) = read_to_end_within(&mut refused, Duration::from_secs(10));
    assert!(ended, "the refused host's connection is closed");
    assert_eq!(
        got,
        b"",
        "no text on a binary bus: {:?}",
        String::from_utf8_lossy(&got)
    );
    assert_eq!(emcl_round_trip(&mut a), 100, "the others are still served");
    drop((a, b));

    // The daisy chain is a terminal: a refused host reads why.
    let chain = c.daisy_chain().expect("daisy chain");
    let mut x = connect(&chain);
    let mut y = connect(&chain);
    for s in [&mut x, &mut y] {
        s.write_all(b"@0P1\r").unwrap();
        let (got, _) = read_until(s, Duration::from_secs(20), |g| g.ends_with(b"0\r\n"));
        assert_eq!(got, b"\n0\r\n", "{:?}", String::from_utf8_lossy(&got));
    }
    let mut refused = connect(&chain);
    let (got, ended) = read_to_end_within(&mut refused, Duration::from_secs(10));
    let text = String::from_utf8_lossy(&got);
    assert!(ended && text.contains("daisy chain is full"), "{text:?}");
}
