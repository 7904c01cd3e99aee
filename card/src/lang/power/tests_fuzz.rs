//! Fuzzing the Power dialect's input (issue 9 item 2, as the Power PMAC inputs landed): random
//! command lines built from the dialect's words (buffers, rotary, M-pointer definitions,
//! `backup`, elements, motion and PLC commands) and raw bytes, with the servo running between
//! them. Every line is answered (an ACK, or nothing for `$$$`) within a bound, nothing panics,
//! and the card still answers afterwards. The M-pointer codec round-trips whatever it accepts.

use crate::domain::PowerErr;
use std::time::{Duration, Instant};

use proptest::prelude::*;

use super::mptr;
use super::tests_programs::T;

const WORDS: &[&str] = &[
    "Motor[1].JogSpeed",
    "Motor[1].JogSpeed=",
    "Motor[99].ActPos",
    "Coord[1].Ta",
    "Sys.Ddata[5]",
    "Sys.Idata[65535]=",
    "Gate3[0].MacroEnableA",
    "Gate3[0].MacroOutA[2][0]=",
    "Ldata.CmdCount",
    "M1->",
    "M2->u.user:$10.4.4",
    "M3->*s.16",
    "M4->Motor[1].ActPos",
    "M5->d.io:$A00008",
    "M(P1)->",
    "M16383=",
    "Sys.M[2]",
    "backup",
    "backup Motor[1].",
    "backup Mdefs",
    "backup Gates",
    "define rotary 4096",
    "delete rotary",
    "open rotary",
    "open prog 1",
    "open prog 2,256,512",
    "open plc 1",
    "open subprog 3",
    "close",
    "list prog 1",
    "enable plc 1",
    "disable plc 1",
    "cx",
    "cpx",
    "cmd\"P1=1\"",
    "send 1,\"x\"",
    "X1",
    "inc",
    "abs",
    "linear",
    "dwell 5",
    "&1",
    "#1",
    "#1->1000X",
    "j+",
    "j/",
    "j=100",
    "k",
    "b0",
    "b1",
    "r",
    "a",
    "echo7",
    "echo0",
    "?",
    "P1=",
    "P(P1)",
    "Q5",
    "L3=",
    "if",
    "while",
    "(",
    ")",
    "{",
    "}",
    "=",
    "==",
    "1",
    "-1",
    "1e308",
    "$A00000",
    ".",
    ":",
    "[",
    "]",
    ",",
];

fn word() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        8 => proptest::sample::select(WORDS).prop_map(|w| w.as_bytes().to_vec()),
        1 => (0u32..100_000).prop_map(|n| n.to_string().into_bytes()),
        1 => proptest::collection::vec(any::<u8>(), 1..4),
    ]
}

/// A line of Power words with random separators, or random bytes.
fn line() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        6 => proptest::collection::vec((word(), prop_oneof![Just(""), Just(" ")]), 0..12)
            .prop_map(|ws| ws.into_iter().flat_map(|(w, s)| [w, s.as_bytes().to_vec()]).flatten().collect()),
        1 => proptest::collection::vec(any::<u8>(), 0..300),
    ]
}

/// The bound on one line's service (debug build, loaded machine).
const BOUND: Duration = Duration::from_secs(5);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn fuzz_power_lines_are_answered_within_a_bound(
        lines in proptest::collection::vec(line(), 1..16),
        gaps in proptest::collection::vec(0u64..30, 1..16),
    ) {
        let mut t = T::new();
        for (k, l) in lines.iter().enumerate() {
            // A generous wall-clock upper bound (a hang fails here, not a slow machine).
            #[allow(clippy::disallowed_methods)]
            let t0 = Instant::now();
            let out = t.raw(l);
            prop_assert!(t0.elapsed() < BOUND, "{:?} took {:?}", String::from_utf8_lossy(l), t0.elapsed());
            let text = String::from_utf8_lossy(l).trim().to_ascii_lowercase();
            if text != "$$$" && text != "$$$***" {
                prop_assert!(out.ends_with(b"\x06\r\n"), "no ACK for {:?}: {:?}", text, String::from_utf8_lossy(&out));
            }
            t.run(gaps[k % gaps.len()]);
        }
        // Still answering (a buffer left open takes the line; close it first).
        let _ = t.raw(b"close");
        let _ = t.raw(b"echo0");
        prop_assert_eq!(t.send("L7=3 L7"), "L7=3\r\n");
    }

    #[test]
    fn fuzz_m_pointer_definitions_round_trip(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
        if let Ok(Some((p, len))) = mptr::parse(&bytes) {
            prop_assert!(len <= bytes.len());
            let text = mptr::text(&p);
            let again = mptr::parse(text.as_bytes());
            prop_assert_eq!(again, Ok(Some((p, text.len()))));
        }
    }

    #[test]
    fn fuzz_m_pointer_texts_round_trip(
        fmt in proptest::sample::select(&["s", "i", "u", "f", "d"][..]),
        bank in proptest::sample::select(&["user", "io"][..]),
        word in 0u32..262_144,
        bit in proptest::option::of((0u32..32, proptest::option::of(1u32..33))),
    ) {
        let mut s = format!("{fmt}.{bank}:${:X}", word * 4);
        if let Some((b, w)) = bit {
            s.push_str(&format!(".{b}"));
            if let Some(w) = w {
                s.push_str(&format!(".{w}"));
            }
        }
        match mptr::parse(s.as_bytes()) {
            Ok(Some((p, len))) => {
                prop_assert_eq!(len, s.len());
                prop_assert_eq!(mptr::parse(mptr::text(&p).as_bytes()), Ok(Some((p, mptr::text(&p).len()))));
            }
            Err(e) => prop_assert!(e.code == PowerErr::IllegalParameter, "{s}: {e:?}"),
            Ok(None) => prop_assert!(false, "{s}: not a definition"),
        }
    }
}
