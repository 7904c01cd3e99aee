//! Benchmarks (`mcc bench ...`).

pub mod host;
pub mod chain;
pub mod inproc;
pub mod ring;
pub mod stats;
pub mod udp;
