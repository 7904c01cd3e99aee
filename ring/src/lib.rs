//! mcc-ring: the MACRO-style ring.
//!
//! Pure protocol core (packets, frames, I995/I996 routing, error classes, ring check, fault
//! layer, holdover clock, member core, deterministic in-process simulator) plus the edges that
//! do I/O: [`transport`] (zenoh and in-process loopback links) and [`runtime`] (a member's
//! cycle loop and control plane).

pub mod check;
pub mod config;
pub mod control;
pub mod core;
pub mod expect;
pub mod fault;
pub mod frame;
pub mod holdover;
pub mod member;
pub mod packet;
pub mod runtime;
pub mod settings;
pub mod sim;
pub mod status;
pub mod transport;
