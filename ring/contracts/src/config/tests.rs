use super::*;

fn err_of(text: &str) -> ConfigError {
    match ClusterConfig::from_toml_str(text) {
        Ok(c) => panic!("expected an error, parsed {c:?}"),
        Err(e) => e,
    }
}

fn invalid(text: &str) -> (String, String) {
    match err_of(text) {
        ConfigError::Invalid { key, problem } => (key, problem),
        other => panic!("expected Invalid, got {other}"),
    }
}

const TWO_BY_TWO: &str = r#"
[[cards]]
name = "card0"
number = 0
master = 0
[[cards]]
name = "card1"
number = 1
master = 1
[[stations]]
name = "station0"
master = 0
[[stations]]
name = "station1"
master = 1
"#;

#[test]
fn minimal_file_gets_defaults() {
    let c = ClusterConfig::from_toml_str(TWO_BY_TWO).unwrap();
    assert_eq!(c.cluster, "mcc");
    assert_eq!(c.clock, ClockMode::Paced);
    assert_eq!(c.rate_hz, 2258.7);
    assert_eq!(c.rtf, 1.0);
    assert_eq!(c.member_timeout_ms, DEFAULT_MEMBER_TIMEOUT_MS);
    assert_eq!(c.ring.name, "0");
    assert_eq!(c.ring.order, ["card0", "station0", "card1", "station1"]);
    assert_eq!(c.ring.sync_master, "card0");
    assert_eq!(c.cards[1].profile, "pmac2");
    assert_eq!(c.cards[1].nodes, [0, 1, 4, 5, 8, 9, 12, 13]);
    assert_eq!(
        c.stations[0].check,
        StationCheck {
            period: 8,
            min_syncs: 4,
            max_errors: 4
        }
    );
    assert_eq!(c.period_ns(), 442_733);
}

#[test]
fn embedded_default_matches_file_form() {
    let d = ClusterConfig::default_cluster(2, 2);
    // The embedded default arms the cards' ring check; a file says so explicitly.
    let text = TWO_BY_TWO.replace(
        "master = 0\n[[cards]]",
        "master = 0\nivars = { I1001 = 16, I1004 = 2, I1005 = 4 }\n[[cards]]",
    );
    let text = text.replace(
        "master = 1\n[[stations]]",
        "master = 1\nivars = { I1001 = 16, I1004 = 2, I1005 = 4 }\n[[stations]]",
    );
    // …and it has one EMCL drive on station0.
    let text =
        format!("{text}\n[[drives]]\nname = \"drive0\"\naddress = 1\nstation = \"station0\"\n");
    let parsed = ClusterConfig::from_toml_str(&text).unwrap();
    assert_eq!(d, parsed);
    d.validate().unwrap();
}

#[test]
fn default_cluster_groups_stations_after_their_card() {
    let d = ClusterConfig::default_cluster(2, 5);
    assert_eq!(
        d.ring.order,
        ["card0", "station0", "station2", "station4", "card1", "station1", "station3"]
    );
    assert_eq!(d.stations[3].master, 1);
    assert_eq!(d.stations[0].nodes, [0, 1]);
    assert_eq!(d.stations[2].nodes, [4, 5, 8]);
    assert_eq!(d.stations[4].nodes, [9, 12, 13]);
    assert_eq!(d.stations[1].nodes, [0, 1, 4, 5]);
    assert_eq!(d.stations[3].nodes, [8, 9, 12, 13]);
    d.validate().unwrap();
    let big = ClusterConfig::default_cluster(4, 8);
    assert_eq!(big.ring.order.len(), 12);
    big.validate().unwrap();
}

#[test]
fn resolved_config_round_trips_through_toml() {
    let mut d = ClusterConfig::default_cluster(2, 2);
    d.clock = ClockMode::Lockstep;
    d.cards[0].ivars.insert("I1001".into(), IVarValue::Int(8));
    d.cards[0]
        .ivars
        .insert("I130".into(), IVarValue::Float(2.5));
    d.zenoh.connect.push("tcp/127.0.0.1:7447".into());
    let text = d.to_toml_string().unwrap();
    assert_eq!(ClusterConfig::from_toml_str(&text).unwrap(), d);
}

