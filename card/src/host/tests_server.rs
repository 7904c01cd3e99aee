//! Server tests: real sockets on 127.0.0.1 port 0, every wait bounded by a timeout.

use super::*;
use crate::domain::Profile;
use crate::host::ascii::MAX_LINE;
use crate::host::eth_codec::{request, VR_DOWNLOAD, VR_PMAC_FLUSH, VR_PMAC_GETRESPONSE};
use crate::host::port::overlong_probe;
use crate::lang::{Card, Session};
use crate::service::handle::{spawn_card_thread, CardHandle};
use mcc_contracts::hostport::HostLimits;

const WAIT: Duration = Duration::from_secs(5);

/// What a fresh card answers to `line` in-process (the port must be byte-transparent).
fn in_process(line: &[u8]) -> Vec<u8> {
    Card::new(Profile::Pmac2).command_line(&mut Session::default(), line)
}

/// Ports with `max` connections and a request timeout of `request_ms`.
fn limits(max: usize, request_ms: u64) -> PortsConfig {
    PortsConfig {
        limits: HostLimits {
            max_connections: max,
            request_timeout_ms: request_ms,
            ..HostLimits::default()
        },
        ..PortsConfig::default()
    }
}

async fn start(cfg: PortsConfig) -> BoundPorts {
    serve(spawn_card_thread(Card::new(Profile::Pmac2)), cfg)
        .await
        .expect("bind")
}

async fn connect(addr: SocketAddr) -> TcpStream {
    let s = tokio::time::timeout(WAIT, TcpStream::connect(addr))
        .await
        .unwrap()
        .unwrap();
    assert!(s.nodelay().is_ok());
    s
}

/// Read exactly `n` bytes.
async fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
    let mut v = vec![0u8; n];
    tokio::time::timeout(WAIT, s.read_exact(&mut v))
        .await
        .expect("reply in time")
        .unwrap();
    v
}

/// True if the peer closed the connection (EOF or reset) within the wait.
async fn closed(s: &mut TcpStream) -> bool {
    let mut b = [0u8; 64];
    loop {
        match tokio::time::timeout(WAIT, s.read(&mut b)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return true,
            Ok(Ok(_)) => continue,
            Err(_) => return false,
        }
    }
}

