//! The rules of [`crate::expect`] against the deterministic in-process ring: random rings
//! (cards, stations, sync master, check parameters), random fault kinds, targets, onsets and
//! durations. Every member the rules say must latch does so within its bound, nobody else
//! latches, and a burst no longer than the safe length trips no check.

use proptest::prelude::*;

use super::*;
use crate::core::RingApp;
use crate::fault::FaultSpec;
use crate::member::RingMember;
use crate::sim::RingSim;
use mcc_contracts::config::IVarValue;

/// Writes something new into every node register each cycle (so packets change).
struct Busy;

impl RingApp for Busy {
    fn tick(&mut self, cycle: u64, _t: u64, regs: &mut RingMember, _fault: bool) {
        for n in 0..15u8 {
            regs.write_regs_mut(n).r0 = (cycle as u32).wrapping_mul(7) & 0xFF_FFFF;
        }
    }
}

/// The ring as the member processes build it ([`crate::builder`]); each member's ring check is
/// the one the model judges by.
fn sim(cfg: &ClusterConfig) -> RingSim<Busy> {
    let model = RingModel::from_config(cfg).unwrap();
    let sim = crate::builder::sim(cfg, cfg.period_ns(), |_, _| Busy).unwrap();
    for (i, m) in model.members.iter().enumerate() {
        assert_eq!(sim.member(i).check().params(), m.check, "member {i}");
    }
    sim
}

#[derive(Clone, Debug)]
struct Case {
    cards: usize,
    stations: usize,
    sync_card: usize,
    card_check: (u32, u32, u32, u32),
    station_check: (u32, u32, u32),
    target: usize,
    kind: FaultKind,
    /// None: until cleared; Some(k): k cycles past the safe burst (0 = exactly the safe burst).
    burst: Option<u64>,
    phase: u64,
}

fn config(c: &Case) -> ClusterConfig {
    let mut cfg = ClusterConfig::default_cluster(c.cards, c.stations);
    let (i1001, i1004, i1005, i8) = c.card_check;
    for card in &mut cfg.cards {
        card.ivars.clear();
        for (k, v) in [
            ("I1001", i1001),
            ("I1004", i1004),
            ("I1005", i1005),
            ("I8", i8),
        ] {
            card.ivars.insert(k.into(), IVarValue::Int(i64::from(v)));
        }
    }
    for st in &mut cfg.stations {
        (st.check.period, st.check.min_syncs, st.check.max_errors) = c.station_check;
    }
    cfg.ring.sync_master = format!("card{}", c.sync_card);
    cfg
}

fn case() -> impl Strategy<Value = Case> {
    (1usize..=3, 1usize..=4)
        .prop_flat_map(|(cards, stations)| {
            let n = cards + stations;
            (
                Just(cards),
                Just(stations),
                0..cards,
                (0u32..=3, 4u32..=40, 1u32..=4).prop_flat_map(|(i8, i1001, i1004)| {
                    let c = i1001.div_ceil(i8 + 1);
                    (Just(i1001), Just(i1004), 1..=c, Just(i8))
                }),
                (4u32..=16, 1u32..=6).prop_flat_map(|(p, e)| (Just(p), 1..=p, Just(e))),
                0..n,
                prop_oneof![
                    Just(FaultKind::DropSync),
                    Just(FaultKind::DropPackets),
                    Just(FaultKind::Corrupt),
                    Just(FaultKind::ByteViolation),
                    Just(FaultKind::Overrun),
                    Just(FaultKind::Underrun),
                    (1u32..=6).prop_map(FaultKind::DelayCycles),
                    (1u32..=20_000).prop_map(FaultKind::DelayMicros),
                    Just(FaultKind::Cut),
                ],
                prop_oneof![Just(None), (0u64..=2).prop_map(Some)],
                0u64..120,
            )
        })
        .prop_map(
            |(
                cards,
                stations,
                sync_card,
                card_check,
                station_check,
                target,
                kind,
                burst,
                phase,
            )| {
                Case {
                    cards,
                    stations,
                    sync_card,
                    card_check,
                    station_check,
                    target,
                    kind,
                    burst,
                    phase,
                }
            },
        )
}

