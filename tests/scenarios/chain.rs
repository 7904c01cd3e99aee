//! The daisy chain served by a running cluster (pmac-commands §8): TCP connections with their
//! own addressing, `@n`/`@@`/`@` rules, control characters to all cards, bad input, the pty,
//! `mcc send`, `mcc term` and the foreground `mcc up` terminal driven through pipes. Cards
//! keep their default framing (I3=1, I6=3): data `<LF>text<CR><LF>`... as in transcript 01.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use mcc_testing::{Cluster, Foreground};
use mcc_tests::process::{bin_dir, text};

/// A host on the chain: write bytes, read the reply.
trait Host: Read + Write {}
impl<T: Read + Write> Host for T {}

/// Send `bytes`, read until `want.len()` bytes came (or 15 s), and compare.
fn exchange(h: &mut dyn Host, bytes: &[u8], want: &[u8]) {
    h.write_all(bytes).expect("write");
    let got = read_for(h, want.len(), Duration::from_secs(15));
    assert_eq!(text(&got), text(want), "reply to {:?}", text(bytes));
}

/// Send `bytes`, expect silence for a while.
fn silent(h: &mut dyn Host, bytes: &[u8]) {
    h.write_all(bytes).expect("write");
    let got = read_for(h, 1, Duration::from_millis(2500));
    assert!(
        got.is_empty(),
        "unexpected reply {:?} to {:?}",
        text(&got),
        text(bytes)
    );
}

fn read_for(h: &mut dyn Host, n: usize, timeout: Duration) -> Vec<u8> {
    let deadline = Instant::now() + timeout;
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    while got.len() < n && Instant::now() < deadline {
        match h.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(_) => std::thread::sleep(Duration::from_millis(10)),
        }
    }
    got
}

fn connect(addr: &str) -> TcpStream {
    let s = TcpStream::connect(addr).expect("connect to the daisy chain");
    s.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    s
}

/// Motor status word 1, hex digit 1: bit 19 (amplifier enabled) = 8, bit 18 (open loop) = 4.
fn amp_and_loop(status_reply: &[u8]) -> u8 {
    let t = text(status_reply);
    let digits: String = t.chars().filter(char::is_ascii_hexdigit).collect();
    u8::from_str_radix(digits.get(1..2).expect("status word"), 16).expect("hex") & 0xC
}

