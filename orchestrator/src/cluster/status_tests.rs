use super::*;
use crate::cluster::rundir::MemberProc;

fn healthy(cfg: &ClusterConfig, cycle: u64) -> Vec<Option<MemberStatus>> {
    cfg.ring
        .order
        .iter()
        .enumerate()
        .map(|(i, name)| {
            Some(MemberStatus {
                name: name.clone(),
                pid: 1000 + i as u32,
                ring_position: i,
                locked: true,
                cycle,
                sync_count: cycle,
                last_rx_cycle: Some(cycle),
                ..Default::default()
            })
        })
        .collect()
}

fn info() -> SupervisorInfo {
    let mut i = SupervisorInfo::starting(42, "mcc");
    i.endpoint = Some("tcp/127.0.0.1:7000".into());
    i.members.push(MemberProc {
        name: "card1".into(),
        kind: "card".into(),
        pid: 777,
    });
    i
}

#[test]
fn healthy_ring_has_no_broken_link() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let st = healthy(&cfg, 5000);
    assert_eq!(broken_link(&cfg, &st, &[], 32), None);
    let doc = build(&cfg, &info(), "/run/x", &st, &[]);
    assert!(doc.ring.locked);
    assert!(!doc.ring.faulted);
    assert_eq!(doc.ring.cycle, 5000);
}

#[test]
fn bad_data_on_a_link_names_it_but_lost_own_packets_do_not() {
    // corrupt on station1's sends: card0 (the sync master, downstream) latched on checksum
    // errors; card1 latched too, only because its own packets did not come back (no link
    // error of its own): the link named is station1 → card0.
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    for i in [0, 2] {
        let m = st[i].as_mut().unwrap();
        m.ring_fault = true;
        m.ring_fault_cycle = Some(2990);
    }
    st[0].as_mut().unwrap().link_error_cycle = Some(2999);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
    // Errors long before the latch did not make it: they name nothing.
    st[0].as_mut().unwrap().link_error_cycle = Some(2900);
    assert_eq!(broken_link(&cfg, &st, &[], 32), None);
    // The link healed (a restarted member, a cleared fault) long ago: the bad data that made
    // the latch still names its link until the reset.
    st[0].as_mut().unwrap().link_error_cycle = Some(2989);
    for m in st.iter_mut().flatten() {
        m.cycle = 9000;
        m.last_rx_cycle = Some(9000);
    }
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
    // A long dark spell (a sync master restarted) that made the latch, light back since.
    st[0].as_mut().unwrap().link_error_cycle = Some(5000);
    assert_eq!(broken_link(&cfg, &st, &[], 32), None);
    st[0].as_mut().unwrap().last_dark_spell = Some((2985, 5000));
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
    st[0].as_mut().unwrap().last_dark_spell = None;
    for m in st.iter_mut().flatten() {
        m.cycle = 3000;
        m.last_rx_cycle = Some(3000);
    }
    // A tolerated burst (no latch) names nothing either.
    for m in st.iter_mut().flatten() {
        m.ring_fault = false;
        m.link_error_cycle = Some(2999);
    }
    assert_eq!(broken_link(&cfg, &st, &[], 32), None);
}

#[test]
fn cut_is_localised_to_the_link_after_the_cutting_member() {
    // order: card0*, station0, card1, station1. station0 cut its outgoing link at cycle 1000:
    // card1 and station1 receive nothing since; the sync master's sync never returns.
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    for i in [2, 3, 0] {
        st[i].as_mut().unwrap().last_rx_cycle = Some(1000);
    }
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station0 → card1")
    );
    let doc = build(&cfg, &info(), "/run/x", &st, &[]);
    assert!(doc.ring.faulted);
    assert_eq!(doc.ring.broken_link.as_deref(), Some("station0 → card1"));
    // The link back into the sync master.
    let mut st = healthy(&cfg, 3000);
    st[0].as_mut().unwrap().last_rx_cycle = Some(10);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
    // The first link out of the sync master, and a member that never received anything.
    let mut st = healthy(&cfg, 3000);
    for s in st.iter_mut().skip(1) {
        s.as_mut().unwrap().last_rx_cycle = None;
    }
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("card0 → station0")
    );
}

#[test]
fn small_lag_within_threshold_is_not_a_break() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    st[3].as_mut().unwrap().last_rx_cycle = Some(3000 - 32);
    assert_eq!(broken_link(&cfg, &st, &[], 32), None);
    st[3].as_mut().unwrap().last_rx_cycle = Some(3000 - 33);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("card1 → station1")
    );
}

