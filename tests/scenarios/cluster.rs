//! Multi-process clusters: `mcc up --detach`, `status --json`, `fault`, `down`, supervisor
//! death, Ctrl-C, two clusters side by side, bad configs. Every test uses its own cluster name
//! and run directory, bounds every wait, and cleans up in a Drop guard.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use serde_json::Value;

/// target/debug (the test exe lives in target/debug/deps).
fn bin_dir() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().expect("test exe path");
        let dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("target dir")
            .to_path_buf();
        // Cargo does not build other packages' binaries for this test: build them (fresh).
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let profile = if dir.ends_with("release") {
            vec!["--release"]
        } else {
            vec![]
        };
        let st = Command::new(cargo)
            .args([
                "build",
                "-q",
                "-p",
                "mcc-orchestrator",
                "-p",
                "mcc-card",
                "-p",
                "mcc-station",
            ])
            .args(profile)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .status()
            .expect("run cargo build");
        assert!(st.success(), "building mcc, mcc-card, mcc-station failed");
        for b in ["mcc", "mcc-card", "mcc-station"] {
            assert!(dir.join(b).is_file(), "{} missing", dir.join(b).display());
        }
        dir
    })
    .clone()
}

/// A run-directory base private to this test process.
fn run_base() -> PathBuf {
    std::env::temp_dir().join(format!("mcc-scenarios-{}", std::process::id()))
}

fn unique(tag: &str) -> String {
    static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!("t{}-{tag}-{n}", std::process::id())
}

fn mcc_cmd(args: &[&str]) -> Command {
    let mut c = Command::new(bin_dir().join("mcc"));
    c.args(args)
        .env("MCC_RUN_DIR", run_base())
        .env_remove("MCC_BIN_DIR")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Run `mcc args...`, killing it after `timeout`.
fn mcc(args: &[&str], timeout: Duration) -> Output {
    let mut child = mcc_cmd(args).spawn().expect("spawn mcc");
    let deadline = Instant::now() + timeout;
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "mcc {args:?} did not finish within {timeout:?}\nstdout: {}\nstderr: {}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Alive and not a zombie (members are re-parented when the supervisor dies; whoever
/// inherits them may reap late).
fn pid_alive(pid: u64) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => false,
        Ok(stat) => stat
            .rfind(')')
            .and_then(|i| stat.get(i + 1..))
            .is_some_and(|rest| !rest.trim_start().starts_with(['Z', 'X'])),
    }
}

