//! Chain semantics (§8.3) on in-process cards: every card sees every byte, replies merged in
//! input order as the orchestrator does. Cards run with I3=2 I6=1 (compact framing).

use super::*;
use crate::domain::{ErrCode, PowerErr, Profile, Refusal};
use mcc_contracts::control::chain::{decode_reply, decode_request, encode_request};
use mcc_contracts::control::CardRefusal;

/// A simulated cable: cards with their chain receivers.
struct Cable {
    cards: Vec<(Card, ChainPort)>,
    /// The language of each card (a `power` card's lines run in its dialect).
    power: Vec<Dialect>,
}

impl Cable {
    fn new(n: u8) -> Self {
        let cards = (0..n)
            .map(|k| {
                let mut c = Card::new(Profile::Pmac2);
                apply_chain_defaults(&mut c, k);
                // Compact framing: data lines end in <CR>, one <ACK> per line, ERRnnn shown.
                c.command_line(&mut Session::default(), b"I3=2 I6=1");
                (c, ChainPort::new())
            })
            .collect();
        let power = (0..n).map(|_| Dialect::Pmac).collect();
        Cable { cards, power }
    }

    /// Card 0 a Power card, card 1 a PMAC2 card.
    fn mixed() -> Self {
        let mut c = Cable::new(2);
        let mut p = Card::new(Profile::Power);
        apply_chain_defaults(&mut p, 0);
        c.cards[0].0 = p;
        c.power[0] = Dialect::for_card(&mut c.cards[0].0);
        c
    }

    /// Broadcast `data` on connection `conn`; merged replies (position, then card order).
    fn send(&mut self, conn: u64, data: &[u8]) -> Vec<u8> {
        let mut segs: Vec<(u32, usize, Vec<u8>)> = Vec::new();
        let cards = self.cards.iter_mut().zip(self.power.iter_mut());
        for (k, ((card, port), power)) in cards.enumerate() {
            for (p, b) in port
                .feed(
                    card,
                    power,
                    conn,
                    data,
                    &mut crate::lang::Budget::unlimited(),
                )
                .unwrap_or_default()
                .segments
            {
                segs.push((p, k, b));
            }
        }
        segs.sort_by_key(|s| (s.0, s.1));
        segs.into_iter().flat_map(|s| s.2).collect()
    }

    /// Ask card `k` directly (not through the chain).
    fn ask(&mut self, k: usize, line: &str) -> Vec<u8> {
        self.cards[k]
            .0
            .command_line(&mut Session::default(), line.as_bytes())
    }
}

#[test]
fn addressed_card_takes_and_answers_the_line() {
    let mut c = Cable::new(2);
    assert_eq!(c.send(1, b"@1P1=5\r"), b"\x06");
    assert_eq!(c.send(1, b"@0P1\r"), b"0\r\x06");
    assert_eq!(c.send(1, b"@1P1\r"), b"5\r\x06");
    assert_eq!(c.ask(0, "P1"), b"0\r\x06");
    // Power-up: card 0 is addressed.
    assert_eq!(c.send(2, b"P1\r"), b"0\r\x06");
}

#[test]
fn one_line_for_two_cards_runs_on_both_at_the_cr() {
    let mut c = Cable::new(2);
    // Only the card addressed at the <CR> (card 1) answers.
    assert_eq!(c.send(1, b"@0P2=11@1P2=22\r"), b"\x06");
    assert_eq!(c.ask(0, "P2"), b"11\r\x06");
    assert_eq!(c.ask(1, "P2"), b"22\r\x06");
    // Split across chunks, `@` tokens too.
    assert_eq!(c.send(1, b"@"), b"");
    assert_eq!(c.send(1, b"0P3=3@"), b"");
    assert_eq!(c.send(1, b"1P3=4\r"), b"\x06");
    assert_eq!(c.ask(0, "P3"), b"3\r\x06");
    assert_eq!(c.ask(1, "P3"), b"4\r\x06");
}

