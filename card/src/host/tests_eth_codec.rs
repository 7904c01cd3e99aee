//! Byte-exact tests of the Ethernet codec against a scripted interpreter.

use super::*;
use crate::host::port::{big_reply, EchoInterp};

fn getresponse(cmd: &[u8]) -> Vec<u8> {
    request(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, 0, cmd.len() as u16, cmd)
}

fn getbuffer() -> Vec<u8> {
    request(VR_UPLOAD, VR_PMAC_GETBUFFER, 0, 2048, &[])
}

fn sends(actions: Vec<EthAction>) -> Vec<Vec<u8>> {
    actions
        .into_iter()
        .map(|a| match a {
            EthAction::Send(b) => b,
            EthAction::Close(r) => panic!("unexpected close: {r}"),
        })
        .collect()
}

#[test]
fn header_round_trip_big_endian() {
    let h = Header {
        request_type: 0x40,
        request: 0xBF,
        value: 0x0102,
        index: 0x0304,
        length: 0x0506,
    };
    assert_eq!(h.to_bytes(), [0x40, 0xBF, 1, 2, 3, 4, 5, 6]);
    assert_eq!(Header::parse(&h.to_bytes()), h);
    assert_eq!(h.payload_len(), 0x0506);
    let up = Header {
        request_type: 0xC0,
        ..h
    };
    assert_eq!(up.payload_len(), 0);
}

#[test]
fn getresponse_executes_line_with_implicit_cr() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    // Exactly what dls-pmaclib sends on connect.
    let mut pkt = vec![0x40, 0xBF, 0, 0, 0, 0, 0, 13];
    pkt.extend_from_slice(b"i6=1 i3=2 ver");
    assert_eq!(
        sends(c.feed(&pkt, &mut i)),
        vec![b"i6=1 i3=2 ver\r\x06".to_vec()]
    );
    assert_eq!(i.log, vec!["i6=1 i3=2 ver"]);
}

#[test]
fn empty_getresponse_is_ack() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    assert_eq!(sends(c.feed(&getresponse(b""), &mut i)), vec![vec![0x06]]);
    assert!(i.log.is_empty());
}

#[test]
fn control_char_inside_getresponse_acts_and_acks() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    // ^K has no output: the reply is a lone ACK.
    assert_eq!(
        sends(c.feed(&getresponse(b"\x0b"), &mut i)),
        vec![vec![0x06]]
    );
    assert_eq!(i.log, vec!["^0B"]);
}

#[test]
fn request_split_across_reads_and_pipelined() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let mut stream = getresponse(b"P1");
    stream.extend(getresponse(b"P2"));
    let (a, b) = stream.split_at(5);
    assert_eq!(c.feed(a, &mut i), vec![]);
    assert!(c.has_partial_request());
    let (b1, b2) = b.split_at(6);
    assert_eq!(sends(c.feed(b1, &mut i)), vec![b"P1\r\x06".to_vec()]);
    assert!(c.has_partial_request());
    assert_eq!(sends(c.feed(b2, &mut i)), vec![b"P2\r\x06".to_vec()]);
    assert!(!c.has_partial_request());
}

#[test]
fn error_reply_passes_through() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    assert_eq!(
        sends(c.feed(&getresponse(b"ERR"), &mut i)),
        vec![b"\x07ERR003\r".to_vec()]
    );
}

#[test]
fn long_reply_in_packets_via_getbuffer() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let full = big_reply(3000);
    let first = sends(c.feed(&getresponse(b"BIG3000"), &mut i)).remove(0);
    // 1400 would end on byte index 1399: 1399 % 11 == 2 -> '2', not a terminator.
    assert_eq!(first.len(), 1400);
    assert_eq!(first, full[..1400]);
    assert_eq!(
        sends(c.feed(&request(0xC0, VR_PMAC_READREADY, 0, 2, &[]), &mut i)),
        vec![vec![1, 0]]
    );
    let second = sends(c.feed(&getbuffer(), &mut i)).remove(0);
    assert_eq!(second, full[1400..2800]);
    let third = sends(c.feed(&getbuffer(), &mut i)).remove(0);
    assert_eq!(third, full[2800..]);
    assert_eq!(*third.last().unwrap(), 0x06);
    assert_eq!(
        sends(c.feed(&request(0xC0, VR_PMAC_READREADY, 0, 2, &[]), &mut i)),
        vec![vec![0, 0]]
    );
    // Nothing pending: GETBUFFER answers a lone ACK.
    assert_eq!(sends(c.feed(&getbuffer(), &mut i)), vec![vec![0x06]]);
}

