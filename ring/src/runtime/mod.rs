//! The I/O edge of a ring member: its cycle loop ([`driver`]; the paced and lockstep sync
//! master in [`stepped`], their wall-clock bookkeeping in [`timing`]), realtime pacing ([`pacer`]),
//! the frozen-member judgement ([`silence`]), the control plane over zenoh ([`control_plane`]),
//! the common process `main` ([`process`])
//! and its logging set-up ([`logging`]).

pub mod control_plane;
pub mod cpu;
pub mod driver;
pub mod inline;
pub mod join;
pub mod light;
pub mod links_up;
pub mod local;
pub mod logging;
pub mod pacer;
pub mod process;
pub mod rt;
pub mod silence;
pub mod stepped;
pub mod timing;

#[cfg(test)]
mod pipeline_tests;
#[cfg(test)]
mod tests;

/// A zenoh declaration (queryable, token, subscriber) of a member's runtime failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("declare {what}: {message}")]
pub struct DeclareError {
    /// What was declared.
    pub what: &'static str,
    /// zenoh's message.
    pub message: String,
}

impl DeclareError {
    /// A `map_err` for the declaration of `what`.
    pub(crate) fn of(what: &'static str) -> impl Fn(zenoh::Error) -> Self {
        move |e| DeclareError {
            what,
            message: e.to_string(),
        }
    }
}
