//! Host ports: ASCII terminal, PMAC Ethernet protocol, zenoh command queryable.
//!
//! - [`bench`]: the host benchmark (`mcc bench host`).
//! - [`ascii`]: terminal byte stream → lines and control characters (pure).
//! - [`eth_codec`]: PMAC Ethernet `VR_` request/reply state machine (pure).
//! - [`port`]: the [`port::Interpreter`] seam between the codecs and the card.
//! - [`server`]: tokio TCP servers for both ports.
//! - [`gpascii`]: the Power PMAC `gpascii` command thread's banner, lines and reply framing (pure).
//! - [`ssh`]: the Power PMAC card's SSH server and its shell emulation.
//! - [`power_ports`]: tokio servers for a Power card's raw `gpascii` port and SSH.
//! - [`link_reply`]: replies through the card's host-link fault (`mcc fault CARD link`).

//! - [`zenoh_cmd`]: the `mcc/<cluster>/card/<n>/cmd` queryable.

#![allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge: threads, clocks, files, sockets

pub(crate) mod ascii;
pub(crate) mod bench;
pub(crate) mod eth_codec;
pub(crate) mod gpascii;
pub(crate) mod link_reply;
pub(crate) mod port;
pub(crate) mod power_ports;
pub(crate) mod server;
pub(crate) mod ssh;
pub(crate) mod zenoh_cmd;

#[cfg(test)]
mod tests_fuzz;
#[cfg(test)]
mod tests_link_faults;
