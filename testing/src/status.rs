//! The `mcc status --json` document (architecture §6) with accessors, and a stream of them
//! (`mcc status --json --watch MS`) for waits counted in ring cycles.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::error::{Error, ErrorKind, Result};

/// One status document: the parsed JSON (`status.0["ring"]["cycle"]`) and shortcuts.
#[derive(Debug, Clone, PartialEq)]
pub struct Status(pub Value);

impl Status {
    /// Ring cycle of the synchronizing master.
    pub fn cycle(&self) -> u64 {
        self.0["ring"]["cycle"].as_u64().unwrap_or(0)
    }

    /// Every member alive and phase-locked.
    pub fn locked(&self) -> bool {
        self.0["ring"]["locked"] == true
    }

    /// A member latched a ring fault, or a link is broken.
    pub fn faulted(&self) -> bool {
        self.0["ring"]["faulted"] == true
    }

    /// The broken link (`"station0 → card1"`).
    pub fn broken_link(&self) -> Option<&str> {
        self.0["ring"]["broken_link"].as_str()
    }

    /// Member names in ring order.
    pub fn member_names(&self) -> Vec<String> {
        self.rows("members")
            .iter()
            .filter_map(|m| m["name"].as_str().map(str::to_string))
            .collect()
    }

    fn rows(&self, key: &str) -> Vec<Value> {
        self.0[key].as_array().cloned().unwrap_or_default()
    }

    /// The row of member `name`.
    pub fn member(&self, name: &str) -> Result<Value> {
        self.rows("members")
            .into_iter()
            .find(|m| m["name"] == name)
            .ok_or_else(|| Error::unknown("member", name, &self.member_names()))
    }

    /// The `cards[]` row of card `number` (I0).
    pub fn card(&self, number: u8) -> Result<Value> {
        let cards = self.rows("cards");
        let have: Vec<u64> = cards.iter().filter_map(|c| c["number"].as_u64()).collect();
        cards
            .into_iter()
            .find(|c| c["number"] == u64::from(number))
            .ok_or_else(|| Error::unknown("card", number, &have))
    }

    /// Numbers of the cards whose ring-fault bit is set.
    pub fn ring_faulted_cards(&self) -> Vec<u8> {
        self.rows("cards")
            .iter()
            .filter(|c| c["ring_fault"] == true)
            .filter_map(|c| c["number"].as_u64().and_then(|n| u8::try_from(n).ok()))
            .collect()
    }

    /// Every pid in the document (members and supervisor).
    pub fn pids(&self) -> Vec<u32> {
        let mut v: Vec<u32> = self
            .rows("members")
            .iter()
            .filter_map(|m| m["pid"].as_u64().and_then(|p| u32::try_from(p).ok()))
            .collect();
        v.extend(
            self.0["supervisor"]["pid"]
                .as_u64()
                .and_then(|p| u32::try_from(p).ok()),
        );
        v
    }
}

/// A running `mcc status --json --watch MS`: documents arrive on a channel.
#[derive(Debug)]
pub struct StatusStream {
    child: Child,
    rx: Receiver<Status>,
}

impl StatusStream {
    /// Start the watch process.
    pub fn start(mut cmd: Command) -> Result<Self> {
        let mut child = cmd
            .spawn()
            .map_err(|e| Error::new(ErrorKind::Other, format!("mcc status --watch: {e}")))?;
        let out = child
            .stdout
            .take()
            .ok_or_else(|| Error::new(ErrorKind::Other, "no stdout"))?;
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out)
                .lines()
                .map_while(std::result::Result::ok)
            {
                if let Ok(v) = serde_json::from_str::<Value>(&line) {
                    if v.get("ring").is_some() && tx.send(Status(v)).is_err() {
                        return;
                    }
                }
            }
        });
        Ok(StatusStream { child, rx })
    }

    /// Still running.
    pub fn alive(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// The first document produced after this call (older ones are dropped), within
    /// `timeout`.
    pub fn next(&mut self, timeout: Duration) -> Result<Status> {
        while self.rx.try_recv().is_ok() {}
        let deadline = Instant::now() + timeout;
        let left = deadline.saturating_duration_since(Instant::now());
        match self.rx.recv_timeout(left) {
            Ok(s) => Ok(s),
            Err(RecvTimeoutError::Timeout) => Err(Error::new(
                ErrorKind::WaitTimeout,
                format!("no status document within {timeout:?}"),
            )),
            Err(RecvTimeoutError::Disconnected) => Err(Error::new(
                ErrorKind::Other,
                "mcc status --watch ended (is the cluster still running?)",
            )),
        }
    }

    /// Stop the watch process.
    pub fn stop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for StatusStream {
    fn drop(&mut self) {
        self.stop();
    }
}
