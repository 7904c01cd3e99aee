//! A cluster under test: started with `mcc up --detach` under a unique name (or adopted as a
//! bare guard), driven with `mcc` verbs, and always cleaned up: when the guard drops it runs
//! `mcc down` and SIGKILLs every process it saw. [`Foreground`] runs a foreground `mcc up`
//! whose stdout is read line by line.

use std::io::{BufRead, BufReader};
use std::process::{Child, ExitStatus, Output, Stdio};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::process::{mcc_command, mcc_env, ok, pid_alive, run_bounded, send_signal, unique};

/// Bound of `mcc up --detach` (the ring must lock; the machine may be busy).
pub const UP_TIMEOUT: Duration = Duration::from_secs(150);
/// Bound of the other verbs run through [`Cluster::mcc`].
pub const VERB_TIMEOUT: Duration = Duration::from_secs(120);

/// A cluster under test; `mcc down` and SIGKILL of every pid seen when dropped.
#[derive(Debug)]
pub struct Cluster {
    /// Cluster name (`--cluster`).
    pub name: String,
    /// Supervisor and member pids seen at start-up (killed on drop if still alive).
    pub pids: Vec<u64>,
}

impl Cluster {
    /// A guard for a cluster named `name` that this test starts itself (or expects to be
    /// refused): nothing is started, but dropping it still runs `mcc down`.
    pub fn guard(name: &str) -> Cluster {
        Cluster {
            name: name.to_string(),
            pids: Vec::new(),
        }
    }

    /// `mcc up --detach --cluster <unique> --timeout 90 <extra…>`; the test fails if it does.
    pub fn up(tag: &str, extra: &[&str]) -> Cluster {
        Cluster::up_with_env(tag, extra, &[])
    }

    /// [`Cluster::up`] with extra environment variables for the cluster's processes.
    pub fn up_with_env(tag: &str, extra: &[&str], env: &[(&str, &str)]) -> Cluster {
        let mut c = Cluster::guard(&unique(tag));
        let mut args = vec!["up", "--detach", "--cluster", &c.name, "--timeout", "90"];
        args.extend_from_slice(extra);
        ok(mcc_env(&args, env, UP_TIMEOUT), "mcc up");
        c.pids = all_pids(&c.status());
        c
    }

    /// `mcc --cluster <name> args…` (bounded by [`VERB_TIMEOUT`]).
    pub fn mcc(&self, args: &[&str]) -> Output {
        let mut a = vec!["--cluster", self.name.as_str()];
        a.extend_from_slice(args);
        mcc_env(&a, &[], VERB_TIMEOUT)
    }

    /// `mcc status --json`, parsed; the test fails if the verb does.
    pub fn status(&self) -> Value {
        let out = ok(self.mcc(&["status", "--json"]), "mcc status");
        serde_json::from_str(&out).expect("status JSON")
    }