#[test]
fn dead_member_breaks_the_link_leaving_it() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    st[2] = None;
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("card1 → station1")
    );
    let doc = build(&cfg, &info(), "/run/x", &st, &[]);
    assert!(!doc.ring.locked);
    let card1 = &doc.members[2];
    assert!(!card1.alive);
    assert_eq!(card1.pid, Some(777), "pid comes from the supervisor record");
}

#[test]
fn lag_threshold_uses_the_smallest_check_period() {
    let mut cfg = ClusterConfig::default_cluster(2, 2);
    assert_eq!(lag_threshold(&cfg), 32);
    cfg.stations[0].check.period = 20;
    cfg.stations[1].check.period = 20;
    assert_eq!(lag_threshold(&cfg), 64);
    cfg.cards[0]
        .ivars
        .insert("I1001".into(), mcc_contracts::config::IVarValue::Int(10));
    assert_eq!(lag_threshold(&cfg), 40);
}

#[test]
fn json_document_has_the_contract_fields() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 77);
    let card0 = st[0].as_mut().unwrap();
    card0.extra.insert("ascii".into(), serde_json::json!(5001));
    card0
        .extra
        .insert("pmac_eth".into(), serde_json::json!("127.0.0.1:5002"));
    // A Power card reports its gpascii and SSH ports instead.
    let card1 = st[2].as_mut().unwrap();
    card1
        .extra
        .insert("gpascii".into(), serde_json::json!(6001));
    card1.extra.insert("ssh".into(), serde_json::json!(6002));
    let doc = serde_json::to_value(build(&cfg, &info(), "/run/x", &st, &[])).unwrap();
    assert_eq!(doc["cards"][1]["gpascii"], 6001);
    assert_eq!(doc["cards"][1]["ssh"], 6002);
    assert_eq!(doc["cards"][0]["gpascii"], serde_json::Value::Null);
    assert_eq!(doc["cards"][0]["ssh"], serde_json::Value::Null);
    for k in [
        "cluster",
        "clock",
        "rate",
        "ring",
        "members",
        "cards",
        "stations",
        "daisy_chain",
        "emcl_bus",
    ] {
        assert!(doc.get(k).is_some(), "missing {k}");
    }
    assert_eq!(doc["clock"], "paced");
    for k in [
        "rtf",
        "rtf_requested",
        "late_cycles",
        "max_lag_us",
        "timing",
    ] {
        assert!(doc.get(k).is_some(), "missing {k}");
    }
    assert_eq!(doc["rate"], 2258.7);
    assert_eq!(doc["daisy_chain"], serde_json::Value::Null);
    for k in ["name", "locked", "cycle", "faulted", "broken_link"] {
        assert!(doc["ring"].get(k).is_some(), "ring.{k}");
    }
    let m = &doc["members"][1];
    assert_eq!(m["name"], "station0");
    assert_eq!(m["kind"], "station");
    assert_eq!(m["ring_position"], 1);
    assert_eq!(m["sync_count"], 77);
    for k in [
        "byte_violation",
        "checksum",
        "overrun",
        "underrun",
        "bad_frames",
    ] {
        assert_eq!(m["errors"][k], 0, "errors.{k}");
    }
    assert_eq!(doc["members"][0]["sync_master"], true);
    assert_eq!(doc["cards"][0]["ascii"], 5001);
    assert_eq!(doc["cards"][0]["pmac_eth"], 5002);
    assert_eq!(doc["cards"][1]["number"], 1);
    assert_eq!(doc["cards"][1]["ascii"], serde_json::Value::Null);
    assert_eq!(
        doc["stations"][1]["nodes"],
        serde_json::json!([0, 1, 4, 5, 8, 9, 12, 13])
    );
    let table = render_table(&build(&cfg, &info(), "/run/x", &st, &[]));
    assert!(table.contains("card0*"), "{table}");
    assert!(table.contains("ascii 127.0.0.1:5001"), "{table}");
}

