//! Host ports: ASCII terminal, PMAC Ethernet protocol, zenoh command queryable.
//!
//! - [`bench`]: the host benchmark (`mcc bench host`).
//! - [`ascii`]: terminal byte stream → lines and control characters (pure).
//! - [`eth_codec`]: PMAC Ethernet `VR_` request/reply state machine (pure).
//! - [`port`]: the [`port::Interpreter`] seam between the codecs and the card.
//! - [`server`]: tokio TCP servers for both ports.
//! - [`standalone`]: `mcc-card --standalone` (one card, its ports, no ring).
//! - [`zenoh_cmd`]: the `mcc/<cluster>/card/<n>/cmd` queryable.

pub mod ascii;
pub mod bench;
pub mod eth_codec;
pub mod port;
pub mod server;
pub mod standalone;
pub mod zenoh_cmd;