    /// Send command lines to card `n`'s ASCII terminal port (from the status document) and
    /// return everything it answered (each line's reply up to its final `<LF>` or `<ACK>`, or
    /// 300 ms of silence).
    pub fn ascii(&self, n: u64, lines: &[&str]) -> String {
        use std::io::{Read, Write};
        let doc = self.status();
        let port = doc["cards"]
            .as_array()
            .and_then(|cards| cards.iter().find(|c| c["number"] == n))
            .and_then(|c| c["ascii"].as_u64())
            .unwrap_or_else(|| panic!("card {n} has no ascii port: {doc:#}"));
        let mut s =
            std::net::TcpStream::connect(("127.0.0.1", port as u16)).expect("connect ascii port");
        s.set_read_timeout(Some(Duration::from_millis(300)))
            .expect("read timeout");
        let mut all = Vec::new();
        for l in lines {
            s.write_all(format!("{l}\r").as_bytes()).expect("write");
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

    /// `mcc down` (default stop timeout).
    pub fn down(&self) -> Output {
        self.mcc(&["down"])
    }

    /// Poll `mcc status` every 200 ms until `f` holds; that status. The test fails naming
    /// `what` (with the last status) after `timeout`.
    pub fn wait(&self, what: &str, timeout: Duration, mut f: impl FnMut(&Value) -> bool) -> Value {
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
        // Never panic here (the test may already be unwinding): errors and hangs are ignored.
        let down = mcc_command(&["--cluster", &self.name, "down", "--timeout", "5"]);
        let _ = run_bounded(down, None, Duration::from_secs(60));
        for &p in &self.pids {
            if pid_alive(p) {
                send_signal(p, "-KILL");
            }
        }
    }
}

/// Every member pid and the supervisor's in a status document.
pub fn all_pids(doc: &Value) -> Vec<u64> {
    let mut v: Vec<u64> = doc["members"]
        .as_array()
        .map(|a| a.iter().filter_map(|m| m["pid"].as_u64()).collect())
        .unwrap_or_default();
    v.extend(doc["supervisor"]["pid"].as_u64());
    v
}

/// The member pids of a status document (each member must have one).
pub fn member_pids(doc: &Value) -> Vec<u64> {
    doc["members"]
        .as_array()
        .expect("members")
        .iter()
        .map(|m| m["pid"].as_u64().expect("member pid"))
        .collect()
}

/// A foreground `mcc up` (stdin piped), its stdout read line by line on a thread. Killed on
/// drop if still running (put it after its [`Cluster::guard`] so `mcc down` runs last).
#[derive(Debug)]
pub struct Foreground {
    /// The `mcc up` process.
    pub child: Child,
    lines: Receiver<String>,
}

impl Foreground {
    /// Start `mcc up --cluster <name> <extra…>` in the foreground.
    pub fn start(name: &str, extra: &[&str]) -> Foreground {
        let mut args = vec!["up", "--cluster", name];
        args.extend_from_slice(extra);
        let mut child = mcc_command(&args)
            .stdin(Stdio::piped())
            .spawn()
            .expect("spawn mcc up");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        Foreground { child, lines }
    }

    /// Wait for the ` up: ` line (the ring is locked); every line up to it. The test fails if
    /// it does not come within `timeout` or `mcc up` exits first.
    pub fn wait_ready(&mut self, timeout: Duration) -> Vec<String> {
        let deadline = Instant::now() + timeout;
        let mut seen = Vec::new();
        loop {
            if let Ok(l) = self.lines.recv_timeout(Duration::from_millis(200)) {
                let ready = l.contains(" up: ");
                seen.push(l);
                if ready {
                    return seen;
                }
            }
            assert!(
                Instant::now() < deadline,
                "foreground up did not report the ring locked: {seen:?}"
            );
            assert!(
                self.child.try_wait().expect("wait").is_none(),
                "foreground up exited early: {seen:?}"
            );
        }
    }

    /// Wait for `mcc up` to exit (the test fails naming `why` after `timeout`).
    pub fn wait_exit(&mut self, why: &str, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait().expect("wait") {
                return s;
            }
            assert!(Instant::now() < deadline, "mcc up did not stop {why}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Read stdout lines until one contains `text`; that line. The test fails naming `text`
    /// (and the lines seen) after `timeout` or at the end of the output.
    pub fn wait_line(&self, text: &str, timeout: Duration) -> String {
        let deadline = Instant::now() + timeout;
        let mut seen = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) if l.contains(text) => return l,
                Ok(l) => seen.push(l),
                Err(_) => panic!("no line with {text:?} within {timeout:?}: {seen:#?}"),
            }
        }
    }

    /// The stdout lines not yet taken, up to the end of the output (or `timeout`).
    pub fn remaining_lines(&self, timeout: Duration) -> Vec<String> {
        let deadline = Instant::now() + timeout;
        let mut rest = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) => rest.push(l),
                Err(_) => return rest,
            }
        }
    }
}

impl Drop for Foreground {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
