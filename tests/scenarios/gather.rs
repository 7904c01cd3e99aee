//! `mcc gather` on a running lockstep cluster (a jog recorded through the card's data
//! gathering into CSV and PNG), and a daisy-chain line that starts programs on two cards
//! (`@0&1B1R@1&1B1R<CR>`) executing through the synchronized start.

use std::path::Path;
use std::time::Duration;

use mcc_testing::Cluster;
use mcc_tests::process::{bin_dir, ok};
use serde_json::Value;

/// A lockstep cluster with the default cards and stations.
fn lockstep(tag: &str) -> Cluster {
    Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .clock("lockstep")
        .tag(tag)
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"))
}

/// `mcc send --show-framing LINE…` on the chain: the printed replies.
fn send(c: &Cluster, lines: &[&str]) -> String {
    let mut a = vec!["send", "--show-framing"];
    a.extend_from_slice(lines);
    ok(c.mcc(&a), "mcc send")
}

fn start_cycles(doc: &Value) -> Vec<Option<u64>> {
    doc["cards"]
        .as_array()
        .expect("cards")
        .iter()
        .map(|c| c["program_start_cycle"].as_u64())
        .collect()
}

#[test]
fn a_chain_line_starting_programs_on_two_cards_starts_them_in_one_ring_cycle() {
    let mut c = lockstep("chainsync");
    // The same short program on both cards (under @@ every card takes the line).
    let setup = send(
        &c,
        &[
            "@@&1#1->1000X",
            "#1J/",
            "OPEN PROG 1 CLEAR",
            "DWELL 1",
            "CLOSE",
        ],
    );
    assert!(!setup.contains("<BELL>"), "{setup}");
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(start_cycles(&c.status().unwrap().0), [None, None]);
    // A start on one card only runs at the <CR> as before: card 1 has no start recorded.
    let single = send(&c, &["@0&1B1R"]);
    assert!(!single.contains("<BELL>"), "{single}");
    let first = start_cycles(&c.status().unwrap().0);
    assert!(first[0].is_some() && first[1].is_none(), "{first:?}");
    let mut last = first[0];
    for round in 0..3 {
        std::thread::sleep(Duration::from_millis(100));
        let r = send(&c, &["@0&1B1R@1&1B1R"]);
        // Card 1 is addressed at the <CR>: its reply is the only one, as for one card.
        assert_eq!(r, single, "round {round}");
        let s = start_cycles(&c.status().unwrap().0);
        assert!(s[0].is_some() && s[0] != last, "round {round}: {s:?}");
        assert_eq!(s[0], s[1], "round {round}: split start");
        last = s[0];
    }
    // `@@…R`: every card starts, card 0 answers, one cycle again.
    std::thread::sleep(Duration::from_millis(100));
    let r = send(&c, &["@@&1B1R"]);
    assert_eq!(r, single);
    let s = start_cycles(&c.status().unwrap().0);
    assert_eq!(s[0], s[1]);
    assert_ne!(s[0], last);
    // A refused start still answers in PMAC terms (program 9 does not exist: ERR015 on
    // both cards, only the addressed card's answer is seen).
    let r = send(&c, &["@0&1B9R@1&1B9R"]);
    assert!(r.contains("<BELL>"), "{r}");
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).expect("gather.csv");
    let mut lines = text.lines();
    let head: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().expect("number"))
                .collect()
        })
        .collect();
    (head, rows)
}

#[test]
fn gather_records_a_jog_into_csv_and_png() {
    let c = lockstep("gather");
    let out = std::env::temp_dir().join(format!("mcc-gather-out-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let dir = out.to_string_lossy().into_owned();
    // A brisk jog acceleration (1 count/ms²) so the move fits in 600 servo cycles.
    let set = ok(
        c.mcc(&["send", "--card", "0", "I119=1", "#1J/"]),
        "mcc send",
    );
    assert!(!set.contains('\x07'), "{set:?}");
    std::thread::sleep(Duration::from_millis(300));
    let text = ok(
        c.mcc(&[
            "gather", "--card", "0", "--motors", "1", "--cycles", "600", "--run", "#1J=2000",
            "--out", &dir,
        ]),
        "mcc gather",
    );
    assert!(text.contains("gather.csv"), "{text}");
    let (head, rows) = read_csv(&out.join("gather.csv"));
    assert_eq!(head, ["cycle", "time_ms", "m1_commanded", "m1_actual"]);
    assert_eq!(rows.len(), 601, "one sample per servo cycle");
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r[0], k as f64, "cycle column");
    }
    let act: Vec<f64> = rows.iter().map(|r| r[3]).collect();
    let cmd: Vec<f64> = rows.iter().map(|r| r[2]).collect();
    assert!(act[0].abs() < 1.0, "starts at rest at 0: {}", act[0]);
    for w in act.windows(2).chain(cmd.windows(2)) {
        assert!(w[1] >= w[0] - 0.5, "not monotonic: {w:?}");
    }
    let last = *act.last().unwrap();
    assert!((last - 2000.0).abs() < 20.0, "ends near 2000: {last}");
    assert!((cmd.last().unwrap() - 2000.0).abs() < 1.0);
    // The time column follows the servo period (I10 = 3713707: 0.4427 ms).
    assert!((rows[600][1] - 600.0 * 3_713_707.0 / 8_388_608.0).abs() < 0.01);
    let png = std::fs::read(out.join("gather.png")).expect("gather.png");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    assert_eq!(
        u32::from_be_bytes([png[16], png[17], png[18], png[19]]),
        1000
    );
    assert_eq!(
        u32::from_be_bytes([png[20], png[21], png[22], png[23]]),
        600
    );
    // Bad input is named.
    let bad = c.mcc(&["gather", "--card", "7", "--out", &dir]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("no card 7"));
    let bad = c.mcc(&["gather", "--card", "0", "--motors", "9", "--out", &dir]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("1-8"));
    if std::env::var_os("MCC_KEEP_GATHER").is_none() {
        let _ = std::fs::remove_dir_all(&out);
    }
}
