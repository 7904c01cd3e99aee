use super::*;

const REPLY: &[u8] = b"1234\r\x06";

fn spec(kind: LinkFaultKind) -> LinkFaultSpec {
    LinkFaultSpec {
        kind,
        probability: 1.0,
        seed: 7,
        replies: None,
        delay_ms: if kind == LinkFaultKind::Late { 20 } else { 0 },
    }
}

fn once(kind: LinkFaultKind) -> LinkOutcome {
    LinkFaulter::new(spec(kind)).on_reply(REPLY)
}

fn bytes(b: &[u8]) -> LinkOutcome {
    LinkOutcome::pass(b)
}

#[test]
fn each_kind_gives_byte_exact_replies_for_a_seed() {
    use LinkFaultKind::*;
    assert_eq!(once(NoReply), bytes(b""));
    assert_eq!(
        once(Late),
        LinkOutcome {
            delay_ms: 20,
            ..bytes(REPLY)
        }
    );
    assert_eq!(once(Short), bytes(b"12"));
    assert_eq!(once(StrayCr), bytes(b"12\r34\r\x06"));
    assert_eq!(once(StrayLf), bytes(b"12\n34\r\x06"));
    assert_eq!(once(StrayBel), bytes(b"12\x0734\r\x06"));
    assert_eq!(once(StrayCtrl), bytes(b"\x0c1234\r\x06"));
    // '3' (0x33) with bit 0 flipped.
    assert_eq!(once(Corrupt), bytes(b"1224\r\x06"));
    assert_eq!(
        once(Reset),
        LinkOutcome {
            reset: true,
            ..bytes(b"")
        }
    );
    assert_eq!(once(BadChecksum), bytes(b"1234\r\x07"));
}

#[test]
fn the_same_seed_faults_the_same_way_another_seed_differs_somewhere() {
    let run = |seed: u64| {
        let mut f = LinkFaulter::new(LinkFaultSpec {
            seed,
            probability: 0.5,
            ..spec(LinkFaultKind::Corrupt)
        });
        (0..64).map(|_| f.on_reply(REPLY).bytes).collect::<Vec<_>>()
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
    let hits = run(3).iter().filter(|b| b.as_slice() != REPLY).count();
    assert!((16..=48).contains(&hits), "p = 0.5 over 64 replies: {hits}");
}

#[test]
fn every_drawn_fault_keeps_its_shape() {
    for seed in 0..200 {
        let draw = |kind| {
            LinkFaulter::new(LinkFaultSpec { seed, ..spec(kind) })
                .on_reply(REPLY)
                .bytes
        };
        let short = draw(LinkFaultKind::Short);
        assert!(short.len() < REPLY.len() && REPLY.starts_with(&short));
        let ctrl = draw(LinkFaultKind::StrayCtrl);
        assert_eq!(ctrl.len(), REPLY.len() + 1);
        let extra: Vec<u8> = ctrl
            .iter()
            .copied()
            .filter(|b| STRAY_CONTROLS.contains(b))
            .collect();
        assert_eq!(extra.len(), 1, "{ctrl:?}");
        let c = draw(LinkFaultKind::Corrupt);
        let diff: u32 = c.iter().zip(REPLY).map(|(a, b)| (a ^ b).count_ones()).sum();
        assert_eq!(diff, 1, "one bit flipped: {c:?}");
    }
}

#[test]
fn replies_count_every_non_empty_reply_then_the_fault_ends() {
    let slot = LinkFaultSlot::default();
    slot.set(LinkFaultSpec {
        replies: Some(2),
        ..spec(LinkFaultKind::NoReply)
    });
    // An empty reply is not counted.
    assert_eq!(slot.on_reply(b""), bytes(b""));
    assert_eq!(slot.active().map(|a| a.seen), Some(0));
    assert_eq!(slot.on_reply(REPLY), bytes(b""));
    assert_eq!(slot.on_reply(REPLY), bytes(b""));
    assert_eq!(slot.active(), None, "ended after 2 replies");
    assert_eq!(slot.on_reply(REPLY), bytes(REPLY));
    slot.set(spec(LinkFaultKind::Short));
    assert!(slot.armed());
    slot.clear();
    assert_eq!(slot.on_reply(REPLY), bytes(REPLY));
}

#[test]
fn probability_zero_never_hits_but_counts() {
    let mut f = LinkFaulter::new(LinkFaultSpec {
        probability: 0.0,
        replies: Some(5),
        ..spec(LinkFaultKind::Reset)
    });
    for _ in 0..5 {
        assert_eq!(f.on_reply(REPLY), bytes(REPLY));
    }
    assert!(f.expired());
    assert_eq!((f.active().seen, f.active().hits), (5, 0));
}

#[test]
fn refusals_name_the_problem_and_the_choices() {
    let e = spec(LinkFaultKind::BadChecksum)
        .validate(LinkTarget::CardPorts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("EMCL bus only") && e.contains("no-reply"), "{e}");
    assert!(!e.contains("bad-checksum,"), "{e}");
    assert!(spec(LinkFaultKind::BadChecksum)
        .validate(LinkTarget::Chain)
        .unwrap_err()
        .to_string()
        .contains("daisy-chain"));
    assert!(spec(LinkFaultKind::BadChecksum)
        .validate(LinkTarget::Bus)
        .is_ok());
    let late0 = LinkFaultSpec {
        delay_ms: 0,
        ..spec(LinkFaultKind::Late)
    };
    assert!(late0
        .validate(LinkTarget::Chain)
        .unwrap_err()
        .to_string()
        .contains("--delay"));
    let delayed = LinkFaultSpec {
        delay_ms: 5,
        ..spec(LinkFaultKind::Short)
    };
    assert!(delayed
        .validate(LinkTarget::Bus)
        .unwrap_err()
        .to_string()
        .contains("late"));
    let p = LinkFaultSpec {
        probability: 1.5,
        ..spec(LinkFaultKind::Short)
    };
    assert!(p
        .validate(LinkTarget::Bus)
        .unwrap_err()
        .to_string()
        .contains("1.5"));
    let e = "melt".parse::<LinkFaultKind>().unwrap_err().to_string();
    assert!(
        e.contains("melt") && e.contains("stray-bel") && e.contains("bad-checksum"),
        "{e}"
    );
    for k in LINK_KINDS {
        assert_eq!(k.word().parse::<LinkFaultKind>(), Ok(k));
        let json = serde_json::to_string(&k).unwrap();
        assert_eq!(json, format!("\"{}\"", k.word()));
    }
}