#[test]
fn at_at_runs_everywhere_card_0_answers_and_refuses_queries() {
    let mut c = Cable::new(3);
    assert_eq!(c.send(1, b"@@P1=7\r"), b"\x06");
    for k in 0..3 {
        assert_eq!(c.ask(k, "P1"), b"7\r\x06");
    }
    assert_eq!(c.send(1, b"P1\r"), b"\x07ERR003\r");
    assert_eq!(c.send(1, b"@\r"), b"@\r\x06");
    // Data-reporting control characters are not accepted under `@@`.
    assert_eq!(c.send(1, b"\x02"), b"");
    assert_eq!(c.send(1, b"@2@\r"), b"2\r\x06");
    assert_eq!(c.send(1, b"@A@\r"), b"");
    assert_eq!(c.send(1, b"@0@\r"), b"0\r\x06");
    // `???` word 1 bits 0/1 follow the addressing of card 0.
    assert_eq!(c.send(1, b"???\r"), b"000001000800\r\x06");
}

#[test]
fn control_characters_to_all_cards_or_only_the_addressed_one() {
    let mut c = Cable::new(2);
    assert_eq!(c.send(1, b"@1\r"), b"\x06");
    // CTRL-K kills on every card, whatever the addressing.
    assert_eq!(c.send(1, b"\x0b"), b"");
    for (card, _) in &c.cards {
        assert!(card
            .state
            .motors
            .iter()
            .all(|m| m.open_loop && !m.amp_enabled));
    }
    // CTRL-P: only the addressed card reports.
    assert_eq!(c.send(1, b"\x10"), b"0 0 0 0 0 0 0 0\r");
    // CTRL-X flushes the partial line on every card.
    assert_eq!(c.send(1, b"@0P4=1\x18@1\r"), b"\x06");
    assert_eq!(c.ask(0, "P4"), b"0\r\x06");
    // CTRL-H edits only the receiving card's buffer.
    assert_eq!(c.send(1, b"P5=12\x08\r"), b"\x06");
    assert_eq!(c.ask(1, "P5"), b"1\r\x06");
    // CTRL-N: checksum of the addressed card's partial line.
    assert_eq!(c.send(1, b"P\x0e"), vec![b'P']);
    assert_eq!(c.send(1, b"\x18"), b"");
    // CTRL-T is not allowed on a chain: ignored.
    assert_eq!(c.send(1, b"\x14P5\r"), b"1\r\x06");
    assert_eq!(c.send(1, b"P5\r"), b"1\r\x06");
}

#[test]
fn connections_have_their_own_addressing() {
    let mut c = Cable::new(2);
    assert_eq!(c.send(1, b"@1\r"), b"\x06");
    assert_eq!(c.send(2, b"@\r"), b"0\r\x06");
    assert_eq!(c.send(1, b"@\r"), b"1\r\x06");
    // A partial line of one connection does not mix with another's.
    assert_eq!(c.send(1, b"P6="), b"");
    assert_eq!(c.send(2, b"P6\r"), b"0\r\x06");
    assert_eq!(c.send(1, b"9\r"), b"\x06");
    assert_eq!(c.ask(1, "P6"), b"9\r\x06");
    assert_eq!(c.ask(0, "P6"), b"0\r\x06");
}

#[test]
fn bad_input_gets_pmac_answers_never_a_panic() {
    let mut c = Cable::new(2);
    // Unknown card: nobody answers; addressing a real card again recovers.
    assert_eq!(c.send(1, b"@7P1=3\r"), b"");
    assert_eq!(c.send(1, b"P1\r"), b"");
    assert_eq!(c.send(1, b"@0P1\r"), b"0\r\x06");
    // `@` followed by something else: the addressed card reports its number, then runs or
    // rejects the rest (`Z` is a motor command).
    assert_eq!(c.send(1, b"@Z\r"), b"0\r\x06");
    assert_eq!(c.send(1, b"@]\r"), b"0\r\x07ERR003\r");
    // An over-long line: ERR003 from the addressed card only, then carry on.
    let mut long = vec![b'P'; MAX_LINE + 50];
    long.push(b'\r');
    assert_eq!(c.send(1, &long), b"\x07ERR003\r");
    assert_eq!(c.send(1, b"P1\r"), b"0\r\x06");
    // Odd control bytes and 8-bit bytes.
    assert_eq!(c.send(1, b"\x05\x17\x1b\x00\r"), b"\x06");
    let r = c.send(1, b"P1\xff\r");
    assert!(r.starts_with(b"\x07ERR"), "{r:?}");
}

#[test]
fn without_software_addressing_the_card_answers_everything() {
    let mut c = Cable::new(1);
    assert_eq!(c.send(1, b"I1=0\r"), b"\x06");
    assert_eq!(c.send(1, b"@1\r"), b"\x07ERR003\r");
    assert_eq!(c.send(1, b"P1\r"), b"0\r\x06");
}

