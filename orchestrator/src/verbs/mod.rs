//! The CLI verbs, one module each (architecture §6): `up` (and the hidden `supervise`),
//! `down`, `status`, `send`, `term`, `fault`, `start-sync`, `gather`, `emcl`, `bench …`. A verb
//! parses nothing itself (`crate::cli` does) and talks to the cluster through
//! [`crate::cluster`] only.

pub mod bench;
pub mod down;
pub mod emcl;
pub mod fault;
pub mod gather;
pub mod send;
pub mod start_sync;
pub mod status;
pub mod term;
pub mod up;
pub mod watch;
