//! Every test vector of spec emcl.md §15, byte for byte: the printed and computed requests,
//! the replies (through a real drive where the situation can be produced), and the download
//! session of the jump-table program.

use super::codec::{checksum, version_string_reply, Instr, Reply, Request, FRAME_LEN};
use super::drive::Drive;
use super::spec::DriveSpec;

fn f9(s: &str) -> [u8; FRAME_LEN] {
    let v: Vec<u8> = s
        .split_whitespace()
        .map(|h| u8::from_str_radix(h, 16).unwrap())
        .collect();
    v.try_into().unwrap()
}

fn req(addr: u8, op: u8, typ: u8, motor: u8, value: i32) -> [u8; FRAME_LEN] {
    Request {
        addr,
        instr: Instr::new(op, typ, motor, value),
    }
    .to_bytes()
}

fn drive() -> Drive {
    Drive::new(DriveSpec::default())
}

/// Send a frame; the reply bytes (the test fails on silence or no reply).
fn send(d: &mut Drive, frame: [u8; FRAME_LEN]) -> [u8; FRAME_LEN] {
    d.handle_frame(&frame)
        .expect("addressed")
        .bytes
        .expect("a reply")
}

#[test]
fn checksum_is_the_low_byte_of_the_sum() {
    assert_eq!(checksum(&[0xFF, 0x02]), 0x01);
    assert_eq!(checksum(&[]), 0);
}

#[test]
fn requests_printed_in_the_manual_15_1() {
    type Fields = (u8, u8, u8, i32);
    let cases: &[(&str, Fields)] = &[
        ("01 01 00 00 00 00 27 10 39", (1, 0, 0, 10000)),
        ("01 02 00 00 00 00 4E 20 71", (2, 0, 0, 20000)),
        ("01 03 00 00 00 00 00 00 04", (3, 0, 0, 0)),
        ("01 04 00 00 00 01 5F 90 F5", (4, 0, 0, 90000)),
        ("01 04 01 00 FF FF D8 F0 CC", (4, 1, 0, -10000)),
        ("01 04 02 00 00 00 00 08 0F", (4, 2, 0, 8)),
        ("01 05 06 00 00 00 00 B0 BC", (5, 6, 0, 176)),
        ("01 06 01 00 00 00 00 00 08", (6, 1, 0, 0)),
        ("01 09 42 00 00 00 00 03 4F", (9, 66, 0, 3)),
        ("01 0A 42 00 00 00 00 00 4D", (10, 66, 0, 0)),
        ("01 0E 07 02 00 00 00 01 19", (14, 7, 2, 1)),
        ("01 0F 00 00 00 00 00 00 10", (15, 0, 0, 0)),
        ("01 13 02 00 FF FF EC 78 78", (19, 2, 0, -5000)),
        ("01 14 00 00 00 00 03 E8 00", (20, 0, 0, 1000)),
        ("01 15 05 00 00 00 00 0A 25", (21, 5, 0, 10)),
        ("01 16 00 00 00 00 00 14 2B", (22, 0, 0, 20)),
        ("01 17 00 00 00 00 00 64 7C", (23, 0, 0, 100)),
        ("01 18 00 00 00 00 00 00 19", (24, 0, 0, 0)),
        ("01 1B 01 00 00 00 00 00 1D", (27, 1, 0, 0)),
        ("01 1C 00 00 00 00 00 00 1D", (28, 0, 0, 0)),
        ("01 1E 01 00 00 00 03 E8 0B", (30, 1, 0, 1000)),
        ("01 1F 01 00 00 00 00 00 21", (31, 1, 0, 0)),
        ("01 20 03 00 00 00 03 E8 0F", (32, 3, 0, 1000)),
        ("01 27 01 00 00 00 00 E8 11", (39, 1, 0, 0xE8)),
        ("01 21 02 00 00 00 00 00 24", (33, 2, 0, 0)),
        ("01 22 00 00 00 00 00 00 23", (34, 0, 0, 0)),
        ("01 23 03 02 00 00 00 00 29", (35, 3, 2, 0)),
        ("01 24 01 00 00 00 00 00 26", (36, 1, 0, 0)),
    ];
    for (hex, (op, typ, motor, value)) in cases {
        assert_eq!(req(1, *op, *typ, *motor, *value), f9(hex), "{hex}");
        // And the parser reads the same fields back.
        let r = Request::parse(&f9(hex)).unwrap();
        assert_eq!(r.instr, Instr::new(*op, *typ, *motor, *value), "{hex}");
    }
}

