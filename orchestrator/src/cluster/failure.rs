//! Failures that scripts and test harnesses tell apart: a kind, the message, and the last
//! lines of the cluster's logs (a cluster that did not lock takes its logs with it when it is
//! stopped, so they travel in the error). With `--json`, `main` prints any error as
//! `{"error": {"kind", "message", "logs"}}` on stdout.

use std::collections::BTreeMap;
use std::fmt;

use crate::cluster::rundir::RunDir;

/// Lines of each log kept in a failure.
pub const LOG_LINES: usize = 40;

/// A classified failure.
#[derive(Debug)]
pub struct Failure {
    /// `config` (the config or an argument was refused), `running` (the cluster already
    /// runs), `exited` (the supervisor or a member exited during start-up), `lock-timeout`
    /// (the ring did not lock in time).
    pub kind: &'static str,
    /// What went wrong.
    pub message: anyhow::Error,
    /// Last lines of each log (`supervisor` and every member), by name.
    pub logs: BTreeMap<String, String>,
}

impl Failure {
    /// A failure without logs.
    pub fn new(kind: &'static str, message: anyhow::Error) -> Self {
        Failure {
            kind,
            message,
            logs: BTreeMap::new(),
        }
    }

    /// Attach the last lines of the supervisor's and every member's log.
    pub fn with_logs(mut self, rd: &RunDir, members: &[String]) -> Self {
        let names = std::iter::once("supervisor").chain(members.iter().map(String::as_str));
        for who in names {
            let tail = rd.log_tail(who, LOG_LINES);
            if !tail.trim().is_empty() {
                self.logs.insert(who.to_string(), tail);
            }
        }
        self
    }

    /// The `{"error": {...}}` document.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "error": {
                "kind": self.kind,
                "message": format!("{:#}", self.message),
                "logs": self.logs,
            }
        })
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#}", self.message)?;
        for (who, tail) in &self.logs {
            write!(f, "\n--- last lines of {who}.log ---\n{tail}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Failure {}

/// The JSON error document of any error (`kind` `error` when it was not classified).
pub fn error_json(e: &anyhow::Error) -> serde_json::Value {
    match e.downcast_ref::<Failure>() {
        Some(f) => f.to_json(),
        None => serde_json::json!({
            "error": { "kind": "error", "message": format!("{e:#}"), "logs": {} }
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failures_keep_their_kind_message_and_logs() {
        let dir = std::env::temp_dir().join(format!("mcc-failure-test-{}", std::process::id()));
        let rd = RunDir {
            dir: dir.clone(),
            cluster: "f".into(),
            host: None,
        };
        std::fs::create_dir_all(dir.join("logs")).unwrap();
        std::fs::write(rd.log_path("card0"), "one\ntwo\n").unwrap();
        let f = Failure::new("lock-timeout", anyhow::anyhow!("the ring did not lock"))
            .with_logs(&rd, &["card0".into(), "station0".into()]);
        let e = anyhow::Error::new(f);
        let j = error_json(&e);
        assert_eq!(j["error"]["kind"], "lock-timeout");
        assert_eq!(j["error"]["message"], "the ring did not lock");
        assert_eq!(j["error"]["logs"]["card0"], "one\ntwo");
        assert!(j["error"]["logs"].get("station0").is_none(), "{j}");
        let text = format!("{e:#}");
        assert!(
            text.contains("--- last lines of card0.log ---\none\ntwo"),
            "{text}"
        );
        let plain = error_json(&anyhow::anyhow!("x"));
        assert_eq!(plain["error"]["kind"], "error");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
