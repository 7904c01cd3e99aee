//! The raw `gpascii` port: real sockets on 127.0.0.1 port 0, every wait bounded.

use super::*;
use crate::domain::Profile;
use crate::host::gpascii::MAX_LINE;
use crate::lang::Card;
use crate::service::handle::spawn_card_thread;

const WAIT: Duration = Duration::from_secs(10);

pub(crate) async fn start(cfg: PowerPortsConfig) -> BoundPowerPorts {
    serve_power(spawn_card_thread(Card::new(Profile::Power)), cfg)
        .await
        .expect("bind")
}

async fn connect(addr: SocketAddr) -> TcpStream {
    let mut s = tokio::time::timeout(WAIT, TcpStream::connect(addr))
        .await
        .expect("connect in time")
        .expect("connect");
    assert_eq!(read_n(&mut s, BANNER.len()).await, BANNER);
    s
}

async fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
    let mut v = vec![0u8; n];
    tokio::time::timeout(WAIT, s.read_exact(&mut v))
        .await
        .expect("reply in time")
        .expect("read");
    v
}

async fn ask(s: &mut TcpStream, send: &[u8], want: &[u8]) {
    s.write_all(send).await.unwrap();
    let got = read_n(s, want.len()).await;
    assert_eq!(
        String::from_utf8_lossy(&got),
        String::from_utf8_lossy(want),
        "reply to {:?}",
        String::from_utf8_lossy(send)
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn banner_then_each_line_is_answered_by_the_power_dialect_and_acknowledged() {
    let ports = start(PowerPortsConfig::default()).await;
    assert!(ports.gpascii.ip().is_loopback() && ports.ssh.ip().is_loopback());
    let mut s = connect(ports.gpascii).await;
    ask(&mut s, b"cid\r\n", b"604020\r\n\x06\r\n").await;
    // CR, LF and CR LF each end one line; an empty line is acknowledged on its own.
    ask(
        &mut s,
        b"P1=5\rP1\n\nP2\r\n",
        b"\x06\r\nP1=5\r\n\x06\r\n\x06\r\nP2=0\r\n\x06\r\n",
    )
    .await;
    // Echo mode 7 (value only), an element write and read; an error names the thread's line
    // (every line counted, the empty one too: this is line 6).
    ask(
        &mut s,
        b"echo7 Motor[1].JogSpeed=12.25\nMotor[1].JogSpeed\nMotor[1].Nonsense\n",
        b"\x06\r\n12.25\r\n\x06\r\n\
          stdin:8:1: error #21: ILLEGAL PARAMETER: Motor[1].Nonsense\r\n\x06\r\n",
    )
    .await;
    ports.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_connection_is_its_own_command_thread() {
    let ports = start(PowerPortsConfig::default()).await;
    let mut a = connect(ports.gpascii).await;
    let mut b = connect(ports.gpascii).await;
    // The addressed motor and the echo mode are per thread (Ldata).
    ask(&mut a, b"#3 echo7\n", b"\x06\r\n").await;
    ask(&mut a, b"Ldata.Motor\n", b"3\r\n\x06\r\n").await;
    ask(&mut b, b"Ldata.Motor\n", b"Ldata.Motor=0\r\n\x06\r\n").await;
    // An open buffer belongs to its thread: the other thread's lines are commands.
    ask(&mut a, b"open plc 1\n", b"\x06\r\n").await;
    ask(&mut b, b"P7=1\n", b"\x06\r\n").await;
    ask(&mut a, b"P7=2\n", b"\x06\r\n").await;
    ask(&mut b, b"P7\n", b"P7=1\r\n\x06\r\n").await;
    // A thread that goes away closes the buffer it left open.
    drop(a);
    tokio::time::timeout(WAIT, async {
        loop {
            b.write_all(b"open plc 2\n").await.unwrap();
            let mut buf = [0u8; 256];
            let n = b.read(&mut buf).await.unwrap();
            if buf[..n] == *b"\x06\r\n" {
                return;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await
    .expect("the buffer of the closed thread is closed");
    ask(&mut b, b"close\n", b"\x06\r\n").await;
    ports.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn overlong_line_is_refused_then_reading_resumes() {
    let ports = start(PowerPortsConfig::default()).await;
    let mut s = connect(ports.gpascii).await;
    let mut long = vec![b'P'; MAX_LINE + 10];
    long.push(b'\n');
    s.write_all(&long).await.unwrap();
    let refused = [
        b"stdin:1:1: error #20: ILLEGAL CMD: ".as_slice(),
        &vec![b'P'; MAX_LINE + 1],
        b"\r\n\x06\r\n",
    ]
    .concat();
    assert_eq!(read_n(&mut s, refused.len()).await, refused);
    ask(&mut s, b"cid\n", b"604020\r\n\x06\r\n").await;
    ports.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_c_ends_the_session_and_the_limit_closes_extra_connections() {
    let cfg = PowerPortsConfig {
        max_connections: 1,
        ..PowerPortsConfig::default()
    };
    let ports = start(cfg).await;
    let mut s = connect(ports.gpascii).await;
    // A second connection beyond the limit is closed at once (no banner).
    let mut extra = TcpStream::connect(ports.gpascii).await.unwrap();
    let mut buf = [0u8; 64];
    let n = tokio::time::timeout(WAIT, extra.read(&mut buf))
        .await
        .expect("closed in time");
    assert!(matches!(n, Ok(0) | Err(_)), "{n:?}");
    s.write_all(b"cid\n\x03P1\n").await.unwrap();
    assert_eq!(read_n(&mut s, 11).await, b"604020\r\n\x06\r\n");
    let n = tokio::time::timeout(WAIT, s.read(&mut buf))
        .await
        .expect("closed in time");
    assert!(matches!(n, Ok(0) | Err(_)), "{n:?}");
    // The slot is free again.
    let mut again = tokio::time::timeout(WAIT, async {
        loop {
            let mut c = TcpStream::connect(ports.gpascii).await.unwrap();
            let mut b = vec![0u8; BANNER.len()];
            if c.read_exact(&mut b).await.is_ok() {
                return c;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await
    .expect("slot freed");
    ask(&mut again, b"cid\n", b"604020\r\n\x06\r\n").await;
    ports.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_bytes_never_break_the_port() {
    let ports = start(PowerPortsConfig::default()).await;
    let mut s = connect(ports.gpascii).await;
    let junk: Vec<u8> = (0u32..5000)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .filter(|b| !matches!(b, 0x03 | 0x04 | 0xFF))
        .collect();
    s.write_all(&junk).await.unwrap();
    s.write_all(b"\n\x18\ncid\n").await.unwrap();
    // Whatever the junk produced, the port still answers, in order, ending with cid's reply.
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    tokio::time::timeout(WAIT, async {
        while !got.ends_with(b"\x06\r\n\x06\r\n604020\r\n\x06\r\n") {
            let n = s.read(&mut buf).await.unwrap();
            assert!(n > 0, "closed");
            got.extend_from_slice(&buf[..n]);
        }
    })
    .await
    .expect("answers in time");
    ports.shutdown().await;
}