#[test]
fn ring_settings_follow_the_spec() {
    let d = ClusterConfig::default_cluster(2, 2);
    let nodes = 0b0011_0011_0011_0011u32;
    let sm = d.ring_settings("card0").unwrap();
    assert_eq!(sm.i995, 0x30);
    assert_eq!(sm.i996, 0x0F_0000 | nodes);
    let c1 = d.ring_settings("card1").unwrap();
    assert_eq!(c1.i995, 0x8090);
    assert_eq!(c1.i996, 0x1F_0000 | 0x8000 | nodes);
    let s1 = d.ring_settings("station1").unwrap();
    assert_eq!(s1.i995, 0x8080);
    assert_eq!(s1.i996, 0x1F_0000 | 0x8000 | nodes);
    assert!(d.ring_settings("nobody").is_none());
}

#[test]
fn ring_navigation() {
    let d = ClusterConfig::default_cluster(2, 2);
    assert_eq!(d.position("card1"), Some(2));
    assert_eq!(d.upstream("card1"), Some("station0"));
    assert_eq!(d.upstream("card0"), Some("station1"));
    assert!(matches!(d.member("station0"), Some(MemberRef::Station(_))));
}

#[test]
fn unknown_key_is_named() {
    let e = err_of(&format!(
        "{TWO_BY_TWO}\n[[stations]]\nname=\"s9\"\nmaster=0\nnodez=[1]\n"
    ));
    let msg = e.to_string();
    assert!(msg.contains("nodez"), "{msg}");
    let e = err_of("colck = \"lockstep\"\n");
    assert!(e.to_string().contains("colck"), "{e}");
}

#[test]
fn wrong_types_and_syntax_are_errors_not_panics() {
    let e = err_of("rate_hz = \"fast\"\n");
    assert!(e.to_string().contains("rate_hz"), "{e}");
    let e = err_of("clock = \"sometimes\"\n");
    assert!(e.to_string().contains("sometimes"), "{e}");
    let e = err_of(&TWO_BY_TWO.replace("number = 1", "number = 300"));
    assert!(e.to_string().contains("number"), "{e}");
    for junk in [
        "[[cards]\n",
        "= 3",
        "cards = 5",
        "\u{0}",
        "[ring]\norder = [1, 2]",
    ] {
        assert!(matches!(err_of(junk), ConfigError::Parse(_)), "{junk:?}");
    }
}

#[test]
fn validation_errors_name_key_and_problem() {
    let cases: &[(&str, &str, &str, &str)] = &[
        (
            "name = \"card1\"",
            "name = \"card0\"",
            "cards[1].name",
            "duplicate",
        ),
        (
            "name = \"station1\"",
            "name = \"card0\"",
            "stations[1].name",
            "duplicate",
        ),
        (
            "number = 1",
            "number = 0",
            "cards[1].number",
            "already used",
        ),
        ("number = 1", "number = 16", "cards[1].number", "0-15"),
        (
            "master = 1\n[[stations]]",
            "master = 0\n[[stations]]",
            "cards[1].master",
            "already",
        ),
        (
            "name = \"station1\"\nmaster = 1",
            "name = \"station1\"\nmaster = 7",
            "stations[1].master",
            "no card",
        ),
    ];
    for (from, to, key, word) in cases {
        let text = TWO_BY_TWO.replacen(from, to, 1);
        assert_ne!(text, TWO_BY_TWO, "{from}");
        let (k, p) = invalid(&text);
        assert_eq!(&k, key, "{p}");
        assert!(p.contains(word), "{k}: {p}");
    }
}

