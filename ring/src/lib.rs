//! mcc-ring: the MACRO-style ring.
//!
//! Two layers. The pure protocol ([`protocol`]: packets, frames, I995/I996 routing, error
//! classes, ring check, fault layer, holdover clock, member core, deterministic in-process
//! simulator) with the cluster config ([`config`]) and host-port limits ([`hostport`]) takes
//! bytes and times as arguments and builds alone (`--no-default-features`). The edges that do
//! I/O, [`transport`] (zenoh and in-process loopback links) and [`runtime`] (a member's cycle
//! loop and control plane), sit behind the `runtime` feature (on by default).

#![warn(missing_docs, unreachable_pub)]

pub mod config;
pub mod hostport;
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
