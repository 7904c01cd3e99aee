//! Running the cluster's binaries from a test: where they are (built on first use), a run
//! directory private to the test process, `mcc` invocations bounded in time, and process
//! helpers (alive, signal, bounded waits).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Environment variables of the user's shell that would change what `mcc` does.
const SCRUBBED_ENV: &[&str] = &[
    "MCC_BIN_DIR",
    "MCC_CHAIN_PTY",
    "MCC_CHAIN_PORT",
    "MCC_EMCL_PTY",
    "MCC_EMCL_PORT",
    "MCC_TEST_AT_DELAY_MS",
];

/// The folder holding `mcc`, `mcc-card` and `mcc-station` (target/debug or target/release:
/// the test exe lives in its `deps`). Cargo does not build other packages' binaries for an
/// integration test, so the first call builds them (a no-op when fresh).
pub fn bin_dir() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().expect("test exe path");
        let dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("target dir")
            .to_path_buf();
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut args = vec![
            "build",
            "-q",
            "-p",
            "mcc-orchestrator",
            "-p",
            "mcc-card",
            "-p",
            "mcc-station",
        ];
        if dir.ends_with("release") {
            args.push("--release");
        }
        let st = Command::new(cargo)
            .args(&args)
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

/// The `MCC_RUN_DIR` of every cluster this test process starts (private to the process).
pub fn run_base() -> PathBuf {
    std::env::temp_dir().join(format!("mcc-scenarios-{}", std::process::id()))
}

/// A cluster name no other test (of this or another test process) uses: `t<pid>-<tag>-<n>`.
pub fn unique(tag: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    format!("t{}-{tag}-{n}", std::process::id())
}

/// `mcc args…` with [`run_base`] as its run directory and a scrubbed environment; stdin
/// null, stdout and stderr piped.
pub fn mcc_command(args: &[&str]) -> Command {
    let mut c = Command::new(bin_dir().join("mcc"));
    c.args(args)
        .env("MCC_RUN_DIR", run_base())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for v in SCRUBBED_ENV {
        c.env_remove(v);
    }
    c
}

/// Run `cmd` with `input` on its stdin (then closed), reading its output while it runs; killed
/// after `timeout` (the test API's runner).
pub use mcc_testing::run::run_bounded;

/// `mcc args…`, killed (and the test failed) after `timeout`.
pub fn mcc(args: &[&str], timeout: Duration) -> Output {
    run_bounded(mcc_command(args), None, timeout).unwrap_or_else(|e| panic!("{e}"))
}

/// Bytes as text (lossy).
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The stdout of a command that must have succeeded (else the test fails naming `what`).
pub fn ok(out: Output, what: &str) -> String {
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "{what} failed\nstdout: {stdout}\nstderr: {}",
        text(&out.stderr)
    );
    stdout
}

/// Alive and not a zombie (members are re-parented when the supervisor dies; whoever
/// inherits them may reap late).
pub fn pid_alive(pid: u64) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => false,
        Ok(stat) => stat
            .rfind(')')
            .and_then(|i| stat.get(i + 1..))
            .is_some_and(|rest| !rest.trim_start().starts_with(['Z', 'X'])),
    }
}

/// `kill <sig> <pid>` (e.g. `-KILL`, `-INT`); failures ignored.
pub fn send_signal(pid: u64, sig: &str) {
    let _ = Command::new("kill")
        .args([sig, &pid.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
}

/// Poll `f` every 100 ms until it holds; the test fails naming `what` after `timeout`.
pub fn wait_until(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !f() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}
