//! Fuzzing the card's host decoders with proptest: command lines (the PMAC dialect, built from
//! its own words so the interpreter is reached, and raw bytes), the ASCII terminal stream in any
//! segmentation, PMAC Ethernet packets (whole, cut anywhere, garbage), the daisy-chain input,
//! and save files. Each input: no panic, an answer within a bounded number of servo-thread
//! slices, the card still answers afterwards; round trips where an encoder exists.
//!
//! The unit tests run a bounded number of cases; a longer run:
//! `PROPTEST_CASES=20000 cargo test -p mcc-card --lib fuzz_` (README, Reliability).

use proptest::prelude::*;

use super::ascii::AsciiCodec;
use super::eth_codec::{
    request, EthAction, EthConn, Header, HEADER_LEN, MAX_PAYLOAD, VR_DOWNLOAD, VR_UPLOAD,
};
use super::port::{run_events, Interpreter};
use crate::core::{CardCore, HostRequest, SLICE_UNITS};
use crate::domain::Profile;
use crate::lang::{Budget, Card, Effect, EffectResult};
use crate::model::persist;

/// Most servo-thread slices one request may take (the heaviest legal line, 1 KB of
/// `P0..8191`, takes well under a thousand).
const MAX_SLICES: usize = 5_000;
/// Longest reply one request may produce, bytes.
const MAX_REPLY: usize = 16 << 20;

/// The card's core behind the host-port seam, serving each request in slices as the servo
/// thread does and counting them.
struct CoreInterp {
    core: CardCore,
    token: u64,
    cycle: u64,
}

impl CoreInterp {
    fn new(profile: Profile) -> Self {
        CoreInterp {
            core: CardCore::new(Card::new(profile)),
            token: 0,
            cycle: 0,
        }
    }

    fn ask(&mut self, req: HostRequest) -> Vec<u8> {
        self.token += 1;
        self.core.submit(self.token, 1, req);
        let mut slices = 0;
        let mut out = Vec::new();
        while self.core.pending() > 0 {
            let mut b = Budget::new(SLICE_UNITS);
            self.core.serve(&mut b);
            slices += 1;
            for (_, r) in self.core.take_replies() {
                out.extend_from_slice(&r.bytes);
            }
            for (t, e) in self.core.take_effects() {
                let r = match e {
                    Effect::Save(_) => EffectResult::Saved(true),
                    Effect::Load => EffectResult::Loaded(Ok(None)),
                };
                self.core.effect_done(t, r);
            }
            // The servo keeps ticking between slices (programs, PLCs, motors).
            self.cycle += 1;
            self.core.tick(self.cycle);
            assert!(
                slices <= MAX_SLICES,
                "request not answered within {MAX_SLICES} slices"
            );
        }
        for (_, r) in self.core.take_replies() {
            out.extend_from_slice(&r.bytes);
        }
        assert!(out.len() <= MAX_REPLY, "reply of {} bytes", out.len());
        out
    }

    /// Run the servo for `n` cycles (programs and PLCs the input started keep running).
    fn run(&mut self, n: u64) {
        for _ in 0..n {
            self.cycle += 1;
            self.core.tick(self.cycle);
        }
    }

    /// The card still works: an open buffer closed, a P-variable written and read back.
    fn still_answers(&mut self) {
        let _ = self.ask(HostRequest::Control(0x01)); // CTRL-A: stop everything
        let _ = self.ask(HostRequest::Line(b"CLOSE".to_vec()));
        let r = self.ask(HostRequest::Line(b"P1=7 P1".to_vec()));
        assert!(
            r.windows(2).any(|w| w == b"7\r"),
            "card no longer answers: {:?}",
            String::from_utf8_lossy(&r)
        );
    }
}

impl Interpreter for CoreInterp {
    fn line(&mut self, line: &[u8]) -> Vec<u8> {
        self.ask(HostRequest::Line(line.to_vec()))
    }

    fn control(&mut self, c: u8) -> Vec<u8> {
        self.ask(HostRequest::Control(c))
    }

