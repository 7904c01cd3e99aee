//! The pure ring protocol: everything a member does with bytes and times it is given, and
//! nothing else — no sockets, zenoh, threads, files or clocks (the crate's `clippy.toml` bans
//! them here). Packets ([`packet`]) and frames ([`frame`]), the member core's cycle logic
//! ([`core`]: I995/I996 routing, error classes, holdover), the ring check ([`check`]), the
//! fault layer ([`fault`]), the holdover clock ([`holdover`]), the member interface
//! ([`member`]), the ring settings ([`settings`]), status bits ([`status`]), the auxiliary
//! channel ([`aux_channel`]), the ring members' control-plane messages ([`control`]), the expected verdict
//! of a fault ([`expect`]), the deterministic in-process simulator ([`sim`]) and the one
//! builder of a config's ring of member cores ([`builder`]).
//!
//! The crate root re-exports each module (`mcc_ring::core`, `mcc_ring::packet`, …), so users
//! need not name this folder. It builds without the `runtime` feature
//! (`cargo build -p mcc-ring --no-default-features`).

pub mod aux_channel;
pub mod builder;
pub mod check;
pub mod control;
pub mod core;
pub mod expect;
pub mod expect_card;
pub mod fault;
pub mod frame;
pub mod holdover;
pub mod linkfault;
pub mod member;
pub mod packet;
pub mod settings;
pub mod sim;
pub mod status;
