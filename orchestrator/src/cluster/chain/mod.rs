//! The daisy chain (pmac-commands §8): a host connection broadcasts every byte to every card
//! of the cluster (each card runs its own §8.3 receiver per connection, card/src/runtime/
//! chain.rs) and gets back the merged replies ([`link`]); the supervisor serves it as a TCP
//! port and optionally a pseudo-terminal ([`server`]); [`text`] turns typed lines into chain
//! bytes and replies into readable text.

pub mod link;
pub mod server;
pub mod text;
