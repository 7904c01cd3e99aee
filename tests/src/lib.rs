//! Shared helpers for the scenario tests: running the cluster's binaries ([`process`])

pub mod inproc;
pub mod process;
