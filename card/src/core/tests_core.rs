//! Card-core tests: requests, slices, effects.

use super::*;
use crate::domain::{ErrCode, PowerErr, Profile};

fn core() -> CardCore {
    CardCore::new(Card::new(Profile::Turbo))
}

fn serve_all(c: &mut CardCore) -> (usize, Vec<(u64, HostReply)>) {
    let mut slices = 0;
    let mut out = Vec::new();
    while c.pending() > 0 {
        let mut b = Budget::new(SLICE_UNITS);
        c.serve(&mut b);
        slices += 1;
        out.extend(c.take_replies());
        for (t, e) in c.take_effects() {
            let r = match e {
                Effect::Save(_) => EffectResult::Saved(true),
                Effect::Load => EffectResult::Loaded(Ok(None)),
            };
            c.effect_done(t, r);
        }
        assert!(slices < 100_000, "never finished");
    }
    (slices, out)
}

#[test]
fn a_heavy_line_is_served_in_bounded_slices_with_the_same_reply() {
    // A 1 KB line of `P0..8191` queries on a Turbo card: 819,200 values.
    let mut line = Vec::new();
    while line.len() + 9 <= 1024 {
        line.extend_from_slice(b"P0..8191 ");
    }
    let want = Card::new(Profile::Turbo).command_line(&mut Session::with_id(7), &line);
    let mut c = core();
    c.submit(1, 7, HostRequest::Line(line.clone()));
    let (slices, replies) = serve_all(&mut c);
    assert_eq!(replies.len(), 1);
    assert_eq!(replies[0].0, 1);
    assert_eq!(replies[0].1.bytes, want, "same reply as in one go");
    let values = (line.len() / 9) * 8192;
    assert!(
        slices as u64 >= values as u64 / SLICE_UNITS,
        "{slices} slices for {values} values: each slice stays within its budget"
    );
}

#[test]
fn requests_of_other_connections_keep_their_order_and_sessions() {
    let mut c = core();
    c.submit(1, 1, HostRequest::Line(b"#3".to_vec()));
    c.submit(2, 2, HostRequest::Line(b"#5".to_vec()));
    c.submit(3, 1, HostRequest::Line(b"#".to_vec()));
    c.submit(4, 2, HostRequest::Line(b"#".to_vec()));
    let (_, r) = serve_all(&mut c);
    let texts: Vec<_> = r.iter().map(|(t, r)| (*t, r.bytes.clone())).collect();
    assert_eq!(texts[2], (3, b"\n3\r\n".to_vec()));
    assert_eq!(texts[3], (4, b"\n5\r\n".to_vec()));
}

#[test]
fn save_waits_for_its_effect_and_reports_a_failed_write() {
    let mut c = core();
    c.submit(1, 1, HostRequest::Line(b"I3=2 SAVE".to_vec()));
    let mut b = Budget::new(SLICE_UNITS);
    c.serve(&mut b);
    assert!(
        c.take_replies().is_empty(),
        "no reply before the write is done"
    );
    let effects = c.take_effects();
    assert_eq!(effects.len(), 1);
    assert!(matches!(effects[0].1, Effect::Save(_)));
    c.effect_done(effects[0].0, EffectResult::Saved(false));
    c.serve(&mut Budget::new(SLICE_UNITS));
    let r = c.take_replies();
    assert_eq!(r[0].1.bytes, b"\x07\rERR003\r");
}

fn heavy_line() -> Vec<u8> {
    let mut line = Vec::new();
    while line.len() + 9 <= 1024 {
        line.extend_from_slice(b"P0..8191 ");
    }
    line
}

#[test]
fn a_streamed_line_comes_in_bounded_parts_that_add_up_to_the_whole_reply() {
    let line = heavy_line();
    let want = Card::new(Profile::Turbo).command_line(&mut Session::with_id(7), &line);
    let mut c = core();
    c.submit(1, 7, HostRequest::LineStreamed(line));
    let mut got = Vec::new();
    let mut parts = 0;
    let mut token = 1;
    for _ in 0..200_000 {
        c.serve(&mut Budget::new(SLICE_UNITS));
        let replies = c.take_replies();
        assert!(replies.len() <= 1);
        let Some((t, r)) = replies.into_iter().next() else {
            continue;
        };
        assert_eq!(t, token, "each part answers the request that asked for it");
        // A part is at most a chunk plus one slice's output (a slice prints < 400 values).
        assert!(
            r.bytes.len() <= STREAM_CHUNK + 400 * 16,
            "{}",
            r.bytes.len()
        );
        got.extend_from_slice(&r.bytes);
        parts += 1;
        if !r.more {
            break;
        }
        // While the host has not asked for more, the line makes no progress.
        c.serve(&mut Budget::new(SLICE_UNITS));
        assert!(c.take_replies().is_empty() && c.pending() == 0);
        token += 1;
        c.submit(token, 7, HostRequest::More);
    }
    assert_eq!(got, want, "the parts add up to the whole reply");
    assert!(parts > want.len() / STREAM_CHUNK / 2, "{parts} parts");
}

