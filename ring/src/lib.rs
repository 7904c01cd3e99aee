//! mcc-ring: the MACRO-style ring.
//!
//! Pure protocol core (packets, frames, I995/I996 routing, error classes, ring check, fault
//! layer, holdover clock, member core, deterministic in-process simulator) plus the edges that
//! do I/O: [`transport`] (zenoh and in-process loopback links) and [`runtime`] (a member's
//! cycle loop and control plane).

#![warn(missing_docs, unreachable_pub)]

pub mod aux_channel;
pub mod check;
pub mod config;
pub mod control;
pub mod core;
pub mod expect;
pub mod fault;
pub mod frame;
pub mod holdover;
pub mod hostport;
pub mod member;
pub mod packet;
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge
pub mod runtime;
pub mod settings;
pub mod sim;
pub mod status;
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge
pub mod transport;