#[test]
fn daisy_chain_rules_over_tcp_pty_send_and_term() {
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .clock("lockstep")
        .cards(2)
        .stations(1)
        .up_arg("--pty")
        .tag("chain")
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"));
    let doc = c.status().unwrap().0;
    let addr = doc["daisy_chain"]
        .as_str()
        .expect("daisy_chain")
        .to_string();
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    let pty = doc["daisy_chain_pty"]
        .as_str()
        .expect("daisy_chain_pty")
        .to_string();
    let mut a = connect(&addr);
    let mut b = connect(&addr);

    // `@1 P1=5`: only card 1 takes it and acknowledges.
    exchange(&mut a, b"@1P1=5\r", b"\n");
    exchange(&mut a, b"@0P1\r", b"\n0\r\n");
    exchange(&mut a, b"@1P1\r", b"\n5\r\n");
    exchange(&mut a, b"@\r", b"\n1\r\n");
    // One line, two cards, one <CR>: each card runs its part; the card addressed last answers.
    exchange(&mut a, b"@0P2=11@1P2=22\r", b"\n");
    exchange(&mut a, b"@0P2@1\r", b"\n");
    exchange(&mut a, b"@0P2\r", b"\n11\r\n");
    exchange(&mut a, b"@1P2\r", b"\n22\r\n");
    // `@@`: every card executes, card 0 alone acknowledges, queries refused, `@` answers `@`.
    exchange(&mut a, b"@@P3=7\r", b"\n");
    exchange(&mut a, b"P3\r", b"\x07\r\nERR003\r");
    exchange(&mut a, b"@\r", b"\n@\r\n");
    exchange(&mut a, b"@0P3\r", b"\n7\r\n");
    exchange(&mut a, b"@1P3\r", b"\n7\r\n");

    // A second connection has its own addressing (power-up: card 0).
    exchange(&mut b, b"@\r", b"\n0\r\n");
    exchange(&mut a, b"@\r", b"\n1\r\n");

    // Control characters acting on all cards: CTRL-K kills the motors of both cards, whichever
    // is addressed.
    exchange(&mut a, b"@@#1J/\r", b"\n");
    exchange(&mut a, b"@1\r", b"\n");
    a.write_all(b"\x0b").unwrap();
    for k in [b"@0#1?\r", b"@1#1?\r"] {
        a.write_all(k).unwrap();
        let r = read_for(&mut a, 15, Duration::from_secs(15));
        assert_eq!(amp_and_loop(&r), 4, "card killed: {:?}", text(&r));
    }

    // Bad input: an unknown card number silences the chain until a real card is addressed.
    silent(&mut b, b"@7P1\r");
    silent(&mut b, b"P1\r");
    exchange(&mut b, b"@1P1\r", b"\n5\r\n");
    // Over-long line: ERR003 from the addressed card, then business as usual.
    let mut long = vec![b'P'; 1100];
    long.push(b'\r');
    exchange(&mut b, &long, b"\x07\r\nERR003\r");
    // Stray control characters in the middle of a line are ignored.
    exchange(&mut b, b"P\x051\x17\r", b"\n5\r\n");

    // The pseudo-terminal is one more host connection.
    let mut t = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&pty)
        .expect("open the chain pty");
    t.write_all(b"@1P1\r").unwrap();
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut byte = [0u8; 1];
    while got.len() < 4 && Instant::now() < deadline {
        if t.read(&mut byte).unwrap_or(0) == 1 {
            got.push(byte[0]);
        }
    }
    assert_eq!(text(&got), "\n5\r\n");
    drop(t);

    // `mcc send` for scripts.
    let out = c.mcc(&["send", "--card", "1", "P4=3", "P4", "P3"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(text(&out.stdout), "3\n7\n");
    let out = c.mcc(&["send", "--show-framing", "@1P4", "@7P4"]);
    assert_eq!(text(&out.stdout), "<LF>3<CR>\n<LF>\n");
    assert!(
        text(&out.stderr).contains("no card answered \"@7P4\""),
        "{}",
        text(&out.stderr)
    );
    let out = c.mcc(&["send", "--card", "16", "P1"]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("--card"),
        "{}",
        text(&out.stderr)
    );

    // `mcc term` through a pipe.
    let out = c.mcc_input(
        &["term"],
        b"@0P4\n@1P4\n.framing\nP1\n@\n.bogus\n.quit\nP1\n",
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        text(&out.stdout),
        "0\n3\n(framing characters shown)\n<LF>5<CR>\n<LF>\n<LF>1<CR>\n<LF>\n"
    );
    assert!(text(&out.stderr).contains("unknown meta command"));
}

#[test]
fn foreground_up_is_a_terminal_on_the_chain() {
    let mut fg = Foreground::start(
        &bin_dir().join("mcc"),
        "fgterm",
        &["--clock", "lockstep", "--cards", "2", "--stations", "1"],
    )
    .expect("mcc up");
    fg.wait_ready(Duration::from_secs(150))
        .expect("ring locked");
    let mut stdin = fg.child.stdin.take().expect("stdin");
    stdin.write_all(b"@1P7=42\n@1P7\n@0P7\n.quit\n").unwrap();
    let status = fg
        .wait_exit(Duration::from_secs(60))
        .expect("exit after .quit");
    assert!(status.success());
    let rest = fg.remaining_lines(Duration::from_secs(5));
    assert!(
        rest.iter().any(|l| l.contains("daisy chain 127.0.0.1:")),
        "{rest:?}"
    );
    let i = rest.iter().position(|l| l == "42").expect("reply 42");
    assert_eq!(rest.get(i + 1).map(String::as_str), Some("0"), "{rest:?}");
    assert!(rest.iter().any(|l| l.contains("stopped")), "{rest:?}");
    assert!(
        !fg.run_base().join(fg.name()).exists(),
        "run dir left behind"
    );
}