#[test]
fn connections_are_bounded_and_closing_frees_the_buffer() {
    let mut c = Cable::new(1);
    let (card, port) = &mut c.cards[0];
    for id in 0..(MAX_CONNECTIONS as u64 + 10) {
        let _ = port.feed(
            card,
            &mut Dialect::Pmac,
            id,
            b"P1\r",
            &mut crate::lang::Budget::unlimited(),
        );
    }
    assert_eq!(port.connections(), MAX_CONNECTIONS);
    assert_eq!(
        port.feed(
            card,
            &mut Dialect::Pmac,
            500,
            b"OPEN PROG 1 CLEAR\r",
            &mut crate::lang::Budget::unlimited()
        )
        .unwrap_or_default()
        .segments,
        vec![(17, vec![6])]
    );
    port.close(card, &mut Dialect::Pmac, 500);
    // The buffer is closed again: another connection may open one.
    assert_eq!(
        port.feed(
            card,
            &mut Dialect::Pmac,
            501,
            b"OPEN PROG 2\r",
            &mut crate::lang::Budget::unlimited()
        )
        .map(|a| a.segments),
        Some(vec![(11, vec![6])])
    );
}

impl Cable {
    /// `op` ([`OP_QUERY_START`]/[`OP_TAKE_START`]) on card `k` for connection `conn`.
    fn op(&mut self, k: usize, op: u8, conn: u64) -> Vec<u8> {
        let (card, port) = &mut self.cards[k];
        port.handle(
            card,
            &mut self.power[k],
            &Request {
                op,
                conn,
                data: &[],
            },
            &mut crate::lang::Budget::unlimited(),
        )
        .unwrap_or_default()
        .payload
    }
}

#[test]
fn lines_that_start_programs_are_handed_over_and_the_cards_stay_silent_at_the_cr() {
    let mut c = Cable::new(3);
    assert_eq!(c.send(1, b"@0&1B1R@2P1=7@1&2B7S"), b"");
    assert_eq!(c.op(0, OP_QUERY_START, 1), [FLAG_STARTS]);
    assert_eq!(c.op(1, OP_QUERY_START, 1), [FLAG_STARTS | FLAG_TALKS]);
    assert_eq!(c.op(2, OP_QUERY_START, 1), [0]);
    // The query changes nothing; an unknown connection has nothing.
    assert_eq!(c.op(0, OP_QUERY_START, 1), [FLAG_STARTS]);
    assert_eq!(c.op(0, OP_QUERY_START, 9), [0]);
    let mut t0 = vec![FLAG_STARTS];
    t0.extend_from_slice(b"#1&1&1B1R");
    assert_eq!(c.op(0, OP_TAKE_START, 1), t0);
    let mut t1 = vec![FLAG_STARTS | FLAG_TALKS];
    t1.extend_from_slice(b"#1&1&2B7S");
    assert_eq!(c.op(1, OP_TAKE_START, 1), t1);
    assert_eq!(c.op(2, OP_TAKE_START, 1), b"");
    // At the <CR> card 2 runs its line (silently: card 1 is addressed); 0 and 1 say nothing.
    assert_eq!(c.send(1, b"\r"), b"");
    assert_eq!(c.ask(2, "P1"), b"7\r\x06");
    // Card 1's connection kept the &2 of the line it handed over.
    assert_eq!(c.send(1, b"@1&\r"), b"2\r\x06");
    // Taken only once; the next <CR> executes normally again.
    assert_eq!(c.op(0, OP_TAKE_START, 1), b"");
    assert_eq!(c.send(1, b"@0\r"), b"\x06");
}

#[test]
fn lines_without_a_start_are_not_taken() {
    let mut c = Cable::new(2);
    for line in [&b"@0P1=5"[..], b"@0#1J+", b"@0OPEN PROG 1", b"@0UUU R"] {
        c.send(1, b"\x18");
        c.send(1, line);
        assert_eq!(c.op(0, OP_QUERY_START, 1), [0], "{line:?}");
        assert_eq!(c.op(0, OP_TAKE_START, 1), b"", "{line:?}");
    }
    // Requests with the new ops decode; unknown ops are still refused.
    assert!(decode_request(&encode_request(OP_TAKE_START, 3, &[])).is_ok());
    assert!(decode_request(&encode_request(b'Z', 3, &[])).is_err());
}

