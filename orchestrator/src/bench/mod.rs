//! Benchmarks (`mcc bench ...`).

pub mod bringup;
pub mod campaign;
pub mod chain;
pub mod crash;
pub mod emcl;
pub mod faults;
pub mod host;
pub mod inproc;
pub mod ring;
pub mod soak;
pub mod stats;
pub mod syncstart;
pub mod udp;
