use super::*;

fn frame(n: u8) -> [u8; FRAME_LEN] {
    Request {
        addr: 1,
        instr: Instr::new(6, n, 0, 0),
    }
    .to_bytes()
}

#[test]
fn instr_bytes_round_trip_and_negative_values() {
    let i = Instr::new(4, 1, 0, -10000);
    assert_eq!(i.to_bytes(), [4, 1, 0, 0xFF, 0xFF, 0xD8, 0xF0]);
    assert_eq!(Instr::from_bytes(i.to_bytes()), i);
    let r = Reply {
        host: 2,
        module: 1,
        status: 100,
        op: 6,
        value: -1,
    };
    assert_eq!(Reply::parse(&r.to_bytes()), Some(r));
    let mut bad = r.to_bytes();
    bad[8] ^= 1;
    assert_eq!(Reply::parse(&bad), None);
}

#[test]
fn assembler_cuts_every_nine_bytes_whatever_the_segmentation() {
    let mut stream = Vec::new();
    for n in 0..5 {
        stream.extend_from_slice(&frame(n));
    }
    for seg in [1usize, 2, 4, 7, 9, 10, 45] {
        let mut a = FrameAssembler::new(500);
        let mut got = Vec::new();
        for (k, chunk) in stream.chunks(seg).enumerate() {
            // Segments arrive close together (well inside the silence timeout).
            got.extend(a.push(chunk, k as u64));
        }
        assert_eq!(
            got,
            (0..5).map(frame).collect::<Vec<_>>(),
            "segments of {seg}"
        );
        assert_eq!(a.pending(), 0);
    }
}

#[test]
fn a_partial_frame_is_dropped_after_the_silence_and_the_stream_resynchronises() {
    let mut a = FrameAssembler::new(500);
    // Three bytes of garbage, then silence.
    assert!(a.push(&[0xAA, 0xBB, 0xCC], 1000).is_empty());
    assert_eq!(a.pending(), 3);
    assert_eq!(a.deadline_ms(), Some(1500));
    assert!(!a.expire(1499));
    // A byte just inside the timeout still belongs to the frame…
    assert!(a.push(&[0xDD], 1499).is_empty());
    assert_eq!(a.pending(), 4);
    // …a frame after a long silence starts clean.
    let got = a.push(&frame(7), 2100);
    assert_eq!(got, vec![frame(7)]);
    assert_eq!(a.discarded(), 1);
    assert!(a.push(&[], 5000).is_empty());
    assert_eq!(a.deadline_ms(), None);
}