/// Run one case: the expectation, and each member's latch cycle minus the onset.
fn run(c: &Case) -> (Expectation, Vec<Option<u64>>, u64) {
    let cfg = config(c);
    let model = RingModel::from_config(&cfg).unwrap();
    let mut s = sim(&cfg);
    s.run(200 + c.phase);
    let n = s.len();
    for i in 0..n {
        // The in-process ring checks from its first cycle (start-up is not under test).
        s.member_mut(i).reset();
        assert!(
            !s.member(i).ring_fault(),
            "{} latched before the fault: {:?}",
            model.members[i].name,
            s.member(i).last_fault()
        );
    }
    let safe = model.safe_burst(c.target, c.kind);
    let cycles = c.burst.map(|k| safe.saturating_add(k).max(1));
    let what = Disturbance::Frames {
        kind: c.kind,
        cycles,
    };
    let e = model.expect(c.target, what);
    s.inject(
        c.target,
        FaultSpec {
            cycles,
            ..FaultSpec::always(c.kind)
        },
    )
    .unwrap();
    let onset = s.cycle() + 1;
    let horizon = e.must.iter().map(|d| d.within).max().unwrap_or(0) + 200;
    s.run(horizon);
    let latched = (0..n)
        .map(|i| {
            s.member(i)
                .status()
                .ring_fault_cycle
                .map(|f| f.saturating_sub(onset))
        })
        .collect();
    (e, latched, safe)
}

fn check(c: &Case) -> Result<(), TestCaseError> {
    let (e, latched, safe) = run(c);
    let cfg = config(c);
    let names = &cfg.ring.order;
    for d in &e.must {
        let got = latched[d.member];
        prop_assert!(
            got.is_some_and(|l| l <= d.within),
            "{} must latch within {} cycles, latched {:?} (all: {:?}, safe burst {safe}) in {c:?}",
            names[d.member],
            d.within,
            got,
            latched
        );
    }
    for (i, l) in latched.iter().enumerate() {
        prop_assert!(
            l.is_none() || e.allows(i),
            "{} latched {:?} cycles after the onset, not expected ({e:?}, safe burst {safe}) in {c:?}",
            names[i],
            l
        );
    }
    if c.burst == Some(0) && safe > 0 {
        prop_assert!(e.quiet(), "the safe burst is quiet: {e:?}");
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn the_in_process_ring_keeps_the_rules(c in case()) {
        check(&c)?;
    }
}

/// `delay-us=N` has one meaning (`docs/ring.md`, Faults): each frame goes on the link N µs
/// late, and in the paced and lockstep clocks the ring waits for it — the same frames in the
/// same cycles, only later on the wall clock. The deterministic simulator is the lockstep
/// ring: with a delay below a period, of a period, of several and beyond the ring check's
/// whole period, on every member, every member ticks in every cycle exactly as in the same ring
/// without the fault (so no frame lands in another cycle), nobody counts an error or latches,
/// and the rules ([`RingModel::expect`]) agree: quiet, whatever the burst.
#[test]
fn delay_us_means_the_ring_waits() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let model = RingModel::from_config(&cfg).unwrap();
    let period_us = cfg.period_ns() / 1000;
    let delays = [
        50,
        period_us as u32 - 1,
        period_us as u32,
        3 * period_us as u32 + 7,
        40 * period_us as u32,
    ];
    for target in 0..model.members.len() {
        assert_eq!(
            model.safe_burst(target, FaultKind::DelayMicros(1)),
            u64::MAX
        );
        for us in delays {
            let kind = FaultKind::DelayMicros(us);
            let what = Disturbance::Frames { kind, cycles: None };
            assert!(model.expect(target, what).quiet(), "{kind} at {target}");
            let (mut faulty, mut clean) = (sim(&cfg), sim(&cfg));
            for s in [&mut faulty, &mut clean] {
                s.run(60);
                for i in 0..s.len() {
                    s.member_mut(i).reset();
                }
            }
            faulty.inject(target, FaultSpec::always(kind)).unwrap();
            for _ in 0..300 {
                let (f, c) = (faulty.step(), clean.step());
                assert_eq!(
                    (&f.ticks, f.completed, &f.faults),
                    (&c.ticks, c.completed, &c.faults),
                    "{kind} at member {target}, cycle {}",
                    f.cycle
                );
            }
            for i in 0..faulty.len() {
                let st = faulty.member(i).status();
                assert_eq!(
                    st.errors,
                    clean.member(i).status().errors,
                    "{kind}: member {i}"
                );
                assert!(!st.ring_fault, "{kind} at {target}: member {i} latched");
                assert_eq!(st.holdover_cycles, 0, "{kind} at {target}: member {i}");
            }
            assert_eq!(
                faulty.member(target).status().faults.len(),
                1,
                "{kind} is active"
            );
        }
    }
}

