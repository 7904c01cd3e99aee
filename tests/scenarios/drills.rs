//! Drills on real multi-process clusters: synchronized starts (never split, even with random
//! delays in the control path), ring faults (drop-sync, cut link, killed station, frozen
//! card) detected, localised and recovered, and a realtime synchronized start's skew.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use serde_json::Value;

/// Ring check period of the default cluster's cards (I1001).
const I1001: u64 = 16;
/// The program every card starts.
const SETUP: &[&str] = &[
    "&1#1->1000X",
    "#1J/",
    "OPEN PROG 1 CLEAR",
    "DWELL 1",
    "CLOSE",
];

fn bin_dir() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().expect("test exe path");
        let dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("target dir")
            .to_path_buf();
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut args = vec!["build", "-q", "-p", "mcc-orchestrator", "-p", "mcc-card"];
        args.extend(["-p", "mcc-station"]);
        if dir.ends_with("release") {
            args.push("--release");
        }
        let st = Command::new(cargo)
            .args(&args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .status()
            .expect("run cargo build");
        assert!(st.success(), "building the binaries failed");
        dir
    })
    .clone()
}

fn run_base() -> PathBuf {
    std::env::temp_dir().join(format!("mcc-drills-{}", std::process::id()))
}

fn mcc_env(args: &[&str], env: &[(&str, &str)], timeout: Duration) -> Output {
    let mut c = Command::new(bin_dir().join("mcc"));
    c.args(args)
        .env("MCC_RUN_DIR", run_base())
        .env("RUST_LOG", "off")
        .env_remove("MCC_BIN_DIR")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in env {
        c.env(k, v);
    }
    let child = c.spawn().expect("spawn mcc");
    let pid = child.id();
    // Read the output while waiting (a long JSON reply would fill the pipe).
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(timeout) {
        Ok(out) => out.expect("mcc output"),
        Err(_) => {
            let _ = Command::new("kill").args(["-9", &pid.to_string()]).status();
            panic!("mcc {args:?} did not finish within {timeout:?}");
        }
    }
}

