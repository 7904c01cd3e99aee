//! Benchmarks (`mcc bench ...`).

pub mod ring;
