//! The one scenario test binary: in-process ring, transcripts, multi-process clusters.

mod chain;
mod cluster;
mod drills;
mod emcl;
mod emcl_bound;
mod gather;
mod host_limits;
mod hosts;
mod motion;
mod programs;
mod ring_inprocess;
mod testing_api;
mod transcripts;