#[test]
fn replies_printed_in_the_manual_15_2() {
    let r = |status, op, value| {
        Reply {
            host: 2,
            module: 1,
            status,
            op,
            value,
        }
        .to_bytes()
    };
    assert_eq!(r(100, 0x06, 10000), f9("02 01 64 06 00 00 27 10 A4"));
    assert_eq!(r(100, 0x0A, 1), f9("02 01 64 0A 00 00 00 01 72"));
    assert_eq!(r(100, 0x0F, 1), f9("02 01 64 0F 00 00 00 01 77"));
    assert_eq!(r(100, 0x0A, 0), f9("02 01 64 0A 00 00 00 00 71"));
    assert_eq!(r(100, 0x1F, 0), f9("02 01 64 1F 00 00 00 00 86"));
    // Produced by a drive: GAP 1 at position 10000, GGP 66, GIO 0,0 with IN_0 high, GCO 1.
    let mut d = Drive::new(DriveSpec {
        inputs: [true, false, false],
        ..DriveSpec::default()
    });
    send(&mut d, req(1, 5, 1, 0, 10000));
    assert_eq!(
        send(&mut d, f9("01 06 01 00 00 00 00 00 08")),
        f9("02 01 64 06 00 00 27 10 A4")
    );
    assert_eq!(
        send(&mut d, f9("01 0A 42 00 00 00 00 00 4D")),
        f9("02 01 64 0A 00 00 00 01 72")
    );
    assert_eq!(
        send(&mut d, f9("01 0F 00 00 00 00 00 00 10")),
        f9("02 01 64 0F 00 00 00 01 77")
    );
    assert_eq!(
        send(&mut d, f9("01 1F 01 00 00 00 00 00 21")),
        f9("02 01 64 1F 00 00 00 00 86")
    );
}

#[test]
fn computed_requests_15_3() {
    let cases: &[(&str, [u8; FRAME_LEN])] = &[
        ("01 0E 02 02 00 00 00 01 14", req(1, 14, 2, 2, 1)),
        ("01 0F 01 00 00 00 00 00 11", req(1, 15, 1, 0, 0)),
        ("01 0F 00 01 00 00 00 00 11", req(1, 15, 0, 1, 0)),
        ("01 09 4B 00 00 00 00 0F 64", req(1, 9, 75, 0, 15)),
        ("01 09 41 00 00 00 00 07 52", req(1, 9, 65, 0, 7)),
        ("01 09 49 00 00 00 04 D2 29", req(1, 9, 73, 0, 1234)),
        ("01 05 04 00 00 07 D0 00 E1", req(1, 5, 4, 0, 512000)),
        ("01 05 81 00 00 00 00 01 88", req(1, 5, 129, 0, 1)),
        ("01 06 85 00 00 00 00 00 8C", req(1, 6, 133, 0, 0)),
        ("01 1E 00 FF 00 00 00 00 1E", req(1, 30, 0, 255, 0)),
        ("01 1B 00 00 00 00 00 32 4E", req(1, 27, 0, 0, 50)),
        ("01 13 09 00 7F FF FF FF 99", req(1, 19, 9, 0, i32::MAX)),
        ("01 01 00 00 FF FF FF FF FE", req(1, 1, 0, 0, -1)),
        ("03 01 00 00 00 00 27 10 3B", req(3, 1, 0, 0, 10000)),
        ("01 41 00 00 00 00 00 00 42", req(1, 65, 0, 0, 0)),
        ("01 41 01 00 00 00 00 00 43", req(1, 65, 1, 0, 0)),
        ("01 80 00 00 00 00 00 00 81", req(1, 128, 0, 0, 0)),
        ("01 81 01 00 00 00 00 08 8B", req(1, 129, 1, 0, 8)),
        ("01 84 00 00 00 00 00 00 85", req(1, 132, 0, 0, 0)),
        ("01 85 00 00 00 00 00 00 86", req(1, 133, 0, 0, 0)),
        ("01 87 00 00 00 00 00 00 88", req(1, 135, 0, 0, 0)),
        ("01 88 00 00 00 00 00 00 89", req(1, 136, 0, 0, 0)),
        ("01 88 01 00 00 00 00 00 8A", req(1, 136, 1, 0, 0)),
        ("01 89 00 00 00 00 04 D2 60", req(1, 137, 0, 0, 1234)),
        ("01 0A 82 00 00 00 00 00 8D", req(1, 10, 130, 0, 0)),
        ("01 07 04 00 00 00 00 00 0C", req(1, 7, 4, 0, 0)),
        ("01 0B 00 02 00 00 00 00 0E", req(1, 11, 0, 2, 0)),
        ("01 0D 00 00 00 00 00 00 0E", req(1, 13, 0, 0, 0)),
        ("01 0D 02 00 00 00 00 00 10", req(1, 13, 2, 0, 0)),
    ];
    for (hex, got) in cases {
        assert_eq!(*got, f9(hex), "{hex}");
    }
    let bad = f9("01 01 00 00 00 00 27 10 38");
    assert!(Request::parse(&bad).is_err());
}

