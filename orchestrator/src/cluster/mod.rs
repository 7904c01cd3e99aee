//! Cluster plumbing: what the verbs are built from. Run directories and the supervisor record
//! ([`rundir`]), member and supervisor processes ([`launch`], [`supervisor`], [`owner`],
//! [`stop`], [`sys`]), the control plane seen from outside ([`ctl`], [`attach`], [`ready`],
//! [`events`], [`drills`]), the status document ([`status`]), the daisy-chain and EMCL bus
//! servers ([`chain`], [`emcl`], [`serve`]), the synchronized-start protocol ([`sync_start`]),
//! the interactive terminal ([`terminal`]), clusters on several hosts ([`hosts`]), checks
//! before start ([`precheck`], [`fixed_ports`]) and failure reports ([`failure`]).
//!
//! Plumbing never uses a verb (`crate::verbs`): the layering test below checks it.

pub mod attach;
pub mod chain;
pub mod ctl;
pub mod drills;
pub mod emcl;
pub mod events;
pub mod failure;
pub mod fixed_ports;
pub mod hosts;
pub mod launch;
pub mod link_ctl;
pub mod owner;
pub mod precheck;
pub mod ready;
pub mod rundir;
pub mod serve;
pub mod status;
pub mod stop;
pub mod supervisor;
pub mod sync_start;
pub mod sys;
pub mod terminal;

#[cfg(test)]
mod layering;
