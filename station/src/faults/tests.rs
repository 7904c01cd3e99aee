use super::*;

fn axis(node: u8, kind: &str, value: Option<f64>, cycles: Option<u64>) -> StationFaultRequest {
    StationFaultRequest::Axis {
        node,
        kind: kind.into(),
        value,
        cycles,
    }
}

#[test]
fn every_kind_word_parses_and_round_trips() {
    for w in AXIS_KINDS {
        let v = VALUE_KINDS.iter().any(|k| k.0 == *w).then_some(12.5);
        let k = AxisFaultKind::parse(w, v).unwrap();
        assert_eq!(k.word(), *w);
        assert_eq!(k.value(), v);
    }
}

#[test]
fn bad_words_and_values_are_refused_naming_the_choices() {
    let e = AxisFaultKind::parse("melt", None).unwrap_err().to_string();
    assert!(
        e.contains("melt") && e.contains("amp-fault") && e.contains("home-chatter"),
        "{e}"
    );
    let e = AxisFaultKind::parse("load", None).unwrap_err().to_string();
    assert!(e.contains("needs --value") && e.contains("N·m"), "{e}");
    let e = AxisFaultKind::parse("jam", Some(1.0))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("takes no --value") && e.contains("encoder-glitch, load"),
        "{e}"
    );
    for v in [f64::NAN, f64::INFINITY, 1e9, -1e9] {
        assert!(
            AxisFaultKind::parse("encoder-glitch", Some(v)).is_err(),
            "{v}"
        );
        assert!(AxisFaultKind::parse("load", Some(v)).is_err(), "{v}");
    }
    assert!(AxisFaultKind::parse("plus-limit-", None).is_err());
    assert!(AxisFaultKind::parse("home-maybe", None).is_err());
}

#[test]
fn requests_are_checked_against_the_servo_nodes() {
    let mut t = FaultTable::default();
    let e = t
        .request(&axis(9, "jam", None, None), &[0, 1, 4, 5])
        .unwrap_err()
        .to_string();
    assert!(e.contains("node 9") && e.contains("0, 1, 4, 5"), "{e}");
    let e = t
        .request(&axis(0, "jam", None, Some(0)), &[0])
        .unwrap_err()
        .to_string();
    assert!(e.contains("at least 1"), "{e}");
    assert!(t.active().is_empty());
    // JSON as the orchestrator sends it; unknown fields are refused.
    let r: StationFaultRequest =
        serde_json::from_str(r#"{"op":"axis","node":0,"kind":"load","value":0.5}"#).unwrap();
    assert_eq!(r, axis(0, "load", Some(0.5), None));
    assert!(serde_json::from_str::<StationFaultRequest>(r#"{"op":"axis","node":0}"#).is_err());
    assert!(
        serde_json::from_str::<StationFaultRequest>(r#"{"op":"power-loss","extra":1}"#).is_err()
    );
    assert!(serde_json::from_str::<StationFaultRequest>(
        r#"{"op":"axis","node":300,"kind":"jam"}"#
    )
    .is_err());
}

#[test]
fn a_fault_starts_at_the_next_tick_and_lasts_its_cycles() {
    let mut t = FaultTable::default();
    t.request(&axis(0, "amp-fault", None, Some(3)), &[0, 1])
        .unwrap();
    assert_eq!(t.active()[0].since, None);
    assert!(!t.effects(0, 99).amp_fault, "not before its first tick");
    for c in 100..103 {
        t.tick(c);
        assert!(t.effects(0, c).amp_fault, "cycle {c}");
        assert!(!t.effects(1, c).amp_fault, "other node");
    }
    assert_eq!(t.active()[0].since, Some(100));
    assert_eq!(t.active()[0].until(), Some(103));
    t.tick(103);
    assert!(t.active().is_empty() && !t.effects(0, 103).amp_fault);
}

#[test]
fn until_cleared_replaced_by_kind_and_power_loss() {
    let mut t = FaultTable::default();
    t.request(&axis(0, "load", Some(0.5), None), &[0, 1])
        .unwrap();
    t.request(&axis(0, "plus-limit-on", None, None), &[0, 1])
        .unwrap();
    t.tick(10);
    t.request(&axis(0, "load", Some(-0.25), None), &[0, 1])
        .unwrap();
    t.request(&axis(0, "plus-limit-off", None, None), &[0, 1])
        .unwrap();
    t.tick(11);
    assert_eq!(t.active().len(), 2, "same slot replaced");
    let e = t.effects(0, 11);
    assert_eq!((e.load, e.plus_limit), (-0.25, Some(false)));
    for c in 12..1000 {
        t.tick(c);
    }
    assert_eq!(t.active().len(), 2, "until cleared");
    t.request(&StationFaultRequest::PowerLoss { cycles: None }, &[0, 1])
        .unwrap();
    t.tick(1000);
    assert!(t.power_loss() && t.effects(1, 1000).amp_fault);
    let j = t.active()[2].to_json();
    assert_eq!(j["kind"], "power-loss");
    assert_eq!(j["since_cycle"], 1000);
    assert!(j["until_cycle"].is_null() && j["node"].is_null());
    t.clear();
    assert!(t.active().is_empty() && t.effects(0, 1001) == NodeFaults::default());
}

#[test]
fn chatter_alternates_every_cycle_starting_on() {
    let mut t = FaultTable::default();
    t.request(&axis(1, "home-chatter", None, Some(5)), &[1])
        .unwrap();
    let mut seen = Vec::new();
    for c in 40..46 {
        t.tick(c);
        seen.push(t.effects(1, c).home);
    }
    assert_eq!(
        seen,
        [
            Some(true),
            Some(false),
            Some(true),
            Some(false),
            Some(true),
            None
        ]
    );
}