#[test]
fn computed_replies_15_4_from_a_drive() {
    let mut d = drive();
    assert_eq!(
        send(&mut d, f9("01 01 00 00 00 00 27 10 39")),
        f9("02 01 64 01 00 00 27 10 9F"),
        "ROR 0,10000 echoes its value (D3)"
    );
    // The zeroed-value variant of the same reply is only a checksum check.
    assert_eq!(
        Reply {
            host: 2,
            module: 1,
            status: 100,
            op: 1,
            value: 0
        }
        .to_bytes(),
        f9("02 01 64 01 00 00 00 00 68")
    );
    assert_eq!(
        send(&mut d, f9("01 05 06 00 00 00 00 B0 BC")),
        f9("02 01 64 05 00 00 00 B0 1C")
    );
    send(&mut d, req(1, 3, 0, 0, 0));
    d.run_ms(2000);
    send(&mut d, req(1, 5, 1, 0, -10000));
    assert_eq!(
        send(&mut d, f9("01 06 01 00 00 00 00 00 08")),
        f9("02 01 64 06 FF FF D8 F0 33")
    );
    assert_eq!(
        send(&mut d, f9("01 01 00 00 00 00 27 10 38")),
        f9("02 01 01 01 00 00 00 00 05"),
        "bad checksum: status 1, instruction echoed, value 0 (D2)"
    );
    assert_eq!(
        send(&mut d, req(1, 99, 0, 0, 0)),
        f9("02 01 02 63 00 00 00 00 68")
    );
    assert_eq!(
        send(&mut d, req(1, 4, 3, 0, 0)),
        f9("02 01 03 04 00 00 00 00 0A")
    );
    assert_eq!(
        send(&mut d, req(1, 22, 0, 0, 20)),
        f9("02 01 06 16 00 00 00 00 1F")
    );
    assert_eq!(
        send(&mut d, f9("01 88 01 00 00 00 00 00 8A")),
        f9("02 01 64 88 05 50 01 31 76")
    );
    assert_eq!(
        send(&mut d, f9("01 88 00 00 00 00 00 00 89")),
        f9("02 31 33 36 30 56 31 33 31")
    );
    assert_eq!(
        version_string_reply(2, b"1360V131"),
        f9("02 31 33 36 30 56 31 33 31")
    );
    assert_eq!(
        send(&mut d, f9("01 41 01 00 00 00 00 00 43")),
        f9("02 01 64 41 00 00 00 01 A9")
    );
    assert_eq!(
        send(&mut d, f9("01 81 01 00 00 00 00 08 8B")),
        f9("02 01 64 81 00 00 00 08 F0")
    );
    assert_eq!(
        send(&mut d, f9("01 87 00 00 00 00 00 00 88")),
        f9("02 01 64 87 00 00 00 01 EF"),
        "135 while the program runs"
    );
    // EEPROM lock, then SGP → status 5.
    assert_eq!(
        send(&mut d, f9("01 09 49 00 00 00 04 D2 29")),
        Reply {
            host: 2,
            module: 1,
            status: 100,
            op: 9,
            value: 1234
        }
        .to_bytes()
    );
    assert_eq!(
        send(&mut d, f9("01 09 42 00 00 00 00 03 4F")),
        f9("02 01 05 09 00 00 00 00 11")
    );
    // A drive at address 3.
    let mut d3 = Drive::new(DriveSpec {
        address: 3,
        ..DriveSpec::default()
    });
    assert!(d3.handle_frame(&f9("01 0A 42 00 00 00 00 00 4D")).is_none());
    assert_eq!(
        send(&mut d3, req(3, 10, 66, 0, 0)),
        f9("02 03 64 0A 00 00 00 03 76")
    );
    assert_eq!(
        send(&mut d3, f9("03 01 00 00 00 00 27 10 3B")),
        f9("02 03 64 01 00 00 27 10 A1")
    );
}

