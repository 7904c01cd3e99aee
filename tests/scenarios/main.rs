//! The one scenario test binary: in-process ring, transcripts, multi-process clusters.

mod cluster;
mod ring_inprocess;
mod transcripts;
