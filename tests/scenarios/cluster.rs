//! Multi-process clusters: `mcc up --detach`, `status --json`, `fault`, `down`, supervisor
//! death, Ctrl-C, two clusters side by side, bad configs. Every test uses its own cluster name
//! and run directory, bounds every wait, and cleans up in a Drop guard.

use std::time::Duration;

use mcc_tests::cluster::{all_pids, member_pids, Cluster, Foreground};
use mcc_tests::process::{mcc, pid_alive, run_base, send_signal, text, unique, wait_until};
use serde_json::Value;

/// `mcc args…` must fail (within 30 s) with a message containing every one of `want`.
fn refused(args: &[&str], want: &[&str]) {
    let out = mcc(args, Duration::from_secs(30));
    assert!(!out.status.success(), "mcc {args:?} succeeded");
    let err = text(&out.stderr);
    for w in want {
        assert!(err.contains(w), "mcc {args:?}: {err}");
    }
}

#[test]
fn lockstep_cluster_runs_reports_faults_and_goes_down_clean() {
    let c = Cluster::up(
        "life",
        &["--clock", "lockstep", "--cards", "2", "--stations", "2"],
    );
    let s1 = c.status();
    assert_eq!(s1["cluster"], c.name.as_str());
    assert_eq!(s1["clock"], "lockstep");
    assert_eq!(s1["ring"]["locked"], true, "{s1:#}");
    assert_eq!(s1["ring"]["faulted"], false, "{s1:#}");
    let names: Vec<&str> = s1["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["card0", "station0", "card1", "station1"]);
    for m in s1["members"].as_array().unwrap() {
        assert_eq!(m["alive"], true);
        assert!(pid_alive(m["pid"].as_u64().unwrap()));
    }
    let cycle1 = s1["ring"]["cycle"].as_u64().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let cycle2 = c.status()["ring"]["cycle"].as_u64().unwrap();
    assert!(
        cycle2 > cycle1,
        "cycle did not advance: {cycle1} -> {cycle2}"
    );

    // A second `up` of the same cluster is refused.
    refused(
        &["up", "--detach", "--cluster", &c.name],
        &["already running"],
    );

    // Cut station0's outgoing link: station0 → card1 is the broken link.
    let out = mcc(
        &["fault", "station0", "cut", "--cluster", &c.name],
        Duration::from_secs(30),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut last = Value::Null;
    wait_until("the cut to be reported", Duration::from_secs(30), || {
        last = c.status();
        last["ring"]["broken_link"] == "station0 → card1" && last["ring"]["faulted"] == true
    });
    let st0 = &last["members"][1];
    assert_eq!(st0["faults"][0]["kind"], "cut", "{last:#}");
    let bad = mcc(
        &["fault", "nobody", "cut", "--cluster", &c.name],
        Duration::from_secs(30),
    );
    assert!(
        text(&bad.stderr).contains("unknown member \"nobody\""),
        "{}",
        text(&bad.stderr)
    );
    let bad = mcc(
        &["fault", "station0", "melt", "--cluster", &c.name],
        Duration::from_secs(30),
    );
    assert!(
        text(&bad.stderr).contains("unknown fault kind 'melt'"),
        "{}",
        text(&bad.stderr)
    );

    let pids = member_pids(&last);
    let sup = last["supervisor"]["pid"].as_u64().unwrap();
    let out = c.down();
    assert!(out.status.success(), "{}", text(&out.stderr));
    for p in pids.iter().chain([&sup]) {
        assert!(!pid_alive(*p), "pid {p} survived mcc down");
    }
    assert!(!run_base().join(&c.name).exists(), "run dir left behind");
    refused(&["status", "--cluster", &c.name], &["not running"]);
}

#[test]
fn killed_supervisor_takes_its_members_with_it() {
    // The default (paced) cluster, one member frozen: every member still exits within 3 s of
    // the orchestrator's SIGKILL (parent-death signal; the orphaned process group of a stopped
    // member gets SIGHUP + SIGCONT from the kernel).
    let c = Cluster::up("orphan", &[]);
    let doc = c.status();
    let sup = doc["supervisor"]["pid"].as_u64().unwrap();
    let pids = member_pids(&doc);
    send_signal(pids[1], "-STOP");
    send_signal(sup, "-KILL");
    let t0 = std::time::Instant::now();
    wait_until(
        "members to exit after the supervisor died",
        Duration::from_secs(20),
        || pids.iter().all(|p| !pid_alive(*p)),
    );
    let took = t0.elapsed();
    assert!(
        took < Duration::from_secs(3),
        "members took {took:?} to exit"
    );
    let out = c.down();
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!run_base().join(&c.name).exists());
}

#[test]
fn ctrl_c_in_the_foreground_stops_everything() {
    let name = unique("fg");
    let mut guard = Cluster::guard(&name);
    let mut fg = Foreground::start(
        &name,
        &["--clock", "lockstep", "--cards", "1", "--stations", "1"],
    );
    fg.wait_ready(Duration::from_secs(120));
    let doc = guard.status();
    guard.pids = all_pids(&doc);
    let pids = member_pids(&doc);
    send_signal(u64::from(fg.child.id()), "-INT");
    let status = fg.wait_exit("on SIGINT", Duration::from_secs(30));
    assert!(status.success(), "exit status {status}");
    for p in pids {
        assert!(!pid_alive(p), "member pid {p} survived Ctrl-C");
    }
    assert!(!run_base().join(&name).exists(), "run dir left behind");
}

#[test]
fn two_clusters_run_side_by_side_without_seeing_each_other() {
    let a = Cluster::up(
        "a",
        &["--clock", "lockstep", "--cards", "1", "--stations", "1"],
    );
    let b = Cluster::up(
        "b",
        &["--clock", "lockstep", "--cards", "1", "--stations", "1"],
    );
    let (da, db) = (a.status(), b.status());
    assert_ne!(da["supervisor"]["endpoint"], db["supervisor"]["endpoint"]);
    let (pa, pb) = (member_pids(&da), member_pids(&db));
    assert!(pa.iter().all(|p| !pb.contains(p)), "{pa:?} vs {pb:?}");
    // Cutting a's ring leaves b's alone.
    let out = mcc(
        &["fault", "station0", "cut", "--cluster", &a.name],
        Duration::from_secs(30),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    wait_until("a's cut to be reported", Duration::from_secs(30), || {
        a.status()["ring"]["broken_link"] == "station0 → card0"
    });
    let db2 = b.status();
    assert_eq!(db2["ring"]["locked"], true, "{db2:#}");
    assert_eq!(db2["ring"]["broken_link"], Value::Null, "{db2:#}");
    assert!(db2["ring"]["cycle"].as_u64() > db["ring"]["cycle"].as_u64());
    // Taking a down leaves b running.
    assert!(a.down().status.success());
    assert!(pa.iter().all(|p| !pid_alive(*p)));
    assert_eq!(b.status()["ring"]["locked"], true);
}

#[test]
fn bad_config_and_arguments_get_a_message_naming_the_problem() {
    let dir = run_base().join("configs");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.toml");
    std::fs::write(
        &file,
        "[[cards]]\nname = \"card0\"\nnumber = 0\nmaster = 0\nprofile = \"pmac3\"\n",
    )
    .unwrap();
    let name = unique("bad");
    let _guard = Cluster::guard(&name);
    let config = file.to_str().unwrap();
    let up_with_config = ["up", "--detach", "--cluster", &name, "--config", config];
    refused(&up_with_config, &["cards[0].profile", "pmac3"]);
    assert!(
        !run_base().join(&name).exists(),
        "a rejected config must not leave a run dir"
    );

    std::fs::write(
        &file,
        "[[cards]]\nname = \"card0\"\nnumber = 0\nmaster = 0\nnodez = [1]\n",
    )
    .unwrap();
    refused(&up_with_config, &["nodez"]);
    refused(&["up", "--cluster", "../evil", "--detach"], &["--cluster"]);
    refused(&["up", "--clock", "sometimes"], &["sometimes"]);
    refused(&["up", "--rate=-3", "--cluster", &name], &["--rate"]);
    // The clock keys: refused before anything starts, the key and the problem named.
    for (args, problem) in [
        (&["--rtf", "0"][..], "real-time factor"),
        (&["--rtf=-1"][..], "real-time factor"),
        (&["--rtf", "NaN"][..], "real-time factor"),
        (&["--rtf", "1e9"][..], "rtf"),
        (
            &["--clock", "lockstep", "--rtf", "2"][..],
            "only the paced clock",
        ),
    ] {
        let mut a = vec!["up", "--detach", "--cluster", &name];
        a.extend_from_slice(args);
        refused(&a, &["rtf", problem]);
        assert!(!run_base().join(&name).exists(), "{args:?} left a run dir");
    }
    std::fs::write(
        &file,
        "rate_hz = 100\nmember_timeout_ms = 5\n[[cards]]\nname = \"card0\"\nnumber = 0\nmaster = 0\n",
    )
    .unwrap();
    refused(
        &up_with_config,
        &["member_timeout_ms", "shorter than one ring period"],
    );
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir(run_base());
}

/// The number in a card's reply (`9995.6<CR><ACK>` → 9995.6).
fn number(reply: &str) -> f64 {
    let t = reply.trim_matches(|c: char| c.is_control() || c.is_whitespace());
    t.parse()
        .unwrap_or_else(|_| panic!("not a number: {reply:?}"))
}

/// `#1?` second status word (home complete = bit 10, in position = bit 0).
fn status_word2(reply: &str) -> u32 {
    let t = reply.trim_matches(|c: char| c.is_control() || c.is_whitespace());
    assert_eq!(t.len(), 12, "{reply:?}");
    u32::from_str_radix(&t[6..], 16).expect("hex")
}

#[test]
fn the_default_paced_cluster_jogs_homes_and_runs_a_program_in_ring_time() {
    // No --clock: the default.
    let c = Cluster::up("paced", &[]);
    let doc = c.status();
    assert_eq!(doc["clock"], "paced", "{doc:#}");
    assert_eq!(doc["rtf_requested"], 1.0);
    assert_eq!(doc["ring"]["faulted"], false, "{doc:#}");
    let wait = |what: &str, f: &mut dyn FnMut() -> bool| {
        wait_until(what, Duration::from_secs(120), f);
    };
    // Jog to 10000 counts and stop there.
    let r = c.ascii(0, &["#1J=10000"]);
    assert!(!r.contains('\x07'), "{r:?}");
    wait("the jog to end at 10000", &mut || {
        let p = number(&c.ascii(0, &["#1P"]));
        let w2 = status_word2(&c.ascii(0, &["#1?"]));
        (p - 10000.0).abs() < 10.0 && w2 & 1 == 1
    });
    // Home: the search runs back down to the home switch (5000-6000 counts on the plant),
    // the trigger becomes zero and the motor settles there.
    let r = c.ascii(0, &["I123=-32", "#1HM"]);
    assert!(!r.contains('\x07'), "{r:?}");
    wait("home complete", &mut || {
        let w2 = status_word2(&c.ascii(0, &["#1?"]));
        w2 & 0x400 != 0 && w2 & 1 == 1
    });
    let p = number(&c.ascii(0, &["#1P"]));
    assert!(p.abs() < 10.0, "homed at {p}");
    // LINEAR 10 units at F5 with TA200: 10/5 s + 0.2 s = 2.2 s of ring time = 4969 servo
    // cycles at I10 = 3713707 (0.44271 ms), recorded by the card's own data gathering.
    let setup = c.ascii(
        0,
        &[
            "&1#1->1000X",
            "OPEN PROG 2 CLEAR",
            "LINEAR ABS TA200 TS0 F5",
            "X10",
            "CLOSE",
        ],
    );
    assert!(!setup.contains('\x07'), "{setup:?}");
    let out = run_base().join(format!("paced-gather-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let dir = out.to_string_lossy().into_owned();
    let started = std::time::Instant::now();
    let text = mcc_tests::process::ok(
        c.mcc(&[
            "gather", "--card", "0", "--motors", "1", "--cycles", "6000", "--run", "&1B2R",
            "--out", &dir,
        ]),
        "mcc gather",
    );
    assert!(text.contains("gather.csv"), "{text}");
    let csv = std::fs::read_to_string(out.join("gather.csv")).expect("gather.csv");
    let cmd: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .nth(2)
                .expect("column")
                .parse()
                .expect("number")
        })
        .collect();
    let _ = std::fs::remove_dir_all(&out);
    assert_eq!(cmd.len(), 6001);
    let from = cmd[0];
    assert!(from.abs() < 10.0, "starts at home: {from}");
    let first = cmd
        .iter()
        .position(|v| (v - from).abs() > 1e-3)
        .expect("moved");
    let last = cmd
        .iter()
        .position(|v| (v - 10_000.0).abs() < 1e-3)
        .expect("reached X10 = 10000 counts");
    let cycles = (last - first + 1) as f64;
    let want = 2.2e3 / (3_713_707.0 / 8_388_608.0);
    eprintln!(
        "LINEAR X10 F5 TA200: {cycles} ring cycles (expected {want:.1}); the gather took {:?}",
        started.elapsed()
    );
    assert!(
        (cycles - want).abs() <= 3.0,
        "{cycles} cycles, want {want:.1}"
    );
    let doc = c.status();
    assert_eq!(doc["ring"]["faulted"], false, "{doc:#}");
    assert!(doc["rtf"].as_f64().is_some(), "{doc:#}");
}

#[path = "cluster_load.rs"]
mod load;
#[test]
fn the_foreground_terminal_prints_cluster_events_as_they_happen() {
    let name = unique("events");
    let mut guard = Cluster::guard(&name);
    let mut fg = Foreground::start(&name, &[]);
    fg.wait_ready(Duration::from_secs(120));
    let doc = guard.status();
    guard.pids = all_pids(&doc);
    let verb = |args: &[&str]| {
        let mut a = args.to_vec();
        a.extend_from_slice(&["--cluster", &name]);
        let out = mcc(&a, Duration::from_secs(60));
        assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
    };
    // A cut: the cards latch (member, class, cycle), each on its own line.
    verb(&["fault", "station0", "cut"]);
    let l = fg.wait_line(
        "ring fault latched: card1 at cycle",
        Duration::from_secs(60),
    );
    assert!(l.starts_with("mcc event: "), "{l}");
    assert!(l.contains("byte violations (loss of light)"), "{l}");
    // Mended and reset: healthy again.
    verb(&["fault", "clear"]);
    wait_until("the ring to re-lock", Duration::from_secs(60), || {
        let d = guard.status();
        d["members"]
            .as_array()
            .unwrap()
            .iter()
            .all(|m| m["locked"] == true && m["dark"] == false)
    });
    wait_until("the ring fault to clear", Duration::from_secs(60), || {
        for n in 0..2 {
            guard.ascii(n, &["$$$"]);
        }
        let _ = mcc(
            &["fault", "reset", "--cluster", &name],
            Duration::from_secs(30),
        );
        guard.status()["ring"]["faulted"] == false
    });
    fg.wait_line("ring healthy again at cycle", Duration::from_secs(60));
    // A member killed and restarted.
    verb(&["fault", "station1", "kill"]);
    fg.wait_line("station1 is gone", Duration::from_secs(60));
    verb(&["fault", "station1", "restart"]);
    fg.wait_line("station1 is back", Duration::from_secs(60));
    send_signal(u64::from(fg.child.id()), "-INT");
    let status = fg.wait_exit("on SIGINT", Duration::from_secs(30));
    assert!(status.success(), "exit status {status}");
}

#[test]
fn a_short_soak_on_the_default_clock_has_no_ring_fault_even_under_load() {
    // Two CPU-bound threads beside the cluster (on top of whatever the machine is doing): the
    // paced ring may run late, never faulted. `mcc bench soak` fails if a paced ring faults.
    let out = mcc(
        &["bench", "soak", "--seconds", "8", "--load", "2"],
        Duration::from_secs(240),
    );
    let t = text(&out.stdout);
    assert!(out.status.success(), "{t}\n{}", text(&out.stderr));
    for want in [
        "bench soak: paced clock at rtf 1",
        "ring faults: 0 (no member latched one), receive errors during the soak: 0",
        "achieved rtf",
        "late cycles:",
        "start lag p50",
        "OS timer probe at the same period",
        "frozen-member wait 10000 ms",
    ] {
        assert!(t.contains(want), "missing {want:?} in:\n{t}");
    }
    // Bad input is refused before anything starts.
    let out = mcc(
        &["bench", "soak", "--seconds", "0"],
        Duration::from_secs(30),
    );
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("--minutes/--seconds"),
        "{}",
        text(&out.stderr)
    );
    let out = mcc(&["bench", "soak", "--rtf", "0"], Duration::from_secs(30));
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("rtf"), "{}", text(&out.stderr));
}