/// The bounds of the default cluster (cards I1001 = 16, I1004 = 2, I1005 = 4, I8 = 2;
/// stations 8/4/4), as README states them.
#[test]
fn default_cluster_bounds() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let m = RingModel::from_config(&cfg).unwrap();
    let card = m.members[2].check;
    let station = m.members[1].check;
    assert_eq!(checks_per_period(&card), 6);
    assert_eq!(error_latency(&card), Some(8));
    assert_eq!(error_latency(&station), Some(6));
    assert_eq!(sync_latency(&card), Some(25));
    assert_eq!(sync_latency(&station), Some(11));
    assert_eq!(safe_error_burst(&card), 1);
    assert_eq!(safe_error_burst(&station), 3);
    assert_eq!(safe_sync_burst(&card), 8);
    assert_eq!(safe_sync_burst(&station), 4);
    // cut on station0: card1, station1 and card0 (the sync master, one cycle later) see dark
    // frames; nothing upstream but card0, which is the sync master.
    let e = m.expect(
        1,
        Disturbance::Frames {
            kind: FaultKind::Cut,
            cycles: None,
        },
    );
    let want = vec![
        Detection {
            member: 2,
            within: 8,
        },
        Detection {
            member: 3,
            within: 6,
        },
        Detection {
            member: 0,
            within: 9,
        },
    ];
    assert_eq!(e.must, want);
    assert_eq!(e.link, Some(1));
    // cut on station1: card1 upstream of the break misses its own packets.
    let e = m.expect(3, Disturbance::Dark);
    assert_eq!(
        e.must,
        vec![
            Detection {
                member: 0,
                within: 9
            },
            Detection {
                member: 2,
                within: 10
            }
        ]
    );
    // The sync master killed: everybody else sees the dark.
    let e = m.expect(0, Disturbance::Dark);
    let who: Vec<usize> = e.must.iter().map(|d| d.member).collect();
    assert_eq!(who, vec![1, 2, 3]);
    assert!(m.expect(2, Disturbance::Stall).quiet());
    for kind in [FaultKind::Corrupt, FaultKind::Cut, FaultKind::DropSync] {
        let e = m.expect(
            1,
            Disturbance::Frames {
                kind,
                cycles: Some(1),
            },
        );
        assert!(e.quiet(), "{kind}: {e:?}");
    }
    assert_eq!(m.safe_burst(0, FaultKind::DelayMicros(500)), u64::MAX);
    assert_eq!(
        m.safe_burst(0, FaultKind::Corrupt),
        3,
        "station0 is downstream"
    );
    assert_eq!(
        m.safe_burst(1, FaultKind::Corrupt),
        1,
        "card1 is downstream"
    );
    assert_eq!(m.safe_burst(1, FaultKind::DropSync), 4);
    assert_eq!(m.safe_burst(1, FaultKind::DropPackets), 2);
}

mod fuzz {
    //! The ring's model of any config the config accepts: real configs with a key's value
    //! replaced, a line dropped or lines swapped (the config's own fuzzing is mcc-contracts'
    //! `config::tests::fuzz`) either fail to parse or give a model without a panic.
    use super::*;

    const VALUES: &[&str] = &[
        "0",
        "1",
        "-1",
        "2",
        "255",
        "65536",
        "4294967296",
        "\"\"",
        "\"card0\"",
        "\"station0\"",
        "\"lockstep\"",
        "true",
        "[]",
        "[\"card0\"]",
        "{}",
    ];

    fn sample() -> String {
        let mut d = ClusterConfig::default_cluster(2, 2);
        d.cards[0].ivars.insert("I1001".into(), IVarValue::Int(8));
        d.to_toml_string().unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn any_valid_config_has_a_model(
            edits in proptest::collection::vec(
                (any::<prop::sample::Index>(), 0u8..4, proptest::sample::select(VALUES)), 1..6),
        ) {
            let mut lines: Vec<String> = sample().lines().map(String::from).collect();
            for (at, what, value) in edits {
                let i = at.index(lines.len());
                match what {
                    0 | 1 => {
                        if let Some((k, _)) = lines[i].split_once(" = ") {
                            lines[i] = format!("{k} = {value}");
                        }
                    }
                    2 => {
                        lines.remove(i);
                        if lines.is_empty() {
                            break;
                        }
                    }
                    _ => {
                        let j = (i + 1) % lines.len();
                        lines.swap(i, j);
                    }
                }
            }
            if let Ok(c) = ClusterConfig::from_toml_str(&lines.join("\n")) {
                let _ = RingModel::from_config(&c);
            }
        }
    }
}
