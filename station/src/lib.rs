//! mcc-station: a MACRO station on the ring.
//!
//! [`station_app::StationApp`] answers each activated servo node with a simulated amplifier,
//! motor and quadrature encoder ([`servo_node`], [`plant`]), configured by
//! [`config::PlantConfig`]. The station meets the card only through ring packets.

#![warn(missing_docs, unreachable_pub)]

#[cfg(test)]
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // reads the crate's own source
#[path = "../../ring/src/api_check.rs"] // one check, shared with mcc-ring
mod api_check;
pub mod config;
pub mod emcl;
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // the I/O edge of the EMCL drives
pub mod emcl_rt;
pub mod faults;
pub mod macro_aux;
pub mod mi;
pub mod plant;
pub mod process;
pub mod save_effect;
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // the save thread's I/O edge
pub mod save_io;
pub mod servo_node;
pub mod station_app;
pub mod station_mi;