    fn overlong(&mut self) -> Vec<u8> {
        self.ask(HostRequest::Line(super::port::overlong_probe()))
    }
}

/// Words, numbers and punctuation of the PMAC language, so random lines get past the lexer
/// into the parser and the interpreter.
const WORDS: &[&str] = &[
    "P",
    "Q",
    "I",
    "M",
    "L",
    "F",
    "#",
    "&",
    "1",
    "2",
    "3",
    "8",
    "13",
    "100",
    "1023",
    "8191",
    "0.5",
    "-1",
    "1E3",
    "$1F",
    "$$$",
    "$$",
    "$",
    "=",
    "==",
    "!=",
    ">",
    "<",
    "+",
    "-",
    "*",
    "/",
    "%",
    "^",
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    ",",
    ":",
    "..",
    ".",
    "'",
    "\"",
    "->",
    "X",
    "Y",
    "Z",
    "A",
    "B",
    "C",
    "U",
    "V",
    "W",
    "J+",
    "J-",
    "J/",
    "J=",
    "J^",
    "K",
    "O",
    "R",
    "S",
    "H",
    "Q",
    "?",
    "??",
    "???",
    "A",
    "ABS",
    "INC",
    "LINEAR",
    "RAPID",
    "CIRCLE1",
    "SPLINE1",
    "PVT",
    "TA",
    "TS",
    "TM",
    "DWELL",
    "DELAY",
    "WHILE",
    "ENDWHILE",
    "ENDW",
    "IF",
    "ELSE",
    "ENDIF",
    "ENDI",
    "GOTO",
    "GOSUB",
    "CALL",
    "RETURN",
    "N",
    "OPEN",
    "PROG",
    "PLC",
    "ROTARY",
    "CLOSE",
    "CLEAR",
    "LIST",
    "DELETE",
    "GATHER",
    "DEFINE",
    "UNDEFINE",
    "ALL",
    "LOOKAHEAD",
    "UBUFFER",
    "COMP",
    "ENABLE",
    "DISABLE",
    "SAVE",
    "SIN",
    "COS",
    "ATAN2",
    "SQRT",
    "ABS",
    "INT",
    "EXP",
    "LN",
    "AND",
    "OR",
    "CMD",
    "SEND",
    "DISPLAY",
    "HOME",
    "HOMEZ",
    "FRAX",
    "PSET",
    "ADDRESS",
    "MACRO",
    "MS",
    "MSR",
    "MSW",
    "MX",
    "CID",
    "VER",
    "TYPE",
    "SID",
    "PASSWORD",
    "SIZE",
    "@",
    "D",
    "X:",
    "Y:",
    "$0720",
    "->X:$C000,24",
    "->D:$0",
    "->*",
    "->L:$1",
    "LH",
    "BLOCKSTART",
    "BSTART",
    "STOP",
    "ENDGATHER",
    "TIMER",
    "PE",
    "V",
    "P0..8191",
];

const SEPARATORS: &[&[u8]] = &[b"", b" ", b"  "];

fn word() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        8 => proptest::sample::select(WORDS).prop_map(|w| w.as_bytes().to_vec()),
        1 => (0u32..100_000).prop_map(|n| n.to_string().into_bytes()),
        1 => proptest::collection::vec(any::<u8>(), 1..4),
    ]
}

/// A line of PMAC words with random separators, or random bytes.
fn line() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        6 => proptest::collection::vec((word(), proptest::sample::select(SEPARATORS)), 0..24)
            .prop_map(|ws| ws.into_iter().flat_map(|(w, s)| [w, s.to_vec()]).flatten().collect()),
        1 => proptest::collection::vec(any::<u8>(), 0..300),
    ]
}

/// A stream of lines, some cut or joined, with control characters between them.
fn stream() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(
        (
            line(),
            prop_oneof![
                Just(vec![13u8]),
                Just(vec![13, 10]),
                (0u8..32).prop_map(|c| vec![c])
            ],
        ),
        0..12,
    )
    .prop_map(|ls| {
        ls.into_iter()
            .flat_map(|(l, end)| [l, end])
            .flatten()
            .collect()
    })
}