#[test]
fn more_validation_rules() {
    let with = |extra: &str| format!("{extra}\n{TWO_BY_TWO}");
    assert_eq!(invalid(&with("rate_hz = 0.0")).0, "rate_hz");
    assert_eq!(invalid(&with("rate_hz = -5")).0, "rate_hz");
    assert_eq!(invalid(&with("rate_hz = nan")).0, "rate_hz");
    assert_eq!(invalid(&with("cluster = \"a/b\"")).0, "cluster");
    assert_eq!(
        invalid(&with("member_timeout_ms = 0")).0,
        "member_timeout_ms"
    );
    // A phase delay of a period or more would tick cycle k after cycle k+1 began.
    let (k, p) = invalid(&with("rate_hz = 1000.0\nphase_delay_us = 1000"));
    assert_eq!(k, "phase_delay_us");
    assert!(p.contains("1000.0 µs"), "{p}");
    assert!(ClusterConfig::from_toml_str(&with("rate_hz = 1000.0\nphase_delay_us = 999")).is_ok());
    let ring = |body: &str| with(&format!("[ring]\n{body}"));
    let (k, p) = invalid(&ring("order = [\"card0\", \"station0\", \"card1\"]"));
    assert_eq!(k, "ring.order");
    assert!(p.contains("station1") && p.contains("missing"), "{p}");
    let (k, p) = invalid(&ring(
        "order = [\"card0\", \"ghost\", \"card1\", \"station1\"]",
    ));
    assert_eq!(k, "ring.order[1]");
    assert!(p.contains("ghost"), "{p}");
    let (k, _) = invalid(&ring(
        "order = [\"card0\", \"card0\", \"card1\", \"station1\"]",
    ));
    assert_eq!(k, "ring.order[1]");
    let (k, p) = invalid(&ring("sync_master = \"station0\""));
    assert_eq!(k, "ring.sync_master");
    assert!(p.contains("must be a card"), "{p}");
    let card =
        |body: &str| format!("{TWO_BY_TWO}\n[[cards]]\nname=\"c9\"\nnumber=9\nmaster=9\n{body}");
    let (k, p) = invalid(&card("profile = \"pmac3\""));
    assert_eq!(k, "cards[2].profile");
    assert!(p.contains("pmac3"), "{p}");
    assert_eq!(invalid(&card("nodes = [0, 16]")).0, "cards[2].nodes[1]");
    assert_eq!(invalid(&card("nodes = [15]")).0, "cards[2].nodes[0]");
    assert_eq!(invalid(&card("nodes = [3, 3]")).0, "cards[2].nodes[1]");
    assert_eq!(invalid(&card("ivars = { P5 = 1 }")).0, "cards[2].ivars.P5");
    assert_eq!(
        invalid(&card("ivars = { I9999 = 1 }")).0,
        "cards[2].ivars.I9999"
    );
    assert_eq!(
        invalid(&card("ivars = { I5 = inf }")).0,
        "cards[2].ivars.I5"
    );
    let ports = card("ascii_port = 5000\npmac_eth_port = 5000");
    assert_eq!(invalid(&ports).0, "cards[2].pmac_eth_port");
    // The Power card's host keys.
    let (k, p) = invalid(&card("ssh_port = 2222"));
    assert_eq!(k, "cards[2].ssh_port");
    assert!(p.contains("power"), "{p}");
    assert_eq!(
        invalid(&card("gpascii_port = 2223")).0,
        "cards[2].gpascii_port"
    );
    assert_eq!(invalid(&card("ssh_user = \"\"")).0, "cards[2].ssh_user");
    assert_eq!(invalid(&card("ssh_user = \"a b\"")).0, "cards[2].ssh_user");
    assert_eq!(
        invalid(&card("ssh_password = \"x\\ny\"")).0,
        "cards[2].ssh_password"
    );
    let long = format!("ssh_password = \"{}\"", "p".repeat(129));
    assert_eq!(invalid(&card(&long)).0, "cards[2].ssh_password");
    let st = |body: &str| format!("{TWO_BY_TWO}\n[[stations]]\nname=\"s9\"\nmaster=0\n{body}");
    let (k, p) = invalid(&st("nodes = [2, 4]"));
    assert_eq!(k, "stations[2].nodes[1]");
    assert!(p.contains("station0"), "{p}");
    assert_eq!(
        invalid(&st("nodes = [2]\ncheck = { period = 0 }")).0,
        "stations[2].check.period"
    );
    let (k, _) = invalid(&st("nodes = [2]\ncheck = { period = 4, min_syncs = 5 }"));
    assert_eq!(k, "stations[2].check.min_syncs");
    assert_eq!(invalid("").0, "cards");
    assert_eq!(
        invalid(&with("[zenoh]\nconnect = [\"localhost\"]")).0,
        "zenoh.connect[0]"
    );
}

