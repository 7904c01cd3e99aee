//! The Rust test API (`mcc_testing`) on real clusters: commands, a synchronized start seen
//! in gathered motion, a cut fibre detected and recovered, bad input, a ring that does not
//! lock, and teardown leaving no process behind.

use std::time::{Duration, Instant};

use mcc_testing::{Cluster, ErrorKind, FaultOptions, DRILLS, FAULT_KINDS};
use mcc_tests::process::{bin_dir, run_base};

const WAIT: Duration = Duration::from_secs(120);

fn builder(tag: &str) -> mcc_testing::Builder {
    Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .clock("lockstep")
        .tag(tag)
}

#[test]
fn the_test_api_drives_starts_faults_and_recovers_a_cluster() {
    let mut c = builder("api").start().expect("cluster up");
    let st = c.status().unwrap();
    assert!(st.locked() && !st.faulted(), "{:#}", st.0);
    assert_eq!(c.members(), ["card0", "station0", "card1", "station1"]);
    assert_eq!(c.send(&["I0", "P1=5 P1"], Some(1)).unwrap(), ["1", "5"]);
    let e = c.send(&["UUU"], Some(0)).unwrap_err();
    assert_eq!(
        e.kind,
        ErrorKind::Card {
            code: "ERR003".into()
        }
    );
    let (a0, e0) = c.ports(0).unwrap();
    let (a1, e1) = c.ports(1).unwrap();
    assert!(a0 != a1 && e0 != e1 && a0 != e0);

    // Both cards start a jog in one tick, recorded from that tick: identical trajectories.
    for n in [0, 1] {
        c.send(&["I119=1", "#1J/"], Some(n)).unwrap();
    }
    c.wait_cycles(200, WAIT).unwrap();
    let g = c.gather(&[1], &[0, 1], 300, Some("#1J=3000")).unwrap();
    assert_eq!(g.len(), 2);
    assert_eq!(g[0].cycle.len(), 301);
    assert_eq!(g[0].cycle, g[1].cycle, "one ring cycle for both cards");
    let m0 = g[0].first_motion(1, 0.5);
    assert!(m0.is_some(), "the jog did not move");
    assert_eq!(m0, g[1].first_motion(1, 0.5));
    assert_eq!(g[0].commanded(1), g[1].commanded(1));
    let s = c.start_sync("#1J=0", &[0, 1]).unwrap();
    assert!(
        s.cards.iter().all(|k| k.executed_cycle == Some(s.cycle)),
        "{s:?}"
    );
    // A refused synchronized line is a typed card error, even when the card's framing (I6=2)
    // shows only a bell: the code comes from the card, not from the reply's bytes.
    for n in [0, 1] {
        c.send(&["I6=2"], Some(n)).unwrap();
    }
    let e = c.start_sync("UUU", &[0, 1]).unwrap_err();
    assert_eq!(
        e.kind,
        ErrorKind::Card {
            code: "ERR003".into()
        },
        "{e}"
    );
    for n in [0, 1] {
        c.send(&["I6=1"], Some(n)).unwrap();
    }

    // A cut fibre: localised, then cleared and reset.
    c.fault("station0", "cut", FaultOptions::default()).unwrap();
    let st = c
        .wait_until(Some(20_000), WAIT, |st| {
            st.broken_link() == Some("station0 → card1") && st.ring_faulted_cards() == [0, 1]
        })
        .unwrap();
    assert_eq!(st.member("station0").unwrap()["faults"][0]["kind"], "cut");
    c.clear(None).unwrap();
    let healthy = c.reset(WAIT).unwrap();
    assert!(healthy.locked() && !healthy.faulted());
    assert_eq!(c.send(&["I0"], Some(1)).unwrap(), ["1"]);

    // Teardown: nothing left, nothing to kill.
    let pids = c.status().unwrap().pids();
    let base = c.run_base();
    assert!(c.stop().is_empty(), "mcc down left processes to kill");
    for p in pids {
        assert!(!mcc_testing::procs::alive(p), "pid {p} survived");
    }
    assert!(!base.exists());
}

#[test]
fn the_test_api_refuses_bad_input_with_the_choices_and_the_cli_message() {
    let mut c = builder("apibad").cards(1).stations(1).start().unwrap();
    let t = Instant::now();
    let e = c
        .fault("station0", "melt", FaultOptions::default())
        .unwrap_err();
    let all: Vec<String> = FAULT_KINDS
        .iter()
        .chain(DRILLS)
        .map(|s| s.to_string())
        .collect();
    assert_eq!(e.kind, ErrorKind::UnknownChoice { choices: all });
    let e = c
        .fault("nobody", "cut", FaultOptions::default())
        .unwrap_err();
    assert_eq!(
        e.kind,
        ErrorKind::UnknownChoice {
            choices: vec!["card0".into(), "station0".into()]
        }
    );
    assert!(matches!(
        c.send(&["I0"], Some(3)).unwrap_err().kind,
        ErrorKind::UnknownChoice { .. }
    ));
    link_fault_refusals(&c);
    assert!(
        t.elapsed() < Duration::from_secs(1),
        "checked without the cluster"
    );
    link_fault_applies_shows_and_clears(&mut c);
    drop(c);

    let e = builder("apicfg")
        .cards(1)
        .stations(0)
        .profile("pmac3")
        .start()
        .unwrap_err();
    assert_eq!(e.kind, ErrorKind::Config);
    assert!(
        e.message.contains("cards[0].profile") && e.message.contains("pmac3"),
        "{e}"
    );
    let e = builder("apiplant")
        .cards(1)
        .stations(1)
        .plant("[nodes.1]\ninertia = -1")
        .start()
        .unwrap_err();
    assert_eq!(e.kind, ErrorKind::Config);
    assert!(e.message.contains("inertia"), "{e}");
}