fn wait_until(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !f() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn send_signal(pid: u64, sig: &str) {
    let _ = Command::new("kill").args([sig, &pid.to_string()]).status();
}

/// A cluster under test; `mcc down` and SIGKILL of every pid seen when dropped.
struct Cluster {
    name: String,
    pids: Vec<u64>,
}

impl Cluster {
    fn up(tag: &str, extra: &[&str]) -> Cluster {
        let name = unique(tag);
        let mut c = Cluster {
            name,
            pids: Vec::new(),
        };
        let mut args = vec!["up", "--detach", "--cluster", &c.name, "--timeout", "90"];
        args.extend_from_slice(extra);
        let out = mcc(&args, Duration::from_secs(120));
        assert!(
            out.status.success(),
            "mcc up failed\nstdout: {}\nstderr: {}",
            text(&out.stdout),
            text(&out.stderr)
        );
        let doc = c.status();
        c.pids = all_pids(&doc);
        c
    }

    fn status(&self) -> Value {
        let out = mcc(
            &["status", "--json", "--cluster", &self.name],
            Duration::from_secs(30),
        );
        assert!(out.status.success(), "status failed: {}", text(&out.stderr));
        serde_json::from_slice(&out.stdout).expect("status JSON")
    }

    fn down(&self) -> Output {
        mcc(&["down", "--cluster", &self.name], Duration::from_secs(60))
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = self.down();
        for &p in &self.pids {
            if pid_alive(p) {
                send_signal(p, "-KILL");
            }
        }
    }
}

fn all_pids(doc: &Value) -> Vec<u64> {
    let mut v: Vec<u64> = doc["members"]
        .as_array()
        .map(|a| a.iter().filter_map(|m| m["pid"].as_u64()).collect())
        .unwrap_or_default();
    v.extend(doc["supervisor"]["pid"].as_u64());
    v
}

fn member_pids(doc: &Value) -> Vec<u64> {
    doc["members"]
        .as_array()
        .expect("members")
        .iter()
        .map(|m| m["pid"].as_u64().expect("member pid"))
        .collect()
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
    let again = mcc(
        &["up", "--detach", "--cluster", &c.name],
        Duration::from_secs(30),
    );
    assert!(!again.status.success());
    assert!(
        text(&again.stderr).contains("already running"),
        "{}",
        text(&again.stderr)
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
    let st = mcc(&["status", "--cluster", &c.name], Duration::from_secs(30));
    assert!(!st.status.success());
    assert!(
        text(&st.stderr).contains("not running"),
        "{}",
        text(&st.stderr)
    );
}

#[test]
fn killed_supervisor_takes_its_members_with_it() {
    let c = Cluster::up(
        "orphan",
        &["--clock", "lockstep", "--cards", "1", "--stations", "1"],
    );
    let doc = c.status();
    let sup = doc["supervisor"]["pid"].as_u64().unwrap();
    let pids = member_pids(&doc);
    send_signal(sup, "-KILL");
    wait_until(
        "members to exit after the supervisor died",
        Duration::from_secs(20),
        || pids.iter().all(|p| !pid_alive(*p)),
    );
    let out = c.down();
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!run_base().join(&c.name).exists());
}

#[test]
fn ctrl_c_in_the_foreground_stops_everything() {
    let name = unique("fg");
    let mut guard = Cluster {
        name: name.clone(),
        pids: Vec::new(),
    };
    let mut child: Child = mcc_cmd(&[
        "up",
        "--cluster",
        &name,
        "--clock",
        "lockstep",
        "--cards",
        "1",
        "--stations",
        "1",
    ])
    .stdin(Stdio::piped())
    .spawn()
    .expect("spawn mcc up");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        match rx.recv_timeout(Duration::from_millis(200)) {
            Ok(l) if l.contains(" up: ") => break,
            _ => {}
        }
        assert!(
            Instant::now() < deadline,
            "foreground up did not report the ring locked"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "foreground up exited early"
        );
    }
    let doc = guard.status();
    guard.pids = all_pids(&doc);
    let pids = member_pids(&doc);
    send_signal(u64::from(child.id()), "-INT");
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "mcc up did not stop on SIGINT");
        std::thread::sleep(Duration::from_millis(50));
    };
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
    let _guard = Cluster {
        name: name.clone(),
        pids: Vec::new(),
    };
    let out = mcc(
        &[
            "up",
            "--detach",
            "--cluster",
            &name,
            "--config",
            file.to_str().unwrap(),
        ],
        Duration::from_secs(30),
    );
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains("cards[0].profile") && err.contains("pmac3"),
        "{err}"
    );
    assert!(
        !run_base().join(&name).exists(),
        "a rejected config must not leave a run dir"
    );

    std::fs::write(
        &file,
        "[[cards]]\nname = \"card0\"\nnumber = 0\nmaster = 0\nnodez = [1]\n",
    )
    .unwrap();
    let out = mcc(
        &[
            "up",
            "--detach",
            "--cluster",
            &name,
            "--config",
            file.to_str().unwrap(),
        ],
        Duration::from_secs(30),
    );
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("nodez"), "{}", text(&out.stderr));

    let out = mcc(
        &["up", "--cluster", "../evil", "--detach"],
        Duration::from_secs(30),
    );
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("--cluster"),
        "{}",
        text(&out.stderr)
    );
    let out = mcc(&["up", "--clock", "sometimes"], Duration::from_secs(30));
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("sometimes"),
        "{}",
        text(&out.stderr)
    );
    let out = mcc(
        &["up", "--rate=-3", "--cluster", &name],
        Duration::from_secs(30),
    );
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("--rate"),
        "{}",
        text(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir(run_base());
}
