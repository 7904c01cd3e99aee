//! Benchmarks (`mcc bench ...`).

pub mod bringup;
pub mod campaign;
pub mod chain;
pub mod cluster;
pub mod crash;
pub mod emcl;
pub mod faults;
pub mod floor;
pub mod host;
pub mod hosts;
pub mod inproc;
pub mod netns;
pub mod procstat;
pub mod ring;
pub mod soak;
pub mod stats;
pub mod syncstart;
pub mod udp;