fn getresponse(cmd: &[u8]) -> Vec<u8> {
    request(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, 0, cmd.len() as u16, cmd)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ascii_port_is_byte_transparent_and_accepts_crlf() {
    let p = start(PortsConfig::default()).await;
    assert_eq!(p.ascii.ip(), IpAddr::V4(Ipv4Addr::LOCALHOST));
    assert_ne!(p.ascii.port(), 0);
    let mut s = connect(p.ascii).await;
    let want = in_process(b"UUU");
    s.write_all(b"UUU\r\n").await.unwrap();
    assert_eq!(read_n(&mut s, want.len()).await, want);
    // A line split over several writes.
    s.write_all(b"UU").await.unwrap();
    s.write_all(b"U\r").await.unwrap();
    assert_eq!(read_n(&mut s, want.len()).await, want);
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ascii_overlong_line_gets_err003_then_resyncs() {
    let p = start(PortsConfig::default()).await;
    let mut s = connect(p.ascii).await;
    let mut line = vec![b'1'; MAX_LINE + 10];
    line.extend_from_slice(b"\rUUU\r");
    s.write_all(&line).await.unwrap();
    let want1 = in_process(&overlong_probe());
    let want2 = in_process(b"UUU");
    let got = read_n(&mut s, want1.len() + want2.len()).await;
    assert_eq!(got, [want1, want2].concat());
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn eth_port_getresponse_empty_and_flush() {
    let p = start(PortsConfig::default()).await;
    let mut s = connect(p.pmac_eth).await;
    s.write_all(&getresponse(b"")).await.unwrap();
    assert_eq!(read_n(&mut s, 1).await, b"\x06");
    let want = in_process(b"UUU");
    s.write_all(&getresponse(b"UUU")).await.unwrap();
    assert_eq!(read_n(&mut s, want.len()).await, want);
    s.write_all(&request(VR_DOWNLOAD, VR_PMAC_FLUSH, 0, 0, &[]))
        .await
        .unwrap();
    assert_eq!(read_n(&mut s, 1).await, b"@");
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_connection_is_closed_others_unaffected() {
    let p = start(PortsConfig::default()).await;
    let mut good = connect(p.pmac_eth).await;
    let mut bad = connect(p.pmac_eth).await;
    bad.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    assert!(closed(&mut bad).await, "garbage must close the connection");
    good.write_all(&getresponse(b"")).await.unwrap();
    assert_eq!(read_n(&mut good, 1).await, b"\x06");
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stalled_request_times_out_without_blocking_others() {
    let p = start(limits(64, 200)).await;
    let mut stalled = connect(p.pmac_eth).await;
    stalled.write_all(&[0x40, 0xBF, 0]).await.unwrap();
    let mut good = connect(p.pmac_eth).await;
    good.write_all(&getresponse(b"")).await.unwrap();
    assert_eq!(read_n(&mut good, 1).await, b"\x06");
    assert!(
        closed(&mut stalled).await,
        "a stalled half request is dropped"
    );
    good.write_all(&getresponse(b"")).await.unwrap();
    assert_eq!(read_n(&mut good, 1).await, b"\x06");
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connection_limit_closes_extra_connections() {
    let p = start(limits(2, 10_000)).await;
    let mut a = connect(p.ascii).await;
    let mut b = connect(p.ascii).await;
    // Make sure both are accepted before the third arrives.
    for s in [&mut a, &mut b] {
        s.write_all(b"UUU\r").await.unwrap();
        let _ = read_n(s, in_process(b"UUU").len()).await;
    }
    let mut c = connect(p.ascii).await;
    assert!(closed(&mut c).await);
    drop(a);
    // A slot frees up once a connection ends.
    let mut ok = false;
    for _ in 0..50 {
        let mut d = connect(p.ascii).await;
        d.write_all(b"UUU\r").await.unwrap();
        let mut buf = [0u8; 1];
        if let Ok(Ok(1)) = tokio::time::timeout(Duration::from_millis(1000), d.read(&mut buf)).await
        {
            ok = true;
            break;
        }
    }
    assert!(ok, "a freed slot must be reusable");
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_closes_connections() {
    let p = start(PortsConfig::default()).await;
    let mut s = connect(p.ascii).await;
    let addr = p.ascii;
    p.shutdown().await;
    assert!(closed(&mut s).await);
    assert!(TcpStream::connect(addr).await.is_err());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simultaneous_connections_get_their_own_whole_replies() {
    let p = start(PortsConfig::default()).await;
    let want = in_process(b"UUU");
    let mut tasks = Vec::new();
    for i in 0..4 {
        let addr = if i % 2 == 0 { p.ascii } else { p.pmac_eth };
        let want = want.clone();
        tasks.push(tokio::spawn(async move {
            let mut s = connect(addr).await;
            for _ in 0..100 {
                if i % 2 == 0 {
                    s.write_all(b"UUU\r").await.unwrap();
                } else {
                    s.write_all(&getresponse(b"UUU")).await.unwrap();
                }
                assert_eq!(read_n(&mut s, want.len()).await, want);
            }
        }));
    }
    for t in tasks {
        t.await.unwrap();
    }
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn addressing_is_per_connection_and_i3_is_card_global() {
    let p = start(PortsConfig::default()).await;
    let mut a = connect(p.ascii).await;
    let mut b = connect(p.pmac_eth).await;
    a.write_all(b"I3=2 I6=1\r").await.unwrap();
    assert_eq!(read_n(&mut a, 1).await, b"\x06");
    b.write_all(&getresponse(b"#3")).await.unwrap();
    assert_eq!(read_n(&mut b, 1).await, b"\x06");
    b.write_all(&getresponse(b"#")).await.unwrap();
    assert_eq!(read_n(&mut b, 3).await, b"3\r\x06");
    a.write_all(b"#\r").await.unwrap();
    assert_eq!(read_n(&mut a, 3).await, b"1\r\x06");
    // I3=3 set on the ASCII port frames the Ethernet port's replies too.
    a.write_all(b"I3=3 P7=12\r").await.unwrap();
    assert_eq!(read_n(&mut a, 1).await, b"\x06");
    b.write_all(&getresponse(b"P7")).await.unwrap();
    assert_eq!(read_n(&mut b, 5).await, b"\n12\r\x06");
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unsolicited_output_reaches_terminal_connections_but_not_the_ethernet_port() {
    let card: CardHandle = spawn_card_thread(Card::new(Profile::Pmac2));
    let p = serve(card.clone(), PortsConfig::default())
        .await
        .expect("bind");
    let mut a = connect(p.ascii).await;
    let mut b = connect(p.ascii).await;
    let mut e = connect(p.pmac_eth).await;
    // Let the connections take their start positions before the program speaks.
    a.write_all(b"\r").await.unwrap();
    let ack = in_process(b"");
    assert_eq!(read_n(&mut a, ack.len()).await, ack);
    b.write_all(b"\r").await.unwrap();
    assert_eq!(read_n(&mut b, ack.len()).await, ack);
    card.publish(b"HOMED\r".to_vec());
    assert_eq!(read_n(&mut a, 6).await, b"HOMED\r");
    assert_eq!(read_n(&mut b, 6).await, b"HOMED\r");
    // The Ethernet port answers only what it is asked.
    e.write_all(&getresponse(b"P1")).await.unwrap();
    let want = in_process(b"P1");
    assert_eq!(read_n(&mut e, want.len()).await, want);
    p.shutdown().await;
}

/// Everything the peer sends until it closes (bounded by the wait).
async fn read_to_close(s: &mut TcpStream) -> Vec<u8> {
    let mut v = Vec::new();
    let _ = tokio::time::timeout(WAIT * 2, s.read_to_end(&mut v)).await;
    v
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn silent_connections_make_room_for_a_new_host() {
    let mut cfg = limits(2, 10_000);
    cfg.limits.evict_idle_after_ms = 100;
    let p = start(cfg).await;
    let mut silent_a = connect(p.ascii).await;
    let mut silent_b = connect(p.ascii).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    // A third host gets in: the connection idle longest (a) is closed with a reason.
    let mut good = connect(p.ascii).await;
    good.write_all(b"UUU\r").await.unwrap();
    let want = in_process(b"UUU");
    assert_eq!(read_n(&mut good, want.len()).await, want);
    let bye = String::from_utf8_lossy(&read_to_close(&mut silent_a).await).into_owned();
    assert!(bye.contains("idle to let a new host in"), "{bye:?}");
    // b is still served.
    silent_b.write_all(b"UUU\r").await.unwrap();
    assert_eq!(read_n(&mut silent_b, want.len()).await, want);
    p.shutdown().await;
}

/// Everything the peer sends and whether it then closed (end of stream within the wait).
async fn read_until_eof(s: &mut TcpStream) -> (Vec<u8>, bool) {
    let mut v = Vec::new();
    let eof = tokio::time::timeout(WAIT * 2, s.read_to_end(&mut v))
        .await
        .is_ok_and(|r| r.is_ok());
    (v, eof)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_terminal_port_of_active_hosts_refuses_with_a_message() {
    let p = start(limits(1, 10_000)).await;
    let mut busy = connect(p.ascii).await;
    busy.write_all(b"UUU\r").await.unwrap();
    let want = in_process(b"UUU");
    assert_eq!(read_n(&mut busy, want.len()).await, want);
    // The only connection was active moments ago (eviction needs 5 s of silence).
    let mut refused = connect(p.ascii).await;
    let text = String::from_utf8_lossy(&read_to_close(&mut refused).await).into_owned();
    assert!(
        text.contains("is full: 1 connections open") && text.contains("host.max_connections"),
        "{text:?}"
    );
    busy.write_all(b"UUU\r").await.unwrap();
    assert_eq!(read_n(&mut busy, want.len()).await, want);
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_ethernet_port_refuses_by_closing_without_a_byte() {
    // Issue 26 item 4: a binary host must not read a text line as a reply packet.
    let p = start(limits(1, 10_000)).await;
    let mut busy = connect(p.pmac_eth).await;
    busy.write_all(&getresponse(b"")).await.unwrap();
    assert_eq!(read_n(&mut busy, 1).await, b"\x06");
    let mut refused = connect(p.pmac_eth).await;
    let (got, eof) = read_until_eof(&mut refused).await;
    assert!(eof, "the refused host's connection is closed");
    assert_eq!(got, b"", "nothing written to a refused binary host");
    busy.write_all(&getresponse(b"")).await.unwrap();
    assert_eq!(read_n(&mut busy, 1).await, b"\x06");
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idle_connections_are_closed_after_the_idle_timeout() {
    let mut cfg = limits(8, 10_000);
    cfg.limits.idle_timeout_s = 1;
    let p = start(cfg).await;
    let mut a = connect(p.ascii).await;
    let mut e = connect(p.pmac_eth).await;
    let text = String::from_utf8_lossy(&read_to_close(&mut a).await).into_owned();
    assert!(
        text.contains("after 1 s idle (host.idle_timeout_s)"),
        "{text:?}"
    );
    assert!(closed(&mut e).await);
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_trickled_request_times_out_from_its_first_byte() {
    // Request timeout 400 ms; one byte every 150 ms: each read is recent, the request is not.
    let p = start(limits(8, 400)).await;
    let mut e = connect(p.pmac_eth).await;
    let pkt = getresponse(b"P1");
    let mut closed_after = None;
    for (k, b) in pkt.iter().enumerate() {
        if e.write_all(&[*b]).await.is_err() {
            closed_after = Some(k);
            break;
        }
        tokio::time::sleep(Duration::from_millis(150)).await;
    }
    assert!(
        closed_after.is_some() || closed(&mut e).await,
        "trickle must be cut"
    );
    // An ASCII line gets six request timeouts (2.4 s) from its first byte.
    let mut a = connect(p.ascii).await;
    let started = std::time::Instant::now();
    let mut text = Vec::new();
    for _ in 0..40 {
        if a.write_all(b"P").await.is_err() {
            break;
        }
        let mut b = [0u8; 256];
        if let Ok(Ok(n)) = tokio::time::timeout(Duration::from_millis(150), a.read(&mut b)).await {
            text.extend_from_slice(&b[..n]);
            if n == 0 {
                break;
            }
        }
    }
    let text = String::from_utf8_lossy(&text).into_owned();
    assert!(
        text.contains("request not completed within 2400 ms"),
        "{text:?}"
    );
    assert!(started.elapsed() >= Duration::from_millis(2_400));
    p.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_long_terminal_reply_arrives_whole_through_the_stream() {
    let card = spawn_card_thread(Card::new(Profile::Turbo));
    let p = serve(card, PortsConfig::default()).await.expect("bind");
    let mut line = Vec::new();
    while line.len() + 9 <= 200 {
        line.extend_from_slice(b"P0..8191 ");
    }
    let want = Card::new(Profile::Turbo).command_line(&mut Session::default(), &line);
    assert!(want.len() > 4 * crate::core::STREAM_CHUNK);
    let mut a = connect(p.ascii).await;
    line.push(b'\r');
    a.write_all(&line).await.unwrap();
    let mut got = vec![0u8; want.len()];
    tokio::time::timeout(WAIT * 6, a.read_exact(&mut got))
        .await
        .expect("whole reply in time")
        .unwrap();
    assert_eq!(got, want);
    p.shutdown().await;
}

/// Read until the bytes end with `tail`.
async fn read_until(s: &mut TcpStream, tail: &[u8]) -> Vec<u8> {
    let mut got = Vec::new();
    let mut b = [0u8; 256];
    while !got.ends_with(tail) {
        let n = tokio::time::timeout(WAIT, s.read(&mut b))
            .await
            .expect("reply in time")
            .unwrap();
        assert!(n > 0, "closed; got {got:?}");
        got.extend_from_slice(&b[..n]);
    }
    got
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_hosts_ctrl_t_leaves_another_hosts_replies_alone() {
    // Issue 26 item 2: after a second host sent CTRL-T, dls-pmaclib's `P5` polls got
    // `P5\r55\r\x06` (its line echoed back before the reply).
    let p = start(PortsConfig::default()).await;
    let mut poller = connect(p.ascii).await;
    let mut other = connect(p.ascii).await;
    poller.write_all(b"I3=2 P5=55\r").await.unwrap();
    read_until(&mut poller, b"\x06").await;
    other.write_all(b"\x14P6\r").await.unwrap();
    assert!(read_until(&mut other, b"\x06").await.ends_with(b"0\r\x06"));
    // The host that asked for full duplex has it.
    other.write_all(b"P6\r").await.unwrap();
    assert_eq!(read_n(&mut other, 6).await, b"P6\r0\r\x06");
    for _ in 0..3 {
        poller.write_all(b"P5\r").await.unwrap();
        assert_eq!(read_n(&mut poller, 4).await, b"55\r\x06");
    }
    p.shutdown().await;
}
