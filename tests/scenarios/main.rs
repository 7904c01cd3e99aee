//! The one scenario test binary: in-process ring, transcripts, multi-process clusters.

mod busy_ports;
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
mod power_ring;
mod private_run_dir;
mod programs;
mod recovery;
mod refusals;
mod registers;
mod reliability;
mod ring_inprocess;
mod station_aux;
mod stations;
mod testing_api;
mod transcripts;
mod triggers;
mod turbo;
