//! Host ports: ASCII terminal, PMAC Ethernet protocol, zenoh command queryable.
//!
//! - [`bench`]: the host benchmark (`mcc bench host`).
//! - [`ascii`]: terminal byte stream → lines and control characters (pure).
//! - [`eth_codec`]: PMAC Ethernet `VR_` request/reply state machine (pure).
//! - [`port`]: the [`port::Interpreter`] seam between the codecs and the card.
//! - [`server`]: tokio TCP servers for both ports.

//! - [`zenoh_cmd`]: the `mcc/<cluster>/card/<n>/cmd` queryable.

#![allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge: threads, clocks, files, sockets

pub mod ascii;
pub mod bench;
pub mod eth_codec;
pub mod port;
pub mod server;
pub mod zenoh_cmd;
