//! A foreground `mcc up` (its terminal on stdin/stdout, stdin piped) for tests of tools that
//! run `mcc up` themselves, with the same private run directory and teardown as [`Cluster`]:
//! when dropped it is killed if still running, `mcc down` runs, and any process of the
//! cluster still alive is killed.
//!
//! [`Cluster`]: crate::Cluster

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use crate::error::{Error, ErrorKind, Result};
use crate::procs::Tracked;
use crate::run::{Runner, VERB_TIMEOUT};
use crate::status::Status;

/// A foreground `mcc up`, its stdout read line by line on a thread.
#[derive(Debug)]
pub struct Foreground {
    /// The `mcc up` process (take its `stdin` to type into the terminal).
    pub child: Child,
    lines: Receiver<String>,
    runner: Runner,
    dir: PathBuf,
    tracked: Tracked,
}

impl Foreground {
    /// Start `mcc up --cluster <unique> <extra…>` in the foreground, in a private run
    /// directory.
    pub fn start(mcc: &Path, tag: &str, extra: &[&str]) -> Result<Foreground> {
        let name = crate::cluster::unique_name(tag);
        let dir = std::env::temp_dir().join(format!("mcc-{name}"));
        let runner = Runner {
            mcc: mcc.to_path_buf(),
            run_dir: dir.join("run"),
            cluster: name,
            env: Vec::new(),
        };
        let mut args = vec!["up"];
        args.extend_from_slice(extra);
        let mut child = runner
            .command(&args)
            .stdin(Stdio::piped())
            .spawn()
            .map_err(|e| Error::new(ErrorKind::Other, format!("spawn mcc up: {e}")))?;
        let stdout = child
            .stdout
            .take()
            .ok_or_else(|| Error::new(ErrorKind::Other, "no stdout"))?;
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout)
                .lines()
                .map_while(std::result::Result::ok)
            {
                let _ = tx.send(line);
            }
        });
        Ok(Foreground {
            child,
            lines,
            runner,
            dir,
            tracked: Tracked::default(),
        })
    }

    /// Cluster name.
    pub fn name(&self) -> &str {
        &self.runner.cluster
    }

    /// The `MCC_RUN_DIR` (the run directory is `<it>/<name>`).
    pub fn run_base(&self) -> &Path {
        &self.runner.run_dir
    }

    /// `mcc status --json` of the running cluster (its pids are remembered for teardown).
    pub fn status(&mut self) -> Result<Status> {
        let st = Status(self.runner.json(&["status", "--json"], VERB_TIMEOUT)?);
        for p in st.pids() {
            self.tracked.add(p);
        }
        Ok(st)
    }

    /// Wait for the ` up: ` line (the ring is locked); every line up to it. An error if it
    /// does not come within `timeout` or `mcc up` exits first.
    pub fn wait_ready(&mut self, timeout: Duration) -> Result<Vec<String>> {
        let deadline = Instant::now() + timeout;
        let mut seen = Vec::new();
        loop {
            if let Ok(l) = self.lines.recv_timeout(Duration::from_millis(200)) {
                let ready = l.contains(" up: ");
                seen.push(l);
                if ready {
                    return Ok(seen);
                }
            }
            if Instant::now() >= deadline {
                return Err(Error::new(
                    ErrorKind::LockTimeout,
                    format!("foreground up did not report the ring locked: {seen:?}"),
                ));
            }
            if !matches!(self.child.try_wait(), Ok(None)) {
                return Err(Error::new(
                    ErrorKind::Start,
                    format!("foreground up exited early: {seen:?}"),
                ));
            }
        }
    }

    /// Wait for `mcc up` to exit within `timeout`.
    pub fn wait_exit(&mut self, timeout: Duration) -> Result<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Ok(s);
            }
            if Instant::now() >= deadline {
                return Err(Error::new(
                    ErrorKind::Other,
                    format!("mcc up did not exit within {timeout:?}"),
                ));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// `mcc --cluster NAME args…` on this cluster (bounded); its output, whatever the exit
    /// status (e.g. `fg.mcc(&["fault", "station0", "cut"])`).
    pub fn mcc(&self, args: &[&str]) -> Result<std::process::Output> {
        self.runner.output(args, VERB_TIMEOUT)
    }

    /// Read stdout lines until one contains `text` (e.g. a `mcc event:` line); that line. The
    /// lines read on the way are consumed. An error naming `text` and the lines seen if none
    /// comes within `timeout` or the output ends first.
    pub fn wait_line(&self, text: &str, timeout: Duration) -> Result<String> {
        let deadline = Instant::now() + timeout;
        let mut seen = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) if l.contains(text) => return Ok(l),
                Ok(l) => seen.push(l),
                Err(e) => {
                    let why = match e {
                        RecvTimeoutError::Timeout => format!("within {timeout:?}"),
                        RecvTimeoutError::Disconnected => "before mcc up's output ended".into(),
                    };
                    return Err(Error::new(
                        ErrorKind::WaitTimeout,
                        format!("no line containing {text:?} {why}; lines seen: {seen:?}"),
                    ));
                }
            }
        }
    }

    /// The stdout lines not yet taken, up to the end of the output (or `timeout`).
    pub fn remaining_lines(&self, timeout: Duration) -> Vec<String> {
        let deadline = Instant::now() + timeout;
        let mut rest = Vec::new();
        while let Ok(l) = self
            .lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
        {
            rest.push(l);
        }
        rest
    }
}

impl Drop for Foreground {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        let _ = self
            .runner
            .output(&["down", "--timeout", "5"], Duration::from_secs(60));
        self.tracked.kill_all(Duration::from_secs(5));
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
