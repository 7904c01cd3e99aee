//! Shared helpers for the scenario tests: running the cluster's binaries ([`process`]) and
//! multi-process clusters under a cleanup guard ([`cluster`]).

pub mod cluster;
pub mod process;