#[test]
fn a_chain_line_waits_for_the_ring_and_the_rest_of_its_request_follows() {
    use mcc_ring::aux_channel::{stream_word, AuxWord, Reply, ValueFormat, WordKind};
    let mut c = Cable::new(2);
    // card 1 is a ring master with Type 1 auxiliary communications on
    assert_eq!(c.ask(1, "I995=$30 I1003=32 I1000=0"), b"\x06");
    assert_eq!(c.send(1, b"@1\r"), b"\x06");
    let (card, port) = &mut c.cards[1];
    assert_eq!(
        port.feed(
            card,
            &mut Dialect::Pmac,
            1,
            b"P1=1 MS0,MI8 P1=2\rP1\r",
            &mut crate::lang::Budget::unlimited()
        ),
        None
    );
    assert!(port.is_parked(1));
    // the servo tick streams the request; the station's reply comes back around the ring
    let first = card.model.aux.servo_tick((0, 0));
    let tag = AuxWord::decode(first.0, first.1).tag;
    let reply = Reply::Value(8.0, ValueFormat::Decimal).words();
    let mut done = None;
    for k in 0..reply.len() as u64 {
        let (r2, r3) = stream_word(WordKind::Reply, tag, 0, &reply, k).encode();
        card.model.aux.servo_tick((r2, r3));
        done = port.resume(
            card,
            &mut Dialect::Pmac,
            1,
            &mut crate::lang::Budget::unlimited(),
        );
        if done.is_some() {
            break;
        }
    }
    let done = done.expect("the line finished");
    let segs = mcc_contracts::control::chain::decode_reply(&done.payload).expect("segments");
    assert!(done.refusals.is_empty(), "no line refused");
    // the parked line's reply at its <CR> (position 17), then the next line's at 20
    assert_eq!(
        segs,
        vec![(17, b"8\r\x06".to_vec()), (20, b"2\r\x06".to_vec())]
    );
    assert!(!port.is_parked(1));
    // a line whose card is not a master gets ERR008 at once (never parked)
    let (card0, port0) = &mut c.cards[0];
    assert_eq!(
        port0.feed(
            card0,
            &mut Dialect::Pmac,
            2,
            b"MS0,MI8\r",
            &mut crate::lang::Budget::unlimited()
        ),
        Some(Answer {
            segments: vec![(7, b"\x07ERR008\r".to_vec())],
            refusals: vec![(7, Refusal::Pmac(ErrCode::MacroAux))],
        })
    );
}

#[test]
fn a_power_card_on_the_chain_speaks_power() {
    let mut c = Cable::mixed();
    // `@0`: the Power card answers in its dialect, as gpascii writes it.
    assert_eq!(
        c.send(1, b"@0Motor[2].JogSpeed=12.5 Motor[2].JogSpeed\r"),
        b"Motor[2].JogSpeed=12.5\r\n\x06\r\n"
    );
    assert_eq!(c.send(1, b"echo1 Motor[2].JogSpeed\r"), b"12.5\r\n\x06\r\n");
    // A PMAC-only command is an error there, in the Power form (line 4 of this thread).
    assert_eq!(
        c.send(1, b"I222\r"),
        b"I222=12.5\r\n\x06\r\n",
        "I222 is Motor[2].JogSpeed in Power numbering"
    );
    let e = c.send(1, b"OPEN PROG 1 CLEAR\r");
    assert_eq!(
        e,
        b"stdin:4:1: error #20: ILLEGAL CMD: OPEN PROG 1 CLEAR\r\n\x06\r\n".to_vec(),
        "{}",
        String::from_utf8_lossy(&e)
    );
    // The PMAC2 card beside it keeps PMAC syntax.
    assert_eq!(c.send(1, b"@1I122\r"), b"32\r\x06");
    // Another chain connection is another Power thread (its own echo mode).
    assert_eq!(
        c.send(2, b"Motor[2].JogSpeed\r"),
        b"Motor[2].JogSpeed=12.5\r\n\x06\r\n"
    );
}