fn ok(out: Output, what: &str) -> String {
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{what} failed\nstdout: {text}\nstderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// A cluster under test, stopped (and its processes killed) when dropped.
struct Cluster {
    name: String,
    pids: Vec<u64>,
}

impl Cluster {
    fn up(tag: &str, extra: &[&str], env: &[(&str, &str)]) -> Cluster {
        let name = format!("d{}-{tag}", std::process::id());
        let mut args = vec!["up", "--detach", "--cluster", &name, "--timeout", "90"];
        args.extend_from_slice(extra);
        ok(mcc_env(&args, env, Duration::from_secs(120)), "mcc up");
        let mut c = Cluster { name, pids: vec![] };
        c.pids = c.pids_now();
        c
    }

    fn mcc(&self, args: &[&str]) -> Output {
        let mut a = vec!["--cluster", self.name.as_str()];
        a.extend_from_slice(args);
        mcc_env(&a, &[], Duration::from_secs(120))
    }

    fn status(&self) -> Value {
        let text = ok(self.mcc(&["status", "--json"]), "mcc status");
        serde_json::from_str(&text).expect("status JSON")
    }

    fn pids_now(&self) -> Vec<u64> {
        let doc = self.status();
        let mut p: Vec<u64> = doc["members"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|m| m["pid"].as_u64())
            .collect();
        p.extend(doc["supervisor"]["pid"].as_u64());
        p
    }

    fn card_port(&self, doc: &Value, n: u64) -> u16 {
        let c = doc["cards"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["number"] == n)
            .expect("card");
        c["ascii"].as_u64().expect("ascii port") as u16
    }

    /// Send lines to card `n`'s ASCII port; the replies.
    fn send(&self, n: u64, lines: &[&str]) -> String {
        let port = self.card_port(&self.status(), n);
        let mut s = TcpStream::connect(("127.0.0.1", port)).expect("connect ascii port");
        s.set_read_timeout(Some(Duration::from_millis(300)))
            .unwrap();
        let mut all = Vec::new();
        for l in lines {
            s.write_all(format!("{l}\r").as_bytes()).unwrap();
            let mut buf = [0u8; 4096];
            while let Ok(k) = s.read(&mut buf) {
                if k == 0 {
                    break;
                }
                all.extend_from_slice(&buf[..k]);
                if buf[..k].ends_with(b"\n") || buf[..k].ends_with(b"\x06") {
                    break;
                }
            }
        }
        String::from_utf8_lossy(&all).into_owned()
    }

    fn wait(&self, what: &str, timeout: Duration, mut f: impl FnMut(&Value) -> bool) -> Value {
        let deadline = Instant::now() + timeout;
        loop {
            let doc = self.status();
            if f(&doc) {
                return doc;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what}: {doc:#}"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = self.mcc(&["down", "--timeout", "5"]);
        for p in &self.pids {
            let _ = Command::new("kill").args(["-9", &p.to_string()]).status();
        }
    }
}

fn start_sync(c: &Cluster, cards: &str, repeat: u32) -> Vec<Value> {
    // Let the `#1J/` of the set-up settle (a jog in progress refuses R with ERR011).
    std::thread::sleep(Duration::from_millis(500));
    let r = repeat.to_string();
    let text = ok(
        c.mcc(&[
            "start-sync",
            "--cards",
            cards,
            "--repeat",
            &r,
            "--json",
            "&1B1R",
        ]),
        "mcc start-sync",
    );
    serde_json::from_str::<Value>(&text)
        .expect("start-sync JSON")
        .as_array()
        .expect("array")
        .clone()
}

#[test]
fn synchronized_start_on_four_cards_never_splits_under_control_path_delays() {
    let c = Cluster::up(
        "sync4",
        &["--cards", "4", "--stations", "4", "--clock", "lockstep"],
        &[("MCC_TEST_AT_DELAY_MS", "15")],
    );
    for n in 0..4 {
        let r = c.send(n, SETUP);
        assert!(!r.contains('\x07'), "card {n} setup: {r:?}");
    }
    let outs = start_sync(&c, "0,1,2,3", 100);
    assert_eq!(outs.len(), 100);
    let mut retried = 0;
    for o in &outs {
        let t = o["cycle"].as_u64().unwrap();
        let cards = o["cards"].as_array().unwrap();
        assert_eq!(cards.len(), 4);
        for card in cards {
            assert_eq!(card["executed_cycle"].as_u64(), Some(t), "{o:#}");
            assert_eq!(card["program_start_cycle"].as_u64(), Some(t), "{o:#}");
            assert!(!card["reply"].as_str().unwrap().contains("<BEL>"), "{o:#}");
        }
        retried += u64::from(o["attempts"].as_u64().unwrap() > 1);
    }
    eprintln!("100 synchronized starts, {retried} needed a retry");
    let last = outs.last().unwrap()["cycle"].as_u64().unwrap();
    let doc = c.status();
    for card in doc["cards"].as_array().unwrap() {
        assert_eq!(card["program_start_cycle"].as_u64(), Some(last), "{doc:#}");
    }
    // Bad input: unknown card, empty list.
    let out = c.mcc(&["start-sync", "--cards", "0,9", "&1B1R"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no card 9"));
}

/// Fault `member` with `args`, check every card in `cards` latches a ring fault and status
/// names `link`. Latency bound: the spec's check (§6.8) judges syncs only at the end of each
/// I1001 period, so a break just after a period's I1005th sync is seen at the end of the next
/// period: at most 2 x I1001 + 1 cycles (the issue's "I1001 + 1" holds only for breaks at a
/// period start).
fn drill(c: &Cluster, args: &[&str], link: &str, downstream: &str, cards: &[&str]) {
    let mut a = vec!["fault"];
    a.extend_from_slice(args);
    ok(c.mcc(&a), "mcc fault");
    let doc = c.wait(
        &format!("{args:?} detected"),
        Duration::from_secs(30),
        |d| {
            d["ring"]["broken_link"] == link
                && d["members"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .filter(|m| cards.contains(&m["name"].as_str().unwrap()))
                    .all(|m| m["ring_fault"] == true)
        },
    );
    let members = doc["members"].as_array().unwrap();
    let get = |n: &str| members.iter().find(|m| m["name"] == n).unwrap();
    let down = get(downstream);
    // The first cycle the member downstream of the break did not get: from its last frame
    // (cut, kill, freeze). With drop-sync frames keep arriving and no status field dates the
    // last sync packet: the latency is only printed.
    let exact = !args.contains(&"drop-sync");
    let lost = down["last_rx_cycle"].as_u64().unwrap() + 1;
    for name in cards {
        let m = get(name);
        let at = m["ring_fault_cycle"].as_u64().expect("fault cycle");
        eprintln!(
            "{args:?}: {name} latched at cycle {at}, last frame at {}",
            lost - 1
        );
        assert!(
            !exact || at <= lost + 2 * I1001 + 1,
            "{name} detected {args:?} at cycle {at}, lost cycle {lost}: {doc:#}"
        );
    }
    for card in doc["cards"].as_array().unwrap() {
        if cards.contains(&card["name"].as_str().unwrap()) {
            assert_eq!(card["ring_fault"], true, "{card:#}");
            assert_eq!(card["motors_killed"], true, "{card:#}");
        }
    }
    eprintln!("{args:?}: {link}, lost cycle {lost}");
}

fn recover(c: &Cluster) {
    ok(c.mcc(&["fault", "clear"]), "fault clear");
    c.wait("ring re-locked", Duration::from_secs(30), |d| {
        d["members"]
            .as_array()
            .unwrap()
            .iter()
            .all(|m| m["alive"] == true && m["locked"] == true)
    });
    for n in 0..2 {
        c.send(n, &["$$$"]);
    }
    let doc = c.wait("ring fault cleared", Duration::from_secs(30), |d| {
        let _ = c.mcc(&["fault", "reset"]);
        d["ring"]["faulted"] == false && d["ring"]["locked"] == true
    });
    assert!(doc["cards"]
        .as_array()
        .unwrap()
        .iter()
        .all(|c| c["ring_fault"] == false));
    // Motion can be commanded again.
    for n in 0..2 {
        let r = c.send(n, SETUP);
        assert!(!r.contains('\x07'), "card {n} after recovery: {r:?}");
    }
    let o = start_sync(c, "0,1", 1);
    let t = o[0]["cycle"].as_u64().unwrap();
    assert!(o[0]["cards"]
        .as_array()
        .unwrap()
        .iter()
        .all(|k| k["executed_cycle"] == t));
}

#[test]
fn ring_faults_are_detected_localised_and_recovered() {
    let c = Cluster::up("faults", &["--clock", "lockstep"], &[]);
    // Ring order: card0 (sync master), station0, card1, station1.
    for n in 0..2 {
        let r = c.send(n, SETUP);
        assert!(!r.contains('\x07'), "card {n} setup: {r:?}");
    }
    drill(
        &c,
        &["station0", "cut"],
        "station0 → card1",
        "card1",
        &["card0", "card1"],
    );
    recover(&c);
    drill(
        &c,
        &["station0", "drop-sync"],
        "station0 → card1",
        "card1",
        &["card0", "card1"],
    );
    recover(&c);
    drill(
        &c,
        &["station0", "kill"],
        "station0 → card1",
        "card1",
        &["card0", "card1"],
    );
    ok(c.mcc(&["fault", "station0", "restart"]), "restart station0");
    recover(&c);
    drill(
        &c,
        &["card1", "freeze"],
        "card1 → station1",
        "station1",
        &["card0"],
    );
    // A thawed member whose zenoh session expired leaves; restart brings it back.
    ok(c.mcc(&["fault", "card1", "restart"]), "restart card1");
    recover(&c);
}

#[test]
fn realtime_synchronized_start_skew_is_recorded() {
    // A modest rate: the machine is shared; late cycles would only fault the ring.
    let c = Cluster::up("rt2", &["--clock", "realtime", "--rate", "500"], &[]);
    for n in 0..2 {
        let r = c.send(n, SETUP);
        assert!(!r.contains('\x07'), "card {n} setup: {r:?}");
    }
    let outs = start_sync(&c, "0,1", 5);
    for o in &outs {
        let ns: Vec<u64> = o["cards"]
            .as_array()
            .unwrap()
            .iter()
            .map(|k| k["executed_ns"].as_u64().expect("execution time"))
            .collect();
        let skew = ns.iter().max().unwrap() - ns.iter().min().unwrap();
        eprintln!("realtime start at cycle {}: skew {skew} ns", o["cycle"]);
    }
}