fn profile() -> impl Strategy<Value = Profile> {
    prop_oneof![Just(Profile::Pmac2), Just(Profile::Turbo)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Command lines straight to the card, the servo running between them.
    #[test]
    fn fuzz_command_lines_are_answered_within_a_bound(
        p in profile(),
        lines in proptest::collection::vec(line(), 1..16),
        gaps in proptest::collection::vec(0u64..40, 1..16),
    ) {
        let mut c = CoreInterp::new(p);
        for (k, l) in lines.iter().enumerate() {
            let _ = c.line(l);
            c.run(gaps[k % gaps.len()]);
        }
        c.still_answers();
    }

    /// The terminal port's byte stream in any segmentation.
    #[test]
    fn fuzz_ascii_stream_in_any_segmentation(
        bytes in stream(),
        cuts in proptest::collection::vec(1usize..64, 1..16),
    ) {
        let mut c = CoreInterp::new(Profile::Pmac2);
        let mut codec = AsciiCodec::new();
        let mut rest = &bytes[..];
        let mut k = 0;
        while !rest.is_empty() {
            let n = cuts[k % cuts.len()].min(rest.len());
            let mut out = Vec::new();
            run_events(codec.feed(&rest[..n]), &mut c, &mut out);
            prop_assert!(codec.partial().len() <= super::ascii::MAX_LINE);
            rest = &rest[n..];
            k += 1;
        }
        c.still_answers();
    }

    /// PMAC Ethernet packets: well-formed requests carrying random lines, requests with wrong
    /// types or lengths, and garbage, in any segmentation. The connection either answers or
    /// closes with a reason; it never holds more than one packet's worth of input or more
    /// than one reply.
    #[test]
    fn fuzz_ethernet_packets(
        packets in proptest::collection::vec(eth_packet(), 1..10),
        cuts in proptest::collection::vec(1usize..200, 1..16),
    ) {
        let bytes: Vec<u8> = packets.concat();
        let mut c = CoreInterp::new(Profile::Turbo);
        let mut conn = EthConn::new();
        let mut closed = false;
        let mut rest = &bytes[..];
        let mut k = 0;
        while !rest.is_empty() {
            let n = cuts[k % cuts.len()].min(rest.len());
            let actions = conn.feed(&rest[..n], &mut c);
            if closed {
                prop_assert!(actions.is_empty(), "a closed connection answered");
            }
            for a in actions {
                match a {
                    EthAction::Send(b) => prop_assert!(!b.is_empty() && b.len() <= 1500),
                    EthAction::Close(_) => closed = true,
                }
            }
            prop_assert!(conn.pending_len() <= MAX_REPLY);
            rest = &rest[n..];
            k += 1;
        }
        c.still_answers();
    }

    /// Daisy-chain input (the `@n` addressing protocol and lines) on any connection.
    #[test]
    fn fuzz_daisy_chain_input(
        chunks in proptest::collection::vec((0u64..3, chain_bytes()), 1..12),
    ) {
        let mut card = Card::new(Profile::Pmac2);
        let mut port = crate::core::chain::ChainPort::new();
        for (id, data) in &chunks {
            // A line waiting for the ring (`MS…` on a card without one) parks: no reply yet.
            let answer = port.feed(&mut card, &mut crate::lang::Dialect::Pmac, *id, data, &mut crate::lang::Budget::unlimited()).unwrap_or_default();
            for (pos, reply) in answer.segments {
                prop_assert!((pos as usize) < data.len());
                prop_assert!(reply.len() <= MAX_REPLY);
            }
            for (pos, _) in answer.refusals {
                prop_assert!((pos as usize) < data.len());
            }
        }
        for id in 0..3 {
            port.close(&mut card, &mut crate::lang::Dialect::Pmac, id);
        }
        let mut s = crate::lang::Session::with_id(9);
        let _ = card.command_line(&mut s, b"CLOSE");
        let r = card.command_line(&mut s, b"P1=7 P1");
        prop_assert!(r.windows(2).any(|w| w == b"7\r"), "{:?}", String::from_utf8_lossy(&r));
    }

    /// Save files: random bytes, a real file cut or with bytes changed, and a real file whose
    /// JSON payload was changed with a correct checksum (so the content is parsed). Each is
    /// loaded by `$$$`: either the saved state or factory defaults with the EAROM error bit;
    /// the card keeps answering.
    #[test]
    fn fuzz_save_files(
        which in 0u8..4,
        junk in proptest::collection::vec(any::<u8>(), 0..400),
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
    ) {
        let good = saved_file();
        let bytes = match which {
            0 => junk,
            1 => good[..cut.index(good.len())].to_vec(),
            2 => {
                let mut b = good.clone();
                for (i, v) in &edits {
                    let i = i.index(b.len());
                    b[i] = *v;
                }
                b
            }
            _ => {
                let (version, mut payload) = split_file(&good);
                for (i, v) in &edits {
                    let i = i.index(payload.len());
                    // Keep it mostly text: JSON punctuation, digits, letters.
                    payload[i] = b"{}[],:\"0123456789.-eEtrufalsn \\"[usize::from(*v) % 30];
                }
                wrap_file(version, &payload)
            }
        };
        let unchanged = bytes == good;
        let mut c = CoreInterp::new(Profile::Pmac2);
        let r = c.core_load(bytes);
        if which <= 2 {
            // Junk and a cut file never load; a changed file loads only if its bytes are
            // the good ones again (the checksum catches every other change).
            prop_assert_eq!(r.is_ok(), unchanged, "{:?}", r);
        }
        let status = c.line(b"???");
        if r.is_err() {
            // Factory defaults, `???` word 1 bit 10 (EAROM error) set.
            let hex: Vec<u8> = status.iter().copied().filter(u8::is_ascii_hexdigit).collect();
            let w1 = hex.get(0..6).and_then(|w| std::str::from_utf8(w).ok()).and_then(|w| u32::from_str_radix(w, 16).ok());
            prop_assert!(w1.is_some_and(|w| w & (1 << 10) != 0), "{:?}", String::from_utf8_lossy(&status));
        }
        c.still_answers();
    }

    /// A save image round-trips through its file format.
    #[test]
    fn save_file_round_trip(
        qvals in proptest::collection::vec(-1e6f64..1e6, 0..32),
        pvals in proptest::collection::vec(-1e9f64..1e9, 0..64),
        password in "[A-Z0-9]{0,8}",
    ) {
        let mut card = Card::new(Profile::Pmac2);
        let mut s = crate::lang::Session::with_id(1);
        let _ = card.command_line(&mut s, format!("PASSWORD={password}").as_bytes());
        for (k, v) in pvals.iter().enumerate() {
            let _ = card.command_line(&mut s, format!("P{k}={v}").as_bytes());
        }
        for (k, v) in qvals.iter().enumerate() {
            let _ = card.command_line(&mut s, format!("&1Q{}={v}", k + 1).as_bytes());
        }
        let file = card.save_image();
        let image = persist::decode(&file).expect("own file");
        prop_assert!(persist::encode(&image) == file, "encode(decode(file)) differs");
        let mut back = Card::new(Profile::Pmac2);
        back.apply_loaded(EffectResult::Loaded(Ok(Some(file.clone())))).expect("loads");
        let again = persist::decode(&back.save_image()).expect("own file");
        prop_assert_eq!(diff(&image, &again), None);
    }
}

/// The first field in which two images differ (name and both values, shortened).
fn diff(a: &persist::PersistImage, b: &persist::PersistImage) -> Option<String> {
    let (ja, jb) = (
        serde_json::to_value(a).unwrap(),
        serde_json::to_value(b).unwrap(),
    );
    let (oa, ob) = (ja.as_object().unwrap(), jb.as_object().unwrap());
    for (k, va) in oa {
        let vb = &ob[k];
        if va != vb {
            if let (Some(xa), Some(xb)) = (va.as_array(), vb.as_array()) {
                for (i, (ea, eb)) in xa.iter().zip(xb).enumerate() {
                    if ea != eb {
                        let s = format!("{k}[{i}]: {ea} vs {eb}");
                        return Some(s.chars().take(400).collect());
                    }
                }
                return Some(format!("{k}: {} vs {} elements", xa.len(), xb.len()));
            }
            return Some(format!("{k}: {va} vs {vb}").chars().take(400).collect());
        }
    }
    None
}

impl CoreInterp {
    /// `$$$` with `bytes` as the saved file; the load's result.
    fn core_load(&mut self, bytes: Vec<u8>) -> Result<(), String> {
        self.core
            .card
            .apply_loaded(EffectResult::Loaded(Ok(Some(bytes))))
    }
}

fn eth_packet() -> impl Strategy<Value = Vec<u8>> {
    let good = (
        proptest::sample::select(&[0xB0u8, 0xB1, 0xB3, 0xBF, 0xC2, 0xC4, 0xC5, 0xC6][..]),
        line(),
        any::<u16>(),
    )
        .prop_map(|(req, l, v)| {
            let l = &l[..l.len().min(MAX_PAYLOAD)];
            let ty = if matches!(req, 0xC2 | 0xC4 | 0xC5) {
                VR_UPLOAD
            } else {
                VR_DOWNLOAD
            };
            if ty == VR_UPLOAD {
                request(ty, req, v, 1400, &[])
            } else {
                request(ty, req, v, l.len() as u16, l)
            }
        });
    let header = (
        any::<[u8; HEADER_LEN]>(),
        proptest::collection::vec(any::<u8>(), 0..64),
    )
        .prop_map(|(h, rest)| {
            let h = Header::parse(&h);
            let mut b = h.to_bytes().to_vec();
            b.extend_from_slice(&rest);
            b
        });
    prop_oneof![
        8 => good,
        1 => header,
        1 => proptest::collection::vec(any::<u8>(), 0..40),
    ]
}

fn chain_bytes() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(
        prop_oneof![
            4 => line(),
            2 => (0u8..16).prop_map(|n| format!("@{n:X}").into_bytes()),
            1 => Just(b"@@".to_vec()),
            2 => proptest::sample::select(&[13u8, 10, 6, 7, 1, 2, 4, 11, 24, 0][..]).prop_map(|c| vec![c]),
        ],
        0..10,
    )
    .prop_map(|v| v.concat())
}