#[test]
fn a_dark_input_names_the_link_and_the_clock_comes_from_the_sync_master() {
    // station0 cut (dark frames): card1, station1 and card0 get no light; their last frame
    // with light is recent enough that only darkness tells.
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    for i in [2, 3, 0] {
        let m = st[i].as_mut().unwrap();
        m.dark = true;
        m.dark_since_cycle = Some(2995);
        m.last_rx_cycle = Some(2994);
    }
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station0 → card1")
    );
    st[0].as_mut().unwrap().clock = Some(ClockReport {
        mode: "paced".into(),
        rtf_requested: 1.0,
        rtf: 0.997,
        late_cycles: 12,
        max_lag_us: 2500,
        ..Default::default()
    });
    let doc = build(&cfg, &info(), "/run/x", &st, &[]);
    assert_eq!(doc.rtf, Some(0.997));
    assert_eq!((doc.late_cycles, doc.max_lag_us), (12, 2500));
    let j = serde_json::to_value(&doc).unwrap();
    assert_eq!(j["members"][2]["dark"], true);
    assert_eq!(j["members"][2]["dark_since_cycle"], 2995);
    assert_eq!(j["timing"]["late_cycles"], 12);
    let table = render_table(&doc);
    assert!(
        table.contains("rtf 1.00 of 1 requested, 12 late cycles, worst lag 2.5 ms"),
        "{table}"
    );
    assert!(table.contains("dark"), "{table}");
}

#[test]
fn a_member_slow_to_answer_is_not_gone_and_breaks_no_link() {
    // card1's status reply came too late for this round (a busy machine) but it holds its
    // liveliness token: it is slow, not dead, and the ring is not faulted.
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    st[2] = None;
    let slow = [false, false, true, false];
    assert_eq!(broken_link(&cfg, &st, &slow, 32), None);
    let doc = build(&cfg, &info(), "/run/x", &st, &slow);
    assert!(!doc.ring.faulted, "{:?}", doc.ring);
    assert_eq!(doc.ring.broken_link, None);
    let card1 = &doc.members[2];
    assert!(!card1.alive && card1.slow);
    assert!(!doc.ring.locked, "card1's lock is not known this round");
    assert!(
        render_table(&doc).contains(" slow "),
        "{}",
        render_table(&doc)
    );
    // A real break downstream of the slow member is still found (station1 dark).
    let m = st[3].as_mut().unwrap();
    m.dark = true;
    assert_eq!(
        broken_link(&cfg, &st, &slow, 32).as_deref(),
        Some("card1 → station1")
    );
    // Gone (no answer, no token): the link leaving it is broken, as before.
    st[3].as_mut().unwrap().dark = false;
    assert_eq!(
        broken_link(&cfg, &st, &[false; 4], 32).as_deref(),
        Some("card1 → station1")
    );
    let doc = build(&cfg, &info(), "/run/x", &st, &[false; 4]);
    assert!(doc.ring.faulted && !doc.members[2].slow);
}

#[test]
fn a_member_running_behind_the_sync_master_is_not_cut_off() {
    // station1 answered late: its snapshot is 1000 cycles behind the master's, but it has
    // received every frame it ran (its own cycle). Only a lag against its own cycle is a break.
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    let m = st[3].as_mut().unwrap();
    m.cycle = 2000;
    m.last_rx_cycle = Some(1999);
    assert_eq!(broken_link(&cfg, &st, &[], 32), None);
    let doc = build(&cfg, &info(), "/run/x", &st, &[]);
    assert!(!doc.ring.faulted && doc.ring.locked);
    // The same member on its holdover clock with nothing received for 33 cycles: broken.
    let m = st[3].as_mut().unwrap();
    m.last_rx_cycle = Some(2000 - 33);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("card1 → station1")
    );
}

#[test]
fn dark_links_name_where_light_is_lost_not_where_darkness_is_passed_on() {
    // card0, station0 | card1, station1: the network between the two pairs is cut.
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 500);
    assert!(dark_links(&cfg, &st).is_empty());
    // Seen from card0's side: card1 and station1 do not answer, card0's input is dark.
    let mut a = st.clone();
    a[2] = None;
    a[3] = None;
    a[0].as_mut().unwrap().dark = true;
    assert_eq!(dark_links(&cfg, &a), vec!["station1 → card0"]);
    // Seen from card1's side: card1's input is dark, station1 only passes the darkness on.
    st[0] = None;
    st[1] = None;
    st[2].as_mut().unwrap().dark = true;
    st[3].as_mut().unwrap().dark = true;
    assert_eq!(dark_links(&cfg, &st), vec!["station0 → card1"]);
    // A cut injected on station0 (station0 lit, card1 and station1 dark).
    let mut cut = healthy(&cfg, 500);
    cut[2].as_mut().unwrap().dark = true;
    cut[3].as_mut().unwrap().dark = true;
    assert_eq!(dark_links(&cfg, &cut), vec!["station0 → card1"]);
}

