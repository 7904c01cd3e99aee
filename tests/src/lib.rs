//! Shared helpers for the scenario tests: running the cluster's binaries ([`process`]),
//! in-process rings ([`inproc`]), CPU load ([`load`]).

pub mod inproc;
pub mod load;
pub mod process;