#[test]
fn ivars_accept_ints_and_floats() {
    let text = format!("{TWO_BY_TWO}\n[[cards]]\nname=\"c9\"\nnumber=9\nmaster=9\nivars = {{ I1001 = 8, I130 = 1.5 }}");
    let c = ClusterConfig::from_toml_str(&text).unwrap();
    assert_eq!(c.cards[2].ivars["I1001"], IVarValue::Int(8));
    assert_eq!(c.cards[2].ivars["I130"].as_f64(), 1.5);
}

#[test]
fn missing_file_is_an_io_error() {
    let e = ClusterConfig::from_file(Path::new("/nonexistent/mcc.toml")).unwrap_err();
    assert!(matches!(e, ConfigError::Io { .. }), "{e}");
    assert!(e.to_string().contains("/nonexistent/mcc.toml"));
}

#[test]
#[allow(clippy::disallowed_methods)] // writes a config file
fn a_directory_as_state_file_is_refused_naming_the_key() {
    let (key, problem) = invalid(
        r#"
[[cards]]
name = "card0"
number = 0
master = 0
state_file = "/tmp/"
"#,
    );
    assert_eq!(key, "cards[0].state_file");
    assert!(problem.contains("directory"), "{problem}");
    // An existing directory given without a trailing slash is caught when the file is read.
    let dir = std::env::temp_dir().join(format!("mcc-cfg-dir-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("cluster.toml");
    let text = format!(
        "[[cards]]\nname = \"card0\"\nnumber = 0\nmaster = 0\nstate_file = {:?}\n",
        dir.display().to_string()
    );
    std::fs::write(&file, text).unwrap();
    match ClusterConfig::from_file(&file) {
        Err(ConfigError::Invalid { key, problem }) => {
            assert_eq!(key, "cards[0].state_file");
            assert!(problem.contains("is a directory"), "{problem}");
        }
        other => panic!("expected Invalid, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn clock_keys_are_checked_before_anything_starts() {
    let with = |extra: &str| format!("{extra}\n{TWO_BY_TWO}");
    // The clock words.
    for (word, mode) in [
        ("paced", ClockMode::Paced),
        ("lockstep", ClockMode::Lockstep),
        ("realtime", ClockMode::Realtime),
    ] {
        let c = ClusterConfig::from_toml_str(&with(&format!("clock = \"{word}\""))).unwrap();
        assert_eq!(c.clock, mode);
        assert_eq!(word.parse::<ClockMode>(), Ok(mode));
        assert_eq!(mode.as_str(), word);
    }
    let e = "sometimes".parse::<ClockMode>().unwrap_err().to_string();
    assert!(e.contains("sometimes") && e.contains("paced"), "{e}");
    match err_of(&with("clock = \"sometimes\"")) {
        ConfigError::Parse(m) => assert!(m.contains("sometimes") && m.contains("paced"), "{m}"),
        other => panic!("{other}"),
    }
    // The real-time factor: positive, finite, not absurd, paced only.
    let c = ClusterConfig::from_toml_str(&with("rtf = 2.5")).unwrap();
    assert_eq!(c.rtf, 2.5);
    assert_eq!(c.wall_period_ns(), (442_733.0f64 / 2.5).round() as u64);
    for bad in [
        "rtf = 0.0",
        "rtf = -1",
        "rtf = nan",
        "rtf = inf",
        "rtf = 1e9",
    ] {
        let (k, p) = invalid(&with(bad));
        assert_eq!(k, "rtf", "{bad}: {p}");
    }
    let (_, p) = invalid(&with("rtf = 0"));
    assert!(p.contains("real-time factor"), "{p}");
    let (k, p) = invalid(&with("clock = \"lockstep\"\nrtf = 2"));
    assert_eq!(k, "rtf");
    assert!(
        p.contains("only the paced clock") && p.contains("lockstep"),
        "{p}"
    );
    assert!(ClusterConfig::from_toml_str(&with("clock = \"lockstep\"\nrtf = 1")).is_ok());
    let (k, p) = invalid(&with("rate_hz = 500000\nrtf = 100"));
    assert_eq!(k, "rtf");
    assert!(p.contains("cycles per second"), "{p}");
    // The frozen-member wait: at least one ring period of wall time.
    let (k, p) = invalid(&with("rate_hz = 100\nmember_timeout_ms = 5"));
    assert_eq!(k, "member_timeout_ms");
    assert!(p.contains("shorter than one ring period"), "{p}");
    let (k, _) = invalid(&with("rate_hz = 100\nrtf = 0.5\nmember_timeout_ms = 15"));
    assert_eq!(k, "member_timeout_ms");
    assert!(ClusterConfig::from_toml_str(&with("rate_hz = 100\nmember_timeout_ms = 10")).is_ok());
    assert_eq!(
        invalid(&with("member_timeout_ms = 60001")).0,
        "member_timeout_ms"
    );
    // The synchronized-start stall: a quarter of the wait on the stepped clocks, ≤ 25 ms in
    // realtime.
    let c = ClusterConfig::from_toml_str(&with("member_timeout_ms = 10000")).unwrap();
    assert_eq!(c.sync_start_stall(), std::time::Duration::from_millis(2500));
    let c = ClusterConfig::from_toml_str(&with("clock = \"realtime\"")).unwrap();
    assert_eq!(c.sync_start_stall(), std::time::Duration::from_millis(25));
    // The old name of the key is still read.
    let c = ClusterConfig::from_toml_str(&with("lockstep_timeout_ms = 250")).unwrap();
    assert_eq!(c.member_timeout_ms, 250);
}

mod fuzz {
    //! Fuzzing the cluster config: any text, and real configs with any key's value replaced,
    //! a line dropped or lines swapped: an error naming the problem or a config whose every
    //! derived quantity (periods, timeouts, ring settings) computes without a panic, and that
    //! round-trips through its TOML (the ring's model of a config, `RingModel::from_config`,
    //! is fuzzed the same way in mcc-ring's `expect_tests.rs`). A longer run:
    //! `PROPTEST_CASES=20000 cargo test -p mcc-contracts --lib config::tests::fuzz`.
    use super::*;
    use proptest::prelude::*;

    /// Values that probe limits and types.
    const VALUES: &[&str] = &[
        "0",
        "1",
        "-1",
        "2",
        "255",
        "256",
        "65535",
        "65536",
        "4294967296",
        "9223372036854775807",
        "18446744073709551615",
        "-9223372036854775808",
        "1e308",
        "-1e308",
        "nan",
        "inf",
        "0.5",
        "\"\"",
        "\"x\"",
        "\"card0\"",
        "\"station0\"",
        "\"lockstep\"",
        "\"paced\"",
        "\"realtime\"",
        "\"/\"",
        "\"/nonexistent/dir/\"",
        "true",
        "false",
        "[]",
        "[\"card0\"]",
        "[\"card0\", \"card0\"]",
        "{}",
        "[[]]",
        "\"tcp/127.0.0.1:0\"",
        "1970-01-01",
    ];

    fn sample() -> String {
        let mut d = ClusterConfig::default_cluster(2, 2);
        d.cards[0].ivars.insert("I1001".into(), IVarValue::Int(8));
        d.to_toml_string().unwrap()
    }

    /// Every quantity the members and the orchestrator derive from a valid config.
    fn derive_all(c: &ClusterConfig) {
        let _ = (
            c.phase_delay_ns(),
            c.wall_period_ns(),
            c.member_timeout(),
            c.period_ns(),
        );
        for m in &c.ring.order {
            let _ = (
                c.ring_settings(m),
                c.upstream(m),
                c.position(m),
                c.member(m),
            );
        }
    }

    fn check(text: &str) -> Result<(), TestCaseError> {
        if let Ok(c) = ClusterConfig::from_toml_str(text) {
            derive_all(&c);
            let again = c.to_toml_string().expect("a valid config serializes");
            let back = ClusterConfig::from_toml_str(&again);
            prop_assert_eq!(back.as_ref(), Ok(&c));
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        #[test]
        fn fuzz_any_text(text in "(?s).{0,400}") {
            check(&text)?;
        }

        #[test]
        fn fuzz_real_config_with_values_replaced(
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
            check(&lines.join("\n"))?;
        }
    }
}
