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

fn sent(out: &[Sent]) -> Vec<Frame> {
    // Through the encoder, as the member sends them.
    out.iter()
        .map(|o| Frame::decode(&o.frame.encode()).unwrap())
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
        r#"{"kind":"delay=2","cycles":5,"probability":1.0,"seed":0}"#
    );
    // One shape for every kind: a string.
    let back: FaultSpec = serde_json::from_str(&j).unwrap();
    assert_eq!(back.kind, FaultKind::DelayCycles(2));
    for k in ["cut", "delay-us=9"] {
        let v = serde_json::to_value(FaultSpec::always(k.parse().unwrap())).unwrap();
        assert_eq!(v["kind"], k);
    }
    assert!(serde_json::from_str::<FaultSpec>(r#"{"kind":"melt"}"#).is_err());
    assert!(serde_json::from_str::<FaultSpec>(r#"{"kind":{"delay":2}}"#).is_err());
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
        vec![Sent {
            frame: frame(1),
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
    // drop-packets: the envelope of the cycle goes, empty.
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec::always(FaultKind::DropPackets)).unwrap();
    let f = sent(&l.on_send(1, frame(1)));
    assert_eq!(f.len(), 1);
    assert_eq!((f[0].cycle, f[0].declared, f[0].packets.len()), (1, 0, 0));
    l.clear();
    assert_eq!(sent(&l.on_send(2, frame(2)))[0], frame(2));
    // cut: a dark frame of the same cycle (loss of light), until cleared.
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec::always(FaultKind::Cut)).unwrap();
    let f = sent(&l.on_send(7, frame(7)));
    assert_eq!(f.len(), 1);
    assert!(f[0].is_dark(), "{f:?}");
    assert_eq!(f[0].cycle, 7);
    l.clear();
    assert_eq!(sent(&l.on_send(8, frame(8)))[0], frame(8));
}

#[test]
fn expiry_after_cycles() {
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec {
        cycles: Some(2),
        ..FaultSpec::always(FaultKind::DropPackets)
    })
    .unwrap();
    let empty = |out: Vec<Sent>| out.len() == 1 && out[0].frame.declared == 0;
    assert!(empty(l.on_send(10, frame(10))));
    assert!(empty(l.on_send(11, frame(11))));
    assert_eq!(l.active().len(), 1);
    assert_eq!(l.on_send(12, frame(12))[0].frame, frame(12));
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
    // Held frames leave an empty frame of their cycle in their place.
    let cycles_and_sizes = |out: &[Sent]| {
        out.iter()
            .map(|o| (o.frame.cycle, o.frame.declared))
            .collect::<Vec<_>>()
    };
    assert_eq!(cycles_and_sizes(&l.on_send(1, frame(1))), vec![(1, 0)]);
    assert_eq!(cycles_and_sizes(&l.on_send(2, frame(2))), vec![(2, 0)]);
    assert!(l.poll(3).is_empty());
    // cycle 4: frame 1 released, then frame 4 (fault expired) goes at once.
    let out = sent(&l.on_send(4, frame(4)));
    assert_eq!(out.iter().map(|f| f.cycle).collect::<Vec<_>>(), vec![1, 4]);
    assert_eq!(out[0], frame(1));
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
            .map(|c| l.on_send(c, frame(c))[0].frame.declared == 0)
            .collect::<Vec<_>>()
    };
    assert_eq!(pattern(7), pattern(7));
    assert_ne!(pattern(7), pattern(8));
    let dropped = pattern(7).iter().filter(|d| **d).count();
    assert!((16..=48).contains(&dropped), "{dropped}");
}

#[test]
fn active_faults_report_the_cycle_they_started_acting_on() {
    let mut l = FaultLayer::new(15);
    l.inject(FaultSpec {
        cycles: Some(3),
        ..FaultSpec::always(FaultKind::Corrupt)
    })
    .unwrap();
    assert_eq!(l.active()[0].since_cycle, None, "nothing sent yet");
    // The runtime polls between cycles (held frames): that does not start the fault.
    l.poll(40);
    assert_eq!(l.active()[0].since_cycle, None, "polled, nothing sent yet");
    l.on_send(41, frame(41));
    l.on_send(42, frame(42));
    let a = &l.active()[0];
    assert_eq!(a.since_cycle, Some(41));
    // The status JSON keeps the spec's shape and adds `since_cycle`.
    let v = serde_json::to_value(a).unwrap();
    assert_eq!(v["kind"], "corrupt");
    assert_eq!(v["cycles"], 3);
    assert_eq!(v["since_cycle"], 41);
    let back: ActiveFault = serde_json::from_value(v).unwrap();
    assert_eq!(&back, a);
    l.on_send(44, frame(44));
    assert!(l.active().is_empty(), "expired after 3 cycles");
}
