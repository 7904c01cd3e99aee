//! Host-link faults on the card's ports: real sockets on 127.0.0.1 port 0, every wait bounded.
//! The faulted bytes are the fault model's for the seed (`mcc_ring::linkfault`), and what the
//! card stores is what it would store without the fault.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use mcc_ring::linkfault::{LinkFaultKind, LinkFaultSlot, LinkFaultSpec, LinkFaulter};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

use crate::domain::Profile;
use crate::host::eth_codec::{request, VR_DOWNLOAD, VR_PMAC_GETRESPONSE};
use crate::host::power_ports::{serve_power, PowerPortsConfig};
use crate::host::server::{serve, PortsConfig};
use crate::lang::{Card, Session};
use crate::service::handle::spawn_card_thread;

const WAIT: Duration = Duration::from_secs(10);

fn spec(kind: LinkFaultKind, seed: u64) -> LinkFaultSpec {
    LinkFaultSpec {
        kind,
        probability: 1.0,
        seed,
        replies: None,
        delay_ms: if kind == LinkFaultKind::Late { 300 } else { 0 },
    }
}

/// What the model makes of `reply` as the first reply of a fresh fault.
fn model(s: &LinkFaultSpec, reply: &[u8]) -> Vec<u8> {
    LinkFaulter::new(s.clone()).on_reply(reply).bytes
}

fn in_process(line: &[u8]) -> Vec<u8> {
    Card::new(Profile::Pmac2).command_line(&mut Session::default(), line)
}

async fn connect(addr: SocketAddr) -> TcpStream {
    tokio::time::timeout(WAIT, TcpStream::connect(addr))
        .await
        .expect("connect in time")
        .expect("connect")
}

async fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
    let mut v = vec![0u8; n];
    tokio::time::timeout(WAIT, s.read_exact(&mut v))
        .await
        .expect("reply in time")
        .expect("read");
    v
}

/// Read until the bytes end with `end`.
async fn read_until(s: &mut TcpStream, end: &[u8]) -> Vec<u8> {
    let mut got = Vec::new();
    let mut b = [0u8; 4096];
    while !got.ends_with(end) {
        let n = tokio::time::timeout(WAIT, s.read(&mut b))
            .await
            .expect("reply in time")
            .expect("read");
        assert!(n > 0, "closed before {end:?}: {got:?}");
        got.extend_from_slice(b.get(..n).unwrap_or_default());
    }
    got
}

