//! Host-port limits on running processes (issue 9 items 4 and 6): silent connections never
//! lock a host out of a card port or the daisy chain (the longest idle one is evicted with a
//! message), and a card's memory stays bounded while hundreds of hosts leave long replies
//! unread (replies are streamed from the card part by part).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use mcc_testing::Cluster;
use mcc_tests::process::bin_dir;

fn connect(addr: &str) -> TcpStream {
    let s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    s
}

/// Everything readable within `t` (stops early at end of stream).
fn read_for(s: &mut TcpStream, t: Duration, until: impl Fn(&[u8]) -> bool) -> Vec<u8> {
    let deadline = Instant::now() + t;
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    while Instant::now() < deadline && !until(&got) {
        match s.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(_) => {}
        }
    }
    got
}

fn host_table(text: &str) -> toml::Value {
    toml::Value::Table(toml::from_str(text).expect("host table"))
}

#[test]
fn silent_connections_never_lock_a_host_out_of_a_card_port_or_the_chain() {
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .clock("lockstep")
        .cards(1)
        .stations(1)
        .extra(
            "host",
            host_table("max_connections = 4\nevict_idle_after_ms = 300"),
        )
        .tag("hostlim")
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"));
    let (ascii, _) = c.ports(0).expect("card 0 ports");
    let card = format!("127.0.0.1:{ascii}");
    let chain = c.daisy_chain().expect("daisy chain");
    for (what, addr, line, want) in [
        ("card0 ASCII port", card.as_str(), &b"P1\r"[..], &b"0\r"[..]),
        ("daisy chain", chain.as_str(), &b"@0P1\r"[..], &b"0\r"[..]),
    ] {
        // Fill the port with hosts that never say anything.
        let mut silent: Vec<TcpStream> = (0..4).map(|_| connect(addr)).collect();
        std::thread::sleep(Duration::from_millis(800));
        // A well-behaved host gets in and is served.
        let mut good = connect(addr);
        good.write_all(line).unwrap();
        let got = read_for(&mut good, Duration::from_secs(30), |g| {
            g.windows(want.len()).any(|w| w == want)
        });
        assert!(
            got.windows(want.len()).any(|w| w == want),
            "{what}: new host not served: {:?}",
            String::from_utf8_lossy(&got)
        );
        // The longest idle one was closed, saying why.
        let bye = read_for(&mut silent[0], Duration::from_secs(10), |g| {
            g.ends_with(b"\r\n") && g.len() > 4
        });
        let bye = String::from_utf8_lossy(&bye).into_owned();
        assert!(bye.contains("idle to let a new host in"), "{what}: {bye:?}");
        // The others are still there: one more new host evicts the next oldest.
        let mut good2 = connect(addr);
        good2.write_all(line).unwrap();
        let got = read_for(&mut good2, Duration::from_secs(30), |g| {
            g.windows(want.len()).any(|w| w == want)
        });
        assert!(
            got.windows(want.len()).any(|w| w == want),
            "{what}: second host"
        );
        silent.clear();
    }
}

/// The card's resident memory in kB.
fn rss_kb(pid: u32) -> u64 {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("proc status");
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("VmRSS")
}

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn getresponse(cmd: &[u8]) -> Vec<u8> {
    let mut v = vec![0x40, 0xBF, 0, 0, 0, 0];
    v.extend_from_slice(&(cmd.len() as u16).to_be_bytes());
    v.extend_from_slice(cmd);
    v
}

#[test]
fn card_memory_stays_bounded_while_500_hosts_leave_long_replies_unread() {
    let mut child = Command::new(bin_dir().join("mcc-card"))
        .args([
            "--standalone",
            "--profile",
            "turbo",
            "--max-connections",
            "512",
            "--exit-on-stdin-eof",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start mcc-card");
    let mut out = child.stdout.take().expect("stdout");
    let card = Killed(child);
    let pid = card.0.id();
    let mut line = String::new();
    let mut b = [0u8; 1];
    while !line.ends_with('\n') {
        assert_eq!(out.read(&mut b).expect("ports line"), 1, "card exited");
        line.push(char::from(b[0]));
    }
    let eth: u16 = line
        .split("\"pmac_eth\":")
        .nth(1)
        .and_then(|r| r.trim().trim_end_matches('}').parse().ok())
        .expect("eth port");
    // 40 queries of P0..8191: a 655 kB reply per host, 328 MB for 500 if each were held.
    let heavy = format!("I3=2 {}", "P0..8191 ".repeat(40));
    let per_reply = 40 * 8192 * 2;
    let before = rss_kb(pid);
    let mut hosts = Vec::new();
    for _ in 0..500 {
        let mut s = TcpStream::connect(("127.0.0.1", eth)).expect("connect");
        s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
        s.write_all(&getresponse(heavy.as_bytes())).unwrap();
        hosts.push(s);
    }
    // Every host gets its first packet and never asks for the rest.
    for s in &mut hosts {
        let mut first = [0u8; 1400];
        s.read_exact(&mut first).expect("first packet");
        assert!(first.starts_with(b"0\r0\r"));
    }
    let after = rss_kb(pid);
    let grown_mb = after.saturating_sub(before) / 1024;
    eprintln!(
        "card RSS {} MB before, {} MB with 500 unread replies of {} kB each ({} MB if held whole)",
        before / 1024,
        after / 1024,
        per_reply / 1024,
        500 * per_reply / 1024 / 1024
    );
    assert!(
        grown_mb < 100,
        "RSS grew by {grown_mb} MB: replies are held whole"
    );
    // A well-behaved host is still served at once.
    let mut good = TcpStream::connect(("127.0.0.1", eth)).expect("connect");
    good.set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    good.write_all(&getresponse(b"I3=2 P1")).unwrap();
    let mut r = [0u8; 3];
    good.read_exact(&mut r).expect("reply");
    assert_eq!(&r, b"0\r\x06");
}