#[test]
fn non_final_packet_never_ends_in_cr_ack_or_nul() {
    // Reply whose byte 1400 (index 1399) is CR followed by ACK and NUL: the cut moves past them.
    struct Fixed(Vec<u8>);
    impl Interpreter for Fixed {
        fn line(&mut self, _: &[u8]) -> Vec<u8> {
            self.0.clone()
        }
        fn control(&mut self, _: u8) -> Vec<u8> {
            Vec::new()
        }
        fn overlong(&mut self) -> Vec<u8> {
            Vec::new()
        }
    }
    let mut reply = vec![b'7'; 1399];
    reply.extend_from_slice(b"\r\x06\x00X");
    reply.extend(vec![b'8'; 1500]);
    reply.extend_from_slice(b"\r\x06");
    let mut c = EthConn::new();
    let mut f = Fixed(reply.clone());
    let first = sends(c.feed(&getresponse(b"x"), &mut f)).remove(0);
    assert_eq!(first.len(), 1403);
    assert_eq!(*first.last().unwrap(), b'X');
    let second = sends(c.feed(&getbuffer(), &mut f)).remove(0);
    assert_eq!(second.len(), 1400);
    let third = sends(c.feed(&getbuffer(), &mut f)).remove(0);
    let mut want = vec![b'8'; 100];
    want.extend_from_slice(b"\r\x06");
    assert_eq!(third, want);
    let mut all = first;
    all.extend(second);
    all.extend(third);
    assert_eq!(all, reply);
    // A tail made only of terminators goes out whole (it is the final packet).
    let mut tail = vec![b'1'; 1399];
    tail.extend_from_slice(b"\r\r\x06");
    let mut f = Fixed(tail.clone());
    let mut c = EthConn::new();
    assert_eq!(sends(c.feed(&getresponse(b"x"), &mut f)), vec![tail]);
}

#[test]
fn getbuffer_honours_smaller_wlength() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let full = big_reply(2000);
    let _ = c.feed(&getresponse(b"BIG2000"), &mut i);
    let p = sends(c.feed(&request(0xC0, VR_PMAC_GETBUFFER, 0, 100, &[]), &mut i)).remove(0);
    assert_eq!(p, full[1400..1500]);
}

#[test]
fn new_command_replaces_pending_and_flush_discards() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let _ = c.feed(&getresponse(b"BIG3000"), &mut i);
    // Two 1000-byte parts were pulled for the first 1400-byte packet; the third waits.
    assert_eq!(c.pending_len(), 600);
    assert_eq!(
        sends(c.feed(&getresponse(b"P1"), &mut i)),
        vec![b"P1\r\x06".to_vec()]
    );
    assert_eq!(c.pending_len(), 0);
    let _ = c.feed(&getresponse(b"BIG3000"), &mut i);
    let flush = request(VR_DOWNLOAD, VR_PMAC_FLUSH, 0, 0, &[]);
    assert_eq!(sends(c.feed(&flush, &mut i)), vec![vec![b'@']]);
    assert_eq!(c.pending_len(), 0);
    assert_eq!(i.log.last().map(String::as_str), Some("^18"));
}

#[test]
fn ctrl_response_takes_char_from_either_byte() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let be = request(VR_UPLOAD, VR_CTRL_RESPONSE, 0x0002, 0, &[]);
    assert_eq!(sends(c.feed(&be, &mut i)), vec![b"^02\r".to_vec()]);
    let le = request(VR_UPLOAD, VR_CTRL_RESPONSE, 0x0700, 0, &[]);
    assert_eq!(sends(c.feed(&le, &mut i)), vec![b"^07\r".to_vec()]);
    // No output (^K) or not a control character: a lone ACK, nothing executed.
    let k = request(VR_UPLOAD, VR_CTRL_RESPONSE, 0x000B, 0, &[]);
    assert_eq!(sends(c.feed(&k, &mut i)), vec![vec![0x06]]);
    let p = request(VR_UPLOAD, VR_CTRL_RESPONSE, u16::from(b'P'), 0, &[]);
    assert_eq!(sends(c.feed(&p, &mut i)), vec![vec![0x06]]);
    assert_eq!(i.log, vec!["^02", "^07", "^0B"]);
}

#[test]
fn sendline_then_getline() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let sl = request(VR_DOWNLOAD, VR_PMAC_SENDLINE, 0, 4, b"P1P2");
    assert_eq!(sends(c.feed(&sl, &mut i)), vec![vec![b'@']]);
    let gl = request(VR_UPLOAD, VR_PMAC_GETLINE, 0, 0, &[]);
    assert_eq!(sends(c.feed(&gl, &mut i)), vec![b"P1P2\r".to_vec()]);
    assert_eq!(sends(c.feed(&gl, &mut i)), vec![b"\x06".to_vec()]);
    assert_eq!(sends(c.feed(&gl, &mut i)), vec![b"\x06".to_vec()]);
    assert_eq!(c.pending_len(), 0);
}

#[test]
fn writebuffer_runs_lines_and_reports_first_error() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let ok = b"OPEN PLC 1 CLEAR\0P1=P1+1\0CLOSE\0";
    let pkt = request(VR_DOWNLOAD, VR_PMAC_WRITEBUFFER, 0, ok.len() as u16, ok);
    assert_eq!(sends(c.feed(&pkt, &mut i)), vec![vec![0, 0, 0, 0]]);
    assert_eq!(i.log, vec!["OPEN PLC 1 CLEAR", "P1=P1+1", "CLOSE"]);
    let bad = b"P1\0P2\0ERR\0P4";
    let pkt = request(VR_DOWNLOAD, VR_PMAC_WRITEBUFFER, 0, bad.len() as u16, bad);
    assert_eq!(sends(c.feed(&pkt, &mut i)), vec![vec![3, 0, 3, 0x80]]);
    assert_eq!(i.log.len(), 6, "P4 must not run after the error");
}

