//! mcc-contracts: the cluster's contracts, what the ring, the cards, the stations and the
//! orchestrator agree on without being the ring.
//!
//! - [`config`]: the cluster TOML config (clock, ring order, cards and their I-variables,
//!   stations, drives and the EMCL bus, hosts, zenoh, security): parsed, validated and written
//!   back, never panicking. Its keys are a public contract (`mcc up --config`).
//! - [`hostport`]: who may use a host port (connection limit, eviction, idle and stalled
//!   limits).
//! - [`control`]: the control-plane messages of the cluster that are not the ring's: the EMCL
//!   bus, the daisy chain, hosts' shares and the synchronized start (the ring's own — member
//!   status, faults, shutdown — are `mcc_ring::control`).
//! - [`atomic_file`]: the one atomic file write of every SAVE-like writer.
//!
//! Pure but for two I/O edges: [`atomic_file`] (allowed here as mcc-ring allows its runtime)
//! and [`config::ClusterConfig::from_file`]. The crate depends on no workspace crate; mcc-ring
//! builds on it (its pure protocol reads the config), never the other way round.

#![warn(missing_docs, unreachable_pub)]

#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge: it writes files
pub mod atomic_file;
pub mod config;
pub mod control;
pub mod hostport;

#[cfg(test)]
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // reads the crate's own source
#[path = "../../src/api_check.rs"] // one check, shared with mcc-ring and mcc-station
mod api_check;
