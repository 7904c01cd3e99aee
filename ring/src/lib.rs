//! mcc-ring: the MACRO-style ring, and only the ring.
//!
//! Two layers. The pure protocol ([`protocol`]: packets, frames, I995/I996 routing, error
//! classes, ring check, fault layer, holdover clock, member core, the ring members' control
//! messages, the rules a fault is judged by, deterministic in-process simulator) takes bytes
//! and times as arguments and builds alone (`--no-default-features`). The edges that do I/O,
//! [`transport`] (zenoh and in-process loopback links) and [`runtime`] (a member's cycle loop
//! and control plane), sit behind the `runtime` feature (on by default).
//!
//! The cluster's contracts that are not the ring — the cluster config with its drives, hosts
//! and security, host-port limits, the EMCL bus, daisy-chain, host and synchronized-start
//! messages, the atomic file write — are the crate `mcc-contracts` ([`mcc_contracts`], in
//! `ring/contracts/`), which this crate builds on: the ring reads the config it is built from.

#![warn(missing_docs, unreachable_pub)]

pub mod protocol;
#[cfg(feature = "runtime")]
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge
pub mod runtime;
#[cfg(feature = "runtime")]
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge
pub mod transport;

#[cfg(test)]
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // reads the crate's own source
mod api_check;

pub use protocol::{
    aux_channel, builder, check, control, core, expect, expect_card, fault, frame, holdover,
    linkfault, member, packet, settings, sim, status,
};