#[test]
fn error_code_parsing() {
    assert_eq!(error_code(b"\x07\rERR017\r"), Some(17));
    assert_eq!(error_code(b"\x07"), None);
    assert_eq!(error_code(b"ERR9"), None);
    assert_eq!(error_code(b"ERR999"), None);
}

#[test]
fn garbage_oversized_and_unknown_requests_close() {
    let mut i = EchoInterp::default();
    let mut c = EthConn::new();
    assert_eq!(
        c.feed(b"GET / HTTP/1.0\r\n", &mut i),
        vec![EthAction::Close(CloseReason::BadRequestType(b'G'))]
    );
    // Once closed, nothing more is processed.
    assert_eq!(c.feed(&getresponse(b"P1"), &mut i), vec![]);
    let mut c = EthConn::new();
    let big = [0x40, 0xBF, 0, 0, 0, 0, 0x05, 0xD5];
    assert_eq!(
        c.feed(&big, &mut i),
        vec![EthAction::Close(CloseReason::Oversized(1493))]
    );
    let mut c = EthConn::new();
    let unknown = request(VR_UPLOAD, 0x77, 0, 0, &[]);
    let mut stream = getresponse(b"P1");
    stream.extend(unknown);
    stream.extend(getresponse(b"P2"));
    assert_eq!(
        c.feed(&stream, &mut i),
        vec![
            EthAction::Send(b"P1\r\x06".to_vec()),
            EthAction::Close(CloseReason::UnsupportedRequest(0x77))
        ]
    );
    assert_eq!(i.log, vec!["P1"]);
}

#[test]
fn max_payload_accepted_and_overlong_line_is_err003() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let line = vec![b'1'; MAX_PAYLOAD];
    let pkt = getresponse(&line);
    assert_eq!(sends(c.feed(&pkt, &mut i)), vec![b"\x07ERR003\r".to_vec()]);
    assert_eq!(i.log, vec!["<overlong>"]);
}

#[test]
fn never_panics_on_random_bytes() {
    let mut seed = 0x1234_5678_u32;
    for _ in 0..200 {
        let mut c = EthConn::new();
        let mut i = EchoInterp::default();
        for _ in 0..20 {
            let len = (seed % 40) as usize;
            let mut chunk = Vec::with_capacity(len);
            for _ in 0..len {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
                // Bias towards valid request types so the state machine is exercised.
                let b = (seed >> 16) as u8;
                chunk.push(match b % 7 {
                    0 => 0x40,
                    1 => 0xC0,
                    2 => 0xBF,
                    3 => 0xC5,
                    _ => b % 16,
                });
            }
            let _ = c.feed(&chunk, &mut i);
            assert!(c.inbuf.len() <= HEADER_LEN + MAX_PAYLOAD);
        }
    }
}

#[test]
fn a_long_reply_is_pulled_part_by_part_and_the_connection_holds_little() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let want = big_reply(200_000);
    let mut packets = sends(c.feed(&getresponse(b"BIG200000"), &mut i));
    let mut most = c.held_bytes();
    let mut got = packets.concat();
    while got.len() < want.len() {
        let p = sends(c.feed(&getbuffer(), &mut i)).remove(0);
        most = most.max(c.held_bytes());
        got.extend_from_slice(&p);
        packets.push(p);
        assert!(packets.len() < 1_000, "never ended");
    }
    assert_eq!(got, want, "every byte, in order");
    for p in &packets[..packets.len() - 1] {
        assert!(!matches!(p.last(), Some(&(0x0D | 0x06 | 0x00))), "{p:?}");
    }
    assert_eq!(sends(c.feed(&getbuffer(), &mut i)), vec![vec![0x06]]);
    // One streamed part plus a packet, never the whole 200 kB.
    assert!(
        most <= crate::host::port::ECHO_PART + PACKET_DATA + 64,
        "held {most} bytes"
    );
    assert!(i.largest_part <= crate::host::port::ECHO_PART);
}

#[test]
fn readready_and_getline_pull_a_streamed_reply_too() {
    let mut c = EthConn::new();
    let mut i = EchoInterp::default();
    let sendline = request(VR_DOWNLOAD, VR_PMAC_SENDLINE, 0, 7, b"BIG5000");
    assert_eq!(sends(c.feed(&sendline, &mut i)), vec![b"@".to_vec()]);
    let ready = request(VR_UPLOAD, VR_PMAC_READREADY, 0, 2, &[]);
    let getline = request(VR_UPLOAD, VR_PMAC_GETLINE, 0, 0, &[]);
    let mut got = Vec::new();
    loop {
        let r = sends(c.feed(&ready, &mut i)).remove(0);
        if r == [0, 0] {
            break;
        }
        got.extend_from_slice(&sends(c.feed(&getline, &mut i)).remove(0));
        assert!(got.len() <= 5000);
    }
    assert_eq!(got, big_reply(5000));
}
