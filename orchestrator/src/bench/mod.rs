//! Benchmarks (`mcc bench ...`).

pub mod chain;
pub mod host;
pub mod inproc;
pub mod ring;
pub mod stats;
pub mod udp;