#[test]
fn a_new_request_abandons_a_parked_streamed_line() {
    let mut c = core();
    c.submit(1, 7, HostRequest::LineStreamed(heavy_line()));
    while c.take_replies().is_empty() {
        c.serve(&mut Budget::new(SLICE_UNITS));
    }
    // The host moves on without reading the rest.
    c.submit(2, 7, HostRequest::Line(b"I3=2 P1=5 P1".to_vec()));
    let (_, r) = serve_all(&mut c);
    assert_eq!(r.len(), 1);
    assert_eq!(
        r[0],
        (
            2,
            HostReply {
                bytes: b"5\r\x06".to_vec(),
                echo: false,
                more: false,
                error: None,
            }
        )
    );
    // More with nothing parked: an empty final part.
    c.submit(3, 7, HostRequest::More);
    let (_, r) = serve_all(&mut c);
    assert_eq!(r[0].1, HostReply::default());
}

#[test]
fn a_short_query_is_not_held_behind_another_hosts_heavy_line() {
    let mut c = core();
    c.submit(1, 1, HostRequest::Line(heavy_line()));
    c.submit(2, 1, HostRequest::Line(b"P2".to_vec()));
    c.submit(3, 2, HostRequest::Line(b"P1".to_vec()));
    // Fairness bound: with one other connection busy, the query is answered within two slices.
    for slice in 1..=2 {
        c.serve(&mut Budget::new(SLICE_UNITS));
        let r = c.take_replies();
        if let Some((t, _)) = r.first() {
            assert_eq!(
                *t, 3,
                "only the other connection's query can be done this early"
            );
            assert_eq!(r.len(), 1);
            let (_, rest) = serve_all(&mut c);
            let order: Vec<u64> = rest.iter().map(|(t, _)| *t).collect();
            assert_eq!(
                order,
                vec![1, 2],
                "a connection's own requests stay in order"
            );
            return;
        }
        assert!(slice < 2, "the short query waited more than two slices");
    }
}

#[test]
fn a_power_card_answers_every_connection_in_its_own_thread() {
    let mut c = CardCore::new(Card::new(Profile::Power));
    c.submit(1, 10, HostRequest::Line(b"#5 echo 1 cid".to_vec()));
    c.submit(2, 11, HostRequest::Line(b"#".to_vec()));
    c.submit(3, 10, HostRequest::Line(b"Ldata.Motor".to_vec()));
    c.submit(4, 10, HostRequest::End);
    c.submit(5, 10, HostRequest::LineStreamed(b"#".to_vec()));
    let (_, replies) = serve_all(&mut c);
    let mut text: Vec<(u64, String)> = replies
        .into_iter()
        .map(|(t, r)| (t, String::from_utf8(r.bytes).unwrap()))
        .collect();
    text.sort();
    assert_eq!(
        text,
        vec![
            (1, "604020\r\n\x06\r\n".to_string()),
            (2, "#0\r\n\x06\r\n".to_string()),
            (3, "5\r\n\x06\r\n".to_string()),
            (4, String::new()),
            // a new connection with the same id starts a fresh thread
            (5, "#0\r\n\x06\r\n".to_string()),
        ]
    );
}

#[test]
fn ctrl_t_toggles_the_echo_of_its_own_connection_only() {
    // Issue 26 item 2: one host's CTRL-T made every other host's port echo its lines.
    let mut c = core();
    c.submit(1, 1, HostRequest::Control(0x14));
    c.submit(2, 2, HostRequest::Line(b"P5".to_vec()));
    c.submit(3, 1, HostRequest::Line(b"P5".to_vec()));
    c.submit(4, 2, HostRequest::Control(0x14));
    c.submit(5, 2, HostRequest::Control(0x14));
    c.submit(6, 2, HostRequest::Line(b"P5".to_vec()));
    let (_, mut r) = serve_all(&mut c);
    r.sort_by_key(|(t, _)| *t);
    let echo: Vec<(u64, bool)> = r.iter().map(|(t, r)| (*t, r.echo)).collect();
    assert_eq!(
        echo,
        vec![
            (1, true),
            (2, false),
            (3, true),
            (4, true),
            (5, false),
            (6, false)
        ]
    );
}

