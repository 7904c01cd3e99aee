//! The cluster's control-plane messages that are not the ring's, exchanged over zenoh
//! (key expressions architecture §3.1, §7; the ring members' own — status, faults, shutdown,
//! links — are `mcc_ring::control`):
//!
//! - `mcc/<cluster>/card/<n>/at`: synchronized start, [`AtRequest`] JSON → [`AtReply`] JSON
//!   ([`sync_start`]).
//! - `mcc/<cluster>/card/<n>/chain`: daisy-chain bytes, binary ([`chain`]).
//! - `mcc/<cluster>/emcl/<host>/{frame,status,io}`: the EMCL bus to drive hosts ([`emcl`]).
//! - `mcc/<cluster>/hosts/<host>/{alive,info,down,drill}`: each host's share ([`hosts`]).
//!
//! A card's refusal of a line travels beside its reply bytes on the `cmd`, `chain` and `at`
//! endpoints as a [`CardRefusal`] ([`refusal`]).

pub mod chain;
pub mod emcl;
pub mod hosts;
pub mod refusal;
pub mod sync_start;

pub use refusal::CardRefusal;
pub use sync_start::{at_key, AtReply, AtRequest};