/// The peer reset or closed the connection (within the wait).
async fn reset(s: &mut TcpStream) -> bool {
    let mut b = [0u8; 64];
    matches!(
        tokio::time::timeout(WAIT, s.read(&mut b)).await,
        Ok(Ok(0)) | Ok(Err(_))
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ascii_port_replies_are_the_models_for_each_kind() {
    let link = LinkFaultSlot::default();
    let cfg = PortsConfig {
        link: link.clone(),
        ..PortsConfig::default()
    };
    let p = serve(spawn_card_thread(Card::new(Profile::Pmac2)), cfg)
        .await
        .unwrap();
    let want = in_process(b"TYPE");
    assert!(want.len() > 4, "{want:?}");
    let mut s = connect(p.ascii).await;
    for kind in [
        LinkFaultKind::Short,
        LinkFaultKind::StrayCr,
        LinkFaultKind::StrayLf,
        LinkFaultKind::StrayBel,
        LinkFaultKind::StrayCtrl,
        LinkFaultKind::Corrupt,
    ] {
        let sp = spec(kind, 11);
        let faulted = model(&sp, &want);
        assert_ne!(faulted, want, "{kind}");
        link.set(sp);
        s.write_all(b"TYPE\r").await.unwrap();
        assert_eq!(read_n(&mut s, faulted.len()).await, faulted, "{kind}");
        // One reply only (`--cycles 1` is the CLI's): the next is intact.
        link.set(LinkFaultSpec {
            replies: Some(1),
            ..spec(kind, 11)
        });
        s.write_all(b"TYPE\rTYPE\r").await.unwrap();
        let mut both = faulted.clone();
        both.extend_from_slice(&want);
        assert_eq!(read_n(&mut s, both.len()).await, both, "{kind}");
        assert!(!link.armed(), "{kind}: ended after its reply");
    }
    // No reply: the next (unfaulted) reply is the first the host reads.
    link.set(LinkFaultSpec {
        replies: Some(1),
        ..spec(LinkFaultKind::NoReply, 1)
    });
    s.write_all(b"TYPE\rTYPE\r").await.unwrap();
    assert_eq!(read_n(&mut s, want.len()).await, want);
    // Late: the whole reply, no sooner than the delay.
    link.set(spec(LinkFaultKind::Late, 1));
    let t = Instant::now();
    s.write_all(b"TYPE\r").await.unwrap();
    assert_eq!(read_n(&mut s, want.len()).await, want);
    assert!(
        t.elapsed() >= Duration::from_millis(300),
        "{:?}",
        t.elapsed()
    );
    // Reset: the connection ends without the reply; a new one works once cleared.
    link.set(spec(LinkFaultKind::Reset, 1));
    s.write_all(b"TYPE\r").await.unwrap();
    assert!(reset(&mut s).await);
    link.clear();
    let mut s = connect(p.ascii).await;
    s.write_all(b"TYPE\r").await.unwrap();
    assert_eq!(read_n(&mut s, want.len()).await, want);
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ethernet_and_gpascii_replies_are_faulted_too() {
    let link = LinkFaultSlot::default();
    let p = serve(
        spawn_card_thread(Card::new(Profile::Pmac2)),
        PortsConfig {
            link: link.clone(),
            ..PortsConfig::default()
        },
    )
    .await
    .unwrap();
    let want = in_process(b"TYPE");
    let mut e = connect(p.pmac_eth).await;
    let sp = spec(LinkFaultKind::Corrupt, 5);
    link.set(sp.clone());
    e.write_all(&request(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, 0, 4, b"TYPE"))
        .await
        .unwrap();
    // The Ethernet reply of a GETRESPONSE is the card's reply bytes as they are.
    let faulted = model(&sp, &want);
    assert_eq!(read_n(&mut e, faulted.len()).await, faulted);
    link.set(spec(LinkFaultKind::Reset, 5));
    e.write_all(&request(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, 0, 4, b"TYPE"))
        .await
        .unwrap();
    assert!(reset(&mut e).await);
    p.shutdown().await;

    let link = LinkFaultSlot::default();
    let p = serve_power(
        spawn_card_thread(Card::new(Profile::Power)),
        PowerPortsConfig {
            link: link.clone(),
            ..PowerPortsConfig::default()
        },
    )
    .await
    .unwrap();
    let mut g = connect(p.gpascii).await;
    let banner = crate::host::gpascii::BANNER;
    // The banner is no reply: never faulted.
    link.set(spec(LinkFaultKind::StrayBel, 2));
    assert_eq!(read_n(&mut g, banner.len()).await, banner);
    let want = b"604020\r\n\x06\r\n";
    let faulted = model(&spec(LinkFaultKind::StrayBel, 2), want);
    g.write_all(b"cid\r\n").await.unwrap();
    assert_eq!(read_n(&mut g, faulted.len()).await, faulted);
    link.set(spec(LinkFaultKind::Short, 2));
    let faulted = model(&spec(LinkFaultKind::Short, 2), want);
    g.write_all(b"cid\r\n").await.unwrap();
    assert_eq!(read_n(&mut g, faulted.len()).await, faulted);
    link.clear();
    g.write_all(b"cid\r\n").await.unwrap();
    assert_eq!(read_n(&mut g, want.len()).await, want);
    p.shutdown().await;
}

/// The commands of the state test: variables, a program, I-variables, an M-variable.
const SEQUENCE: &[&[u8]] = &[
    b"P1=5",
    b"P2=P1*3 Q7=2.5",
    b"I130=1234 I5=2",
    b"OPEN PROG 3 CLEAR",
    b"LINEAR INC X10 Y(P2)",
    b"DWELL 100",
    b"CLOSE",
    b"M1->X:$0078,0,24",
    b"P3=P2+1",
    b"OPEN PLC 1 CLEAR",
    b"P4=P4+1",
    b"CLOSE",
    b"LIST PROG 3",
    b"P1..4",
];

/// What the card holds after `SEQUENCE`, read on a fresh, unfaulted connection.
const DUMP: &[u8] = b"P1..4 Q7 I130 I5 M1-> LIST PROG 3 LIST PLC 1 P999";

/// The end of P999's reply (factory I3: no ACK).
const MARKER: &[u8] = b"424242\r\n";

/// The replies the sequence's last line (`P999`) ends with.
const LAST: &[u8] = b"P999";

/// Run `SEQUENCE` then `P999` under `fault`; once the fault has looked at `replies` replies
/// (`None`: read until the intact marker, the fault must never hit) clear it and dump the
/// card's state on a fresh connection. The dump, the replies the fault looked at and hit.
async fn state_after(fault: LinkFaultSpec, replies: Option<u64>) -> (Vec<u8>, u64, u64) {
    let link = LinkFaultSlot::default();
    let p = serve(
        spawn_card_thread(Card::new(Profile::Pmac2)),
        PortsConfig {
            link: link.clone(),
            ..PortsConfig::default()
        },
    )
    .await
    .unwrap();
    let mut s = connect(p.ascii).await;
    s.write_all(b"P999=424242 P999\r").await.unwrap();
    let _ = read_until(&mut s, MARKER).await;
    link.set(fault);
    for l in SEQUENCE.iter().chain(&[LAST]) {
        s.write_all(l).await.unwrap();
        s.write_all(b"\r").await.unwrap();
    }
    match replies {
        None => {
            let _ = read_until(&mut s, MARKER).await;
        }
        Some(n) => {
            let t = Instant::now();
            while link.active().map_or(0, |a| a.seen) < n {
                assert!(t.elapsed() < WAIT, "the fault saw {:?}", link.active());
                tokio::time::sleep(Duration::from_millis(5)).await;
            }
        }
    }
    let a = link.active().expect("the fault is still installed");
    link.clear();
    let mut d = connect(p.ascii).await;
    d.write_all(DUMP).await.unwrap();
    d.write_all(b"\r").await.unwrap();
    let dump = read_until(&mut d, MARKER).await;
    p.shutdown().await;
    (dump, a.seen, a.hits)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_cards_state_is_the_same_with_and_without_a_link_fault() {
    // Probability 0: nothing is hit, every reply is counted.
    let (clean, n, hits) = state_after(
        LinkFaultSpec {
            probability: 0.0,
            ..spec(LinkFaultKind::NoReply, 0)
        },
        None,
    )
    .await;
    assert_eq!(hits, 0);
    assert!(n >= 3, "non-empty replies of the sequence: {n}");
    let text = String::from_utf8_lossy(&clean).to_string();
    assert!(text.contains("1234") && text.contains("X10"), "{text}");
    for (i, kind) in [
        LinkFaultKind::NoReply,
        LinkFaultKind::Short,
        LinkFaultKind::StrayCr,
        LinkFaultKind::StrayLf,
        LinkFaultKind::StrayBel,
        LinkFaultKind::StrayCtrl,
        LinkFaultKind::Corrupt,
        LinkFaultKind::Late,
    ]
    .into_iter()
    .enumerate()
    {
        let f = LinkFaultSpec {
            probability: 0.6,
            delay_ms: if kind == LinkFaultKind::Late { 5 } else { 0 },
            ..spec(kind, i as u64)
        };
        let (dump, seen, hits) = state_after(f, Some(n)).await;
        assert_eq!(seen, n, "{kind}");
        assert!(hits > 0, "{kind}: the fault hit no reply");
        assert_eq!(String::from_utf8_lossy(&dump), text, "{kind}");
    }
}