#[test]
fn a_power_line_that_starts_a_program_is_taken_with_its_thread_addressing() {
    let mut c = Cable::mixed();
    assert_eq!(c.send(1, b"@0#3&2\r"), b"\x06\r\n");
    let _ = c.send(1, b"b1r");
    assert_eq!(c.op(0, OP_QUERY_START, 1), vec![FLAG_STARTS | FLAG_TALKS]);
    let mut want = vec![FLAG_STARTS | FLAG_TALKS];
    want.extend_from_slice(b"#3&2 b1r");
    assert_eq!(c.op(0, OP_TAKE_START, 1), want);
    // Silent at the <CR>: the line runs in the synchronized start.
    assert_eq!(c.send(1, b"\r"), b"");
    // A query is no start; nor is a line with a syntax error.
    let _ = c.send(1, b"&3 Coord[3].Status[0]");
    assert_eq!(c.op(0, OP_QUERY_START, 1), [0]);
    let _ = c.send(1, b"\r");
    let _ = c.send(1, b"r)");
    assert_eq!(c.op(0, OP_QUERY_START, 1), [0]);
    let _ = c.send(1, b"\r");
    assert_eq!(c.send(1, b"#\r"), b"#3\r\n\x06\r\n");
}

/// Issue 13, [DECISION] in `power_control`: a `gpascii` thread has no PMAC control
/// characters, so on the chain they neither act on a Power card nor answer from it; line
/// editing (`<BS>`, `<CTRL-X>`) still edits the line it collects. The PMAC2 card beside it
/// keeps its control characters.
#[test]
fn control_characters_do_not_act_on_a_power_card() {
    let mut c = Cable::mixed();
    // CTRL-B (status report) and CTRL-P (positions) to the addressed Power card: no answer.
    assert_eq!(c.send(1, b"@0\x02"), b"");
    assert_eq!(c.send(1, b"\x10"), b"");
    // <BS> erases the last collected character, CTRL-X the whole line.
    assert_eq!(
        c.send(1, b"P1=35\x08\x08 P2=9\x18P3=4 P3\r"),
        b"P3=4\r\n\x06\r\n"
    );
    assert_eq!(c.send(1, b"P1=35\x086 P1\r"), b"P1=36\r\n\x06\r\n");
    // The PMAC2 card still answers its CTRL-B.
    let r = c.send(1, b"@1\x02");
    assert_eq!(
        String::from_utf8_lossy(&r),
        "850000000000 050000000000 050000000000 050000000000 050000000000 050000000000 \
         050000000000 050000000000\r"
    );
}

impl Cable {
    /// Broadcast `data` on connection `conn`; the refusals every card reported, as
    /// `(card, position, refusal)`.
    fn refusals(&mut self, conn: u64, data: &[u8]) -> Vec<(usize, u32, Refusal)> {
        let cards = self.cards.iter_mut().zip(self.power.iter_mut());
        let mut out = Vec::new();
        for (k, ((card, port), power)) in cards.enumerate() {
            let a = port
                .feed(
                    card,
                    power,
                    conn,
                    data,
                    &mut crate::lang::Budget::unlimited(),
                )
                .unwrap_or_default();
            out.extend(a.refusals.into_iter().map(|(p, r)| (k, p, r)));
        }
        out
    }
}

#[test]
fn the_answering_card_reports_its_refusals_whatever_i6_prints() {
    let mut c = Cable::new(2);
    // I6 = 2 on card 1: a refused line answers a bare <BELL>, no ERRnnn in the bytes.
    assert_eq!(c.ask(1, "I6=2"), b"\x06");
    assert_eq!(c.send(1, b"@1UUU\r"), b"\x07");
    // Only card 1 collected the lines: it alone reports their refusals, at the position of
    // each line's <CR>.
    let data = b"UUU\rP1\rUUU\r";
    assert_eq!(
        c.refusals(1, data),
        vec![
            (1, 3, Refusal::Pmac(ErrCode::Data)),
            (1, 10, Refusal::Pmac(ErrCode::Data)),
        ]
    );
    // Under `@@` every card runs the line, card 0 answers: only card 0 reports.
    assert_eq!(
        c.refusals(1, b"@@UUU\r"),
        vec![(0, 5, Refusal::Pmac(ErrCode::Data))]
    );
    // The encoded reply carries the refusal in its attachment, the payload is the bytes.
    let (card, port) = &mut c.cards[1];
    let e = port
        .handle(
            card,
            &mut Dialect::Pmac,
            &Request {
                op: mcc_contracts::control::chain::OP_DATA,
                conn: 7,
                data: b"@1UUU\r",
            },
            &mut crate::lang::Budget::unlimited(),
        )
        .expect("answered");
    assert_eq!(
        e.payload,
        mcc_contracts::control::chain::encode_reply(&[(5, b"\x07".to_vec())])
    );
    assert_eq!(
        mcc_contracts::control::chain::decode_refusals(&e.refusals),
        Ok(vec![(5, CardRefusal::Pmac(3))])
    );
    // A good line: no attachment.
    let e = port
        .handle(
            card,
            &mut Dialect::Pmac,
            &Request {
                op: mcc_contracts::control::chain::OP_DATA,
                conn: 7,
                data: b"P1\r",
            },
            &mut crate::lang::Budget::unlimited(),
        )
        .expect("answered");
    assert!(e.refusals.is_empty());
}

