//! The I/O edge of a ring member: its cycle loop ([`driver`]), realtime pacing ([`pacer`]),
//! the control plane over zenoh ([`control_plane`]), the common process `main` ([`process`])
//! and its logging set-up ([`logging`]).

pub mod control_plane;
pub mod driver;
pub mod inline;
pub mod local;
pub mod logging;
pub mod pacer;
pub mod process;

#[cfg(test)]
mod tests;
