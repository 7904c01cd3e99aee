//! Shared helpers for the scenario tests: running the cluster's binaries ([`process`]) and
//! multi-process clusters under a cleanup guard ([`cluster`]), in-process rings ([`inproc`]), CPU load ([`load`]).

pub mod cluster;
pub mod inproc;
pub mod load;
pub mod process;