#[test]
fn ctrl_i_and_overlong_lines_report_their_refusal() {
    let mut c = Cable::new(1);
    assert_eq!(c.ask(0, "I6=0"), b"\x06");
    assert_eq!(
        c.refusals(1, b"UUU\r"),
        vec![(0, 3, Refusal::Pmac(ErrCode::Data))]
    );
    // CTRL-I runs `UUU` again.
    assert_eq!(
        c.refusals(1, b"\x09"),
        vec![(0, 0, Refusal::Pmac(ErrCode::Data))]
    );
    let mut long = vec![b'P'; MAX_LINE + 10];
    long.push(b'\r');
    assert_eq!(
        c.refusals(1, &long),
        vec![(0, MAX_LINE as u32 + 10, Refusal::Pmac(ErrCode::Data))]
    );
}

#[test]
fn a_power_card_reports_its_refusal() {
    let mut c = Cable::mixed();
    assert_eq!(
        c.refusals(1, b"@0OPEN PROG 1 CLEAR\r"),
        vec![(0, 19, Refusal::Power(PowerErr::IllegalCmd))]
    );
    assert_eq!(c.refusals(1, b"Motor[2].JogSpeed\r"), vec![]);
}

/// Issue 24 item 3: a chain line runs within the slice budget it is given; a long reply
/// (`P0..1023`) parks the line, and the rest of its request follows once it is done: the
/// reply is the same as in one go, in the same order.
#[test]
fn a_long_chain_line_runs_in_slices_and_the_rest_of_its_request_follows() {
    use crate::lang::Budget;
    let mut whole = Cable::new(1);
    let expected = whole.send(1, b"P0..1023\rP1=5 P1\r");
    assert!(expected.len() > 1024 * 2, "{}", expected.len());
    let mut c = Cable::new(1);
    let (card, port) = &mut c.cards[0];
    let mut budget = Budget::new(100);
    assert_eq!(
        port.feed(
            card,
            &mut Dialect::Pmac,
            1,
            b"P0..1023\rP1=5 P1\r",
            &mut budget
        ),
        None,
        "1024 variables do not fit a slice of 100 units"
    );
    assert!(budget.exhausted());
    assert!(port.is_parked(1));
    let mut slices = 1;
    let reply = loop {
        let mut budget = Budget::new(100);
        if let Some(r) = port.resume(card, &mut Dialect::Pmac, 1, &mut budget) {
            break r;
        }
        assert!(budget.exhausted(), "a parked line used its whole slice");
        slices += 1;
        assert!(slices < 1000, "no end");
    };
    assert!(
        slices >= 10,
        "{slices} slices of 100 units for 1024 variables"
    );
    let merged: Vec<u8> = decode_reply(&reply.payload)
        .unwrap()
        .into_iter()
        .flat_map(|s| s.1)
        .collect();
    assert_eq!(merged, expected);
}

/// CTRL-I on the chain re-runs the last line within the budget too (parked, then resumed).
/// Seed 004 lines 6096-6115 (repeat last command line; control characters are not repeated).
#[test]
fn ctrl_i_on_the_chain_is_sliced_like_a_line() {
    use crate::lang::Budget;
    let mut c = Cable::new(1);
    let first = c.send(1, b"P0..999\r");
    let (card, port) = &mut c.cards[0];
    assert_eq!(
        port.feed(card, &mut Dialect::Pmac, 1, b"\x09", &mut Budget::new(50)),
        None::<Answer>
    );
    let reply = loop {
        if let Some(r) = port.resume(card, &mut Dialect::Pmac, 1, &mut Budget::new(50)) {
            break r;
        }
    };
    let merged: Vec<u8> = decode_reply(&reply.payload)
        .unwrap()
        .into_iter()
        .flat_map(|s| s.1)
        .collect();
    assert_eq!(merged, first);
    // Not remembered anew: CTRL-Y still gives the line typed.
    assert_eq!(c.send(1, b"\x19"), b"P0..999");
}