#[test]
fn a_ring_that_does_not_lock_fails_with_the_member_logs_and_leaves_nothing() {
    // A card binary that starts but never joins the ring.
    let dir = run_base().join(format!("slow-bin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let marker = format!("{}.{}", std::process::id(), 4242);
    let card = format!(
        "#!/bin/sh\necho 'card wrapper: pretending to boot slowly' >&2\nexec sleep {marker}\n"
    );
    let station = format!(
        "#!/bin/sh\nexec \"{}\" \"$@\"\n",
        bin_dir().join("mcc-station").display()
    );
    for (name, text) in [("mcc-card", card), ("mcc-station", station)] {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        std::process::Command::new("chmod")
            .arg("755")
            .arg(&p)
            .status()
            .unwrap();
    }
    let e = builder("nolock")
        .cards(1)
        .stations(1)
        .lock_timeout(Duration::from_secs(3))
        .env("MCC_BIN_DIR", dir.to_str().unwrap())
        .start()
        .unwrap_err();
    assert_eq!(e.kind, ErrorKind::LockTimeout, "{e}");
    assert!(e.message.contains("did not lock within 3 s"), "{e}");
    assert!(
        e.logs
            .get("card0")
            .is_some_and(|l| l.contains("pretending to boot slowly")),
        "{e}"
    );
    let left = std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter(|d| {
            std::fs::read(d.path().join("cmdline"))
                .map(|c| String::from_utf8_lossy(&c).contains(&marker))
                .unwrap_or(false)
        })
        .count();
    assert_eq!(left, 0, "the slow member was left running");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cluster_follows_its_owner_process() {
    // `mcc up --owner-pid`: the cluster stops by itself when the owner exits (a killed test
    // runner never leaves members behind).
    let mut owner = std::process::Command::new("sleep")
        .arg("600")
        .spawn()
        .expect("spawn the owner");
    let mut c = builder("owned")
        .cards(1)
        .stations(1)
        .owner(owner.id())
        .start()
        .unwrap();
    let pids = c.status().unwrap().pids();
    assert_eq!(pids.len(), 3, "two members and the supervisor");
    let _ = owner.kill();
    let _ = owner.wait();
    let deadline = Instant::now() + Duration::from_secs(30);
    while pids.iter().any(|p| mcc_testing::procs::alive(*p)) {
        assert!(Instant::now() < deadline, "the cluster outlived its owner");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(c.stop().is_empty());
}

/// `link_fault` refuses unknown targets and kinds, and bad-checksum off the bus, with the
/// valid choices (without asking the cluster).
fn link_fault_refusals(c: &mcc_testing::Cluster) {
    let e = c
        .link_fault("station0", "short", FaultOptions::default())
        .unwrap_err();
    assert_eq!(
        e.kind,
        ErrorKind::UnknownChoice {
            choices: vec!["card0".into(), "chain".into(), "bus".into()]
        }
    );
    let e = c
        .link_fault("card0", "melt", FaultOptions::default())
        .unwrap_err();
    let all: Vec<String> = mcc_testing::LINK_KINDS
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(
        e.kind,
        ErrorKind::UnknownChoice {
            choices: all.clone()
        }
    );
    let e = c
        .link_fault("chain", "bad-checksum", FaultOptions::default())
        .unwrap_err();
    let not_bus: Vec<String> = all.into_iter().filter(|k| k != "bad-checksum").collect();
    assert_eq!(e.kind, ErrorKind::UnknownChoice { choices: not_bus });
    assert!(e.to_string().contains("EMCL bus only"), "{e}");
}

/// A card link fault shows in the card's status entry and `clear` removes it; a `late`
/// without `--delay` is the CLI's refusal.
fn link_fault_applies_shows_and_clears(c: &mut mcc_testing::Cluster) {
    let opts = FaultOptions {
        cycles: Some(5),
        probability: Some(0.5),
        seed: Some(3),
        delay: None,
    };
    let msg = c.link_fault("card0", "corrupt", opts).unwrap();
    assert!(msg.contains("corrupt"), "{msg}");
    let st = c.status().unwrap();
    let f = &st.0["cards"][0]["link_fault"];
    assert_eq!(
        (
            f["kind"].as_str(),
            f["replies"].as_u64(),
            f["seed"].as_u64()
        ),
        (Some("corrupt"), Some(5), Some(3)),
        "{f}"
    );
    let e = c
        .link_fault("card0", "late", FaultOptions::default())
        .unwrap_err();
    assert!(e.to_string().contains("--delay"), "{e}");
    c.clear(None).unwrap();
    assert!(c.status().unwrap().0["cards"][0]["link_fault"].is_null());
}