/// A save file of a card with programs, PLCs, M-definitions and variables.
fn saved_file() -> Vec<u8> {
    let mut card = Card::new(Profile::Pmac2);
    let mut s = crate::lang::Session::with_id(1);
    for l in [
        "P1=3 P2=4.5 Q1=2 I130=3000 M1->X:$C000,0,24,S M2->Y:$0720,0,16",
        "OPEN PROG 1 CLEAR LINEAR TA20 X(P1) DWELL 10 X0 CLOSE",
        "OPEN PLC 3 CLEAR IF (P1>2) P2=P2+1 ENDIF CLOSE",
        "&1#1->1000X",
        "DEFINE UBUFFER 100",
    ] {
        let _ = card.command_line(&mut s, l.as_bytes());
    }
    card.save_image()
}

/// (format version, payload) of a save file.
fn split_file(file: &[u8]) -> (u32, Vec<u8>) {
    let version = u32::from_le_bytes(file[8..12].try_into().unwrap());
    (version, file[20..file.len() - 8].to_vec())
}

/// A save file around `payload` with a correct length and checksum.
fn wrap_file(version: u32, payload: &[u8]) -> Vec<u8> {
    let mut b = persist::MAGIC.to_vec();
    b.extend_from_slice(&version.to_le_bytes());
    b.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    b.extend_from_slice(payload);
    b.extend_from_slice(&persist::fnv1a64(payload).to_le_bytes());
    b
}

#[test]
fn the_save_file_layout_the_fuzzer_rewraps_is_the_real_one() {
    let good = saved_file();
    let (v, payload) = split_file(&good);
    assert_eq!(v, persist::VERSION);
    assert_eq!(wrap_file(v, &payload), good);
    assert_eq!(HEADER_LEN, 8);
}
