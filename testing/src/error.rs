//! Errors of the test API: the `mcc` CLI's own message, typed by what went wrong.

use std::collections::BTreeMap;
use std::fmt;

/// What failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ErrorKind {
    /// The `mcc` binary was not found.
    NotFound,
    /// The cluster refused its configuration (or an argument) before anything ran.
    Config,
    /// A cluster of that name already runs in that run directory.
    Busy,
    /// A member or the supervisor exited during start-up.
    Start,
    /// The ring did not lock within the stated time.
    LockTimeout,
    /// A card answered a line with an error (`code`: `ERRnnn` or `BELL`).
    Card {
        /// `ERR003` etc.
        code: String,
    },
    /// A member, card, fault kind or option that does not exist (`choices`: the valid ones).
    UnknownChoice {
        /// The valid values.
        choices: Vec<String>,
    },
    /// [`crate::Cluster::wait_until`] gave up (cycles or wall time).
    WaitTimeout,
    /// Anything else the CLI reported.
    Other,
}

/// An error with the CLI's message and, for start-up failures, the last lines of every
/// member's log.
#[derive(Debug, Clone)]
pub struct Error {
    /// What failed.
    pub kind: ErrorKind,
    /// The message (the CLI's, without `mcc: error:`).
    pub message: String,
    /// Last lines of each log (`supervisor` and members), by name.
    pub logs: BTreeMap<String, String>,
}

impl Error {
    /// An error of `kind` with `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Error {
            kind,
            message: message.into(),
            logs: BTreeMap::new(),
        }
    }

    /// An [`ErrorKind::UnknownChoice`] naming `what`, the value and the valid choices.
    pub fn unknown<T: fmt::Display>(what: &str, value: impl fmt::Display, choices: &[T]) -> Self {
        let choices: Vec<String> = choices.iter().map(ToString::to_string).collect();
        Error::new(
            ErrorKind::UnknownChoice {
                choices: choices.clone(),
            },
            format!("unknown {what} '{value}' (valid: {})", choices.join(", ")),
        )
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)?;
        for (who, tail) in &self.logs {
            write!(f, "\n--- last lines of {who}.log ---\n{tail}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Error {}

/// Result of the test API.
pub type Result<T> = std::result::Result<T, Error>;
