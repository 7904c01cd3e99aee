//! Unit tests of the fault layer.

use super::*;
use crate::packet::NodeRegs;

fn frame(cycle: u64) -> Frame {
    let sync = Packet::sync(0, 15, cycle);
    let cmd = Packet::new(
        0,
        1,
        NodeRegs {
            r0: 42,
            ..Default::default()
        },
    );
    Frame::with_packets(0, cycle, 0, cycle, &[sync, cmd])
}

fn sent(out: &[Outgoing]) -> Vec<Frame> {
    out.iter()
        .map(|o| Frame::decode(&o.frame_bytes).unwrap())
        .collect()
}

#[test]
fn words_parse_and_serde() {
    assert_eq!("drop-sync".parse(), Ok(FaultKind::DropSync));
    assert_eq!("delay=3".parse(), Ok(FaultKind::DelayCycles(3)));
    assert_eq!("delay-us:250".parse(), Ok(FaultKind::DelayMicros(250)));
    assert!("delay"
        .parse::<FaultKind>()
        .unwrap_err()
        .to_string()
        .contains("needs an amount"));
    assert!("cut=2"
        .parse::<FaultKind>()
        .unwrap_err()
        .to_string()
        .contains("takes no amount"));
    assert!("melt"
        .parse::<FaultKind>()
        .unwrap_err()
        .to_string()
        .contains("unknown fault kind 'melt'"));
    assert!("delay=x"
        .parse::<FaultKind>()
        .unwrap_err()
        .to_string()
        .contains("not a number"));
    for k in ["byte-violation", "delay=7", "delay-us=9", "cut", "overrun"] {
        assert_eq!(k.parse::<FaultKind>().unwrap().to_string(), k);
    }
    let s: FaultSpec = serde_json::from_str(r#"{"kind":"byte-violation"}"#).unwrap();
    assert_eq!(s, FaultSpec::always(FaultKind::ByteViolation));
    let j = serde_json::to_string(&FaultSpec {
        cycles: Some(5),
        ..FaultSpec::always(FaultKind::DelayCycles(2))
    })
    .unwrap();
    assert_eq!(
        j,
        r#"{"kind":{"delay":2},"cycles":5,"probability":1.0,"seed":0}"#
    );
    assert!(FaultLayer::new(15)
        .inject(FaultSpec {
            probability: 1.5,
            ..FaultSpec::always(FaultKind::Cut)
        })
        .is_err());
}

#[test]
fn no_fault_passes_frame_unchanged() {
    let mut l = FaultLayer::new(15);
    let out = l.on_send(1, frame(1));
    assert_eq!(
        out,
        vec![Outgoing {
            frame_bytes: frame(1).encode(),
            delay_us: 0
        }]
    );
}

#[test]
fn byte_edits() {
    let cases = [
        (FaultKind::Corrupt, 12 + 11),
        (FaultKind::ByteViolation, 12),
    ];
    for (kind, idx) in cases {
        let mut l = FaultLayer::new(15);
        l.inject(FaultSpec::always(kind)).unwrap();
        let f = &sent(&l.on_send(1, frame(1)))[0];
        let orig = frame(1).packets;
        let diff: Vec<usize> = (0..24).filter(|i| f.packets[*i] != orig[*i]).collect();
        assert_eq!(diff, vec![idx], "{kind}");
    }
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec::always(FaultKind::Overrun)).unwrap();
    let f = &sent(&l.on_send(1, frame(1)))[0];
    assert_eq!((f.declared, f.packets.len()), (2, 29));
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec::always(FaultKind::Underrun)).unwrap();
    let f = &sent(&l.on_send(1, frame(1)))[0];
    assert_eq!((f.declared, f.packets.len()), (2, 19));
}

#[test]
fn drop_sync_drop_and_cut() {
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec::always(FaultKind::DropSync)).unwrap();
    let f = &sent(&l.on_send(1, frame(1)))[0];
    assert_eq!(f.declared, 1);
    assert_eq!(Packet::decode(&f.packets).unwrap().node, 1);
    for k in [FaultKind::DropPackets, FaultKind::Cut] {
        let mut l = FaultLayer::new(15);
        l.inject(FaultSpec::always(k)).unwrap();
        assert!(l.on_send(1, frame(1)).is_empty());
        l.clear();
        assert_eq!(l.on_send(2, frame(2)).len(), 1);
    }
}

#[test]
fn expiry_after_cycles() {
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec {
        cycles: Some(2),
        ..FaultSpec::always(FaultKind::DropPackets)
    })
    .unwrap();
    assert!(l.on_send(10, frame(10)).is_empty());
    assert!(l.on_send(11, frame(11)).is_empty());
    assert_eq!(l.active().len(), 1);
    assert_eq!(l.on_send(12, frame(12)).len(), 1);
    assert!(l.active().is_empty());
}

#[test]
fn delay_cycles_hold_and_release() {
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec {
        cycles: Some(2),
        ..FaultSpec::always(FaultKind::DelayCycles(3))
    })
    .unwrap();
    assert!(l.on_send(1, frame(1)).is_empty());
    assert!(l.on_send(2, frame(2)).is_empty());
    assert!(l.poll(3).is_empty());
    // cycle 4: frame 1 released, then frame 4 (fault expired) goes at once.
    let out = sent(&l.on_send(4, frame(4)));
    assert_eq!(out.iter().map(|f| f.cycle).collect::<Vec<_>>(), vec![1, 4]);
    assert_eq!(
        sent(&l.poll(5)).iter().map(|f| f.cycle).collect::<Vec<_>>(),
        vec![2]
    );
}

#[test]
fn delay_us_marks_outgoing() {
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec::always(FaultKind::DelayMicros(250)))
        .unwrap();
    assert_eq!(l.on_send(1, frame(1))[0].delay_us, 250);
}

#[test]
fn probability_is_seeded() {
    let pattern = |seed| {
        let mut l = FaultLayer::new(15);
        l.inject(FaultSpec {
            probability: 0.5,
            seed,
            ..FaultSpec::always(FaultKind::DropPackets)
        })
        .unwrap();
        (0..64)
            .map(|c| l.on_send(c, frame(c)).is_empty())
            .collect::<Vec<_>>()
    };
    assert_eq!(pattern(7), pattern(7));
    assert_ne!(pattern(7), pattern(8));
    let dropped = pattern(7).iter().filter(|d| **d).count();
    assert!((16..=48).contains(&dropped), "{dropped}");
}