/// Content before lag: a member between the sync master and the break that is starved of
/// CPU lags the master's own-clock count, but the member whose input carries the break's
/// content (dark frames, bad data) names the link.
#[test]
fn content_names_the_link_before_a_starved_member_s_lag() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    // card1 (position 2) ran behind: 100 cycles without a frame of its own count.
    st[2].as_mut().unwrap().last_rx_cycle = Some(2900);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station0 → card1"),
        "lag alone still names a link"
    );
    // The sync master's input is dark: that is the break.
    st[0].as_mut().unwrap().dark = true;
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
    // Or it latched on bad data from its input.
    st[0].as_mut().unwrap().dark = false;
    let m = st[0].as_mut().unwrap();
    m.ring_fault = true;
    m.ring_fault_cycle = Some(2995);
    m.link_error_cycle = Some(2998);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
}

/// A link-error stamp beyond the member's own cycle is from before a renumbering (a
/// restarted sync master): it is no evidence of the present latch.
#[test]
fn a_link_error_stamp_from_before_a_renumbering_names_nothing() {
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 3000);
    for i in [0, 2] {
        let m = st[i].as_mut().unwrap();
        m.ring_fault = true;
        m.ring_fault_cycle = Some(2990);
    }
    st[2].as_mut().unwrap().link_error_cycle = Some(90_000);
    st[0].as_mut().unwrap().link_error_cycle = Some(2999);
    assert_eq!(
        broken_link(&cfg, &st, &[], 32).as_deref(),
        Some("station1 → card0")
    );
}

#[test]
fn link_faults_show_in_the_card_entry_the_document_and_the_table() {
    use mcc_ring::linkfault::{LinkFaultKind, LinkFaultSlot, LinkFaultSpec};
    let cfg = ClusterConfig::default_cluster(2, 2);
    let mut st = healthy(&cfg, 10);
    let clean = render_table(&build(&cfg, &info(), "/run/x", &st, &[]));
    assert!(!clean.contains("host-link"), "{clean}");
    let slot = LinkFaultSlot::default();
    slot.set(LinkFaultSpec {
        kind: LinkFaultKind::Corrupt,
        probability: 0.5,
        seed: 3,
        replies: Some(5),
        delay_ms: 0,
    });
    let card0 = st[0].as_mut().unwrap();
    card0.extra.insert(
        "link_fault".into(),
        serde_json::to_value(slot.active()).unwrap(),
    );
    let mut doc = build(&cfg, &info(), "/run/x", &st, &[]);
    doc.link_faults = Some(crate::cluster::link_ctl::LinkFaults {
        chain: None,
        bus: slot.active(),
    });
    let json = serde_json::to_value(&doc).unwrap();
    assert_eq!(json["cards"][0]["link_fault"]["kind"], "corrupt");
    assert_eq!(json["cards"][1]["link_fault"], serde_json::Value::Null);
    assert_eq!(json["link_faults"]["bus"]["replies"], 5);
    assert_eq!(json["link_faults"]["chain"], serde_json::Value::Null);
    let table = render_table(&doc);
    assert!(
        table.contains(
            "host-link faults: card0 corrupt (p 0.5, 0/5 replies seen, 0 hit); \
             bus corrupt (p 0.5, 0/5 replies seen, 0 hit)"
        ),
        "{table}"
    );
}

#[test]
fn a_station_s_axis_faults_show_in_json_and_table() {
    let cfg = ClusterConfig::default_cluster(1, 2);
    let mut st = healthy(&cfg, 500);
    let station1 = st[2].as_mut().unwrap();
    station1.extra.insert(
        "axis_faults".into(),
        serde_json::json!([
            {"node": 4, "kind": "load", "value": 0.5, "cycles": 100,
             "since_cycle": 400, "until_cycle": 500},
            {"node": null, "kind": "power-loss", "value": null, "cycles": null,
             "since_cycle": 450, "until_cycle": null}
        ]),
    );
    station1
        .extra
        .insert("power_loss".into(), serde_json::json!(true));
    let status = build(&cfg, &info(), "/run/x", &st, &[]);
    let doc = serde_json::to_value(&status).unwrap();
    assert_eq!(doc["stations"][1]["axis_faults"][0]["kind"], "load");
    assert_eq!(doc["stations"][1]["power_loss"], true);
    assert_eq!(doc["stations"][0]["axis_faults"], serde_json::json!([]));
    assert_eq!(doc["stations"][0]["power_loss"], serde_json::Value::Null);
    let table = render_table(&status);
    assert!(
        table.contains(
            "station station1: axis faults: node 4 load=0.5 (cycles 400-499), power-loss (since 450, until cleared)"
        ),
        "{table}"
    );
    assert!(!table.contains("station station0:"), "{table}");
}
