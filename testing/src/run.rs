//! Running `mcc`: where it is, bounded invocations (a hung verb is killed), JSON output and
//! the CLI's JSON errors turned into typed [`Error`]s.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use serde_json::Value;

use crate::error::{Error, ErrorKind, Result};

/// Environment variables of the user's shell that would change what a test cluster does.
pub const SCRUBBED_ENV: &[&str] = &[
    "MCC_CHAIN_PTY",
    "MCC_CHAIN_PORT",
    "MCC_TEST_AT_DELAY_MS",
    "MCC_RUN_DIR",
];

/// Bound of one verb (the machine may be busy).
pub const VERB_TIMEOUT: Duration = Duration::from_secs(120);

/// The `mcc` binary: `$MCC_BIN`, else `mcc` next to the running test's target directory
/// (`target/debug/mcc` for a test in `target/debug/deps`), else `mcc` on `PATH`.
pub fn find_mcc() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("MCC_BIN").filter(|p| !p.is_empty()) {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(Error::new(
                ErrorKind::NotFound,
                format!("MCC_BIN={} does not exist", p.display()),
            ))
        };
    }
    let exe = std::env::current_exe().ok();
    let near = exe
        .as_deref()
        .and_then(Path::parent)
        .into_iter()
        .flat_map(|d| {
            [
                d.join("mcc"),
                d.parent().map(|p| p.join("mcc")).unwrap_or_default(),
            ]
        });
    for cand in near {
        if cand.is_file() {
            return Ok(cand);
        }
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    for dir in std::env::split_paths(&path) {
        let cand = dir.join("mcc");
        if cand.is_file() {
            return Ok(cand);
        }
    }
    Err(Error::new(
        ErrorKind::NotFound,
        "the mcc binary was not found: set MCC_BIN=/path/to/mcc or put mcc on PATH",
    ))
}

/// Runs `mcc --cluster NAME ...` with a private `MCC_RUN_DIR`.
#[derive(Debug, Clone)]
pub struct Runner {
    /// The `mcc` binary.
    pub mcc: PathBuf,
    /// `MCC_RUN_DIR` of the cluster.
    pub run_dir: PathBuf,
    /// Cluster name.
    pub cluster: String,
    /// Extra environment.
    pub env: Vec<(String, String)>,
}

impl Runner {
    /// The command `mcc --cluster NAME args…` (stdin null, output piped).
    pub fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(&self.mcc);
        c.arg("--cluster")
            .arg(&self.cluster)
            .args(args)
            .env("MCC_RUN_DIR", &self.run_dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        for v in SCRUBBED_ENV.iter().filter(|v| **v != "MCC_RUN_DIR") {
            c.env_remove(v);
        }
        c.envs(self.env.iter().map(|(k, v)| (k, v)));
        c
    }

    /// Run a verb within `timeout`; its output (exit status not checked).
    pub fn output(&self, args: &[&str], timeout: Duration) -> Result<Output> {
        run_bounded(self.command(args), None, timeout).map_err(|e| Error::new(ErrorKind::Other, e))
    }

    /// Run a verb that must succeed; its stdout.
    pub fn run(&self, args: &[&str]) -> Result<String> {
        let out = self.output(args, VERB_TIMEOUT)?;
        if !out.status.success() {
            return Err(error_from(&out));
        }
        Ok(text(&out.stdout))
    }

    /// Run a `--json` verb; its (last) JSON document, or the typed error.
    pub fn json(&self, args: &[&str], timeout: Duration) -> Result<Value> {
        let out = self.output(args, timeout)?;
        let docs = documents(&text(&out.stdout));
        let is_err = docs
            .last()
            .is_some_and(|d| d.get("error").is_some_and(Value::is_object));
        if !out.status.success() || is_err {
            return Err(error_from(&out));
        }
        docs.into_iter()
            .next_back()
            .ok_or_else(|| Error::new(ErrorKind::Other, format!("mcc {args:?} printed no JSON")))
    }
}

/// Bytes as text (lossy).
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Every JSON document in `s`, in order.
pub fn documents(s: &str) -> Vec<Value> {
    serde_json::Deserializer::from_str(s)
        .into_iter::<Value>()
        .map_while(|r| r.ok())
        .collect()
}

/// The CLI's message in `stderr` (after `mcc: error: `), else all of it.
pub fn cli_message(stderr: &str) -> String {
    match stderr.find("mcc: error: ") {
        Some(i) => stderr[i + "mcc: error: ".len()..].trim().to_string(),
        None => stderr.trim().to_string(),
    }
}