/// The jump-table program of §12 as downloaded in §15.5.
pub(super) const SESSION: &[(&str, &str)] = &[
    ("01 16 00 00 00 00 00 03 1A", "02 01 65 16 00 00 00 03 81"),
    ("01 16 00 00 00 00 00 08 1F", "02 01 65 16 00 00 00 08 86"),
    ("01 16 00 00 00 00 00 0C 23", "02 01 65 16 00 00 00 0C 8A"),
    ("01 04 00 00 00 00 03 E8 F0", "02 01 65 04 00 00 03 E8 57"),
    ("01 1B 01 00 00 00 00 00 1D", "02 01 65 1B 00 00 00 00 83"),
    ("01 04 00 00 00 00 00 00 05", "02 01 65 04 00 00 00 00 6C"),
    ("01 1B 01 00 00 00 00 00 1D", "02 01 65 1B 00 00 00 00 83"),
    ("01 1C 00 00 00 00 00 00 1D", "02 01 65 1C 00 00 00 00 84"),
    ("01 02 00 00 00 00 01 F4 F8", "02 01 65 02 00 00 01 F4 5F"),
    ("01 1B 00 00 00 00 00 64 80", "02 01 65 1B 00 00 00 64 E7"),
    ("01 03 00 00 00 00 00 00 04", "02 01 65 03 00 00 00 00 6B"),
    ("01 1C 00 00 00 00 00 00 1D", "02 01 65 1C 00 00 00 00 84"),
    ("01 01 00 00 00 00 03 E8 ED", "02 01 65 01 00 00 03 E8 54"),
    ("01 1B 00 00 00 00 02 BC DA", "02 01 65 1B 00 00 02 BC 41"),
    ("01 03 00 00 00 00 00 00 04", "02 01 65 03 00 00 00 00 6B"),
    ("01 1C 00 00 00 00 00 00 1D", "02 01 65 1C 00 00 00 00 84"),
];

/// Download the §15.5 session into `d`, checking every reply byte for byte.
pub(super) fn download_session(d: &mut Drive) {
    assert_eq!(
        send(d, f9("01 84 00 00 00 00 00 00 85")),
        f9("02 01 64 84 00 00 00 00 EB")
    );
    for (rq, rp) in SESSION {
        assert_eq!(send(d, f9(rq)), f9(rp), "{rq}");
    }
    assert_eq!(
        send(d, f9("01 85 00 00 00 00 00 00 86")),
        f9("02 01 64 85 00 00 00 00 EC")
    );
}

#[test]
fn download_session_15_5_then_func2_runs_to_its_result() {
    let mut d = drive();
    download_session(&mut d);
    assert_eq!(d.eeprom().program.len(), 16);
    // Nothing moved while downloading: the instructions were stored, not executed.
    assert_eq!(d.get_ap(1), Ok(0));
    assert_eq!(
        send(&mut d, f9("01 81 01 00 00 00 00 08 8B")),
        f9("02 01 64 81 00 00 00 08 F0")
    );
    d.run_ms(500);
    assert!(d.get_ap(3).unwrap() < 0, "ROL 500 turns negative");
    d.run_ms(1500);
    assert_eq!(
        send(&mut d, f9("01 87 00 00 00 00 00 00 88")),
        f9("02 01 64 87 00 00 00 00 EE"),
        "135 → 0 (stopped)"
    );
    assert_eq!(
        send(&mut d, f9("01 0A 82 00 00 00 00 00 8D")),
        Reply {
            host: 2,
            module: 1,
            status: 100,
            op: 10,
            value: 11
        }
        .to_bytes(),
        "GGP 130 → 11: the PC stays on STOP"
    );
    assert_eq!(d.get_ap(3), Ok(0), "MST ran: stopped");
    assert!(d.get_ap(1).unwrap() < -400, "turned about 500 µsteps left");
}