#[test]
fn a_power_save_is_answered_once_written_and_a_failed_one_is_an_error() {
    let mut c = CardCore::new(Card::new(Profile::Power));
    let answer = |c: &mut CardCore, token: u64, line: &[u8], ok: bool| -> Vec<u8> {
        c.submit(token, 1, HostRequest::Line(line.to_vec()));
        c.serve(&mut Budget::new(SLICE_UNITS));
        let effects = c.take_effects();
        if let [(t, Effect::Save(_))] = effects.as_slice() {
            assert!(c.take_replies().is_empty(), "no reply before the write");
            c.effect_done(*t, EffectResult::Saved(ok));
        }
        let r = c.take_replies();
        assert_eq!(r.len(), 1, "one reply to {line:?}");
        let want = (!ok).then_some(Refusal::Power(PowerErr::IllegalParameter));
        assert_eq!(r[0].1.error, want, "the refusal of {line:?}, typed");
        r[0].1.bytes.clone()
    };
    assert_eq!(answer(&mut c, 1, b"echo7 P1=4242", true), b"\x06\r\n");
    assert_eq!(answer(&mut c, 2, b"save", true), b"\x06\r\n");
    assert_eq!(
        answer(&mut c, 3, b"save", false),
        b"stdin:3:1: error #21: ILLEGAL PARAMETER: save\r\n\x06\r\n"
    );
    assert_eq!(answer(&mut c, 4, b"P1", true), b"4242\r\n\x06\r\n");
}

/// Every reply carries its line's refusal typed, whatever the framing printed of it: PMAC
/// under I6 = 3 (`ERR003`), I6 = 2 (a bare BELL) and I6 = 1; Power's `error #n`.
#[test]
fn a_reply_carries_its_refusal_typed_whatever_the_framing_printed() {
    let ask = |c: &mut CardCore, line: &[u8]| -> HostReply {
        c.submit(9, 1, HostRequest::Line(line.to_vec()));
        let (_, r) = serve_all(c);
        assert_eq!(r.len(), 1, "one reply to {line:?}");
        r[0].1.clone()
    };
    let mut c = core();
    ask(&mut c, b"I3=2");
    let ok = ask(&mut c, b"P1=5 P1");
    assert_eq!((ok.bytes.as_slice(), ok.error), (&b"5\r\x06"[..], None));
    for (i6, bytes) in [
        (3, &b"\x07\rERR003\r"[..]),
        (2, &b"\x07"[..]),
        (1, &b"\x07ERR003\r"[..]),
    ] {
        ask(&mut c, format!("I6={i6}").as_bytes());
        let r = ask(&mut c, b"XYZZY");
        assert_eq!(r.bytes, bytes, "I6={i6}");
        assert_eq!(r.error, Some(Refusal::Pmac(ErrCode::Data)), "I6={i6}");
    }
    ask(&mut c, b"I6=3");
    let r = ask(&mut c, b"&1B99R");
    assert_eq!(r.error, Some(Refusal::Pmac(ErrCode::NoMotors)));
    let mut p = CardCore::new(Card::new(Profile::Power));
    let r = ask(&mut p, b"foo");
    assert_eq!(
        r.bytes,
        b"stdin:1:1: error #20: ILLEGAL CMD: foo\r\n\x06\r\n"
    );
    assert_eq!(r.error, Some(Refusal::Power(PowerErr::IllegalCmd)));
    let r = ask(&mut p, b"P1=1 Motor[1].Status[0]=1");
    assert_eq!(r.error, Some(Refusal::Power(PowerErr::ReadOnly)));
    assert_eq!(ask(&mut p, b"P1").error, None, "the next line starts clean");
}

/// A Power line runs whole but costs its data lines in the slice's budget, as a PMAC line
/// does: after a line answering 1,000 values, another connection's line waits for the next
/// slice; short lines share one.
#[test]
fn a_power_line_costs_its_data_lines_in_the_slice_budget() {
    let mut c = CardCore::new(Card::new(Profile::Power));
    c.submit(1, 1, HostRequest::Line(b"P0..999".to_vec()));
    c.submit(2, 2, HostRequest::Line(b"P1".to_vec()));
    c.serve(&mut Budget::new(SLICE_UNITS));
    let r = c.take_replies();
    assert_eq!(r.len(), 1, "the long line used the slice");
    assert_eq!(r[0].1.bytes.iter().filter(|&&b| b == b'\n').count(), 1001);
    c.serve(&mut Budget::new(SLICE_UNITS));
    assert_eq!(
        c.take_replies().len(),
        1,
        "the short line in the next slice"
    );
    for t in 3..6 {
        c.submit(t, 3, HostRequest::Line(b"P1".to_vec()));
    }
    c.serve(&mut Budget::new(SLICE_UNITS));
    assert_eq!(c.take_replies().len(), 3, "short lines share one slice");
}