/// The typed error of a failed verb (from its JSON error document when there is one).
pub fn error_from(out: &Output) -> Error {
    let stderr = text(&out.stderr);
    let docs = documents(&text(&out.stdout));
    if let Some(err) = docs
        .last()
        .and_then(|d| d.get("error"))
        .filter(|e| e.is_object())
    {
        let kind = match err["kind"].as_str().unwrap_or("error") {
            "config" => ErrorKind::Config,
            "running" => ErrorKind::Busy,
            "lock-timeout" => ErrorKind::LockTimeout,
            "start" | "exited" => ErrorKind::Start,
            _ => ErrorKind::Other,
        };
        let mut e = Error::new(kind, err["message"].as_str().unwrap_or_default());
        if let Some(logs) = err["logs"].as_object() {
            for (k, v) in logs {
                e.logs
                    .insert(k.clone(), v.as_str().unwrap_or_default().to_string());
            }
        }
        return e;
    }
    let message = cli_message(&stderr);
    // clap refused an argument (exit status 2, usage text): a configuration the CLI refuses.
    let usage = stderr.contains("error: invalid value") || stderr.contains("Usage:");
    let kind = if out.status.code() == Some(2) && usage {
        ErrorKind::Config
    } else {
        ErrorKind::Other
    };
    Error::new(kind, message)
}

/// Run `cmd` with `input` on its stdin, reading its output while it runs. After `timeout` it
/// is killed: an error naming it, with what it printed.
pub fn run_bounded(
    mut cmd: Command,
    input: Option<&[u8]>,
    timeout: Duration,
) -> std::result::Result<Output, String> {
    let what = format!("{:?}", cmd.get_args().collect::<Vec<_>>());
    if input.is_some() {
        cmd.stdin(Stdio::piped());
    }
    let mut child = cmd.spawn().map_err(|e| format!("spawn {what}: {e}"))?;
    let pid = child.id();
    let stdin = child.stdin.take();
    let input = input.unwrap_or_default().to_vec();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        if let Some(mut i) = stdin {
            let _ = i.write_all(&input);
        }
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(timeout) {
        Ok(out) => out.map_err(|e| format!("{what}: {e}")),
        Err(_) => {
            crate::procs::kill(pid, libc::SIGKILL);
            let out = rx
                .recv_timeout(Duration::from_secs(5))
                .ok()
                .and_then(std::result::Result::ok);
            let (o, e) = out.map_or_else(Default::default, |o| (text(&o.stdout), text(&o.stderr)));
            Err(format!(
                "mcc {what} did not finish within {timeout:?}\nstdout: {o}\nstderr: {e}"
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::process::ExitStatusExt;

    fn out(code: i32, stdout: &str, stderr: &str) -> Output {
        Output {
            status: std::process::ExitStatus::from_raw(code << 8),
            stdout: stdout.as_bytes().to_vec(),
            stderr: stderr.as_bytes().to_vec(),
        }
    }

    #[test]
    fn cli_errors_become_typed_errors() {
        let e = error_from(&out(
            1,
            r#"{"error": {"kind": "lock-timeout", "message": "did not lock", "logs": {"card0": "tail"}}}"#,
            "",
        ));
        assert_eq!(e.kind, ErrorKind::LockTimeout);
        assert_eq!(e.logs["card0"], "tail");
        assert!(e
            .to_string()
            .contains("--- last lines of card0.log ---\ntail"));
        let e = error_from(&out(
            1,
            r#"{"error": {"kind": "config", "message": "config: x"}}"#,
            "",
        ));
        assert_eq!(
            (e.kind, e.message.as_str()),
            (ErrorKind::Config, "config: x")
        );
        let e = error_from(&out(2, "", "error: invalid value 'x' for '--clock <MODE>'"));
        assert_eq!(e.kind, ErrorKind::Config);
        let e = error_from(&out(1, "", "mcc: ring 0\nmcc: error: boom\n"));
        assert_eq!((e.kind, e.message.as_str()), (ErrorKind::Other, "boom"));
        assert_eq!(documents("{\"a\":1}\n{\"b\":2}").len(), 2);
        assert!(documents("nope").is_empty());
    }

    #[test]
    fn a_hung_command_is_killed_at_its_bound() {
        let t = std::time::Instant::now();
        let mut c = Command::new("sleep");
        c.arg("30").stdout(Stdio::piped()).stderr(Stdio::piped());
        let e = run_bounded(c, None, Duration::from_millis(200)).unwrap_err();
        assert!(e.contains("did not finish"), "{e}");
        assert!(t.elapsed() < Duration::from_secs(10));
    }
}
