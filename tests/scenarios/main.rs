//! The one scenario test binary: in-process ring, transcripts, multi-process clusters.

mod chain;
mod cluster;
mod drills;
mod emcl;
mod emcl_bound;
mod gather;
mod host_limits;
mod hosts;
mod macro_station;
mod motion;
mod persistence;
mod power_ring;
mod programs;
mod recovery;
mod registers;
mod reliability;
mod ring_inprocess;
mod station_aux;
mod stations;
mod testing_api;
mod transcripts;
mod triggers;
mod turbo;