/// Issue 24 item 3: CTRL-I runs the last line again as a line job, in bounded slices, with
/// the same reply as the line had; the line is not remembered anew. Seed 004 lines
/// 6096-6115: the most recent command line is "re-commanded" (as if sent again).
#[test]
fn ctrl_i_repeats_the_last_line_in_bounded_slices() {
    let mut c = core();
    c.submit(1, 7, HostRequest::Line(b"P0..8191".to_vec()));
    let (_, first) = serve_all(&mut c);
    c.submit(2, 7, HostRequest::Control(0x09));
    let (slices, again) = serve_all(&mut c);
    assert_eq!(again.len(), 1);
    assert_eq!(again[0].1.bytes, first[0].1.bytes);
    assert!(
        slices as u64 >= 8192 / SLICE_UNITS,
        "{slices} slices for 8192 values"
    );
    c.submit(3, 7, HostRequest::Control(0x19));
    let (_, y) = serve_all(&mut c);
    assert_eq!(y[0].1.bytes, b"P0..8191");
}

/// Issue 24 item 3: the ring reaches the card only as typed input to the core's tick
/// (`core::ring_io`): feedback of the activated nodes latched, their commands read back,
/// zero commands and the global ring-fault bit from a ring fault until `$$$` clears it; the
/// ring I-variables go both ways.
#[test]
fn the_ring_is_a_typed_input_and_output_of_the_tick() {
    use crate::core::ring_io::{RingIn, RingVars};
    let mut c = CardCore::new(Card::new(Profile::Pmac2));
    c.set_ring_nodes(&[0, 1, 20]);
    assert_eq!(c.ring_nodes(), [0, 1]);
    let mut s = Session::with_id(1);
    let _ = c.card.command_line(&mut s, b"I100=0 I3=2");
    c.card
        .state
        .write(crate::model::Space::Y, 0xC0A0, 0x00_1234);
    let mut input = RingIn {
        cycle: 1,
        fault: false,
        feedback: [[0; 4]; 16],
        aux_back: (0, 0),
    };
    input.feedback[1] = [0x11, 0x2200, 0x3300, 0x4400];
    input.feedback[2] = [0x99, 0, 0, 0];
    let out = c.ring_tick(&input);
    assert_eq!(out.commands[0][0], 0x1234);
    assert_eq!(out.commands[2], [0; 4], "not an activated node");
    assert_eq!(
        c.card.state.node_feedback(1),
        [0x11, 0x2200, 0x3300, 0x4400]
    );
    input.cycle = 2;
    input.fault = true;
    assert_eq!(c.ring_tick(&input).commands, [[0; 4]; 16]);
    assert!(c.card.state.global.ring_fault);
    input.cycle = 3;
    input.fault = false;
    assert_eq!(c.ring_tick(&input).commands[0][0], 0, "latched until $$$");
    assert!(!c.take_ring_reset());
    c.card.state.global.ring_fault = false;
    input.cycle = 4;
    assert_eq!(c.ring_tick(&input).commands[0][0], 0x1234);
    assert!(
        c.take_ring_reset(),
        "the ring core is asked to reset its latch"
    );
    assert!(!c.take_ring_reset());
    // Ring I-variables: the ring core's values at the start, then the card's changes win.
    let ring = RingVars {
        i995: 0x30,
        i996: 0xF_0003,
        i1001: 16,
        i1004: 2,
        i1005: 4,
    };
    let want = c.ring_settings(ring, true);
    assert_eq!((want.vars.i995, want.vars.i996), (0x30, 0xF_0003));
    c.ring_mirror(ring, 0);
    assert_eq!(
        c.card.command_line(&mut s, b"I996 I1001"),
        b"$F0003\r16\r\x06"
    );
    let _ = c.card.command_line(&mut s, b"I1001=32");
    let want = c.ring_settings(ring, true);
    assert_eq!(want.vars.i1001, 32);
    assert_eq!(want.rearm, None);
}
